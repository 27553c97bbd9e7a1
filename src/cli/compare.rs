//! `tdeploy compare MODEL LOG`: the model replayed through a log, residuals
//! per sensor, per direction and overall, in a table, CSV files and SVG
//! figures, and a sentence on where the model fails worst.
//!
//! Writes in DIR, as a whole: `residuals.csv` and `sensors.csv` (formats
//! in [`tensegrity_deploy::io::comparison_files`]) and three figures
//! ([`tensegrity_deploy::report::comparison_figures`]). `--json FILE`
//! writes the whole comparison as one JSON object (its fields in
//! [`tensegrity_deploy::io::comparison_files`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::comparison_files::{
    sensor_ids, write_comparison, write_comparison_report, ComparisonReport,
};
use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::measure::compare::{compare as compare_runs, Comparison};
use tensegrity_deploy::measure::comparison_verdict::{verdict, ComparisonVerdict};
use tensegrity_deploy::measure::evidence::{evidence, Evidence, NoiseTest, Statistic, Subject};
use tensegrity_deploy::measure::log::MeasurementLog;
use tensegrity_deploy::measure::outliers::{drop_outliers, find_outliers};
use tensegrity_deploy::measure::settings::DiagnoseSettings;
use tensegrity_deploy::report::comparison_figures::{
    measured_vs_predicted_svg, residuals_over_steps_svg, residuals_vs_features_svg,
};

use super::words::{number, outliers_in_words, signed_number, where_it_fails_in_words};
use super::{plant_stopped, value, Outcome};

/// The `compare` subcommand's arguments.
pub fn command() -> Command {
    Command::new("compare")
        .about("Replay a measurement log through a model and report the residuals per sensor, step and direction")
        .arg(Arg::new("model").required(true).value_parser(value_parser!(PathBuf)).help("Model file (TOML)"))
        .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/compare").value_parser(value_parser!(PathBuf)).help("Report folder (CSV and SVG)"))
        .arg(Arg::new("json").long("json").value_parser(value_parser!(PathBuf)).help("Also write the comparison and its verdict as JSON to this file (an existing file with other contents needs --force)"))
        .arg(super::force_arg())
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
            return plant_stopped(e, context);
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
    write_comparison(out, &log, &c, &e)?;
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
        let report = ComparisonReport {
            model: &o.model,
            log: &o.log,
            sensors: sensor_ids(&log),
            comparison: &c,
            outliers: &outliers,
            evidence: &e,
            verdict: &v,
        };
        write_comparison_report(json, &report, o.force)?;
        say!("JSON report in {}", json.display());
    }
    say!("report in {}", o.out.display());
    Ok(Outcome::GoalReached)
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
            test_cell(e.test_of(Subject::Sensor(i), Statistic::Mean), true),
            test_cell(e.test_of(Subject::Sensor(i), Statistic::Spread), false)
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
                test_cell(e.test_of(t.subject, Statistic::Spread), false)
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
