//! `tdeploy deploy [--truth F] [--model F] [--policy P] [--problem F]
//! [--seed S] [--threads N] [-o DIR] [--force] [--json]`: a closed-loop deployment
//! of a simulated bridge (the truth) by the controller planning on its
//! model, corrected by a noisy measurement after every command (see
//! [`tensegrity_deploy::plan::closed_loop`]).
//!
//! Defaults: the truth is the reference bridge with
//! [`tensegrity_deploy::sim::default_truth`]'s effects (μ = 0.2, 3 mm motor
//! backlash); the controller plans on the same bridge without friction;
//! the policy is `policies/qp.toml`'s (built in); the problem is the
//! default 40 cm fold; seed 1.
//!
//! Prints one line per command (command per motor in mm, the largest
//! measured gap, the truth's worst utilisation, the QP status, the
//! planning time) and a verdict; exit 0 when connected, 1 when not, 2 on
//! bad input. With `--json`, prints `summary.json` instead.
//!
//! Writes in DIR, as a whole (a crash leaves the old set or the new one;
//! a folder holding files tdeploy did not write needs `--force`):
//! - `commands.csv`: the command file (`tdeploy simulate -c` replays it):
//!   step 0 is the fold from the designed state, steps 1… the commands;
//! - `log/`: the measurement log (`tdeploy compare`/`diagnose` read it):
//!   one cycle whose step 0 is the designed state (not measured), step 1
//!   the fold (the folded start, measured) and steps 2… the commands;
//! - `truth.toml`, `model.toml`: the truth and the controller's model as
//!   model files (`tdeploy compare DIR/truth.toml DIR/log` shows the
//!   sensor noise alone; with `model.toml`, what the controller's model
//!   misses);
//! - `problem.toml`: the problem solved (given or the default), every
//!   field written out (`tdeploy replay DIR/log --problem DIR/problem.toml`
//!   replays under the same limits);
//! - `deployment.csv`: one row per step (0: the start): predicted,
//!   measured and true gap per pair, the truth's utilisation, minimum
//!   tension and limit violations along the command, the planner's QP
//!   status, trust region, rejected trials and active constraints;
//! - `summary.json`: status, verdict, gaps, counts (format
//!   `tensegrity-deploy/deployment/1`);
//! - `deployment.svg`: the measured gaps over the commands beside the
//!   truth's final state;
//! - `timing.csv`: `step,planning_time_s`. The only file that changes from
//!   run to run: every other one is the same, byte for byte, for the same
//!   inputs and seed at any thread count.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use tensegrity_deploy::control::{
    deploy_closed_loop, ClosedLoopSetup, DeployError, DeployObserver, DeployRecord, DeployStart,
    Deployment,
};
use tensegrity_deploy::io::log::write_log;
use tensegrity_deploy::io::model_file::{read_model, ModelFile, StructureSource};
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::problem_file::problem_to_toml;
use tensegrity_deploy::io::{write_atomically, write_json, CsvTable};
use tensegrity_deploy::measure::log::{Cycle, MeasurementLog};
use tensegrity_deploy::model::{Effects, JointFriction};
use tensegrity_deploy::plan::PlanStatus;
use tensegrity_deploy::report::deployment_figure::deployment_svg;
use tensegrity_deploy::report::drawing::DrawnState;
use tensegrity_deploy::sim::default_truth::{default_truth, default_truth_effects};
use tensegrity_deploy::sim::{standard_sensors, EffectModel, PlantError};

use super::plan::{
    mm_list, planning_model, policy_or_default, problem_or_default, write_fold_and_commands,
};
use super::{value, Outcome};

/// The `format` of `summary.json`; a folder holding it is one this command
/// wrote and may write again.
const SUMMARY_FORMAT: &str = "tensegrity-deploy/deployment/1";

/// The `deploy` subcommand's arguments.
pub fn command() -> Command {
    Command::new("deploy")
        .about("Deploy a simulated bridge (the truth) in closed loop: plan on the model, command the truth, measure, correct; exit code 1 if it does not connect")
        .arg(Arg::new("truth").long("truth").value_parser(value_parser!(PathBuf)).help("Truth model file (TOML: structure and effects) standing in for the real bridge. Default: the reference bridge with joint friction μ = 0.2 (wrap angle) and 3 mm motor backlash"))
        .arg(Arg::new("model").long("model").value_parser(value_parser!(PathBuf)).help("Model file the controller plans on (its structure, stiffness and friction). Default: the reference bridge without friction"))
        .arg(Arg::new("policy").long("policy").value_parser(value_parser!(PathBuf)).help("Policy file (default: policies/qp.toml's settings, built in)"))
        .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file (default: fold 0.40 m, 30 mm connection, documented limits)"))
        .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the sensor noise"))
        .arg(Arg::new("threads").long("threads").value_parser(value_parser!(usize)).help("Worker threads, at least 1 (default: one per core); the results do not depend on it"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/deploy").value_parser(value_parser!(PathBuf)).help("Folder for commands.csv, log/, deployment.csv, summary.json, deployment.svg, timing.csv, truth.toml and model.toml"))
        .arg(Arg::new("force").long("force").action(ArgAction::SetTrue).help("Replace a folder that holds files tdeploy did not write"))
        .arg(Arg::new("json").long("json").action(ArgAction::SetTrue).help("Print summary.json on stdout instead of the per-command lines and verdict (no progress bar)"))
}

/// Options of `tdeploy deploy`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Truth model file; `None`: the default truth.
    pub truth: Option<PathBuf>,
    /// Controller's model file; `None`: the frictionless reference bridge.
    pub model: Option<PathBuf>,
    /// Policy file; `None`: the built-in default.
    pub policy: Option<PathBuf>,
    /// Problem file; `None`: the default problem.
    pub problem: Option<PathBuf>,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Worker threads; `None`: rayon's default.
    pub threads: Option<usize>,
    /// Results folder.
    pub out: PathBuf,
    /// Print the summary as JSON instead of lines.
    pub json: bool,
    /// Replace a folder of other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let threads = m.get_one::<usize>("threads").copied();
        if threads == Some(0) {
            bail!("--threads: must be at least 1");
        }
        Ok(Options {
            truth: m.get_one::<PathBuf>("truth").cloned(),
            model: m.get_one::<PathBuf>("model").cloned(),
            policy: m.get_one::<PathBuf>("policy").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            seed: value(m, "seed")?,
            threads,
            out: value(m, "out")?,
            json: m.get_flag("json"),
            force: m.get_flag("force"),
        })
    }
}

/// A model file's structure source made independent of the working
/// folder, so that the copy written in DIR still finds its structure.
fn absolute(file: ModelFile) -> Result<ModelFile> {
    Ok(match file.structure {
        StructureSource::File(p) if p.is_relative() => ModelFile {
            structure: StructureSource::File(
                std::env::current_dir()
                    .context("the working folder")?
                    .join(p),
            ),
            ..file
        },
        _ => file,
    })
}

/// Command per motor in mm, runs of equal values folded: `-50.0×10`.
pub(super) fn compact_mm(command_m: &[f64]) -> String {
    let mut runs: Vec<(String, usize)> = Vec::new();
    for c in command_m {
        let text = format!("{:.1}", 1e3 * c);
        match runs.last_mut() {
            Some((t, n)) if *t == text => *n += 1,
            _ => runs.push((text, 1)),
        }
    }
    runs.iter()
        .map(|(t, n)| {
            if *n > 1 {
                format!("{t}×{n}")
            } else {
                t.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// A gap in mm with one decimal, `-` when unknown.
pub(super) fn gap_mm(g: Option<f64>) -> String {
    g.map(|g| format!("{:.1}", 1e3 * g))
        .unwrap_or_else(|| "-".into())
}

/// The per-command lines and progress bar.
struct Printer {
    bar: ProgressBar,
    quiet: bool,
}

impl Printer {
    fn say(&self, line: String) {
        if !self.quiet {
            self.bar.suspend(|| say!("{line}"));
        }
    }
}

impl DeployObserver for Printer {
    fn on_start(&mut self, s: &DeployStart) {
        self.bar.set_length(s.max_commands as u64);
        self.say(format!(
            "start: gaps measured {} mm (true {} mm, controller's model {} mm)",
            s.measured_gaps_m
                .iter()
                .map(|g| gap_mm(*g))
                .collect::<Vec<_>>()
                .join(", "),
            mm_list(&s.true_gaps_m),
            mm_list(&s.model_gaps_m)
        ));
    }

    fn on_command(&mut self, r: &DeployRecord) {
        self.bar.inc(1);
        self.say(format!(
            "{:>3}: command {} mm; largest gap {} mm; truth utilisation {:.2}{}; {}; {:.0} ms",
            r.index,
            compact_mm(&r.command_m),
            gap_mm(r.largest_measured_gap_m()),
            r.truth_worst_utilisation,
            if r.truth_violations.is_empty() {
                String::new()
            } else {
                format!(" ({} LIMITS BROKEN)", r.truth_violations.len())
            },
            r.qp_status
                .map(|s| format!("QP {}", s.as_str()))
                .unwrap_or_else(|| "no QP".into()),
            1e3 * r.planning_time_s
        ));
    }
}

/// `summary.json` (no timings: it is compared byte for byte).
#[derive(Serialize)]
struct Summary<'a> {
    format: &'static str,
    verdict: String,
    connected: bool,
    status: &'a PlanStatus,
    seed: u64,
    policy: &'a str,
    planner: &'static str,
    truth: String,
    model: String,
    /// The problem file given, or the built-in default; `problem.toml`
    /// beside the summary holds its values either way.
    problem: String,
    commands: usize,
    max_commands: usize,
    connection_tolerance_m: f64,
    start_payout_m: &'a [f64],
    start_measured_gaps_m: &'a [Option<f64>],
    start_true_gaps_m: &'a [f64],
    final_measured_gaps_m: &'a [Option<f64>],
    final_true_gaps_m: &'a [f64],
    largest_final_measured_gap_m: Option<f64>,
    largest_final_true_gap_m: Option<f64>,
    truth_worst_utilisation: f64,
    truth_limit_violations: usize,
    truth_increments_checked: usize,
    first_command_below_60_mm: Option<usize>,
    corrective_commands: Option<usize>,
}

/// `n command(s)`.
fn commands_count(n: usize) -> String {
    format!("{n} command{}", if n == 1 { "" } else { "s" })
}

/// The verdict line.
fn verdict(d: &Deployment) -> String {
    let gaps = format!(
        "largest measured gap {} mm, true {} mm",
        gap_mm(d.final_measured_gap_m()),
        gap_mm(d.final_true_gap_m())
    );
    let n = commands_count(d.records.len());
    match &d.status {
        PlanStatus::Connected => format!("connected after {n} ({gaps})"),
        other => format!("not connected: {} (after {n}; {gaps})", other.describe()),
    }
}

/// `deployment.csv`: one row per step, step 0 the start.
fn deployment_table(d: &Deployment) -> CsvTable {
    let pairs = d.start.true_gaps_m.len();
    let mut header = vec!["step".to_string()];
    for kind in ["predicted", "measured", "true"] {
        header.extend((0..pairs).map(|p| format!("{kind}_gap_{p}_m")));
    }
    header.extend(
        [
            "largest_measured_gap_m",
            "largest_true_gap_m",
            "truth_worst_utilisation",
            "truth_min_tension_n",
            "truth_violations",
            "truth_increments",
            "truth_increments_checked",
            "model_worst_utilisation",
            "qp_status",
            "trust_region_m",
            "rejected_trials",
            "active_constraints",
            "truth_violation_list",
        ]
        .map(String::from),
    );
    let mut table = CsvTable::new(&header.iter().map(String::as_str).collect::<Vec<_>>());
    let opt = |g: &Option<f64>| g.map(|g| g.to_string()).unwrap_or_default();
    let true_largest = |g: &[f64]| g.iter().copied().fold(0.0, f64::max).to_string();
    let mut row = vec!["0".to_string()];
    row.extend((0..pairs).map(|_| String::new()));
    row.extend(d.start.measured_gaps_m.iter().map(opt));
    row.extend(d.start.true_gaps_m.iter().map(|g| g.to_string()));
    row.push(opt(&d.start.largest_measured_gap_m()));
    row.push(true_largest(&d.start.true_gaps_m));
    // The truth's path and the planner's columns have no start value.
    row.resize(header.len(), String::new());
    table.row(row);
    for r in &d.records {
        let mut row = vec![r.index.to_string()];
        row.extend(r.predicted_gaps_m.iter().map(|g| g.to_string()));
        row.extend(r.measured_gaps_m.iter().map(opt));
        row.extend(r.true_gaps_m.iter().map(|g| g.to_string()));
        row.push(opt(&r.largest_measured_gap_m()));
        row.push(true_largest(&r.true_gaps_m));
        row.push(r.truth_worst_utilisation.to_string());
        row.push(r.truth_min_tension_n.to_string());
        row.push(r.truth_violations.len().to_string());
        row.push(r.truth_increments.to_string());
        row.push(r.truth_increments_checked.to_string());
        row.push(r.model_worst_utilisation.to_string());
        row.push(
            r.qp_status
                .map(|s| s.as_str().to_string())
                .unwrap_or_default(),
        );
        row.push(r.trust_region_m.map(|t| t.to_string()).unwrap_or_default());
        row.push(r.rejected_trials.to_string());
        row.push(r.active_constraints.join("; "));
        let violations: Vec<String> = r.truth_violations.iter().map(|v| v.describe()).collect();
        row.push(violations.join("; "));
        table.row(row);
    }
    table
}

/// `timing.csv`: planning time per command.
fn timing_table(d: &Deployment) -> CsvTable {
    let mut table = CsvTable::new(&["step", "planning_time_s"]);
    for r in &d.records {
        table.row([r.index.to_string(), r.planning_time_s.to_string()]);
    }
    table
}

/// The deployment as a measurement log: step 0 the designed state (not
/// measured), step 1 the fold to the start, then the commands.
fn deployment_log(
    d: &Deployment,
    truth: &EffectModel,
    sensors: Vec<tensegrity_deploy::sim::Sensor>,
) -> MeasurementLog {
    let mut commands = vec![d.start.start_payout_m.clone()];
    commands.extend(d.commands());
    let mut readings = vec![vec![None; sensors.len()]];
    readings.extend(d.readings.iter().cloned());
    MeasurementLog {
        structure: truth.structure.name.clone(),
        sensors,
        cycles: vec![Cycle {
            label: 1,
            step_labels: (1..=commands.len() as u64).collect(),
            commands,
            readings,
        }],
    }
}

/// Runs `tdeploy deploy`.
pub fn run(o: &Options) -> Result<Outcome> {
    // Claimed before the work, so that a refusal costs nothing; the set
    // is written whole (old or new, never a mix).
    let folder = ResultsFolder::claim(&o.out, "deploy", o.force)?;
    let (truth_file, truth_words) = match &o.truth {
        Some(p) => (absolute(read_model(p)?)?, p.display().to_string()),
        None => {
            // The default truth is the controller's bridge with the
            // default effects.
            let structure = match &o.model {
                Some(p) => absolute(read_model(p)?)?.structure,
                None => StructureSource::Reference,
            };
            (
                ModelFile {
                    structure,
                    effects: default_truth_effects(),
                },
                "default (μ = 0.2 wrap angle, 3 mm backlash)".to_string(),
            )
        }
    };
    let truth = match &o.truth {
        Some(_) => truth_file.measurement_model()?,
        None => default_truth(truth_file.load_structure()?),
    };
    let (model_file, model_words) = match &o.model {
        Some(p) => (absolute(read_model(p)?)?, p.display().to_string()),
        None => (
            ModelFile {
                structure: StructureSource::Reference,
                effects: Effects::default(),
            },
            "the reference bridge without friction".to_string(),
        ),
    };
    let model = planning_model(o.model.as_deref(), JointFriction::frictionless())?;
    let policy = policy_or_default(o.policy.as_deref())?;
    let problem = problem_or_default(o.problem.as_deref())?;
    let sensors = standard_sensors(&truth.structure);
    let setup = ClosedLoopSetup {
        model: &model,
        problem: &problem,
        policy: &policy,
        truth: &truth,
        sensors: &sensors,
        temperature_c: None,
        seed: o.seed,
    };
    let quiet = o.json;
    if !quiet {
        say!(
            "deploy: policy {} ({}), truth {truth_words}, controller's model {model_words}, seed {}",
            policy.name,
            policy.planner.as_str(),
            o.seed
        );
    }
    let show_bar = !quiet && std::io::stderr().is_terminal();
    let bar = if show_bar {
        ProgressBar::new(policy.max_commands as u64)
    } else {
        ProgressBar::hidden()
    };
    if let Ok(style) = ProgressStyle::with_template("{bar:30} {pos}/{len} commands (budget)") {
        bar.set_style(style);
    }
    let deploy = || {
        let mut printer = Printer {
            bar: bar.clone(),
            quiet,
        };
        deploy_closed_loop(&setup, &mut printer)
    };
    let result = match o.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("--threads: cannot start the worker threads")?
            .install(deploy),
        None => deploy(),
    };
    bar.finish_and_clear();
    let d = match result {
        Ok(d) => d,
        // The truth failing to fold is a solve that did not converge
        // (exit 1); everything else is input the deployment cannot use.
        Err(DeployError::TruthStart(
            e @ (PlantError::Solver { .. } | PlantError::SeatsUnsettled { .. }),
        )) => {
            return Ok(Outcome::GoalMissed(format!(
                "the truth plant could not reach the folded start: {e}"
            )))
        }
        Err(e) => return Err(e.into()),
    };

    let out = folder.path();
    write_fold_and_commands(
        &out.join("commands.csv"),
        model.structure(),
        d.start.start_payout_m.clone(),
        d.commands(),
    )?;
    write_log(
        &out.join("log"),
        &deployment_log(&d, &truth, sensors.clone()),
        &truth.structure,
    )?;
    // Paths in the model files are relative to where the set will be.
    write_atomically(
        &out.join("truth.toml"),
        truth_file.to_toml(&o.out).as_bytes(),
    )?;
    write_atomically(
        &out.join("model.toml"),
        model_file.to_toml(&o.out).as_bytes(),
    )?;
    // The problem solved, so that `replay --problem` can use its limits.
    write_atomically(
        &out.join("problem.toml"),
        problem_to_toml(&problem).as_bytes(),
    )?;
    deployment_table(&d).write(&out.join("deployment.csv"))?;
    timing_table(&d).write(&out.join("timing.csv"))?;
    let truth_model = truth.forward_model()?;
    let (start_forces, end_forces) = (
        truth_model.member_forces(&d.start_true_state),
        truth_model.member_forces(&d.final_true_state),
    );
    let svg = deployment_svg(
        truth_model.structure(),
        &d,
        DrawnState {
            state: &d.final_true_state,
            forces: &end_forces,
            label: "truth at the end",
        },
        DrawnState {
            state: &d.start_true_state,
            forces: &start_forces,
            label: "truth folded at the start",
        },
        problem.connection_tolerance_m,
        &format!("Closed-loop deployment, seed {}", o.seed),
    )?;
    write_atomically(&out.join("deployment.svg"), svg.as_bytes())?;

    let verdict = verdict(&d);
    let last_measured = d
        .records
        .last()
        .map(|r| r.measured_gaps_m.as_slice())
        .unwrap_or(&d.start.measured_gaps_m);
    let last_true = d
        .records
        .last()
        .map(|r| r.true_gaps_m.as_slice())
        .unwrap_or(&d.start.true_gaps_m);
    let summary = Summary {
        format: SUMMARY_FORMAT,
        verdict: verdict.clone(),
        connected: d.status.is_connected(),
        status: &d.status,
        seed: o.seed,
        policy: &policy.name,
        planner: policy.planner.as_str(),
        truth: truth_words,
        model: model_words,
        problem: o.problem.as_ref().map_or_else(
            || "the default problem".to_string(),
            |p| p.display().to_string(),
        ),
        commands: d.records.len(),
        max_commands: policy.max_commands,
        connection_tolerance_m: problem.connection_tolerance_m,
        start_payout_m: &d.start.start_payout_m,
        start_measured_gaps_m: &d.start.measured_gaps_m,
        start_true_gaps_m: &d.start.true_gaps_m,
        final_measured_gaps_m: last_measured,
        final_true_gaps_m: last_true,
        largest_final_measured_gap_m: d.final_measured_gap_m(),
        largest_final_true_gap_m: d.final_true_gap_m(),
        truth_worst_utilisation: d
            .records
            .iter()
            .map(|r| r.truth_worst_utilisation)
            .fold(0.0, f64::max),
        truth_limit_violations: d.truth_limit_violations,
        truth_increments_checked: d.records.iter().map(|r| r.truth_increments_checked).sum(),
        first_command_below_60_mm: d.first_below_corrective_gap,
        corrective_commands: d.corrective_commands,
    };
    write_json(&out.join("summary.json"), &summary)?;
    folder.commit()?;
    let out = &o.out;

    if o.json {
        say!(
            "{}",
            std::fs::read_to_string(out.join("summary.json"))
                .with_context(|| format!("{}: cannot read back", out.display()))?
                .trim_end()
        );
    } else {
        say!("{verdict}");
        match (d.first_below_corrective_gap, d.corrective_commands) {
            (Some(k), Some(n)) => say!(
                "largest measured gap below 60 mm after command {k}; {} after it (corrective)",
                commands_count(n)
            ),
            _ => say!("the largest measured gap never came below 60 mm"),
        }
        if d.truth_limit_violations == 0 {
            say!(
                "the truth kept every limit at every increment ({} increments checked)",
                summary.truth_increments_checked
            );
        } else {
            say!(
                "the truth broke {} limits along the way (see deployment.csv)",
                d.truth_limit_violations
            );
        }
        say!(
            "results in {} (commands.csv, log/, problem.toml, deployment.csv, summary.json, deployment.svg, timing.csv)",
            out.display()
        );
    }
    Ok(if d.status.is_connected() {
        Outcome::GoalReached
    } else {
        Outcome::GoalMissed(verdict)
    })
}
