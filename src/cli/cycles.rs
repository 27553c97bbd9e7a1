//! `tdeploy cycles [--truth T] [--model M] [--policy P] [--problem F]
//! [--cycles N] [--memory FILE] [--temperature °C] [--seed S]
//! [--slip-event-substeps] [--threads N] [-o DIR] [--force]`: repeated
//! deployment-fold cycles on one truth, learning into a case memory
//! ([`tensegrity_deploy::studies::cycles`]).
//!
//! Defaults: the truth of `tdeploy deploy` (μ = 0.2, 3 mm backlash), the
//! frictionless reference bridge as the controller's model, the policy
//! `policies/memory.toml` (built in), 10 cycles, seed 1. A truth with a
//! thermal effect needs `--temperature` (°C, every cycle at it).
//!
//! Writes in DIR (as a whole): `cycles.csv` (one row per cycle) and
//! `timing.csv` (planning time per cycle, the only file that changes from
//! run to run), formats in [`tensegrity_deploy::io::cycles_files`];
//! `cycles.svg`, the learning curve
//! ([`tensegrity_deploy::report::cycles_figure`]); and, without
//! `--memory`, `memory.tdm` with the cycles' cases
//! ([`tensegrity_deploy::io::memory_file`]). With `--memory FILE` the
//! cases already in FILE are learnt from and each new case is appended to
//! it as its cycle ends (atomically: a crash loses nothing stored before).
//!
//! Exit 0 when every cycle connected with no truth limit broken, 1
//! otherwise, 2 on bad input.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::control::{ClosedLoopSetup, DeployError, Deployment};
use tensegrity_deploy::io::cycles_files::write_cycles;
use tensegrity_deploy::io::memory_file::{append_checked_case, read_memory_or_empty};
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::policy_file::{parse_policy, read_policy};
use tensegrity_deploy::io::{write_atomically, FileError};
use tensegrity_deploy::learn::{Case, CaseMemory};
use tensegrity_deploy::model::JointFriction;
use tensegrity_deploy::plan::Policy;
use tensegrity_deploy::report::cycles_figure::cycles_svg;
use tensegrity_deploy::sim::standard_sensors;
use tensegrity_deploy::studies::cycles::{run_cycles, CycleObserver, CycleResult};

use super::inputs::{
    deployment_temperature, planning_effect_model, planning_model, problem_or_default,
    truth_or_default,
};
use super::words::mm;
use super::{plant_stopped, value, with_threads, Outcome};

/// The built-in default policy of `cycles`: `policies/memory.toml`.
const MEMORY_POLICY: &str = include_str!("../../policies/memory.toml");

/// Most cycles one run may have: a bound on the work a flag can ask for.
pub const MAX_CYCLES: usize = 10_000;

/// The `cycles` subcommand's arguments.
pub fn command() -> Command {
    Command::new("cycles")
        .about("Repeated deployment-fold cycles on one truth with hidden effects, learning into a case memory: the learning curve; exit code 1 if a cycle did not connect or broke a truth limit")
        .arg(Arg::new("truth").long("truth").value_parser(value_parser!(PathBuf)).help("Truth model file (TOML). Default: the reference bridge with joint friction μ = 0.2 (wrap angle) and 3 mm motor backlash"))
        .arg(Arg::new("model").long("model").value_parser(value_parser!(PathBuf)).help("Model file the controller plans on. Default: the reference bridge without friction"))
        .arg(Arg::new("policy").long("policy").value_parser(value_parser!(PathBuf)).help("Policy file. Default: policies/memory.toml's settings, built in (the QP planner with the case memory)"))
        .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file (fold, connection, limits)"))
        .arg(Arg::new("cycles").long("cycles").default_value("10").value_parser(value_parser!(usize)).help("Cycles to run (1 to 10000)"))
        .arg(Arg::new("memory").long("memory").value_parser(value_parser!(PathBuf)).help("Memory file to learn from and append each cycle's case to (created if missing). Default: a new memory, written to DIR/memory.tdm"))
        .arg(Arg::new("temperature").long("temperature").value_parser(value_parser!(f64)).help("Air temperature during the deployment, °C (held throughout); needed by a truth with a thermal effect, which expands its members from their reference temperature"))
        .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the sensor noise (cycle k uses a seed derived from it)"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/cycles").value_parser(value_parser!(PathBuf)).help("Folder for cycles.csv, cycles.svg, timing.csv (and memory.tdm without --memory)"))
        .arg(super::truth_substeps_arg())
        .arg(super::threads_arg())
        .arg(super::force_arg())
}

/// Options of `tdeploy cycles`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Truth model file; `None`: the default truth.
    pub truth: Option<PathBuf>,
    /// Controller's model file; `None`: frictionless reference bridge.
    pub model: Option<PathBuf>,
    /// Policy file; `None`: the built-in memory policy.
    pub policy: Option<PathBuf>,
    /// Problem file; `None`: the default problem.
    pub problem: Option<PathBuf>,
    /// Cycles to run.
    pub cycles: usize,
    /// Memory file; `None`: a new memory in the results folder.
    pub memory: Option<PathBuf>,
    /// Air temperature, °C (`--temperature`); `None`: not given (refused
    /// with a thermal truth).
    pub temperature_c: Option<f64>,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// The truth splits its increments at slip events.
    pub truth_slip_event_substeps: bool,
    /// Worker threads; `None`: rayon's default.
    pub threads: Option<usize>,
    /// Results folder.
    pub out: PathBuf,
    /// Replace an existing results folder.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let cycles: usize = value(m, "cycles")?;
        if !(1..=MAX_CYCLES).contains(&cycles) {
            bail!("--cycles: {cycles} is not from 1 to {MAX_CYCLES}");
        }
        Ok(Options {
            truth: m.get_one::<PathBuf>("truth").cloned(),
            model: m.get_one::<PathBuf>("model").cloned(),
            policy: m.get_one::<PathBuf>("policy").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            cycles,
            memory: m.get_one::<PathBuf>("memory").cloned(),
            temperature_c: m.get_one::<f64>("temperature").copied(),
            seed: value(m, "seed")?,
            truth_slip_event_substeps: m.get_flag("slip-event-substeps"),
            threads: super::threads_option(m)?,
            out: value(m, "out")?,
            force: m.get_flag("force"),
        })
    }
}

/// Appends each cycle's case to the memory file as the cycle ends; the
/// first failure is kept (and ends the command after the cycles).
struct MemoryWriter<'a> {
    path: &'a Path,
    /// The memory's index of the next case appended.
    next_case: usize,
    /// Motors and midspan pairs of the bridge, which every case is
    /// checked against before it is written.
    motors: usize,
    pairs: usize,
    failure: Option<FileError>,
}

impl CycleObserver for MemoryWriter<'_> {
    fn on_start(&mut self, note: &str) {
        say!("model: {note}");
    }

    fn on_cycle(&mut self, result: &CycleResult, _: &Deployment, case: &Case) {
        if self.failure.is_none() {
            match append_checked_case(self.path, case, self.next_case, self.motors, self.pairs) {
                Ok(()) => self.next_case += 1,
                Err(e) => self.failure = Some(e),
            }
        }
        // A cycle that did not connect says why (what binds, or which
        // limits the truth broke).
        let why = if result.status == "connected" {
            String::new()
        } else {
            format!(" ({})", result.verdict)
        };
        say!(
            "cycle {}: {}{why} after {} commands ({} corrective), gap after the first approach {} mm, final {} mm; readings against the controller's model {}",
            result.cycle,
            result.status,
            result.commands,
            result.corrective_commands.map_or("–".into(), |c| c.to_string()),
            mm(result.approach_gap_m),
            mm(result.final_gap_m),
            result
                .planning_model_rms
                .map_or("– (its replay failed)".into(), |r| format!("{r:.2} σ RMS"))
        );
        if let Some(note) = &result.planning_note {
            say!("  planned on the model file: {note}");
        }
        if let Some(why) = &result.memory_declined {
            say!("  memory: no guidance: {why}");
        }
        if let Some(error) = &result.adaptation_error {
            say!("  memory: no guidance, its case could not be adapted: {error}");
        }
        if let Some(u) = &result.model_update {
            let scored = if u.held_out { "held-out" } else { "in-sample" };
            let planner = if u.planner_takes == "none" || u.planner_takes.is_empty() {
                "the planner takes none of it".to_string()
            } else {
                format!("the planner takes {}", u.planner_takes)
            };
            let what = match u.outcome() {
                "accepted" => format!(
                    "{scored} {:.2} σ on the model planned on → {:.2} σ fitted: the next cycle's model carries {} ({planner})",
                    u.planned_rms, u.fitted_rms, u.carried
                ),
                "not_better" => format!(
                    "{scored} {:.2} σ on the model planned on, {:.2} σ fitted: the next cycle's model keeps {}",
                    u.planned_rms, u.fitted_rms, u.carried
                ),
                "nothing_learnt" => format!(
                    "{scored} {:.2} σ on the model planned on; nothing learnt, the next cycle's model keeps {}",
                    u.planned_rms, u.carried
                ),
                _ => format!("the next cycle's model keeps {}", u.carried),
            };
            let note = u.note.as_ref().map_or(String::new(), |n| format!(" ({n})"));
            say!("  model: {}{note} ({:.1} s); {what}", u.verdict, u.time_s);
        }
    }
}

/// Runs `tdeploy cycles`.
pub fn run(o: &Options) -> Result<Outcome> {
    let policy: Policy = match &o.policy {
        Some(p) => read_policy(p)?,
        None => parse_policy(MEMORY_POLICY, Path::new("policies/memory.toml (built in)"))?,
    };
    let model = planning_model(o.model.as_deref(), JointFriction::frictionless())?;
    // The controller's model as the measurement tools replay it: each
    // cycle's readings are compared with it (the model's error per
    // cycle), stepped as the planner steps its model.
    let mut replayed = planning_effect_model(o.model.as_deref())?;
    replayed.increment_m = policy.increment_m;
    // The default truth stands on the bridge the model file names, before
    // its effects: those are the controller's belief, not the bridge's.
    let (_, truth, truth_words) = truth_or_default(
        o.truth.as_deref(),
        o.model.as_deref(),
        o.truth_slip_event_substeps,
    )?;
    let temperature_c = deployment_temperature(o.temperature_c, &truth.effects, &truth_words)?;
    let problem = problem_or_default(
        o.problem.as_deref(),
        model.structure().continuous_cables.len(),
    )?;
    let mut memory = match &o.memory {
        Some(p) => read_memory_or_empty(
            p,
            model.structure().continuous_cables.len(),
            model.structure().midspan_pairs.len(),
        )?,
        None => CaseMemory::default(),
    };
    let stored_before = memory.cases.len();
    let folder = ResultsFolder::claim(&o.out, "cycles", o.force)?;
    let memory_path = match &o.memory {
        Some(p) => p.clone(),
        None => folder.path().join("memory.tdm"),
    };
    let sensors = standard_sensors(&truth.structure);
    say!(
        "cycles: {} cycles, policy {}{}, truth {truth_words}, seed {}; memory {} ({} cases stored)",
        o.cycles,
        policy.name,
        if policy.memory.is_some() {
            " (learns from the memory)"
        } else {
            " (no memory)"
        },
        o.seed,
        o.memory
            .as_ref()
            .map_or("new".into(), |p| p.display().to_string()),
        stored_before
    );
    let setup = ClosedLoopSetup {
        model: &model,
        problem: &problem,
        policy: &policy,
        truth: &truth,
        sensors: &sensors,
        temperature_c,
        seed: o.seed,
    };
    let mut writer = MemoryWriter {
        path: &memory_path,
        next_case: stored_before,
        motors: model.structure().continuous_cables.len(),
        pairs: model.structure().midspan_pairs.len(),
        failure: None,
    };
    let end = match with_threads(o.threads, || {
        run_cycles(&setup, o.cycles, &mut memory, Some(&replayed), &mut writer)
    })? {
        Ok(end) => end,
        // The truth failing to reach a start is a solve that did not
        // converge (exit 1), as in `deploy`; the rest is input it cannot use.
        Err(DeployError::TruthStart(e)) => {
            return plant_stopped(e, "the truth plant, reaching the folded start".into())
        }
        Err(e) => return Err(e.into()),
    };
    if let Some(e) = writer.failure {
        return Err(e.into());
    }
    write_cycles(folder.path(), &end.results)?;
    let svg = cycles_svg(&policy.name, o.cycles, &end.results)
        .map_err(|e| anyhow::anyhow!("drawing cycles.svg: {e}"))?;
    write_atomically(&folder.path().join("cycles.svg"), svg.as_bytes())?;
    folder.commit()?;
    say!(
        "results in {} (cycles.csv, cycles.svg, timing.csv{})",
        o.out.display(),
        if o.memory.is_none() {
            ", memory.tdm"
        } else {
            ""
        }
    );
    if let Some(stop) = end.stopped {
        return Ok(Outcome::GoalMissed(stop.describe()));
    }
    let failed: Vec<String> = end
        .results
        .iter()
        .filter(|r| r.status != "connected" || r.truth_limit_violations > 0)
        .map(|r| r.cycle.to_string())
        .collect();
    Ok(if failed.is_empty() {
        Outcome::GoalReached
    } else {
        Outcome::GoalMissed(format!(
            "cycles {} did not connect or broke a truth limit",
            failed.join(", ")
        ))
    })
}
