//! Closed-loop replay of a logged deployment: what the policy would have
//! commanded, step by step, given the logged measurements, beside what was
//! commanded; and a counterfactual run of the policy on a model calibrated
//! on that log.
//!
//! # Where a deployment starts in a log
//! A log holds cycles of commands (payout changes per motor) and readings
//! (step 0, then after each command). The motors' payout at a step is the
//! sum of every command logged before it, from the log's first cycle (logs
//! start at the as-built payout, and every cycle starts where the previous
//! one ended). Two layouts are read:
//!
//! - **deploy** (`tdeploy deploy`'s `log/`): a cycle whose step 0 has no
//!   reading at all (the designed state, not measured). Step 1 is the fold
//!   to the folded start, measured; every later step is a command of the
//!   deployment.
//! - **lab** (`tdeploy lab`, or a real bridge's log): a cycle whose step 0
//!   is measured. A lab cycle pays every motor out and reels it back in;
//!   its deployment starts at the measured step where the mean payout over
//!   the motors is largest (the end of the fold; the earliest such step),
//!   and its commands are every step after it.
//!
//! The controller starts at the folded start of its own model with the
//! start's payout ([`crate::plan::folded_start`], from the designed
//! state): a lab cycle's earlier history is in its readings, which the
//! correction of the first measurement takes up.
//!
//! # Replay
//! At every logged command the [`Controller`] decides first (the command it
//! would have sent, or that it would have stopped), then observes the
//! logged command and the logged readings after it. Replaying a log that
//! `deploy` wrote, with the same policy and model, gives the logged
//! commands back: the controller is deterministic given the same readings,
//! and logs keep every number exactly.
//!
//! # Counterfactual
//! A model calibrated on the log
//! ([`crate::measure::calibrate::calibrate_on_log`]: the diagnosis's
//! effects, or a chosen set of effects fitted in turn) stands in as the
//! truth of a closed-loop run of the policy from the logged start
//! ([`counterfactual`]): would it have connected, after how many commands,
//! with what margins.

use serde::Serialize;
use thiserror::Error;

use crate::control::measured_gap_vectors;
use crate::control::{
    deploy_closed_loop, ClosedLoopSetup, Controller, ControllerDecision, ControllerError,
    DeployError, Deployment,
};
use crate::measure::log::MeasurementLog;
use crate::model::ForwardModel;
use crate::plan::{DeploymentProblem, PerMotor, PlanError, PlanStatus, Policy};
use crate::sim::{EffectModel, SensorTarget};

/// How a logged cycle is laid out (see the module notes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LogLayout {
    /// Step 0 not measured (the designed state), step 1 the fold.
    Deploy,
    /// Step 0 measured; the fold ends where the mean payout peaks.
    Lab,
}

impl LogLayout {
    /// The layout's name, as reports write it.
    pub fn as_str(self) -> &'static str {
        match self {
            LogLayout::Deploy => "deploy",
            LogLayout::Lab => "lab",
        }
    }
}

/// Where the replayed deployment starts in the log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayStart {
    /// Index of the cycle in the log (0 for the first).
    pub cycle_index: usize,
    /// The cycle's label as logged.
    pub cycle: u64,
    /// The cycle's layout.
    pub layout: LogLayout,
    /// The start's index among the cycle's readings (0: step 0, `k`: after
    /// the cycle's `k`-th command).
    pub start_reading: usize,
    /// The start's step label as logged (0 for step 0).
    pub start_step: u64,
    /// Payout of every motor at the start, m: every command logged before
    /// it, summed.
    pub start_payout_m: Vec<f64>,
    /// Temperature read at the start, °C, if a thermometer read it.
    pub temperature_c: Option<f64>,
}

/// Why a log cannot be replayed as a deployment. Each names the log file
/// and the field at fault ([`Self::file`], [`Self::field`]).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReplayInputError {
    /// The cycle asked for is not in the log.
    #[error("no cycle {cycle} in the log (cycles: {known:?})")]
    UnknownCycle {
        /// The label asked for.
        cycle: u64,
        /// The labels logged.
        known: Vec<u64>,
    },
    /// The cycle has no command after its start.
    #[error("cycle {cycle} has no command after its start (step {start_step}): nothing to replay")]
    NoCommandsAfterStart {
        /// The cycle's label.
        cycle: u64,
        /// The start's step label.
        start_step: u64,
    },
    /// The cycle has no measured step at all.
    #[error("cycle {cycle} has no measured step")]
    NoMeasuredStep {
        /// The cycle's label.
        cycle: u64,
    },
    /// The start is a payout the problem does not allow (a stroke limit).
    #[error("cycle {cycle}: the start payout {start_payout_m:?} m cannot be a deployment's start: {error}")]
    BadStart {
        /// The cycle's label.
        cycle: u64,
        /// The payouts at the start, m.
        start_payout_m: Vec<f64>,
        /// What the problem or the controller's model said.
        error: PlanError,
    },
}

impl ReplayInputError {
    /// The log file at fault.
    pub fn file(&self) -> &'static str {
        match self {
            ReplayInputError::NoMeasuredStep { .. } => "measurements.csv",
            _ => "commands.csv",
        }
    }

    /// The field at fault.
    pub fn field(&self) -> &'static str {
        match self {
            ReplayInputError::UnknownCycle { .. } => "cycle",
            ReplayInputError::NoCommandsAfterStart { .. } => "step",
            ReplayInputError::NoMeasuredStep { .. } => "value",
            ReplayInputError::BadStart { .. } => "payout_change_m",
        }
    }
}

/// The cycle a replay takes by default: the one with the largest fold
/// (mean start payout; the first of equals), so a deploy log's only cycle
/// and a lab log's largest amplitude.
pub fn default_cycle(log: &MeasurementLog) -> Option<u64> {
    let mut best: Option<(u64, f64)> = None;
    for i in 0..log.cycles.len() {
        if let Ok(s) = locate_start(log, i) {
            let fold = mean(&s.start_payout_m);
            if best.is_none_or(|(_, b)| fold > b) {
                best = Some((s.cycle, fold));
            }
        }
    }
    best.map(|(c, _)| c)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Where cycle `cycle` (its label) of `log` starts as a deployment (see
/// the module notes).
pub fn deployment_start(log: &MeasurementLog, cycle: u64) -> Result<ReplayStart, ReplayInputError> {
    let index = log
        .cycles
        .iter()
        .position(|c| c.label == cycle)
        .ok_or_else(|| ReplayInputError::UnknownCycle {
            cycle,
            known: log.cycles.iter().map(|c| c.label).collect(),
        })?;
    locate_start(log, index)
}

fn locate_start(log: &MeasurementLog, index: usize) -> Result<ReplayStart, ReplayInputError> {
    let motors = log
        .cycles
        .iter()
        .flat_map(|c| c.commands.first())
        .map(Vec::len)
        .next()
        .unwrap_or(0);
    let mut payout = vec![0.0; motors];
    for c in &log.cycles[..index] {
        for command in &c.commands {
            add(&mut payout, command);
        }
    }
    let cycle = &log.cycles[index];
    let measured = |k: usize| {
        cycle
            .readings
            .get(k)
            .is_some_and(|r| r.iter().any(Option::is_some))
    };
    // Payout at each reading of the cycle (0: step 0).
    let mut payouts = vec![payout.clone()];
    for command in &cycle.commands {
        add(&mut payout, command);
        payouts.push(payout.clone());
    }
    let (layout, start_reading) = if !measured(0) && !cycle.commands.is_empty() && measured(1) {
        (LogLayout::Deploy, 1)
    } else {
        let mut best: Option<(usize, f64)> = None;
        for (k, p) in payouts.iter().enumerate() {
            if measured(k) && best.is_none_or(|(_, b)| mean(p) > b) {
                best = Some((k, mean(p)));
            }
        }
        let (k, _) = best.ok_or(ReplayInputError::NoMeasuredStep { cycle: cycle.label })?;
        (LogLayout::Lab, k)
    };
    let start_step = match start_reading {
        0 => 0,
        k => cycle.step_labels[k - 1],
    };
    if start_reading >= cycle.commands.len() {
        return Err(ReplayInputError::NoCommandsAfterStart {
            cycle: cycle.label,
            start_step,
        });
    }
    let thermometer = log
        .sensors
        .iter()
        .position(|s| s.target == SensorTarget::Temperature);
    Ok(ReplayStart {
        cycle_index: index,
        cycle: cycle.label,
        layout,
        start_reading,
        start_step,
        start_payout_m: payouts[start_reading].clone(),
        temperature_c: thermometer.and_then(|t| cycle.readings[start_reading][t]),
    })
}

fn add(payout: &mut [f64], command: &[f64]) {
    for (p, c) in payout.iter_mut().zip(command) {
        *p += c;
    }
}

/// `problem` started at the replay's start payout.
pub fn problem_from(problem: &DeploymentProblem, start: &ReplayStart) -> DeploymentProblem {
    DeploymentProblem {
        start_payout_m: PerMotor::Each(start.start_payout_m.clone()),
        ..problem.clone()
    }
}

/// One logged command, replayed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReplayStep {
    /// The step's label as logged.
    pub step: u64,
    /// The command logged, per motor, m.
    pub logged_command_m: Vec<f64>,
    /// The drum command the policy would have sent instead, per motor, m
    /// (`None`: it would have stopped).
    pub policy_command_m: Option<Vec<f64>>,
    /// Why the policy would have sent nothing (`None`: it would have sent
    /// a command).
    pub policy_stop: Option<PlanStatus>,
    /// Largest difference per motor between the two commands, m.
    pub largest_difference_m: Option<f64>,
    /// Whether the logged command was the policy's own (within
    /// [`crate::control::OWN_COMMAND_TOLERANCE_M`]).
    pub same_as_policy: bool,
    /// Gap per pair the policy predicted for its own command, m.
    pub policy_predicted_gaps_m: Option<Vec<f64>>,
    /// Gap per pair the controller predicted for the logged command, m.
    pub logged_predicted_gaps_m: Vec<f64>,
    /// Gap per pair measured after the logged command, m (`None`: a
    /// reading missing).
    pub measured_gaps_m: Vec<Option<f64>>,
    /// Wall-clock planning time, s (not a function of the inputs).
    #[serde(skip)]
    pub planning_time_s: f64,
}

/// A replayed cycle.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Replay {
    /// Where the deployment starts.
    pub start: ReplayStart,
    /// Gap per pair measured at the start, m.
    pub start_measured_gaps_m: Vec<Option<f64>>,
    /// One entry per logged command after the start, in order (fewer if
    /// the controller could not follow one, see [`Self::stopped`]).
    pub steps: Vec<ReplayStep>,
    /// What the policy would do after the last logged command: its drum
    /// command, or why it would stop.
    pub next_command_m: Option<Vec<f64>>,
    /// Why the policy would send nothing after the last logged command.
    pub next_stop: Option<PlanStatus>,
    /// Why the replay stopped before the log's end (the controller's model
    /// could not follow a logged command), if it did.
    pub stopped: Option<ReplayStop>,
}

/// Where and why a replay stopped before the log's end. Serialised as its
/// [`ReplayStop::describe`] text.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayStop {
    /// The logged step whose command the controller could not follow.
    pub step: u64,
    /// What the controller said.
    pub error: ControllerError,
}

impl ReplayStop {
    /// Plain words.
    pub fn describe(&self) -> String {
        format!("step {}: {}", self.step, self.error)
    }
}

impl Serialize for ReplayStop {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.describe())
    }
}

impl Replay {
    /// Largest difference between a logged and a policy command over the
    /// steps where both exist, m (`None`: the policy stopped at every
    /// step).
    pub fn largest_difference_m(&self) -> Option<f64> {
        self.steps
            .iter()
            .filter_map(|s| s.largest_difference_m)
            .reduce(f64::max)
    }

    /// Steps whose logged command was the policy's own.
    pub fn same_commands(&self) -> usize {
        self.steps.iter().filter(|s| s.same_as_policy).count()
    }
}

/// Replays the cycle at `start` of `log` through a [`Controller`] on
/// `model` with `policy`; `problem` gives the limits (its start payout is
/// replaced by the logged one).
///
/// Errors when the controller cannot start there (the start payout breaks
/// a stroke limit, or the model cannot fold to it).
pub fn replay_log(
    model: &ForwardModel,
    problem: &DeploymentProblem,
    policy: &Policy,
    log: &MeasurementLog,
    start: &ReplayStart,
) -> Result<Replay, ReplayInputError> {
    let problem = problem_from(problem, start);
    let cycle = &log.cycles[start.cycle_index];
    let s = model.structure();
    let gaps = |readings: &[Option<f64>]| -> Vec<Option<f64>> {
        measured_gap_vectors(s, &log.sensors, readings)
            .iter()
            .map(|g| g.map(|g| g.norm()))
            .collect()
    };
    let first = &cycle.readings[start.start_reading];
    let bad_start = |error: PlanError| ReplayInputError::BadStart {
        cycle: start.cycle,
        start_payout_m: start.start_payout_m.clone(),
        error,
    };
    let mut controller =
        Controller::new(model, &problem, policy, &log.sensors, first).map_err(bad_start)?;
    let mut steps = Vec::new();
    let mut stopped = None;
    for k in start.start_reading..cycle.commands.len() {
        let logged = &cycle.commands[k];
        let after = &cycle.readings[k + 1];
        let (policy_command_m, policy_stop, policy_predicted_gaps_m, planning_time_s) =
            match controller.decide() {
                ControllerDecision::Send(p) => (
                    Some(p.sent_m),
                    None,
                    Some(p.predicted_gaps_m),
                    p.planning_time_s,
                ),
                ControllerDecision::Stop(status) => (None, Some(status), None, 0.0),
            };
        let observation = match controller.observe(logged, after) {
            Ok(o) => o,
            Err(error) => {
                stopped = Some(ReplayStop {
                    step: cycle.step_labels[k],
                    error,
                });
                break;
            }
        };
        steps.push(ReplayStep {
            step: cycle.step_labels[k],
            logged_command_m: logged.clone(),
            largest_difference_m: policy_command_m.as_ref().map(|p| {
                p.iter()
                    .zip(logged)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            }),
            policy_command_m,
            policy_stop,
            same_as_policy: observation.own_decision,
            policy_predicted_gaps_m,
            logged_predicted_gaps_m: observation.predicted_gaps_m,
            measured_gaps_m: gaps(after),
            planning_time_s,
        });
    }
    let (next_command_m, next_stop) = if stopped.is_some() {
        (None, None)
    } else {
        match controller.decide() {
            ControllerDecision::Send(p) => (Some(p.sent_m), None),
            ControllerDecision::Stop(status) => (None, Some(status)),
        }
    };
    Ok(Replay {
        start: start.clone(),
        start_measured_gaps_m: gaps(first),
        steps,
        next_command_m,
        next_stop,
        stopped,
    })
}

/// The margins of a closed-loop run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Margins {
    /// Whether it connected: its verdict ([`crate::plan::RunVerdict`]) is
    /// `connected`.
    pub connected: bool,
    /// The verdict's label: what the truth did (`connected`,
    /// `limits_broken`, …).
    pub outcome: &'static str,
    /// How the controller itself ended.
    pub status: PlanStatus,
    /// Commands sent.
    pub commands: usize,
    /// Largest measured gap at the end, m.
    pub final_measured_gap_m: Option<f64>,
    /// Largest true gap at the end, m.
    pub final_true_gap_m: Option<f64>,
    /// Worst member utilisation of the truth along every command.
    pub worst_utilisation: f64,
    /// Smallest cable, spring or segment tension of the truth along every
    /// command, N (`None`: no command sent).
    pub min_tension_n: Option<f64>,
    /// Truth limit violations over all commands and increments.
    pub violations: usize,
}

impl Margins {
    /// The margins of `d`, judged against the connection tolerance
    /// `tolerance_m`.
    pub fn of(d: &Deployment, tolerance_m: f64) -> Margins {
        let verdict = d.verdict(tolerance_m);
        Margins {
            connected: verdict.is_connected(),
            outcome: verdict.label(),
            status: d.status.clone(),
            commands: d.records.len(),
            final_measured_gap_m: d.final_measured_gap_m(),
            final_true_gap_m: d.final_true_gap_m(),
            worst_utilisation: d.truth_worst_utilisation(),
            min_tension_n: d
                .records
                .iter()
                .map(|r| r.truth_min_tension_n)
                .reduce(f64::min),
            violations: d.truth_limit_violations,
        }
    }
}

/// The counterfactual at one end of a calibrated parameter's 95 %
/// interval ([`crate::measure::calibrate::IntervalEnd`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IntervalEndRun {
    /// Which end, e.g. `joint_friction mu = 0.2057 (+2 SE)`.
    pub label: String,
    /// Its margins, if it ran.
    pub counterfactual: Option<Margins>,
    /// Why it did not run.
    pub failed: Option<String>,
}

impl IntervalEndRun {
    /// Whether the policy connected there, within every limit.
    pub fn connected(&self) -> bool {
        self.counterfactual.as_ref().is_some_and(|m| m.connected)
    }
}

/// The counterfactual: `policy` on `model` deploys `truth` (the model
/// calibrated on the log) in closed loop from the replay's start, read by
/// the log's sensors with their noise drawn from `seed`.
#[allow(clippy::too_many_arguments)]
pub fn counterfactual(
    model: &ForwardModel,
    problem: &DeploymentProblem,
    policy: &Policy,
    truth: &EffectModel,
    log: &MeasurementLog,
    start: &ReplayStart,
    seed: u64,
) -> Result<Deployment, DeployError> {
    let problem = problem_from(problem, start);
    deploy_closed_loop(
        &ClosedLoopSetup {
            model,
            problem: &problem,
            policy,
            truth,
            sensors: &log.sensors,
            temperature_c: start.temperature_c,
            seed,
        },
        &mut (),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::log::Cycle;
    use crate::sim::{Axis, Sensor};

    fn log(cycles: Vec<Cycle>) -> MeasurementLog {
        MeasurementLog {
            structure: "b".into(),
            sensors: vec![
                Sensor {
                    id: "z".into(),
                    target: SensorTarget::Position {
                        node: 0,
                        axis: Axis::Z,
                    },
                    noise_sd: 0.001,
                },
                Sensor {
                    id: "t".into(),
                    target: SensorTarget::Temperature,
                    noise_sd: 0.1,
                },
            ],
            cycles,
        }
    }

    fn cycle(label: u64, commands: Vec<Vec<f64>>, step0_measured: bool) -> Cycle {
        let n = commands.len();
        let mut readings: Vec<Vec<Option<f64>>> = (0..=n)
            .map(|k| vec![Some(k as f64), Some(20.0 + k as f64)])
            .collect();
        if !step0_measured {
            readings[0] = vec![None, None];
        }
        Cycle {
            label,
            step_labels: (1..=n as u64).collect(),
            commands,
            readings,
        }
    }

    #[test]
    fn a_replay_stop_and_a_bad_start_read_as_before() {
        let stop = ReplayStop {
            step: 4,
            error: ControllerError::WrongLength {
                what: "the sent command",
                found: 9,
                expected: 10,
            },
        };
        let text = "step 4: the sent command: 9 values, the controller expects 10";
        assert_eq!(stop.describe(), text);
        assert_eq!(serde_json::to_value(&stop).unwrap(), text);
        let bad = ReplayInputError::BadStart {
            cycle: 2,
            start_payout_m: vec![0.4, 0.3],
            error: PlanError::NoMidspanPairs,
        };
        assert_eq!(
            bad.to_string(),
            "cycle 2: the start payout [0.4, 0.3] m cannot be a deployment's start: the structure has no midspan pairs to connect"
        );
    }

    #[test]
    fn a_deploy_cycle_starts_at_its_fold_and_a_lab_cycle_at_its_largest_payout() {
        // Deploy layout: step 0 unmeasured, step 1 the fold.
        let d = log(vec![cycle(
            1,
            vec![vec![0.4, 0.3], vec![-0.1, -0.1], vec![0.05, 0.0]],
            false,
        )]);
        let s = deployment_start(&d, 1).unwrap();
        assert_eq!(
            (s.layout, s.start_reading, s.start_step),
            (LogLayout::Deploy, 1, 1)
        );
        assert_eq!(s.start_payout_m, vec![0.4, 0.3]);
        assert_eq!(s.temperature_c, Some(21.0));

        // Lab layout: two cycles; the second starts from where the first
        // ended (+0.01 left over) and peaks after its second pay-out.
        let up_down =
            |a: f64, rest: f64| vec![vec![a; 2], vec![a; 2], vec![-a; 2], vec![-a + rest; 2]];
        let l = log(vec![
            cycle(1, up_down(0.02, 0.01), true),
            cycle(2, up_down(0.05, 0.0), true),
        ]);
        let s = deployment_start(&l, 2).unwrap();
        assert_eq!(
            (s.layout, s.start_reading, s.start_step),
            (LogLayout::Lab, 2, 2)
        );
        for p in &s.start_payout_m {
            assert!((p - (0.01 + 0.10)).abs() < 1e-15, "{p}");
        }
        assert_eq!(default_cycle(&l), Some(2));

        // Nothing after the peak, an unknown cycle: refused, naming the
        // file and field.
        let e = deployment_start(&log(vec![cycle(3, vec![vec![0.1; 2]], true)]), 3).unwrap_err();
        assert!(
            matches!(
                e,
                ReplayInputError::NoCommandsAfterStart {
                    cycle: 3,
                    start_step: 1
                }
            ),
            "{e}"
        );
        assert_eq!((e.file(), e.field()), ("commands.csv", "step"));
        let e = deployment_start(&l, 9).unwrap_err();
        assert_eq!((e.file(), e.field()), ("commands.csv", "cycle"));
    }
}
