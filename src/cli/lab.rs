//! `tdeploy lab TRUTH.toml`: a synthetic measurement log from a truth model.
//! Writes the log folder ([`tensegrity_deploy::io::log`]) and, beside it,
//! the truth record `<out>.truth.toml`
//! ([`tensegrity_deploy::io::model_file::write_truth_record`]).

use std::path::PathBuf;

use anyhow::{anyhow, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::experiment_file::PAYOUT_RANGE_M;
use tensegrity_deploy::io::log::write_log;
use tensegrity_deploy::io::model_file::{
    check_truth_record, read_model, truth_record_path, write_truth_record, LabRun,
};
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::measure::lab::{run_lab, standard_cycles};
use tensegrity_deploy::numerics::NumberRange;
use tensegrity_deploy::sim::standard_sensors;

use super::{number_in, plant_stopped, value, Outcome};

/// Most `--steps` each way per cycle: the limit on a cycle's work (the
/// default is 5).
const MAX_STEPS: usize = 1000;
/// Range of `--temperature-swing`, K: beyond ±100 K about 20 °C no bridge
/// is deployed.
const SWING_RANGE_K: NumberRange = NumberRange::non_negative_up_to(100.0);
/// Range of each of `--amplitudes`, m.
const AMPLITUDE_RANGE_M: NumberRange = NumberRange {
    min_exclusive: true,
    ..PAYOUT_RANGE_M
};

/// The `lab` subcommand's arguments.
pub fn command() -> Command {
    Command::new("lab")
        .about("Run deployment-fold cycles on a truth model file and write a measurement log with sensor noise")
        .arg(Arg::new("truth").required(true).value_parser(value_parser!(PathBuf)).help("Truth model file (TOML: structure and effects)"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/lab-log").value_parser(value_parser!(PathBuf)).help("Log folder to write; the truth is recorded beside it as <out>.truth.toml"))
        .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the sensor noise"))
        .arg(Arg::new("amplitudes").long("amplitudes").value_delimiter(',').default_value("0.01,0.05,0.1,0.4").value_parser(value_parser!(f64)).help("Cable actuation of each cycle, m, each in (0, 1] (paid out, then reeled back in)"))
        .arg(Arg::new("steps").long("steps").default_value("5").value_parser(value_parser!(usize)).help("Steps in each direction of a cycle, 1 to 1000"))
        .arg(super::force_arg())
        .arg(Arg::new("temperature-swing").long("temperature-swing").default_value("12").value_parser(value_parser!(f64)).help("Amplitude of the temperature's daily swing about 20 °C, K, in [0, 100]"))
}

/// Options of `tdeploy lab`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Truth model file.
    pub truth: PathBuf,
    /// Log folder to write.
    pub out: PathBuf,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Actuation of each cycle, m.
    pub amplitudes_m: Vec<f64>,
    /// Steps each way per cycle.
    pub steps: usize,
    /// Daily temperature swing, K.
    pub swing_k: f64,
    /// Replace an output folder or truth record that holds other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let amplitudes_m: Vec<f64> = m
            .get_many::<f64>("amplitudes")
            .map(|v| v.copied().collect())
            .unwrap_or_default();
        if amplitudes_m.is_empty() {
            return Err(anyhow!("--amplitudes: give at least one"));
        }
        for a in &amplitudes_m {
            AMPLITUDE_RANGE_M
                .check(*a)
                .map_err(|why| anyhow!("--amplitudes: {why}"))?;
        }
        let steps: usize = value(m, "steps")?;
        if !(1..=MAX_STEPS).contains(&steps) {
            return Err(anyhow!(
                "--steps: must be at least 1 and at most {MAX_STEPS} (the limit on a cycle's work), got {steps}"
            ));
        }
        Ok(Options {
            truth: value(m, "truth")?,
            out: value(m, "out")?,
            seed: value(m, "seed")?,
            amplitudes_m,
            steps,
            swing_k: number_in(m, "temperature-swing", SWING_RANGE_K)?,
            force: m.get_flag("force"),
        })
    }
}

/// Runs `tdeploy lab`.
pub fn run(o: &Options) -> Result<Outcome> {
    let truth = read_model(&o.truth)?;
    let model = truth.measurement_model()?;
    let sensors = standard_sensors(&model.structure);
    let cycles = standard_cycles(
        model.structure.continuous_cables.len(),
        &o.amplitudes_m,
        o.steps,
        o.swing_k,
    );
    // Claimed before the work, so that a refusal costs nothing.
    check_truth_record(&o.out, o.force)?;
    let folder = ResultsFolder::claim(&o.out, "lab", o.force)?;
    let log = match run_lab(&model, &sensors, &cycles, o.seed) {
        Ok(log) => log,
        Err(e) => return plant_stopped(e, format!("truth model {}", o.truth.display())),
    };
    write_log(folder.path(), &log, &model.structure)?;
    folder.commit()?;
    write_truth_record(
        &o.out,
        &truth,
        &LabRun {
            seed: o.seed,
            amplitudes_m: &o.amplitudes_m,
            steps: o.steps,
            swing_k: o.swing_k,
        },
    )?;
    let readings: usize = log
        .cycles
        .iter()
        .map(|c| c.readings.len() * log.sensors.len())
        .sum();
    say!(
        "lab: {} cycles ({} steps each), {} sensors, {readings} readings, seed {}",
        log.cycles.len(),
        2 * o.steps,
        log.sensors.len(),
        o.seed
    );
    say!(
        "log in {}; truth recorded in {}",
        o.out.display(),
        truth_record_path(&o.out).display()
    );
    Ok(Outcome::GoalReached)
}
