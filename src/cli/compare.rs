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
use tensegrity_deploy::io::{write_atomically, write_new_json, CsvTable};
use tensegrity_deploy::measure::compare::{compare as compare_runs, Comparison};
use tensegrity_deploy::measure::comparison_verdict::{verdict, ComparisonVerdict, WhereItFails};
use tensegrity_deploy::measure::evidence::{evidence, Evidence, NoiseTest, Statistic, Subject};
use tensegrity_deploy::measure::log::MeasurementLog;
use tensegrity_deploy::measure::outliers::{drop_outliers, find_outliers, Outlier};
use tensegrity_deploy::measure::settings::{DiagnoseSettings, OutlierSettings};
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
        .arg(Arg::new("json").long("json").value_parser(value_parser!(PathBuf)).help("Also write the comparison and its verdict as JSON to this file (an existing file with other contents needs --force)"))
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
    outliers: &'a [Outlier],
    evidence: &'a Evidence,
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
    // Outliers are named and left out of the tests, not taken as structure;
    // noise and outliers are what diagnose takes them to be by default.
    let settings = DiagnoseSettings::default();
    let outliers = find_outliers(&c, log.sensors.len(), &settings.outliers);
    let tested = drop_outliers(&c, &outliers, log.sensors.len());
    let e = evidence(&tested, &log.sensors, &settings.noise);
    let v = verdict(&tested, &e, &settings.noise);
    if let Some(words) = outliers_in_words(&log, &outliers, &settings.outliers) {
        say!("{words}");
    }
    print_tables(&log, &c, &e, &v);
    let folder = ResultsFolder::claim(&o.out, "compare", o.force)?;
    let out = folder.path();
    residuals_csv(&log, &c).write(&out.join("residuals.csv"))?;
    sensors_csv(&log, &c, &e).write(&out.join("sensors.csv"))?;
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
            outliers: &outliers,
            evidence: &e,
            verdict: &v,
        };
        write_new_json(json, &report, o.force)?;
        say!("JSON report in {}", json.display());
    }
    say!("report in {}", o.out.display());
    Ok(Outcome::GoalReached)
}

/// A sentence naming the `outliers` of `log`, found with `settings`
/// (`None` if there are none).
pub fn outliers_in_words(
    log: &MeasurementLog,
    outliers: &[Outlier],
    settings: &OutlierSettings,
) -> Option<String> {
    if outliers.is_empty() {
        return None;
    }
    let named: Vec<String> = outliers
        .iter()
        .map(|o| {
            let cycle = &log.cycles[o.cycle];
            let step = match o.step {
                0 => 0,
                k => cycle.step_labels.get(k - 1).copied().unwrap_or(k as u64),
            };
            format!(
                "{} (cycle {}, step {step}, z {})",
                log.sensors[o.sensor].id,
                cycle.label,
                signed_number(o.z, 1)
            )
        })
        .collect();
    Some(format!(
        "outliers: {} reading(s) beyond {} robust SDs of their sensor's median, left out of the tests: {}",
        outliers.len(),
        settings.limit_robust_sds,
        named.join(", ")
    ))
}

/// The test of `statistic` about `subject` in `e`.
fn test_of(e: &Evidence, subject: Subject, statistic: Statistic) -> Option<&NoiseTest> {
    e.tests
        .iter()
        .find(|t| t.subject == subject && t.statistic == statistic)
}

/// `value (p)` of a test, starred where it rejects noise.
fn test_cell(t: Option<&NoiseTest>, signed: bool) -> String {
    match t {
        Some(t) => format!(
            "{}{}",
            if signed {
                signed_number(t.value, 1)
            } else {
                number(t.value, 2)
            },
            if t.significant { "*" } else { "" }
        ),
        None => "-".into(),
    }
}

fn print_tables(log: &MeasurementLog, c: &Comparison, e: &Evidence, v: &ComparisonVerdict) {
    say!(
        "{:<22} {:>5} {:>11} {:>11} {:>11} {:>11} {:>8} {:>9} {:>8}",
        "sensor",
        "n",
        "mean",
        "sd",
        "rms",
        "worst",
        "rms/σ",
        "mean/SE",
        "sd/σ"
    );
    for (i, (s, (stats, z))) in log.sensors.iter().zip(&c.per_sensor).enumerate() {
        if stats.count == 0 {
            continue;
        }
        say!(
            "{:<22} {:>5} {:>11} {:>11} {:>11} {:>11} {:>8} {:>9} {:>8}",
            s.id,
            stats.count,
            number(stats.mean, 4),
            number(stats.sd, 4),
            number(stats.rms, 4),
            number(stats.worst, 4),
            number(z.rms, 2),
            test_cell(test_of(e, Subject::Sensor(i), Statistic::Mean), true),
            test_cell(test_of(e, Subject::Sensor(i), Statistic::Spread), false)
        );
    }
    for t in e.tests.iter().filter(|t| t.statistic == Statistic::Mean) {
        if let Subject::Group(g) = t.subject {
            say!(
                "group {:<16} {:>5} {:>56} {:>9} {:>8}",
                g.name(),
                t.count,
                "",
                test_cell(Some(t), true),
                test_cell(test_of(e, t.subject, Statistic::Spread), false)
            );
        }
    }
    say!(
        "per-sensor tests: mean/SE is the mean z in standard errors, sd/σ the spread of z about its mean; * rejects noise (Holm, family-wise error {}): {} of {} tests",
        e.family_alpha,
        e.significant().count(),
        e.tests.len()
    );
    say!("residuals in noise SDs (z) by direction:");
    for (d, z) in &c.per_direction {
        if z.count > 0 {
            say!(
                "  {:<10} n {:>5}  mean {:>7}  sd {:>6}  rms {:>6}",
                d.as_str(),
                z.count,
                number(z.mean, 2),
                number(z.sd, 2),
                number(z.rms, 2)
            );
        }
    }
    say!(
        "overall: rms {} noise SDs over {} readings (about 1 if the model explains the log)",
        number(c.overall.rms, 2),
        c.overall.count
    );
    say!("{}", verdict_in_words(log, v));
}

/// The comparison's verdict in words.
fn verdict_in_words(log: &MeasurementLog, v: &ComparisonVerdict) -> String {
    match v {
        ComparisonVerdict::NoReadings => "no reading could be compared".into(),
        ComparisonVerdict::Noise { rms_z, limit } => format!(
            "the residuals are consistent with sensor noise (overall RMS {rms_z:.2} σ ≤ {limit:.2} σ, no per-sensor test rejects noise)"
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
        "the model fails worst at {sensor} (RMS {} σ, mean {} σ; {} per-sensor tests reject noise), most in the {direction} direction (RMS {} σ); {feature}",
        number(w.sensor_rms_z, 1),
        signed_number(w.sensor_mean_z, 1),
        w.significant_tests,
        number(w.direction_rms_z, 1)
    )
}

/// `x` with `decimals` decimals, or in scientific notation (four
/// significant figures) where that would print more than ten digits or
/// show nothing but zeros: a sensor with a bad noise SD must not print a
/// number hundreds of digits long.
pub(super) fn number(x: f64, decimals: usize) -> String {
    let small = x != 0.0 && x.abs() < 0.5 * 10f64.powi(-(decimals as i32));
    if x.is_finite() && x.abs() < 1e5 && !small {
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}

/// [`number`] with its sign always shown.
pub(super) fn signed_number(x: f64, decimals: usize) -> String {
    let text = number(x, decimals);
    if text.starts_with('-') || x.is_nan() {
        text
    } else {
        format!("+{text}")
    }
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

fn sensors_csv(log: &MeasurementLog, c: &Comparison, e: &Evidence) -> CsvTable {
    let mut t = CsvTable::new(&[
        "sensor",
        "count",
        "mean",
        "sd",
        "rms",
        "worst",
        "rms_z",
        "mean_z",
        "mean_se",
        "mean_p",
        "mean_significant",
        "spread_z",
        "spread_p",
        "spread_significant",
    ]);
    for (i, (sensor, (st, z))) in log.sensors.iter().zip(&c.per_sensor).enumerate() {
        if st.count > 0 {
            let cells = |statistic| match test_of(e, Subject::Sensor(i), statistic) {
                Some(t) => [
                    t.value.to_string(),
                    t.p_value.to_string(),
                    t.significant.to_string(),
                ],
                None => Default::default(),
            };
            let [mean_se, mean_p, mean_sig] = cells(Statistic::Mean);
            let [spread, spread_p, spread_sig] = cells(Statistic::Spread);
            t.row([
                sensor.id.clone(),
                st.count.to_string(),
                st.mean.to_string(),
                st.sd.to_string(),
                st.rms.to_string(),
                st.worst.to_string(),
                z.rms.to_string(),
                z.mean.to_string(),
                mean_se,
                mean_p,
                mean_sig,
                spread,
                spread_p,
                spread_sig,
            ]);
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_and_tiny_numbers_print_in_scientific_notation() {
        assert_eq!(number(4.23991, 4), "4.2399");
        assert_eq!(number(-0.0001, 4), "-0.0001");
        assert_eq!(number(0.0, 2), "0.00");
        assert_eq!(number(1.0e300, 2), "1.000e300");
        assert_eq!(number(-3.0e-7, 4), "-3.000e-7");
        assert_eq!(number(f64::INFINITY, 2), "inf");
        assert_eq!(signed_number(1.25, 1), "+1.2");
        assert_eq!(signed_number(-1.0e9, 1), "-1.000e9");
    }
}
