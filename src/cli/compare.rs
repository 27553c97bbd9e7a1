//! `tdeploy compare MODEL LOG`: the model replayed through a log, residuals
//! per sensor, per direction and overall, in a table, CSV files and SVG
//! figures, and a sentence on where the model fails worst.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::ArgMatches;

use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::measure::compare::{
    compare as compare_runs, noise_rms_limit, Comparison, FEATURES,
};
use tensegrity_deploy::report::figures::{
    measured_vs_predicted_svg, residuals_over_steps_svg, residuals_vs_features_svg,
};

/// Runs `tdeploy compare`.
pub fn compare(a: &ArgMatches) -> Result<()> {
    let model_path = a.get_one::<PathBuf>("model").unwrap();
    let log_dir = a.get_one::<PathBuf>("log").unwrap();
    let out = a.get_one::<PathBuf>("out").unwrap();
    let model_file = read_model(model_path)?;
    let model = super::effect_model(&model_file)?;
    let log = read_log(log_dir, &model.structure)?;
    let c = compare_runs(&model, &log).with_context(|| {
        format!(
            "replaying {} through {}",
            log_dir.display(),
            model_path.display()
        )
    })?;
    print_tables(&log, &c);
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    write_atomically(
        &out.join("residuals.csv"),
        residuals_csv(&log, &c).as_bytes(),
    )?;
    write_atomically(&out.join("sensors.csv"), sensors_csv(&log, &c).as_bytes())?;
    write_atomically(
        &out.join("measured_vs_predicted.svg"),
        measured_vs_predicted_svg(&log, &c)?.as_bytes(),
    )?;
    write_atomically(
        &out.join("residuals_over_steps.svg"),
        residuals_over_steps_svg(&log, &c)?.as_bytes(),
    )?;
    write_atomically(
        &out.join("residuals_vs_features.svg"),
        residuals_vs_features_svg(&c)?.as_bytes(),
    )?;
    say!("report in {}", out.display());
    Ok(())
}

fn print_tables(log: &tensegrity_deploy::measure::log::MeasurementLog, c: &Comparison) {
    say!(
        "{:<22} {:>5} {:>11} {:>11} {:>11} {:>11} {:>8}",
        "sensor",
        "n",
        "mean",
        "sd",
        "rms",
        "worst",
        "rms/σ"
    );
    for (s, (stats, z)) in log.sensors.iter().zip(&c.per_sensor) {
        if stats.count == 0 {
            continue;
        }
        say!(
            "{:<22} {:>5} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {:>8.2}",
            s.id,
            stats.count,
            stats.mean,
            stats.sd,
            stats.rms,
            stats.worst,
            z.rms
        );
    }
    say!("residuals in noise SDs (z) by direction:");
    for (d, z) in &c.per_direction {
        if z.count > 0 {
            say!(
                "  {:<10} n {:>5}  mean {:>7.2}  sd {:>6.2}  rms {:>6.2}",
                d.as_str(),
                z.count,
                z.mean,
                z.sd,
                z.rms
            );
        }
    }
    say!(
        "overall: rms {:.2} noise SDs over {} readings (about 1 if the model explains the log)",
        c.overall.rms,
        c.overall.count
    );
    say!("{}", verdict(log, c));
}

/// The comparison's verdict in words: noise, or where the model fails.
fn verdict(log: &tensegrity_deploy::measure::log::MeasurementLog, c: &Comparison) -> String {
    let limit = noise_rms_limit(c.overall.count);
    if c.worst_sensor().is_some() && c.overall.rms <= limit {
        return format!(
            "the residuals are consistent with sensor noise (overall RMS {:.2} σ ≤ {:.2} σ)",
            c.overall.rms, limit
        );
    }
    where_it_fails(log, c)
}

/// Where the model fails worst: sensor, direction and the feature its
/// residual correlates with most, in words.
pub(super) fn where_it_fails(
    log: &tensegrity_deploy::measure::log::MeasurementLog,
    c: &Comparison,
) -> String {
    let Some(worst) = c.worst_sensor() else {
        return "no reading could be compared".into();
    };
    let z = c.per_sensor[worst].1;
    let (dir, dz) = c
        .per_direction
        .iter()
        .filter(|(_, s)| s.count > 0)
        .max_by(|a, b| a.1.rms.total_cmp(&b.1.rms))
        .map(|(d, s)| (d.as_str(), s.rms))
        .unwrap_or(("-", 0.0));
    let corr = c.feature_correlations(worst);
    let (f, r) = corr
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map(|(f, r)| (FEATURES[f], *r))
        .unwrap_or(("-", 0.0));
    format!(
        "the model fails worst at {} (RMS {:.1} σ, mean {:+.1} σ), most in the {dir} direction (RMS {:.1} σ); its residual correlates most with {f} (r = {r:+.2})",
        log.sensors[worst].id, z.rms, z.mean, dz
    )
}

fn residuals_csv(log: &tensegrity_deploy::measure::log::MeasurementLog, c: &Comparison) -> String {
    let mut s = String::from(
        "cycle,step,sensor,direction,measured,predicted,residual,z,payout_m,command_m,joint_angle_deg,temperature_c\n",
    );
    for r in &c.residuals {
        s += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{}\n",
            log.cycles[r.cycle].label,
            if r.step == 0 {
                0
            } else {
                log.cycles[r.cycle].step_labels[r.step - 1]
            },
            log.sensors[r.sensor].id,
            r.direction.as_str(),
            r.measured,
            r.predicted,
            r.residual,
            r.z,
            r.features.payout_m,
            r.features.command_m,
            r.features.joint_angle_rad.to_degrees(),
            r.features
                .temperature_c
                .map(|t| t.to_string())
                .unwrap_or_default()
        );
    }
    s
}

fn sensors_csv(log: &tensegrity_deploy::measure::log::MeasurementLog, c: &Comparison) -> String {
    let mut s = String::from("sensor,count,mean,sd,rms,worst,rms_z,mean_z\n");
    for (sensor, (st, z)) in log.sensors.iter().zip(&c.per_sensor) {
        if st.count > 0 {
            s += &format!(
                "{},{},{},{},{},{},{},{}\n",
                sensor.id, st.count, st.mean, st.sd, st.rms, st.worst, z.rms, z.mean
            );
        }
    }
    s
}
