//! `tdeploy evaluate [--policy P]… [--scenarios N] [--seed S]
//! [--distribution F] [--model M] [--problem F] [--cycles K]
//! [--slip-event-substeps] [--shard k/n]
//! [--threads N] [-o DIR] [--force]`: offline evaluation of policies on
//! the same seeded scenarios ([`tensegrity_deploy::studies::evaluation`]).
//!
//! Writes in DIR (as a whole: a crash leaves the old set or the new one):
//! `evaluation.toml` (what ran), `runs.csv` (one row per scenario and
//! policy, with the scenario's seed and drawn values), `summary.csv`,
//! `paired.csv` (the first policy against each other: exact McNemar on
//! success, exact sign tests on the final true gap and the commands),
//! `by_fold.csv` (each policy's runs in 10 cm bands of each half's fold:
//! succeeded, broke limits, failed otherwise; also printed when the runs
//! span more than one band), and `timing.csv` (planning times, the only file that changes from run
//! to run), formats in [`tensegrity_deploy::io::evaluation_files`] and
//! [`tensegrity_deploy::io::evaluation_summary`]; and `evaluation.svg`
//! ([`tensegrity_deploy::report::evaluation_figure`]). Every other file
//! is the same, byte for byte, at any thread count, and `tdeploy merge`
//! of the shards `1/n … n/n` of a sweep writes the same files as the
//! sweep in one piece.
//!
//! Exit 0 when no run broke a truth limit, 1 when one did (the
//! evaluation's standard: violations must be 0), 2 on bad input.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};

use tensegrity_deploy::control::check_same_bridge;
use tensegrity_deploy::io::evaluation_files::{
    read_distribution, EvaluationRecord, EvaluationRuns,
};
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::model::JointFriction;
use tensegrity_deploy::plan::Policy;
use tensegrity_deploy::studies::evaluation::{
    evaluate, EvaluationSetup, ScenarioDistribution, Shard,
};

use super::evaluation_table::{all_policies, print_and_write};
use super::inputs::{
    model_fingerprint, planning_model_and_bridge, policy_or_default, problem_or_default,
};
use super::progress::{Progress, Unit};
use super::{value, with_threads, Outcome};

/// Most scenarios one sweep may have: a bound on the work a flag can ask
/// for (a million deployments is about a day on 2 cores).
pub const MAX_SCENARIOS: usize = 1_000_000;

/// Most cycles per scenario (the learning curve of `tdeploy cycles` has
/// settled well before).
pub const MAX_CYCLES: usize = 100;

/// The `evaluate` subcommand's arguments.
pub fn command() -> Command {
    Command::new("evaluate")
        .about("Evaluate policies offline on the same seeded scenarios (hidden effects, noise, fold drawn from a distribution); exit code 1 if any run broke a truth limit")
        .arg(Arg::new("policy").long("policy").action(ArgAction::Append).value_parser(value_parser!(PathBuf)).help("Policy file; repeat to compare policies on the same scenarios (the first against each other). Default: policies/qp.toml's settings, built in"))
        .arg(Arg::new("scenarios").long("scenarios").default_value("100").value_parser(value_parser!(usize)).help("Scenarios in the sweep (1 to 1000000)"))
        .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the scenario draws (each scenario's seed is recorded)"))
        .arg(Arg::new("distribution").long("distribution").value_parser(value_parser!(PathBuf)).help("Scenario distribution file (TOML, format tensegrity-deploy/scenarios/1). Default: joint friction, motor slip and backlash, stiffness and joint-mass errors over their plausible ranges; standard sensor noise; the 40 cm fold"))
        .arg(Arg::new("model").long("model").value_parser(value_parser!(PathBuf)).help("Model file the controller plans on. Default: the reference bridge without friction"))
        .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file (its start fold is replaced by each scenario's)"))
        .arg(Arg::new("cycles").long("cycles").default_value("1").value_parser(value_parser!(usize)).help("Deployment-fold cycles per scenario (1 to 100), each run from an empty case memory: how a policy with a [memory] section does after learning. Each run's row reports its last cycle; a limit broken in any cycle counts"))
        .arg(super::truth_substeps_arg())
        .arg(Arg::new("shard").long("shard").default_value("1/1").help("Run shard k of n (scenarios i with i mod n = k − 1); `tdeploy merge` joins the shards"))
        .arg(super::threads_arg())
        .arg(Arg::new("out").long("out").short('o').default_value("out/evaluate").value_parser(value_parser!(PathBuf)).help("Folder for evaluation.toml, runs.csv, summary.csv, paired.csv, by_fold.csv, evaluation.svg, timing.csv"))
        .arg(super::force_arg())
}

/// Options of `tdeploy evaluate`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Policy files; empty: the built-in default.
    pub policies: Vec<PathBuf>,
    /// Scenarios in the sweep.
    pub scenarios: usize,
    /// Seed of the draws.
    pub seed: u64,
    /// Distribution file; `None`: the default distribution.
    pub distribution: Option<PathBuf>,
    /// Controller's model file; `None`: frictionless reference bridge.
    pub model: Option<PathBuf>,
    /// Problem file; `None`: the default problem.
    pub problem: Option<PathBuf>,
    /// Deployment-fold cycles per scenario.
    pub cycles: usize,
    /// The truths split their increments at slip events.
    pub truth_slip_event_substeps: bool,
    /// This run's shard.
    pub shard: Shard,
    /// Worker threads; `None`: rayon's default.
    pub threads: Option<usize>,
    /// Results folder.
    pub out: PathBuf,
    /// Replace a folder of other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let threads = super::threads_option(m)?;
        let scenarios: usize = value(m, "scenarios")?;
        if !(1..=MAX_SCENARIOS).contains(&scenarios) {
            bail!("--scenarios: {scenarios} is not from 1 to {MAX_SCENARIOS}");
        }
        let cycles: usize = value(m, "cycles")?;
        if !(1..=MAX_CYCLES).contains(&cycles) {
            bail!("--cycles: {cycles} is not from 1 to {MAX_CYCLES}");
        }
        let shard_text: String = value(m, "shard")?;
        let shard = Shard::parse(&shard_text)
            .with_context(|| format!("--shard: `{shard_text}` is not k/n with 1 ≤ k ≤ n"))?;
        Ok(Options {
            policies: m
                .get_many::<PathBuf>("policy")
                .map(|v| v.cloned().collect())
                .unwrap_or_default(),
            scenarios,
            seed: value(m, "seed")?,
            distribution: m.get_one::<PathBuf>("distribution").cloned(),
            model: m.get_one::<PathBuf>("model").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            cycles,
            truth_slip_event_substeps: m.get_flag("slip-event-substeps"),
            shard,
            threads,
            out: value(m, "out")?,
            force: m.get_flag("force"),
        })
    }
}

/// Runs `tdeploy evaluate`.
pub fn run(o: &Options) -> Result<Outcome> {
    let policies: Vec<Policy> = if o.policies.is_empty() {
        vec![policy_or_default(None)?]
    } else {
        o.policies
            .iter()
            .map(|p| policy_or_default(Some(p)))
            .collect::<Result<_>>()?
    };
    // A self-diagnosis per cycle (seconds to tens of seconds) over every
    // scenario would dwarf the evaluation; refused rather than run
    // without it under the policy's name.
    for (policy, path) in policies.iter().zip(&o.policies) {
        if policy.memory.is_some_and(|m| m.model_learning_enable) {
            bail!(
                "{}: [memory] model_learning_enable: evaluate does not learn models between cycles (a self-diagnosis per cycle and scenario); `tdeploy cycles` does, or set it to false",
                path.display()
            );
        }
    }
    let names: Vec<String> = policies.iter().map(|p| p.name.clone()).collect();
    if let Some(dup) = names
        .iter()
        .enumerate()
        .find(|(i, n)| names[..*i].contains(n))
    {
        bail!(
            "two policies are named `{}`: give each policy file its own name",
            dup.1
        );
    }
    let distribution = match &o.distribution {
        Some(p) => read_distribution(p)?,
        None => ScenarioDistribution::default(),
    };
    let (model, bridge) =
        planning_model_and_bridge(o.model.as_deref(), JointFriction::frictionless())?;
    // Every truth is drawn on the bridge; a model that is not that bridge
    // node for node would leave every run unstarted, so it is refused
    // once, here (flexible supports' bearing and ground nodes, after the
    // bridge's, are accepted).
    if let (Some(path), Err(e)) = (&o.model, check_same_bridge(model.structure(), &bridge)) {
        bail!(
            "{}: the controller cannot plan on this model against truths drawn on its bridge: {e}",
            path.display()
        );
    }
    let problem = problem_or_default(
        o.problem.as_deref(),
        model.structure().continuous_cables.len(),
    )?;
    let record = EvaluationRecord::new(
        o.seed,
        o.scenarios,
        o.shard,
        &policies,
        o.model
            .as_ref()
            .map_or("reference".into(), |p| p.display().to_string()),
        o.model.as_deref().map(model_fingerprint).transpose()?,
        o.cycles,
        o.truth_slip_event_substeps,
        distribution.clone(),
    )?;
    // Claimed before the work, so that a refusal costs nothing.
    let folder = ResultsFolder::claim(&o.out, "evaluate", o.force)?;

    let indices = o.shard.scenarios(o.scenarios);
    say!(
        "evaluate: {} × {} scenarios × {} cycles (shard {}/{} of {}, seed {}); policies {}{}",
        indices.len(),
        policies.len(),
        o.cycles,
        o.shard.index,
        o.shard.count,
        o.scenarios,
        o.seed,
        names.join(", "),
        if o.truth_slip_event_substeps {
            "; truths split at slip events"
        } else {
            ""
        }
    );
    let progress = Progress::new(
        Unit::Deployments,
        (indices.len() * policies.len()) as u64,
        false,
    );
    let setup = EvaluationSetup {
        bridge: &bridge,
        model: &model,
        policies: &policies,
        distribution: &distribution,
        problem: &problem,
        seed: o.seed,
        cycles: o.cycles,
        truth_slip_event_substeps: o.truth_slip_event_substeps,
    };
    let (scenarios, results) = with_threads(o.threads, || {
        evaluate(&setup, &indices, &|| progress.tick())
    })?;
    progress.finish();
    let runs = EvaluationRuns::new(&distribution, names, &scenarios, results);
    let limits = print_and_write(&record, &runs, folder.path())?;
    folder.commit()?;
    say!(
        "results in {} (evaluation.toml, runs.csv, summary.csv, paired.csv, by_fold.csv, evaluation.svg; planning times in timing.csv)",
        o.out.display()
    );
    Ok(match all_policies(&limits).failure() {
        None => Outcome::GoalReached,
        Some(why) => Outcome::GoalMissed(why),
    })
}
