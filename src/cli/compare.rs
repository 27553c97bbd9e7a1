//! `tdeploy compare MODEL LOG`: the model replayed through a log, residuals
//! per sensor, per direction and overall, in a table, CSV files and SVG
//! figures, and a sentence on where the model fails worst.
//!
//! `--json FILE` writes the whole comparison as one JSON object:
//! `model` and `log` (the paths), `sensors` (sensor ids in log order: the
//! `sensor` index of every residual and the order of `per_sensor`),
//! `comparison` ([`Comparison`]: `residuals`, `per_sensor` as
//! `[stats of the residual in its unit, stats of z]`, `per_direction`,
//! `overall`; `overall.rms` is the overall RMS in noise SDs) and `verdict`
//! ([`ComparisonVerdict`], tagged by its `verdict` field).

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{value_parser, Arg, ArgMatches, Command};
use serde::Serialize;

use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::{write_atomically, write_json, CsvTable};
use tensegrity_deploy::measure::compare::{
    compare as compare_runs, verdict, Comparison, ComparisonVerdict, WhereItFails,
};
use tensegrity_deploy::measure::log::MeasurementLog;
use tensegrity_deploy::report::figures::{
    measured_vs_predicted_svg, residuals_over_steps_svg, residuals_vs_features_svg,
};

use super::{replay_stopped, value, Outcome};

/// The `compare` subcommand's arguments.
pub fn command() -> Command {
    Command::new("compare")
        .about("Replay a measurement log through a model and report the residuals per sensor, step and direction")
        .arg(Arg::new("model").required(true).value_parser(value_parser!(PathBuf)).help("Model file (TOML)"))
        .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/compare").value_parser(value_parser!(PathBuf)).help("Report folder (CSV and SVG)"))
        .arg(Arg::new("json").long("json").value_parser(value_parser!(PathBuf)).help("Also write the comparison and its verdict as JSON to this file"))
        .arg(Arg::new("force").long("force").action(clap::ArgAction::SetTrue).help("Replace the report folder even if it holds files tdeploy did not write"))
}

/// Options of `tdeploy compare`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Model file.
    pub model: PathBuf,
    /// Log folder.
    pub log: PathBuf,
    /// Report folder.
    pub out: PathBuf,
    /// JSON report file, if asked for.
    pub json: Option<PathBuf>,
    /// Replace a report folder that holds other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(Options {
            model: value(m, "model")?,
            log: value(m, "log")?,
            out: value(m, "out")?,
            json: m.get_one::<PathBuf>("json").cloned(),
            force: m.get_flag("force"),
        })
    }
}

/// The JSON report (see the module notes).
#[derive(Serialize)]
struct CompareReport<'a> {
    model: &'a Path,
    log: &'a Path,
    sensors: Vec<&'a str>,
    comparison: &'a Comparison,
    verdict: &'a ComparisonVerdict,
}

/// Runs `tdeploy compare`.
pub fn run(o: &Options) -> Result<Outcome> {
    let model = read_model(&o.model)?.measurement_model()?;
    let log = read_log(&o.log, &model.structure)?;
    let c = match compare_runs(&model, &log) {
        Ok(c) => c,
        Err(e) => {
            let context = format!(
                "replaying {} through {}",
                o.log.display(),
                o.model.display()
            );
            return replay_stopped(e, context);
        }
    };
    let v = verdict(&c);
    print_tables(&log, &c, &v);
    let folder = ResultsFolder::claim(&o.out, "compare", o.force)?;
    let out = folder.path();
    residuals_csv(&log, &c).write(&out.join("residuals.csv"))?;
    sensors_csv(&log, &c).write(&out.join("sensors.csv"))?;
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
    folder.commit()?;
    if let Some(json) = &o.json {
        let report = CompareReport {
            model: &o.model,
            log: &o.log,
            sensors: log.sensors.iter().map(|s| s.id.as_str()).collect(),
            comparison: &c,
            verdict: &v,
        };
        write_json(json, &report)?;
        say!("JSON report in {}", json.display());
    }
    say!("report in {}", o.out.display());
    Ok(Outcome::GoalReached)
}

fn print_tables(log: &MeasurementLog, c: &Comparison, v: &ComparisonVerdict) {
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
    say!("{}", verdict_in_words(log, v));
}

/// The comparison's verdict in words.
fn verdict_in_words(log: &MeasurementLog, v: &ComparisonVerdict) -> String {
    match v {
        ComparisonVerdict::NoReadings => "no reading could be compared".into(),
        ComparisonVerdict::Noise { rms_z, limit } => format!(
            "the residuals are consistent with sensor noise (overall RMS {rms_z:.2} σ ≤ {limit:.2} σ)"
        ),
        ComparisonVerdict::Fails(w) => where_it_fails_in_words(log, w),
    }
}

/// Where the model fails worst, in words.
pub(super) fn where_it_fails_in_words(log: &MeasurementLog, w: &WhereItFails) -> String {
    let sensor = log
        .sensors
        .get(w.sensor)
        .map(|s| s.id.as_str())
        .unwrap_or("-");
    let direction = w.direction.map(|d| d.as_str()).unwrap_or("-");
    let feature = match &w.feature {
        Some(f) => format!(
            "its residual correlates most with {f} (r = {:+.2})",
            w.correlation
        ),
        None => "its residual correlates with no feature".into(),
    };
    format!(
        "the model fails worst at {sensor} (RMS {:.1} σ, mean {:+.1} σ), most in the {direction} direction (RMS {:.1} σ); {feature}",
        w.sensor_rms_z, w.sensor_mean_z, w.direction_rms_z
    )
}

fn residuals_csv(log: &MeasurementLog, c: &Comparison) -> CsvTable {
    let mut t = CsvTable::new(&[
        "cycle",
        "step",
        "sensor",
        "direction",
        "measured",
        "predicted",
        "residual",
        "z",
        "payout_m",
        "command_m",
        "joint_angle_deg",
        "temperature_c",
    ]);
    for r in &c.residuals {
        let cycle = &log.cycles[r.cycle];
        let step = if r.step == 0 {
            0
        } else {
            cycle.step_labels[r.step - 1]
        };
        t.row([
            cycle.label.to_string(),
            step.to_string(),
            log.sensors[r.sensor].id.clone(),
            r.direction.as_str().to_string(),
            r.measured.to_string(),
            r.predicted.to_string(),
            r.residual.to_string(),
            r.z.to_string(),
            r.features.payout_m.to_string(),
            r.features.command_m.to_string(),
            r.features.joint_angle_rad.to_degrees().to_string(),
            r.features
                .temperature_c
                .map(|t| t.to_string())
                .unwrap_or_default(),
        ]);
    }
    t
}

fn sensors_csv(log: &MeasurementLog, c: &Comparison) -> CsvTable {
    let mut t = CsvTable::new(&[
        "sensor", "count", "mean", "sd", "rms", "worst", "rms_z", "mean_z",
    ]);
    for (sensor, (st, z)) in log.sensors.iter().zip(&c.per_sensor) {
        if st.count > 0 {
            t.row([
                sensor.id.clone(),
                st.count.to_string(),
                st.mean.to_string(),
                st.sd.to_string(),
                st.rms.to_string(),
                st.worst.to_string(),
                z.rms.to_string(),
                z.mean.to_string(),
            ]);
        }
    }
    t
}
