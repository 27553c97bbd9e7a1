//! Command-line interface: argument parsing, printing and exit codes. The
//! numerics it calls never print; the files it reads and writes are the
//! library's ([`tensegrity_deploy::io`]).
//!
//! Every subcommand is a module with the same three parts, so that a new
//! one is added the same way (as hyperfine's CLI is laid out):
//! - `command() -> clap::Command`: its arguments;
//! - `Options::from_matches(&ArgMatches) -> Result<Options>`: the typed
//!   options, every flag value checked here, with an error naming the flag;
//! - `run(&Options) -> Result<Outcome>`: the work; it calls the library,
//!   reads and writes files only through [`tensegrity_deploy::io`] (every
//!   output format has its writer there, every figure is drawn in
//!   [`tensegrity_deploy::report`]), prints what it found and maps the
//!   outcome to an exit code.
//!
//! No subcommand module uses another. What several share lives in its
//! own module: [`inputs`] (the model, policy and problem the flags name),
//! [`words`] (the numbers and sentences they print), [`progress`] (the
//! one progress bar), [`evaluation_table`] (the printed table of an
//! evaluation, for `evaluate`, `merge` and the deployment experiment).
//!
//! Subcommands: `structure` ([`structure`]), `simulate` ([`simulate`]),
//! `experiment` ([`experiment`]), `lab` ([`lab`]), `compare` ([`compare`]),
//! `diagnose` ([`diagnose`]), `calibrate` ([`calibrate`]), `plan`
//! ([`plan`]), `deploy` ([`deploy`]), `evaluate` ([`evaluate`]), `merge`
//! ([`merge`]), `replay` ([`replay`]), `cycles` ([`cycles`]), `policy
//! migrate` ([`policy`]), `memory repair` ([`memory`]).
//!
//! # Exit codes
//! | code | meaning |
//! |------|---------|
//! | 0 | done: the command reached its goal |
//! | 1 | it ran but did not reach its goal ([`Outcome::GoalMissed`]): a solve did not converge, a replay or a fit stopped on a solver failure, a plan or a deployment did not connect |
//! | 2 | bad input or an I/O error: a file that does not parse or validate, a bad flag value, a file that cannot be read or written; clap's own usage errors exit 2 too |
//!
//! Either failure prints one line on stderr (`error: …` for 2, `goal not
//! reached: …` for 1); what a run that missed its goal did write (results
//! up to the failure) stays on disk.

/// `println!` that ends the program quietly when stdout is closed early
/// (`tdeploy … | head`), where `println!` would panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
        }
    }};
}

mod calibrate;
mod compare;
mod cycles;
mod deploy;
mod diagnose;
mod evaluate;
mod evaluation_table;
mod experiment;
mod inputs;
mod lab;
mod memory;
mod merge;
mod plan;
mod policy;
mod progress;
mod replay;
mod rig;
mod session;
mod simulate;
mod structure;
mod words;

use std::process::ExitCode;

use anyhow::{anyhow, bail, Context, Result};
use clap::{Arg, ArgMatches, Command};

use tensegrity_deploy::numerics::NumberRange;
use tensegrity_deploy::sim::PlantError;

/// How a command that ran to its end came out. Errors (bad input, I/O)
/// are the `Err` of [`run`] instead.
#[derive(Debug, Clone, PartialEq)]
#[must_use]
pub enum Outcome {
    /// The command did what it was asked: exit 0.
    GoalReached,
    /// The command ran but did not get there (why, in one line): exit 1.
    GoalMissed(String),
}

/// Exit code of a run that did not reach its goal.
const EXIT_GOAL_MISSED: u8 = 1;
/// Exit code of bad input or an I/O error (as clap's usage errors).
const EXIT_BAD_INPUT: u8 = 2;

/// The `tdeploy` command with its subcommands.
pub fn command() -> Command {
    Command::new("tdeploy")
        .about("Plan and learn the deployment of a tensegrity footbridge")
        .version(env!("CARGO_PKG_VERSION"))
        .subcommand_required(true)
        .subcommand(structure::command())
        .subcommand(simulate::command())
        .subcommand(lab::command())
        .subcommand(compare::command())
        .subcommand(diagnose::command())
        .subcommand(calibrate::command())
        .subcommand(experiment::command())
        .subcommand(plan::command())
        .subcommand(deploy::command())
        .subcommand(evaluate::command())
        .subcommand(merge::command())
        .subcommand(replay::command())
        .subcommand(cycles::command())
        .subcommand(policy::command())
        .subcommand(memory::command())
        .subcommand(session::command())
        .subcommand(rig::command())
}

/// The typed options of one subcommand.
#[derive(Debug, Clone)]
pub enum Options {
    /// `tdeploy structure`.
    Structure(structure::Options),
    /// `tdeploy simulate`.
    Simulate(simulate::Options),
    /// `tdeploy lab`.
    Lab(lab::Options),
    /// `tdeploy compare`.
    Compare(compare::Options),
    /// `tdeploy diagnose`.
    Diagnose(diagnose::Options),
    /// `tdeploy calibrate`.
    Calibrate(calibrate::Options),
    /// `tdeploy experiment`.
    Experiment(experiment::Options),
    /// `tdeploy plan`.
    Plan(plan::Options),
    /// `tdeploy deploy`.
    Deploy(deploy::Options),
    /// `tdeploy evaluate`.
    Evaluate(evaluate::Options),
    /// `tdeploy merge`.
    Merge(merge::Options),
    /// `tdeploy replay`.
    Replay(replay::Options),
    /// `tdeploy cycles`.
    Cycles(cycles::Options),
    /// `tdeploy policy`.
    Policy(policy::Options),
    /// `tdeploy memory`.
    Memory(memory::Options),
    /// `tdeploy session`.
    Session(session::Options),
    /// `tdeploy rig`.
    Rig(rig::Options),
}

impl Options {
    /// The options of the parsed command line, every flag value checked.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(match m.subcommand() {
            Some(("structure", a)) => Options::Structure(structure::Options::from_matches(a)?),
            Some(("simulate", a)) => Options::Simulate(simulate::Options::from_matches(a)?),
            Some(("lab", a)) => Options::Lab(lab::Options::from_matches(a)?),
            Some(("compare", a)) => Options::Compare(compare::Options::from_matches(a)?),
            Some(("diagnose", a)) => Options::Diagnose(diagnose::Options::from_matches(a)?),
            Some(("calibrate", a)) => Options::Calibrate(calibrate::Options::from_matches(a)?),
            Some(("experiment", a)) => Options::Experiment(experiment::Options::from_matches(a)?),
            Some(("plan", a)) => Options::Plan(plan::Options::from_matches(a)?),
            Some(("deploy", a)) => Options::Deploy(deploy::Options::from_matches(a)?),
            Some(("evaluate", a)) => Options::Evaluate(evaluate::Options::from_matches(a)?),
            Some(("merge", a)) => Options::Merge(merge::Options::from_matches(a)?),
            Some(("replay", a)) => Options::Replay(replay::Options::from_matches(a)?),
            Some(("cycles", a)) => Options::Cycles(cycles::Options::from_matches(a)?),
            Some(("policy", a)) => Options::Policy(policy::Options::from_matches(a)?),
            Some(("memory", a)) => Options::Memory(memory::Options::from_matches(a)?),
            Some(("session", a)) => Options::Session(session::Options::from_matches(a)?),
            Some(("rig", a)) => Options::Rig(rig::Options::from_matches(a)?),
            Some((other, _)) => bail!("unknown subcommand `{other}`"),
            None => bail!("a subcommand is required"),
        })
    }
}

/// Runs one subcommand.
pub fn run(options: &Options) -> Result<Outcome> {
    match options {
        Options::Structure(o) => structure::run(o),
        Options::Simulate(o) => simulate::run(o),
        Options::Lab(o) => lab::run(o),
        Options::Compare(o) => compare::run(o),
        Options::Diagnose(o) => diagnose::run(o),
        Options::Calibrate(o) => calibrate::run(o),
        Options::Experiment(o) => experiment::run(o),
        Options::Plan(o) => plan::run(o),
        Options::Deploy(o) => deploy::run(o),
        Options::Evaluate(o) => evaluate::run(o),
        Options::Merge(o) => merge::run(o),
        Options::Replay(o) => replay::run(o),
        Options::Cycles(o) => cycles::run(o),
        Options::Policy(o) => policy::run(o),
        Options::Memory(o) => memory::run(o),
        Options::Session(o) => session::run(o),
        Options::Rig(o) => rig::run(o),
    }
}

/// Says how `result` ended, in one line on stderr, and gives its exit code
/// (see the module notes).
pub fn finish(result: Result<Outcome>) -> ExitCode {
    match result {
        Ok(Outcome::GoalReached) => ExitCode::SUCCESS,
        Ok(Outcome::GoalMissed(why)) => {
            eprintln!("goal not reached: {}", one_line(&why));
            ExitCode::from(EXIT_GOAL_MISSED)
        }
        Err(e) => {
            eprintln!("error: {}", one_line(&format!("{e:#}")));
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

/// `text` with any line breaks folded: an error is one line.
fn one_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

/// The value of flag `id` (one clap gives a default or requires).
fn value<T: Clone + Send + Sync + 'static>(m: &ArgMatches, id: &str) -> Result<T> {
    m.get_one::<T>(id)
        .cloned()
        .ok_or_else(|| anyhow!("--{id}: missing"))
}

/// The value of the number flag `id`, checked against `range`.
fn number_in(m: &ArgMatches, id: &str, range: NumberRange) -> Result<f64> {
    let v: f64 = value(m, id)?;
    range.check(v).map_err(|why| anyhow!("--{id}: {why}"))?;
    Ok(v)
}

/// A plant (a replay, the truth of a run) that stopped, classified: a
/// solve that did not converge, a bridge that does not stand as built, or
/// seat arcs that did not settle, is a run that missed its goal (exit 1);
/// any other failure (effects the structure cannot take, a command the
/// model cannot apply) is bad input (exit 2).
fn plant_stopped(e: PlantError, context: String) -> Result<Outcome> {
    match e {
        PlantError::Solver { .. }
        | PlantError::AsBuilt { .. }
        | PlantError::SeatsUnsettled { .. } => Ok(Outcome::GoalMissed(format!("{context}: {e}"))),
        other => Err(anyhow::Error::new(other).context(context)),
    }
}

/// `--threads N`, one meaning for every command that runs in parallel.
fn threads_arg() -> Arg {
    Arg::new("threads")
        .long("threads")
        .value_parser(clap::value_parser!(usize))
        .help("Worker threads, at least 1 (default: one per core); the results do not depend on it")
}

/// The `--threads` count given (`None`: rayon's default); 0 refused.
fn threads_option(m: &ArgMatches) -> Result<Option<usize>> {
    let threads = m.get_one::<usize>("threads").copied();
    if threads == Some(0) {
        anyhow::bail!("--threads: must be at least 1");
    }
    Ok(threads)
}

/// `--force`, one meaning for every command that writes a results folder
/// (see [`tensegrity_deploy::io::output`]).
fn force_arg() -> Arg {
    Arg::new("force")
        .long("force")
        .action(clap::ArgAction::SetTrue)
        .help("Replace the output folder, whole, if it exists: an earlier result (of any seed or policy) or other files. Without it an existing non-empty folder is refused")
}

/// `--slip-event-substeps` of the commands that deploy a truth (`deploy`,
/// `cycles`, `evaluate`, `rig`): the truth splits its increments where a
/// joint reverses or stops, so its path no longer depends on the 1 cm
/// increment.
fn truth_substeps_arg() -> Arg {
    Arg::new("slip-event-substeps")
        .long("slip-event-substeps")
        .action(clap::ArgAction::SetTrue)
        .help("The truth (the simulated bridge) splits each increment in which a joint reverses or stops, in halves down to about 1 mm, so its path no longer depends on its 1 cm increment (62 µm between 1 cm and 1 mm over a 5 cm reel-in and pay-out at μ 0.2, against 1.7 mm); about 1.1× the time. It judges the controller on the more exact path; the controller's model is unchanged (a model file asks for the same with `[solver] slip_event_substeps = true`, a truth file too). Recorded in the truth.toml a deploy writes and in evaluate's evaluation.toml")
}

/// Runs `work` on `threads` worker threads (`None`: rayon's default, one
/// per core); the results of the library do not depend on the count.
fn with_threads<R: Send>(threads: Option<usize>, work: impl FnOnce() -> R + Send) -> Result<R> {
    Ok(match threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("--threads: cannot start the worker threads")?
            .install(work),
        None => work(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_line_definition_is_consistent() {
        command().debug_assert();
    }

    #[test]
    fn every_subcommand_has_options() {
        for sub in command().get_subcommands() {
            let name = sub.get_name().to_string();
            let mut args = vec!["tdeploy".to_string(), name.clone()];
            // A subcommand with actions (`policy migrate`): its first.
            let sub = match sub.get_subcommands().next() {
                Some(action) => {
                    args.push(action.get_name().to_string());
                    action
                }
                None => sub,
            };
            // The required positional arguments and flags, with a value.
            for a in sub.get_arguments().filter(|a| a.is_required_set()) {
                if let Some(long) = a.get_long() {
                    args.push(format!("--{long}"));
                }
                args.push(if a.get_id() == "add" {
                    "motor".into()
                } else {
                    format!("some-{}", a.get_id())
                });
            }
            let m = command().try_get_matches_from(&args).unwrap();
            assert!(Options::from_matches(&m).is_ok(), "{name}: {args:?}");
        }
    }

    #[test]
    fn a_bad_flag_value_names_the_flag() {
        let m = command()
            .try_get_matches_from(["tdeploy", "simulate", "--tol=-1"])
            .unwrap();
        let e = Options::from_matches(&m).unwrap_err().to_string();
        assert_eq!(e, "--tol: must be a finite number in (0, 0.01], got -1");
    }

    #[test]
    fn errors_are_one_line() {
        assert_eq!(one_line("a\n  b\n\nc"), "a; b; c");
    }
}
