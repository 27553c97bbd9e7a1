//! `tdeploy rig [--truth F] [--model M] [--problem F] [--temperature °C]
//! [--seed S] [--slip-event-substeps] --stdio`: a simulated bridge that speaks the session
//! protocol ([`tensegrity_deploy::io::session_protocol`]), standing in
//! for the motors and the data acquisition of a lab.
//!
//! It folds the truth to the problem's start, sends `hello` and the
//! start's `measurements` (step 0), then executes every `command` it
//! reads: it answers with a `truth` message (the true gaps and the limits
//! the truth broke along the command: what only a simulator knows) and
//! the `measurements` of the step; a `read_again` of its current step is
//! answered with a new reading of the same state. The truth, its default, the sensors and
//! the noise are `tdeploy deploy`'s: the same truth and seed give the
//! same readings for the same commands, drawn in the same order. A
//! command that is not the next step, or not `cleared`, is refused with
//! an `error` message and not executed.
//!
//! Exit 0 at the end of its input; 2 when the truth cannot be built or
//! folded.

use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};
use rand::rngs::StdRng;
use rand::SeedableRng;

use tensegrity_deploy::control::TruthWatch;
use tensegrity_deploy::io::session_protocol::{parse_in_message, InMessage, OutMessage, PROTOCOL};
use tensegrity_deploy::plan::limits::Limits;
use tensegrity_deploy::sim::{standard_sensors, Plant};

use super::inputs::{deployment_temperature, problem_or_default, truth_or_default};
use super::{plant_stopped, value, Outcome};

/// The `rig` subcommand's arguments.
pub fn command() -> Command {
    Command::new("rig")
        .about("A simulated bridge speaking the session protocol on standard input and output: executes commands on a truth and answers with its noisy readings")
        .arg(Arg::new("truth").long("truth").value_parser(value_parser!(PathBuf)).help("Truth model file. Default: `tdeploy deploy`'s default truth (μ = 0.2, 3 mm backlash)"))
        .arg(Arg::new("model").long("model").value_parser(value_parser!(PathBuf)).help("Without --truth, the model file whose structure the default truth is built on"))
        .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file: the fold the rig starts at (default: 0.40 m)"))
        .arg(Arg::new("temperature").long("temperature").value_parser(value_parser!(f64)).help("Air temperature, °C (needed by a thermal truth)"))
        .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the sensor noise"))
        .arg(super::truth_substeps_arg())
        .arg(Arg::new("stdio").long("stdio").action(ArgAction::SetTrue).help("Use standard input and output (the one transport; required)"))
}

/// Options of `tdeploy rig`.
#[derive(Debug, Clone)]
pub struct Options {
    stdio: bool,
    truth: Option<PathBuf>,
    model: Option<PathBuf>,
    problem: Option<PathBuf>,
    temperature_c: Option<f64>,
    seed: u64,
    slip_event_substeps: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(Options {
            stdio: m.get_flag("stdio"),
            truth: m.get_one::<PathBuf>("truth").cloned(),
            model: m.get_one::<PathBuf>("model").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            temperature_c: m.get_one::<f64>("temperature").copied(),
            seed: value(m, "seed")?,
            slip_event_substeps: m.get_flag("slip-event-substeps"),
        })
    }
}

/// Runs `tdeploy rig --stdio`.
pub fn run(o: &Options) -> Result<Outcome> {
    if !o.stdio {
        anyhow::bail!("rig: --stdio is required (standard input and output are the one transport)");
    }
    let (_, truth, words) = truth_or_default(
        o.truth.as_deref(),
        o.model.as_deref(),
        o.slip_event_substeps,
    )?;
    let temperature_c = deployment_temperature(o.temperature_c, &truth.effects, &words)?;
    let structure = truth.structure.clone();
    let problem = problem_or_default(o.problem.as_deref(), structure.continuous_cables.len())?;
    let motors = problem.motor_limits(structure.continuous_cables.len())?;
    let sensors = standard_sensors(&structure);
    let mut plant = match Plant::new(&truth, Some(&motors.start_payout_m), temperature_c) {
        Ok(plant) => plant,
        Err(e) => return plant_stopped(e, "the truth, reaching the folded start".into()),
    };
    let truth_model = plant.model().clone();
    let limits = Limits::new(&truth_model, &problem, plant.state());
    let mut restored = vec![false; limits.required.len()];
    let mut rng = StdRng::seed_from_u64(o.seed);

    let out = super::session::send;
    let readings_message = |step: usize, values: &[Option<f64>]| -> String {
        let readings: BTreeMap<&str, Option<f64>> = sensors
            .iter()
            .zip(values)
            .map(|(s, v)| (s.id.as_str(), *v))
            .collect();
        OutMessage::Measurements { step, readings }.line()
    };
    out(OutMessage::Hello {
        protocol: PROTOCOL,
        role: "rig",
        phase: None,
        motors: structure
            .continuous_cables
            .iter()
            .map(|c| c.id.as_str())
            .collect(),
        sensors: sensors.iter().map(|s| s.id.as_str()).collect(),
    })?;
    let first = plant.measure(&sensors, &mut rng);
    say!("{}", readings_message(0, &first));
    let mut step = 0;
    for line in std::io::stdin().lock().lines() {
        let line = line.context("standard input")?;
        if line.trim().is_empty() {
            continue;
        }
        let message = parse_in_message(&line, &sensors);
        if let Ok(InMessage::ReadAgain { step: k }) = message {
            if k != step {
                let text = format!("read again step {k}, but the rig is at step {step}");
                out(OutMessage::Error {
                    field: "step",
                    message: &text,
                })?;
            } else {
                let readings = plant.measure(&sensors, &mut rng);
                say!("{}", readings_message(step, &readings));
            }
            continue;
        }
        let (k, command, cleared) = match message {
            Ok(InMessage::Command {
                step,
                payout_change_m,
                cleared,
            }) => (step, payout_change_m, cleared),
            Ok(other) => {
                let text = format!(
                    "the rig executes commands; a \"{}\" message is not one",
                    other.type_name()
                );
                out(OutMessage::Error {
                    field: "type",
                    message: &text,
                })?;
                continue;
            }
            Err(e) => {
                out(OutMessage::Error {
                    field: &e.field,
                    message: &e.message,
                })?;
                continue;
            }
        };
        if k != step + 1 {
            let text = format!(
                "command {k}, but the next step is {}; not executed",
                step + 1
            );
            out(OutMessage::Error {
                field: "step",
                message: &text,
            })?;
            continue;
        }
        if cleared == Some(false) {
            let text = format!("command {k} is not cleared (it awaits approval); not executed");
            out(OutMessage::Error {
                field: "cleared",
                message: &text,
            })?;
            continue;
        }
        let mut watch = TruthWatch::new(&truth_model, &limits, &restored);
        if let Err(e) = plant.apply(&command, temperature_c, &mut watch) {
            let text = format!("command {k}: the truth plant failed: {e}");
            out(OutMessage::Error {
                field: "payout_change_m",
                message: &text,
            })?;
            continue;
        }
        step = k;
        if let Some((rows, tolerance_n)) = watch.last_rows.take() {
            for (r, meets) in limits
                .meets_required(&rows, tolerance_n)
                .into_iter()
                .enumerate()
            {
                restored[r] |= meets;
            }
        }
        let violations: Vec<String> = watch
            .breaches
            .iter()
            .map(|(increment, v)| format!("increment {increment}: {}", v.describe()))
            .collect();
        let gaps = plant.state().midspan_gaps_m(&structure);
        out(OutMessage::Truth {
            step,
            true_gaps_m: &gaps,
            violations,
        })?;
        let readings = plant.measure(&sensors, &mut rng);
        say!("{}", readings_message(step, &readings));
    }
    Ok(Outcome::GoalReached)
}
