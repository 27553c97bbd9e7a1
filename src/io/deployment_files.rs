//! The files of a closed-loop deployment (`tdeploy deploy`), written as one
//! set ([`write_deployment`]) into a results folder. Every file but
//! `timing.csv` is the same, byte for byte, for the same inputs and seed at
//! any thread count. Units are SI (m, N); numbers are written as the
//! shortest text that reads back to the same value.
//!
//! - `commands.csv`: a command file ([`super::commands`]) whose step 0 is
//!   the fold from the designed state and steps 1… the commands sent
//!   (`tdeploy simulate -c` replays it).
//! - `log/`: a measurement log ([`super::log`]) of one cycle: step 0 the
//!   designed state (no reading: not measured), step 1 the fold to the
//!   folded start (measured), steps 2… the commands. `tdeploy compare`,
//!   `diagnose` and `replay` read it.
//! - `truth.toml`, `model.toml`: the truth and the controller's model as
//!   model files ([`super::model_file`]); a structure file they name is
//!   written relative to the results folder.
//! - `problem.toml`: the problem solved ([`super::problem_file`]), every
//!   field written out.
//! - `deployment.csv`: one row per step, step 0 the start. Columns:
//!   `step`; `predicted_gap_{p}_m`, `measured_gap_{p}_m`, `true_gap_{p}_m`
//!   for every midspan pair `p` (the gap the controller predicted for the
//!   command, the gap measured after it, the truth's); then
//!   `largest_measured_gap_m`, `largest_true_gap_m`,
//!   `truth_worst_utilisation` (worst member utilisation of the truth along
//!   the command, every increment), `truth_min_tension_n`,
//!   `truth_violations` (limits broken along the command),
//!   `truth_increments`, `truth_increments_checked` (the payout's
//!   increments, and with cable seats the state they settle into, one
//!   more),
//!   `model_worst_utilisation` (the controller's prediction), `qp_status`,
//!   `trust_region_m`, `rejected_trials`, `active_constraints` (`; `
//!   separated), `truth_violation_list` (`; ` separated). Empty: no value
//!   (a gap whose sensors read nothing; at step 0 every column that belongs
//!   to a command; the QP columns of a planner without a QP).
//! - `summary.json` ([`DeploymentSummary`], format
//!   [`DEPLOYMENT_SUMMARY_FORMAT`]): how it ended and with what margins; no
//!   timings. `null`: no value.
//! - `timing.csv`: `step,planning_time_s`, wall-clock planning time per
//!   command: the one file that changes from run to run.
//!
//! The set's figure, `deployment.svg`, is drawn by
//! `report::deployment_figure`.

use std::path::Path;

use serde::Serialize;

use super::commands::write_fold_and_commands;
use super::log::write_log;
use super::model_file::ModelFile;
use super::problem_file::problem_to_toml;
use super::{write_atomically, write_json, CsvTable, FileError};
use crate::control::Deployment;
use crate::model::Structure;
use crate::plan::limits::{StartBrokenLimit, StateBreach};
use crate::plan::{Breach, DeploymentProblem, PlanStatus, Policy, RunVerdict};
use crate::sim::{EffectModel, Sensor};
use crate::studies::deployment_log::deployment_log;

/// The `format` of `summary.json`; a folder holding it is one `tdeploy
/// deploy` wrote and may write again.
pub const DEPLOYMENT_SUMMARY_FORMAT: &str = "tensegrity-deploy/deployment/2";

/// What a deployment's summary names besides the deployment: its inputs,
/// in the words the summary writes them.
#[derive(Debug, Clone)]
pub struct DeploymentSources {
    /// The truth: its model file, or the default's description.
    pub truth: String,
    /// The controller's model: its model file, or the default's
    /// description.
    pub model: String,
    /// The problem file given, or `the default problem`.
    pub problem: String,
    /// Seed of the sensor noise.
    pub seed: u64,
}

/// `summary.json` (no timings: it is compared byte for byte). Gaps in m;
/// `null` where there is no value.
#[derive(Debug, Serialize)]
pub struct DeploymentSummary<'a> {
    /// [`DEPLOYMENT_SUMMARY_FORMAT`].
    pub format: &'static str,
    /// The verdict line `tdeploy deploy` prints.
    pub verdict: String,
    /// Whether the run connected: the controller stopped as connected,
    /// every true gap within the tolerance, the truth broke no limit and
    /// restored every limit its start broke ([`RunVerdict`]).
    pub connected: bool,
    /// The verdict's label ([`RunVerdict::label`]): `connected`,
    /// `limits_broken`, `not_reachable`, `command_limit`,
    /// `solver_failure`, `gap_out_of_tolerance`, `limits_not_restored`.
    pub outcome: &'static str,
    /// How the controller itself ended (it cannot see the truth).
    pub status: &'a PlanStatus,
    /// The truth limits broken, one per limit with its first command and
    /// increment.
    pub truth_limits_broken: Vec<Breach>,
    /// The truth's limits its folded start already broke, with whether
    /// the end meets them.
    pub truth_start_broken: &'a [StartBrokenLimit],
    /// Where the truth broke a limit or left one unrestored, the limits
    /// its own as-built state (before any fold) breaks by itself (empty:
    /// none); `null` where the run kept every limit and nothing was
    /// checked ([`crate::plan::RunVerdict::as_built_broken`]).
    pub truth_as_built_broken: Option<&'a [StateBreach]>,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// The policy's name.
    pub policy: &'a str,
    /// Its planner.
    pub planner: &'static str,
    /// The truth (see [`DeploymentSources`]).
    pub truth: String,
    /// The controller's model.
    pub model: String,
    /// The problem file given, or the built-in default; `problem.toml`
    /// beside the summary holds its values either way.
    pub problem: String,
    /// Commands sent.
    pub commands: usize,
    /// The policy's command budget.
    pub max_commands: usize,
    /// Connection tolerance of the problem, m.
    pub connection_tolerance_m: f64,
    /// Payout per motor at the folded start, m.
    pub start_payout_m: &'a [f64],
    /// Gap per pair measured at the start.
    pub start_measured_gaps_m: &'a [Option<f64>],
    /// True gap per pair at the start.
    pub start_true_gaps_m: &'a [f64],
    /// Gap per pair measured after the last command (the start's if none).
    pub final_measured_gaps_m: &'a [Option<f64>],
    /// True gap per pair after the last command (the start's if none).
    pub final_true_gaps_m: &'a [f64],
    /// Largest of the final measured gaps.
    pub largest_final_measured_gap_m: Option<f64>,
    /// Largest of the final true gaps.
    pub largest_final_true_gap_m: Option<f64>,
    /// Worst member utilisation of the truth over every command.
    pub truth_worst_utilisation: f64,
    /// Limits the truth broke, over every command and increment.
    pub truth_limit_violations: usize,
    /// Increments of the truth checked against the limits.
    pub truth_increments_checked: usize,
    /// The command after which the largest measured gap first came below
    /// 60 mm.
    pub first_command_below_60_mm: Option<usize>,
    /// Commands after that one.
    pub corrective_commands: Option<usize>,
    /// The payout scale `ŝ` of each bridge half as the controller
    /// estimated it at the end (empty without the estimate), 1.
    pub estimated_payout_scale: &'a [f64],
    /// The load cells' common bias as the controller estimated it at the
    /// end (`null` without the estimate), N.
    pub estimated_load_cell_bias_n: Option<Estimate>,
}

/// An estimate with its standard deviation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// Posterior mean.
    pub mean: f64,
    /// Posterior standard deviation.
    pub sd: f64,
}

impl<'a> DeploymentSummary<'a> {
    /// The summary of `d`, deployed by `policy` under `problem` from
    /// `sources`, judged by `run` (`d`'s [`Deployment::verdict`]);
    /// `verdict` is the line the command prints.
    pub fn new(
        d: &'a Deployment,
        run: &RunVerdict,
        policy: &'a Policy,
        problem: &DeploymentProblem,
        sources: DeploymentSources,
        verdict: String,
    ) -> Self {
        let last = d.records.last();
        DeploymentSummary {
            format: DEPLOYMENT_SUMMARY_FORMAT,
            verdict,
            connected: run.is_connected(),
            outcome: run.label(),
            status: &d.status,
            truth_limits_broken: run.broken.clone(),
            truth_start_broken: &d.truth_start_broken,
            truth_as_built_broken: d.truth_as_built_broken.as_deref(),
            seed: sources.seed,
            policy: &policy.name,
            planner: policy.planner.as_str(),
            truth: sources.truth,
            model: sources.model,
            problem: sources.problem,
            commands: d.records.len(),
            max_commands: policy.max_commands,
            connection_tolerance_m: problem.connection_tolerance_m,
            start_payout_m: &d.start.start_payout_m,
            start_measured_gaps_m: &d.start.measured_gaps_m,
            start_true_gaps_m: &d.start.true_gaps_m,
            final_measured_gaps_m: last.map_or(&d.start.measured_gaps_m, |r| &r.measured_gaps_m),
            final_true_gaps_m: last.map_or(&d.start.true_gaps_m, |r| &r.true_gaps_m),
            largest_final_measured_gap_m: d.final_measured_gap_m(),
            largest_final_true_gap_m: d.final_true_gap_m(),
            truth_worst_utilisation: d.truth_worst_utilisation(),
            truth_limit_violations: d.truth_limit_violations,
            truth_increments_checked: d.records.iter().map(|r| r.truth_increments_checked).sum(),
            first_command_below_60_mm: d.first_below_corrective_gap,
            corrective_commands: d.corrective_commands,
            estimated_payout_scale: &d.final_payout_scale,
            estimated_load_cell_bias_n: d
                .final_load_cell_bias_n
                .map(|(mean, sd)| Estimate { mean, sd }),
        }
    }
}

/// Everything the set records of one deployment.
#[derive(Clone, Copy)]
pub struct DeploymentSet<'a> {
    /// The deployment.
    pub deployment: &'a Deployment,
    /// The controller's structure (the cables `commands.csv` names).
    pub structure: &'a Structure,
    /// The truth deployed (the log's structure).
    pub truth: &'a EffectModel,
    /// The sensors that read the truth, in the log's order.
    pub sensors: &'a [Sensor],
    /// The truth as a model file.
    pub truth_file: &'a ModelFile,
    /// The controller's model as a model file.
    pub model_file: &'a ModelFile,
    /// The problem solved.
    pub problem: &'a DeploymentProblem,
    /// The summary.
    pub summary: &'a DeploymentSummary<'a>,
    /// Where the set will be once in place: the model files name their
    /// structure files relative to it.
    pub target: &'a Path,
}

/// Writes every file of the set but its figure into `dir`.
pub fn write_deployment(dir: &Path, set: &DeploymentSet) -> Result<(), FileError> {
    let d = set.deployment;
    write_fold_and_commands(
        &dir.join("commands.csv"),
        set.structure,
        d.start.start_payout_m.clone(),
        d.commands(),
    )?;
    write_log(
        &dir.join("log"),
        &deployment_log(d, &set.truth.structure.name, set.sensors.to_vec()),
        &set.truth.structure,
    )?;
    write_atomically(
        &dir.join("truth.toml"),
        set.truth_file.to_toml(set.target).as_bytes(),
    )?;
    write_atomically(
        &dir.join("model.toml"),
        set.model_file.to_toml(set.target).as_bytes(),
    )?;
    write_atomically(
        &dir.join("problem.toml"),
        problem_to_toml(set.problem).as_bytes(),
    )?;
    deployment_table(d).write(&dir.join("deployment.csv"))?;
    timing_table(d).write(&dir.join("timing.csv"))?;
    write_json(&dir.join("summary.json"), set.summary)
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
