//! The files of a replayed log (`tdeploy replay`), written as one set
//! ([`write_replay`]) into a results folder. Units are SI (m, N); numbers
//! are written as the shortest text that reads back to the same value;
//! motors are named by their continuous cable's id and midspan pairs by
//! their index `p`.
//!
//! - `replay.csv`: step 0 the start, then one row per logged command
//!   replayed. Columns: `step` (the logged step label), `same_as_policy`
//!   (whether the logged command was the policy's own), `policy_stop` (why
//!   the policy would have sent nothing, in words; empty: it would have
//!   sent a command), `largest_difference_m` (largest difference per motor
//!   between the policy's and the logged command); `logged_{motor}_m`,
//!   `policy_{motor}_m`, `difference_{motor}_m` (policy minus logged) per
//!   motor; `measured_gap_{p}_m`, `predicted_logged_gap_{p}_m` (what the
//!   controller predicted for the logged command),
//!   `predicted_policy_gap_{p}_m` (for its own) per pair. Empty: no value
//!   (the policy stopped, a reading missing; at step 0 every column but
//!   the measured gaps).
//! - `counterfactual.csv`: the policy deploying the calibrated model from
//!   the logged start; step 0 the start, then one row per command.
//!   Columns: `step`, `command_{motor}_m` per motor, `measured_gap_{p}_m`,
//!   `true_gap_{p}_m` per pair, `truth_worst_utilisation`,
//!   `truth_min_tension_n`, `truth_violations`. Only the header when the
//!   counterfactual could not run (`summary.json` says why).
//! - `summary.json` ([`ReplaySummary`], format [`REPLAY_SUMMARY_FORMAT`]):
//!   the verdict, where the replay started, how often the policy agreed,
//!   the calibration ([`crate::measure::calibrate::Calibration`]) and the
//!   counterfactual's margins (its `connected` and `outcome` are the run
//!   verdict's, [`crate::plan::RunVerdict`]; format 1 had no `outcome` and
//!   took the controller's status for `connected`); format 3 adds
//!   `calibration_standing` (whether the calibrated model explains the
//!   log or the log refutes it, [`CalibrationStanding`]) and
//!   `interval_ends` (the counterfactual at both ends of every calibrated
//!   parameter's 95 % interval); no timings. `null`: no value.
//! - `timing.csv`: `step,planning_time_s` per replayed step, wall clock:
//!   the one file that changes from run to run.
//!
//! The set's figure, `replay.svg`, is drawn by `report::replay_figure`.

use std::path::Path;

use serde::Serialize;

use super::{write_json, CsvTable, FileError};
use crate::control::Deployment;
use crate::measure::calibrate::{Calibration, CalibrationStanding};
use crate::plan::{PlanStatus, Policy};
use crate::studies::log_replay::{IntervalEndRun, Margins, Replay, ReplayStart, ReplayStop};

/// The `format` of `summary.json`.
pub const REPLAY_SUMMARY_FORMAT: &str = "tensegrity-deploy/replay/3";

/// `summary.json` (no timings: the same inputs give the same bytes).
#[derive(Debug, Serialize)]
pub struct ReplaySummary<'a> {
    /// [`REPLAY_SUMMARY_FORMAT`].
    pub format: &'static str,
    /// The verdict line `tdeploy replay` prints.
    pub verdict: String,
    /// The log folder replayed.
    pub log: String,
    /// The policy's name.
    pub policy: &'a str,
    /// Its planner.
    pub planner: &'static str,
    /// The controller's model: its model file, or the default's
    /// description.
    pub model: String,
    /// Where the replay started in the log.
    pub start: &'a ReplayStart,
    /// Commands the cycle logged after its start.
    pub logged_commands: usize,
    /// Commands replayed (fewer when the replay stopped early).
    pub replayed_commands: usize,
    /// Replayed commands that were the policy's own.
    pub same_as_policy: usize,
    /// Replayed steps at which the policy would have stopped.
    pub policy_would_have_stopped: usize,
    /// Largest difference between a logged and a policy command, m.
    pub largest_difference_m: Option<f64>,
    /// Why the replay stopped before the log's end.
    pub replay_stopped: &'a Option<ReplayStop>,
    /// The policy's command after the last logged one, m.
    pub policy_next_command_m: &'a Option<Vec<f64>>,
    /// Why the policy would send nothing after the last logged command.
    pub policy_next_stop: &'a Option<PlanStatus>,
    /// The calibrated model.
    pub calibration: Option<&'a Calibration>,
    /// Why there is no calibrated model.
    pub calibration_failed: Option<String>,
    /// Seed of the counterfactual's sensor noise.
    pub seed: u64,
    /// How far the calibrated model stands for the bridge: it explains
    /// the log, or the log refutes it (then the counterfactual is no
    /// evidence).
    pub calibration_standing: Option<CalibrationStanding>,
    /// The counterfactual's margins.
    pub counterfactual: Option<Margins>,
    /// The counterfactual at both ends of every calibrated parameter's
    /// 95 % interval (run only on a model that explains the log).
    pub interval_ends: &'a [IntervalEndRun],
    /// Why the counterfactual did not run.
    pub counterfactual_failed: Option<String>,
}

/// What a replay's summary names besides the replay.
#[derive(Debug, Clone)]
pub struct ReplaySources {
    /// The log folder, as given.
    pub log: String,
    /// The controller's model, in words.
    pub model: String,
    /// Commands the cycle logged after the start.
    pub logged_commands: usize,
    /// Seed of the counterfactual's noise.
    pub seed: u64,
}

impl<'a> ReplaySummary<'a> {
    /// The summary of `replay` by `policy`, its calibration (or why there
    /// is none) and the counterfactual's margins (or why there are none);
    /// `verdict` is the line the command prints.
    pub fn new(
        replay: &'a Replay,
        policy: &'a Policy,
        sources: ReplaySources,
        calibration: Result<&'a Calibration, String>,
        counterfactual: Result<Margins, String>,
        interval_ends: &'a [IntervalEndRun],
        verdict: String,
    ) -> Self {
        ReplaySummary {
            format: REPLAY_SUMMARY_FORMAT,
            verdict,
            log: sources.log,
            policy: &policy.name,
            planner: policy.planner.as_str(),
            model: sources.model,
            start: &replay.start,
            logged_commands: sources.logged_commands,
            replayed_commands: replay.steps.len(),
            same_as_policy: replay.same_commands(),
            policy_would_have_stopped: replay
                .steps
                .iter()
                .filter(|s| s.policy_stop.is_some())
                .count(),
            largest_difference_m: replay.largest_difference_m(),
            replay_stopped: &replay.stopped,
            policy_next_command_m: &replay.next_command_m,
            policy_next_stop: &replay.next_stop,
            calibration_failed: calibration.as_ref().err().cloned(),
            calibration_standing: calibration.as_ref().ok().map(|c| c.standing()),
            calibration: calibration.ok(),
            interval_ends,
            seed: sources.seed,
            counterfactual_failed: counterfactual.as_ref().err().cloned(),
            counterfactual: counterfactual.ok(),
        }
    }
}

/// Everything the set records of one replay.
#[derive(Clone, Copy)]
pub struct ReplaySet<'a> {
    /// The replay.
    pub replay: &'a Replay,
    /// The counterfactual run, if it ran.
    pub counterfactual: Option<&'a Deployment>,
    /// The motors' names (the continuous cables' ids), in order.
    pub motors: &'a [String],
    /// Midspan pairs.
    pub pairs: usize,
    /// The summary.
    pub summary: &'a ReplaySummary<'a>,
}

/// Writes every file of the set but its figure into `dir`.
pub fn write_replay(dir: &Path, set: &ReplaySet) -> Result<(), FileError> {
    replay_table(set.replay, set.motors, set.pairs).write(&dir.join("replay.csv"))?;
    counterfactual_table(set.counterfactual, set.motors, set.pairs)
        .write(&dir.join("counterfactual.csv"))?;
    let mut timing = CsvTable::new(&["step", "planning_time_s"]);
    for s in &set.replay.steps {
        timing.row([s.step.to_string(), s.planning_time_s.to_string()]);
    }
    timing.write(&dir.join("timing.csv"))?;
    write_json(&dir.join("summary.json"), set.summary)
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// `replay.csv`: step 0 the start, then one row per logged command.
fn replay_table(r: &Replay, motors: &[String], pairs: usize) -> CsvTable {
    let mut header = vec![
        "step".to_string(),
        "same_as_policy".into(),
        "policy_stop".into(),
        "largest_difference_m".into(),
    ];
    for kind in ["logged", "policy", "difference"] {
        header.extend(motors.iter().map(|m| format!("{kind}_{m}_m")));
    }
    for kind in ["measured", "predicted_logged", "predicted_policy"] {
        header.extend((0..pairs).map(|p| format!("{kind}_gap_{p}_m")));
    }
    let mut table = CsvTable::new(&header.iter().map(String::as_str).collect::<Vec<_>>());
    let mut row = vec![r.start.start_step.to_string()];
    row.resize(4 + 3 * motors.len(), String::new());
    row.extend(r.start_measured_gaps_m.iter().map(|g| opt(*g)));
    row.resize(header.len(), String::new());
    table.row(row);
    for s in &r.steps {
        let mut row = vec![
            s.step.to_string(),
            s.same_as_policy.to_string(),
            s.policy_stop
                .as_ref()
                .map(|p| p.describe())
                .unwrap_or_default(),
            opt(s.largest_difference_m),
        ];
        row.extend(s.logged_command_m.iter().map(|c| c.to_string()));
        match &s.policy_command_m {
            Some(p) => {
                row.extend(p.iter().map(|c| c.to_string()));
                row.extend(
                    p.iter()
                        .zip(&s.logged_command_m)
                        .map(|(a, b)| (a - b).to_string()),
                );
            }
            None => row.extend(std::iter::repeat_n(String::new(), 2 * motors.len())),
        }
        row.extend(s.measured_gaps_m.iter().map(|g| opt(*g)));
        row.extend(s.logged_predicted_gaps_m.iter().map(|g| g.to_string()));
        match &s.policy_predicted_gaps_m {
            Some(g) => row.extend(g.iter().map(|g| g.to_string())),
            None => row.extend(std::iter::repeat_n(String::new(), pairs)),
        }
        table.row(row);
    }
    table
}

/// `counterfactual.csv`: step 0 the start, then one row per command.
fn counterfactual_table(d: Option<&Deployment>, motors: &[String], pairs: usize) -> CsvTable {
    let mut header = vec!["step".to_string()];
    header.extend(motors.iter().map(|m| format!("command_{m}_m")));
    for kind in ["measured", "true"] {
        header.extend((0..pairs).map(|p| format!("{kind}_gap_{p}_m")));
    }
    header.extend(
        [
            "truth_worst_utilisation",
            "truth_min_tension_n",
            "truth_violations",
        ]
        .map(String::from),
    );
    let mut table = CsvTable::new(&header.iter().map(String::as_str).collect::<Vec<_>>());
    let Some(d) = d else { return table };
    let mut row = vec!["0".to_string()];
    row.resize(1 + motors.len(), String::new());
    row.extend(d.start.measured_gaps_m.iter().map(|g| opt(*g)));
    row.extend(d.start.true_gaps_m.iter().map(|g| g.to_string()));
    row.resize(header.len(), String::new());
    table.row(row);
    for r in &d.records {
        let mut row = vec![r.index.to_string()];
        row.extend(r.command_m.iter().map(|c| c.to_string()));
        row.extend(r.measured_gaps_m.iter().map(|g| opt(*g)));
        row.extend(r.true_gaps_m.iter().map(|g| g.to_string()));
        row.push(r.truth_worst_utilisation.to_string());
        row.push(r.truth_min_tension_n.to_string());
        row.push(r.truth_violations.len().to_string());
        table.row(row);
    }
    table
}
