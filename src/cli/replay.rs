//! `tdeploy replay LOG [--policy P] [--model M] [--problem F] [--cycle C]
//! [--fit EFFECTS] [--seed S] -o DIR [--force]`: closed-loop replay of a
//! logged deployment (see [`tensegrity_deploy::studies::log_replay`]).
//!
//! 1. **Replay**: at every logged command after the logged start, the drum
//!    command the policy would have sent given the logged measurements so
//!    far, beside the command logged; then the controller takes the logged
//!    command and readings in. A deploy log replayed with the policy and
//!    model that made it gives its own commands back.
//! 2. **Calibration**: the controller's model calibrated on the whole log
//!    ([`tensegrity_deploy::measure::calibrate`]): by default the
//!    diagnosis (`tdeploy diagnose`, two rounds; the effects it finds),
//!    with `--fit` the listed effects fitted in turn (cheaper, cruder),
//!    each kept only if it lowers the held-out residual.
//! 3. **Counterfactual**: the policy deploys the calibrated model (as the
//!    truth, read by the log's sensors with noise from `--seed`) in closed
//!    loop from the logged start.
//!
//! Writes in DIR, as a whole: `replay.csv`, `counterfactual.csv`,
//! `summary.json` and `timing.csv` (formats in
//! [`tensegrity_deploy::io::replay_files`]; `timing.csv` holds the
//! planning times, the only file that changes from run to run) and
//! `replay.svg` ([`tensegrity_deploy::report::replay_figure`]).
//!
//! Exit 0 when the counterfactual connected, 1 when it did not (or could
//! not run), 2 on bad input (a log that cannot be read or replayed, named
//! by file and field).

use std::path::PathBuf;

use anyhow::{anyhow, bail, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::control::DeployError;
use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::replay_files::{write_replay, ReplaySet, ReplaySources, ReplaySummary};
use tensegrity_deploy::io::{write_atomically, FileError};
use tensegrity_deploy::measure::calibrate::{
    calibrate_on_log, CalibrationError, CalibrationMethod, CalibrationStanding, KeepFit,
};
use tensegrity_deploy::model::{EffectKind, JointFriction};
use tensegrity_deploy::report::replay_figure::replay_svg;
use tensegrity_deploy::sim::{EffectModel, PlantError};
use tensegrity_deploy::studies::log_replay::{
    counterfactual, default_cycle, deployment_start, replay_log, IntervalEndRun, Margins, Replay,
    ReplayInputError,
};

use super::inputs::{controller_model_file, planning_model, policy_or_default, problem_or_default};
use super::words::{compact_mm, mm};
use super::{value, Outcome};

/// The `replay` subcommand's arguments.
pub fn command() -> Command {
    Command::new("replay")
        .about("Replay a logged deployment in closed loop: what the policy would have commanded beside what was commanded, and a counterfactual run on a model calibrated on the log; exit code 1 if the counterfactual does not connect")
        .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder (from tdeploy deploy's log/, tdeploy lab, or a bridge)"))
        .arg(Arg::new("policy").long("policy").value_parser(value_parser!(PathBuf)).help("Policy file (default: policies/qp.toml's settings, built in)"))
        .arg(Arg::new("model").long("model").value_parser(value_parser!(PathBuf)).help("Model file of the controller (and the base of the calibration). Default: the reference bridge without friction"))
        .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file for the limits and the connection tolerance (its start payout is replaced by the logged start; `deploy` writes the one it solved to DIR/problem.toml). Default: the documented default problem"))
        .arg(Arg::new("cycle").long("cycle").value_parser(value_parser!(u64)).help("Cycle of the log to replay, by its label (default: the one with the largest fold)"))
        .arg(Arg::new("fit").long("fit").value_delimiter(',').help("Calibrate by fitting these effects in turn (e.g. joint_friction,motor) instead of the full diagnosis"))
        .arg(Arg::new("rounds").long("rounds").default_value("2").value_parser(value_parser!(usize)).help("Effects the diagnosis looks for at most (1 to the number of effects)"))
        .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the counterfactual's sensor noise"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/replay").value_parser(value_parser!(PathBuf)).help("Folder for replay.csv, counterfactual.csv, summary.json, replay.svg and timing.csv"))
        .arg(super::force_arg())
}

/// Options of `tdeploy replay`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Log folder.
    pub log: PathBuf,
    /// Policy file; `None`: the built-in default.
    pub policy: Option<PathBuf>,
    /// Controller's model file; `None`: the frictionless reference bridge.
    pub model: Option<PathBuf>,
    /// Problem file; `None`: the default problem.
    pub problem: Option<PathBuf>,
    /// Cycle label; `None`: the largest fold.
    pub cycle: Option<u64>,
    /// How the counterfactual's model is calibrated.
    pub calibration: CalibrationMethod,
    /// Seed of the counterfactual's noise.
    pub seed: u64,
    /// Results folder.
    pub out: PathBuf,
    /// Replace a folder of other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let rounds: usize = value(m, "rounds")?;
        if !(1..=EffectKind::ALL.len()).contains(&rounds) {
            bail!(
                "--rounds: must be 1 to {}, got {rounds}",
                EffectKind::ALL.len()
            );
        }
        let calibration = match m.get_many::<String>("fit") {
            None => CalibrationMethod::Diagnose { max_rounds: rounds },
            Some(names) => {
                let mut kinds = Vec::new();
                for name in names {
                    let kind = EffectKind::ALL
                        .into_iter()
                        .find(|k| k.name() == name)
                        .ok_or_else(|| {
                            let known: Vec<_> = EffectKind::ALL.iter().map(|k| k.name()).collect();
                            anyhow!(
                                "--fit: unknown effect \"{name}\" (known: {})",
                                known.join(", ")
                            )
                        })?;
                    if !kinds.contains(&kind) {
                        kinds.push(kind);
                    }
                }
                CalibrationMethod::Fit {
                    effects: kinds,
                    keep: KeepFit::IfHeldOutFalls,
                }
            }
        };
        Ok(Options {
            log: value(m, "log")?,
            policy: m.get_one::<PathBuf>("policy").cloned(),
            model: m.get_one::<PathBuf>("model").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            cycle: m.get_one::<u64>("cycle").copied(),
            calibration,
            seed: value(m, "seed")?,
            out: value(m, "out")?,
            force: m.get_flag("force"),
        })
    }
}

/// A log that cannot be replayed, as a file error naming file and field.
fn log_error(o: &Options, e: ReplayInputError) -> FileError {
    FileError::Invalid {
        path: o.log.join(e.file()),
        entry: e.field().into(),
        message: e.to_string(),
    }
}

/// Largest of the known gaps.
fn largest(gaps: &[Option<f64>]) -> Option<f64> {
    gaps.iter().flatten().copied().reduce(f64::max)
}

/// Runs `tdeploy replay`.
pub fn run(o: &Options) -> Result<Outcome> {
    let folder = ResultsFolder::claim(&o.out, "replay", o.force)?;
    let (model_file, model_words) = controller_model_file(o.model.as_deref())?;
    let base = model_file.measurement_model()?;
    let model = planning_model(o.model.as_deref(), JointFriction::frictionless())?;
    let policy = policy_or_default(o.policy.as_deref())?;
    let problem = problem_or_default(
        o.problem.as_deref(),
        model.structure().continuous_cables.len(),
    )?;
    let log = read_log(&o.log, &base.structure)?;
    let cycle = match o.cycle.or_else(|| default_cycle(&log)) {
        Some(c) => c,
        None => {
            // No cycle can start a deployment: say why for the first.
            let first = log.cycles.first().map_or(0, |c| c.label);
            return Err(deployment_start(&log, first)
                .err()
                .map(|e| log_error(o, e))
                .unwrap_or_else(|| FileError::Invalid {
                    path: o.log.join("commands.csv"),
                    entry: "cycle".into(),
                    message: "no cycle can be replayed as a deployment".into(),
                })
                .into());
        }
    };
    let start = deployment_start(&log, cycle).map_err(|e| log_error(o, e))?;
    let replay =
        replay_log(&model, &problem, &policy, &log, &start).map_err(|e| log_error(o, e))?;
    say!(
        "replay: {} log {}, cycle {} from step {} (fold {} mm), policy {} ({}), controller's model {model_words}",
        start.layout.as_str(),
        o.log.display(),
        start.cycle,
        start.start_step,
        mm(Some(
            start.start_payout_m.iter().sum::<f64>() / start.start_payout_m.len().max(1) as f64
        )),
        policy.name,
        policy.planner.as_str(),
    );
    for s in &replay.steps {
        say!(
            "{:>4}: logged {} mm | policy {} | largest gap measured {} mm, predicted for the logged command {} mm",
            s.step,
            compact_mm(&s.logged_command_m),
            match (&s.policy_command_m, &s.policy_stop) {
                (Some(p), _) if s.same_as_policy => format!("{} mm (the same)", compact_mm(p)),
                (Some(p), _) => format!("{} mm (differs by up to {} mm)", compact_mm(p), mm(s.largest_difference_m)),
                (None, Some(stop)) => format!("would stop: {}", stop.describe()),
                (None, None) => "-".into(),
            },
            mm(largest(&s.measured_gaps_m)),
            mm(s.logged_predicted_gaps_m.iter().copied().reduce(f64::max)),
        );
    }
    if let Some(why) = &replay.stopped {
        say!("the replay stopped early: {}", why.describe());
    }

    let context = format!("calibrating on {}", o.log.display());
    let calibration = match calibrate_on_log(&base, &log, &o.calibration) {
        Ok(c) => Ok(c),
        Err(CalibrationError::Replay(
            e @ (PlantError::Solver { .. }
            | PlantError::AsBuilt { .. }
            | PlantError::SeatsUnsettled { .. }),
        )) => Err(format!("{context}: {e}")),
        Err(e) => return Err(anyhow::Error::new(e).context(context)),
    };
    let cf = match &calibration {
        Ok(c) => {
            // The model file's solver settings stay: the calibration ran on them.
            let truth = EffectModel {
                effects: c.effects.clone(),
                ..base.clone()
            };
            match counterfactual(&model, &problem, &policy, &truth, &log, &start, o.seed) {
                Ok(d) => Ok(d),
                Err(DeployError::TruthStart(e)) => Err(format!(
                    "the calibrated model could not reach the logged start: {e}"
                )),
                Err(e) => return Err(e.into()),
            }
        }
        Err(why) => Err(format!("no calibrated model ({why})")),
    };
    let tolerance_m = problem.connection_tolerance_m;
    let margins = cf.as_ref().ok().map(|d| Margins::of(d, tolerance_m));
    let standing = calibration.as_ref().ok().map(|c| c.standing());
    // The interval's ends matter only where the estimate's run means
    // something: on a model that explains the log.
    let mut ends = Vec::new();
    if let (Ok(c), Some(s)) = (&calibration, &standing) {
        if s.explains() && margins.is_some() {
            for end in c.interval_ends() {
                let truth = EffectModel {
                    effects: end.effects,
                    ..base.clone()
                };
                let run =
                    match counterfactual(&model, &problem, &policy, &truth, &log, &start, o.seed) {
                        Ok(d) => Ok(Margins::of(&d, tolerance_m)),
                        Err(DeployError::TruthStart(e)) => {
                            Err(format!("could not reach the logged start: {e}"))
                        }
                        Err(e) => return Err(e.into()),
                    };
                ends.push(IntervalEndRun {
                    label: end.label,
                    failed: run.as_ref().err().cloned(),
                    counterfactual: run.ok(),
                });
            }
        }
    }
    let verdict = verdict(
        &replay,
        margins.as_ref(),
        cf.as_ref().err(),
        standing.as_ref(),
        &ends,
    );

    let s = model.structure();
    let motors: Vec<String> = s.continuous_cables.iter().map(|c| c.id.clone()).collect();
    let summary = ReplaySummary::new(
        &replay,
        &policy,
        ReplaySources {
            log: o.log.display().to_string(),
            model: model_words,
            logged_commands: log.cycles[start.cycle_index].commands.len() - start.start_reading,
            seed: o.seed,
        },
        calibration.as_ref().map_err(Clone::clone),
        cf.as_ref()
            .map(|d| Margins::of(d, tolerance_m))
            .map_err(Clone::clone),
        &ends,
        verdict.clone(),
    );
    let out = folder.path();
    write_replay(
        out,
        &ReplaySet {
            replay: &replay,
            counterfactual: cf.as_ref().ok(),
            motors: &motors,
            pairs: s.midspan_pairs.len(),
            summary: &summary,
        },
    )?;
    let svg = replay_svg(&replay, cf.as_ref().ok(), problem.connection_tolerance_m)?;
    write_atomically(&out.join("replay.svg"), svg.as_bytes())?;
    folder.commit()?;

    if let Ok(c) = &calibration {
        for f in &c.fitted {
            say!(
                "calibrated: {} {} ({}) = {:?}",
                f.effect,
                if f.kept { "kept" } else { "not kept" },
                f.parameters.join(", "),
                f.values
            );
        }
        say!(
            "held-out RMS residual on the log: {:.2} σ before calibration, {:.2} σ after",
            c.held_out_rms_before,
            c.held_out_rms_after
        );
    }
    say!("{verdict}");
    say!(
        "results in {} (replay.csv, counterfactual.csv, summary.json, replay.svg, timing.csv)",
        o.out.display()
    );
    // Connected only on a model the log does not refute, at the estimate
    // and at every end of its parameters' intervals.
    let trusted = standing.is_some_and(|s| s.explains());
    Ok(match margins {
        Some(m) if m.connected && trusted && ends.iter().all(|e| e.connected()) => {
            Outcome::GoalReached
        }
        _ => Outcome::GoalMissed(verdict),
    })
}

/// The verdict in plain words: the replay, then the counterfactual with
/// how far its model stands for the bridge and how it fares across the
/// calibrated parameters' intervals.
fn verdict(
    r: &Replay,
    m: Option<&Margins>,
    failed: Option<&String>,
    standing: Option<&CalibrationStanding>,
    ends: &[IntervalEndRun],
) -> String {
    let n = r.steps.len();
    let replayed = format!(
        "replay: the policy would have sent the logged command at {} of {n} steps (largest difference {} mm){}",
        r.same_commands(),
        mm(r.largest_difference_m()),
        match r.steps.iter().filter(|s| s.policy_stop.is_some()).count() {
            0 => String::new(),
            k => format!(", and would have stopped before {k} of them"),
        }
    );
    let counterfactual = match (m, failed) {
        (Some(m), _) => {
            let margins = format!(
                "final largest gap measured {} mm, true {} mm; worst utilisation {:.2}; min tension {} N; {} limit violations",
                mm(m.final_measured_gap_m),
                mm(m.final_true_gap_m),
                m.worst_utilisation,
                m.min_tension_n.map_or("-".into(), |t| format!("{t:.0}")),
                m.violations
            );
            let run = if m.connected {
                format!("connected after {} commands ({margins})", m.commands)
            } else {
                format!(
                    "not connected ({}; the controller: {}) after {} commands ({margins})",
                    m.outcome,
                    m.status.describe(),
                    m.commands
                )
            };
            match standing {
                Some(s) if !s.explains() => format!(
                    "{}: the counterfactual on it is no evidence of what the bridge would do ({run})",
                    s.describe()
                ),
                Some(s) => format!(
                    "{}; counterfactual on it: {run}{}",
                    s.describe(),
                    interval_words(ends)
                ),
                None => format!("counterfactual on the calibrated model: {run}"),
            }
        }
        (None, Some(why)) => format!("counterfactual not run: {why}"),
        (None, None) => "counterfactual not run".into(),
    };
    format!("{replayed}; {counterfactual}")
}

/// How the counterfactual fares at the ends of the calibrated
/// parameters' intervals, in words (empty without any).
fn interval_words(ends: &[IntervalEndRun]) -> String {
    if ends.is_empty() {
        return String::new();
    }
    match ends.iter().find(|e| !e.connected()) {
        None => format!(
            "; the same at both ends of every calibrated parameter's 95 % interval ({} runs)",
            ends.len()
        ),
        Some(e) => match (&e.counterfactual, &e.failed) {
            (Some(m), _) => format!(
                "; but at {}: not connected ({}, {} limit violations)",
                e.label, m.outcome, m.violations
            ),
            (None, Some(why)) => format!("; but at {}: not run ({why})", e.label),
            (None, None) => format!("; but at {}: not run", e.label),
        },
    }
}
