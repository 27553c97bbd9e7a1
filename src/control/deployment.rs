//! What a closed-loop deployment produced: its start, one record per
//! command (planned, done by the truth, measured), the whole run, and
//! the observer that receives them as they happen.

use serde::Serialize;

use crate::model::DeploymentState;
use crate::plan::limits::{StartBrokenLimit, StateBreach};
use crate::plan::{Breach, LimitViolation, PlanStatus, QpStepStatus, RunVerdict};

/// The largest measured gap below which the deployment is in its last,
/// corrective phase, m: twice the 30 mm connection tolerance (the issue's
/// "corrective commands, after the first that brings the largest gap below
/// 60 mm").
pub const CORRECTIVE_PHASE_GAP_M: f64 = 0.060;

/// The start of a deployment, as the observer and the result see it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeployStart {
    /// Payout of every motor at the start, m (the problem's fold).
    pub start_payout_m: Vec<f64>,
    /// Gap per midspan pair on the controller's model, m.
    pub model_gaps_m: Vec<f64>,
    /// Gap per midspan pair as measured, m (`None`: a position reading
    /// missing).
    pub measured_gaps_m: Vec<Option<f64>>,
    /// Gap per midspan pair of the truth, m (reports only).
    pub true_gaps_m: Vec<f64>,
    /// Largest number of commands the policy allows.
    pub max_commands: usize,
}

impl DeployStart {
    /// Largest measured gap at the start, m (`None` when no pair was
    /// measured).
    pub fn largest_measured_gap_m(&self) -> Option<f64> {
        largest(&self.measured_gaps_m)
    }
}

/// One command of a deployment: what was planned, what the truth did,
/// what the sensors saw.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeployRecord {
    /// Command number, 1 for the first.
    pub index: usize,
    /// Payout change per motor, m (positive pays out).
    pub command_m: Vec<f64>,
    /// Gap per pair the controller predicted for the command: its model's
    /// trial plus the correction in force when it planned, m.
    pub predicted_gaps_m: Vec<f64>,
    /// Gap per pair from the measurement after the command, m (`None`
    /// where a position reading is missing).
    pub measured_gaps_m: Vec<Option<f64>>,
    /// Gap per pair of the truth after the command, m (for reports and
    /// tests; the controller never reads it).
    pub true_gaps_m: Vec<f64>,
    /// Worst member utilisation of the truth along the command's
    /// increments.
    pub truth_worst_utilisation: f64,
    /// Smallest cable, spring or segment tension of the truth along the
    /// command, N.
    pub truth_min_tension_n: f64,
    /// Limits the truth broke along the command (empty when none), in
    /// increment order.
    pub truth_violations: Vec<LimitViolation>,
    /// The increment (1 for the first) of each of `truth_violations`.
    pub truth_violation_increments: Vec<usize>,
    /// Increments the truth applied the command in.
    pub truth_increments: usize,
    /// Increments whose state was checked against the limits (all of them
    /// unless one did not converge).
    pub truth_increments_checked: usize,
    /// Worst member utilisation along the command on the controller's
    /// model (with the force correction).
    pub model_worst_utilisation: f64,
    /// Status of the step's QP (QP planner).
    pub qp_status: Option<QpStepStatus>,
    /// Trust region the command was planned in, m (QP planner).
    pub trust_region_m: Option<f64>,
    /// Trials rejected before the command was accepted.
    pub rejected_trials: usize,
    /// Constraints active in the decision.
    pub active_constraints: Vec<String>,
    /// Whether the command took up slack cables
    /// ([`crate::plan::PlannedCommand::take_up`]).
    pub take_up: bool,
    /// Wall-clock planning time, s (the one value that is not a function
    /// of the inputs).
    #[serde(skip)]
    pub planning_time_s: f64,
}

impl DeployRecord {
    /// Largest measured gap, m (`None` when no pair was measured).
    pub fn largest_measured_gap_m(&self) -> Option<f64> {
        largest(&self.measured_gaps_m)
    }
}

/// Largest of the known values.
pub(super) fn largest(gaps: &[Option<f64>]) -> Option<f64> {
    gaps.iter().flatten().copied().reduce(f64::max)
}

/// A closed-loop deployment.
#[derive(Debug, Clone, PartialEq)]
pub struct Deployment {
    /// How it ended: connected (as measured), the command budget spent,
    /// the planner's stop, or a failure of a solver or of the truth plant.
    pub status: PlanStatus,
    /// The start.
    pub start: DeployStart,
    /// One record per command sent, in order.
    pub records: Vec<DeployRecord>,
    /// Sensor readings per step (step 0: the start; step k: after command
    /// k), one `Option` per sensor in the setup's order.
    pub readings: Vec<Vec<Option<f64>>>,
    /// The truth's state at the start (folded).
    pub start_true_state: DeploymentState,
    /// The truth's state at the end.
    pub final_true_state: DeploymentState,
    /// The controller's model state at the end.
    pub final_model_state: DeploymentState,
    /// Truth limit violations over all commands and increments.
    pub truth_limit_violations: usize,
    /// The truth's limits that its folded start already broke, with
    /// whether the end meets them (see [`crate::plan::limits`]).
    pub truth_start_broken: Vec<StartBrokenLimit>,
    /// Where the truth broke a limit during the run or left one its start
    /// broke unrestored, the limits its own as-built state breaks by itself
    /// ([`RunVerdict::as_built_broken`]; empty: none); `None` where the run
    /// kept every limit, so nothing was checked.
    pub truth_as_built_broken: Option<Vec<StateBreach>>,
    /// The number of the first command after which the largest measured
    /// gap is below [`CORRECTIVE_PHASE_GAP_M`] (0: already at the start).
    pub first_below_corrective_gap: Option<usize>,
    /// Commands after that one: the corrective commands.
    pub corrective_commands: Option<usize>,
    /// Commands of the first approach: with a feedforward
    /// ([`super::Guidance::feedforward_m`]), the take-ups sent before it,
    /// if any, and the feedforward commands sent (a halved learnt
    /// command's parts counted one by one); otherwise the
    /// commands up to the first the controller predicted would connect
    /// (`None`: it never predicted so).
    pub approach_commands: Option<usize>,
    /// With a feedforward, whether every learnt command was sent (some in
    /// parts, see [`super::Guidance::feedforward_splits`]); `None`
    /// without one.
    pub learnt_approach_completed: Option<bool>,
    /// The payout scale of each independent part as estimated at the end
    /// (index = part id; empty without an estimator), 1.
    pub final_payout_scale: Vec<f64>,
    /// The load cells' common bias as estimated at the end: mean and
    /// standard deviation, N (`None` without the estimate; see
    /// [`super::ForceOffsetFilter`]).
    pub final_load_cell_bias_n: Option<(f64, f64)>,
}

impl Deployment {
    /// The verdict on the run, judged on the truth: connected only when
    /// the controller stopped as connected, every true gap is within
    /// `tolerance_m`, the truth broke no limit and every start-broken
    /// limit was restored ([`RunVerdict`]).
    pub fn verdict(&self, tolerance_m: f64) -> RunVerdict {
        RunVerdict {
            status: self.status.clone(),
            largest_gap_m: self.final_true_gap_m(),
            tolerance_m,
            broken: Breach::first_per_limit(self.records.iter().flat_map(|r| {
                r.truth_violation_increments
                    .iter()
                    .zip(&r.truth_violations)
                    .map(move |(&k, v)| (r.index, k, v))
            })),
            violations: self.truth_limit_violations,
            start_broken: self.truth_start_broken.clone(),
            as_built_broken: self.truth_as_built_broken.clone().unwrap_or_default(),
        }
    }

    /// The commands sent, per command and motor, m.
    pub fn commands(&self) -> Vec<Vec<f64>> {
        self.records.iter().map(|r| r.command_m.clone()).collect()
    }

    /// Indices (0 for the first) of the commands that took up slack
    /// cables.
    pub fn take_up_commands(&self) -> Vec<usize> {
        self.records
            .iter()
            .enumerate()
            .filter(|(_, r)| r.take_up)
            .map(|(k, _)| k)
            .collect()
    }

    /// Largest measured gap at the end, m.
    pub fn final_measured_gap_m(&self) -> Option<f64> {
        match self.records.last() {
            Some(r) => r.largest_measured_gap_m(),
            None => self.start.largest_measured_gap_m(),
        }
    }

    /// Largest measured gap after the first approach, m (`None` without
    /// an approach or a reading).
    pub fn approach_gap_m(&self) -> Option<f64> {
        let k = self.approach_commands?;
        match k {
            0 => self.start.largest_measured_gap_m(),
            k => self.records.get(k - 1)?.largest_measured_gap_m(),
        }
    }

    /// Worst truth utilisation over the commands (0 without a command).
    pub fn truth_worst_utilisation(&self) -> f64 {
        self.records
            .iter()
            .map(|r| r.truth_worst_utilisation)
            .fold(0.0, f64::max)
    }

    /// How far the truth's forces went beyond their bounds at worst, N
    /// ([`crate::plan::LimitViolation::force_excess_n`] over every
    /// command's breaches; `None` when no force bound was broken): tells a
    /// breach at the solver's rounding from one that slackens a cable.
    pub fn largest_force_breach_n(&self) -> Option<f64> {
        self.records
            .iter()
            .flat_map(|r| &r.truth_violations)
            .filter_map(|v| v.force_excess_n())
            .reduce(f64::max)
    }

    /// Largest true gap at the end, m.
    pub fn final_true_gap_m(&self) -> Option<f64> {
        let gaps = match self.records.last() {
            Some(r) => &r.true_gaps_m,
            None => &self.start.true_gaps_m,
        };
        gaps.iter().copied().reduce(f64::max)
    }
}

/// Receives the deployment's progress (the CLI's lines and progress bar;
/// numerics never print).
pub trait DeployObserver {
    /// Called once the start is measured, before the first command.
    fn on_start(&mut self, start: &DeployStart);
    /// Called after each command is applied and measured.
    fn on_command(&mut self, record: &DeployRecord);
}

/// An observer that ignores everything.
impl DeployObserver for () {
    fn on_start(&mut self, _: &DeployStart) {}
    fn on_command(&mut self, _: &DeployRecord) {}
}
