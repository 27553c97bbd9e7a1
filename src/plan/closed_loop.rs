//! The closed-loop deployment: a planner on the controller's model, a
//! truth plant that stands in for the real bridge, and the sensors
//! between them.
//!
//! The controller never reads the truth's state. It holds its own model
//! state (the folded start on its model, then each command's confirmed
//! trial, see [`super::planner::Trial`]) and, after the start and after
//! every command, one noisy measurement of the plant. Model and
//! measurement are reconciled in three ways:
//! - the payout scale of each bridge half is estimated from the measured
//!   midspan motion ([`super::estimation`]); commands are sent scaled by
//!   it, and after each command the model state is re-solved to where the
//!   command really took the bridge;
//! - for every quantity the policy [`Policy::measures`], the offset
//!   measured − predicted is added to every later prediction of it, until
//!   the next measurement ([`model_correction`], [`super::correction`]);
//!   with midspan positions measured, the connection test therefore reads
//!   the *measured* gaps;
//! - the load-cell offsets are filtered across measurements
//!   ([`super::correction::ForceOffsetFilter`]), so that one noisy reading
//!   does not move a force limit.
//!
//! The truth is checked too, as a supervisor would on the real bridge:
//! every increment of every command is checked against the problem's
//! limits built on the truth's own structure and start ([`TruthWatch`]).
//! A violation does not stop the run (the controller cannot see it); it
//! is recorded and counted.
//!
//! Randomness: the sensor noise only, from one `StdRng` seeded with the
//! setup's seed and drawn in a fixed order (one measurement of every
//! sensor per step), so a seed gives the same deployment at any thread
//! count. Planning times are the only values that are not a function of
//! the inputs.

use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::SeedableRng;
use serde::Serialize;
use thiserror::Error;

use super::controller::{Controller, ControllerDecision};
use super::correction::{ForceOffsetFilter, ModelCorrection};
use super::limits::{force_rows, LimitCheck, Limits};
use super::outcome::{PlanError, PlanStatus};
use super::planner::worst_along_path;
use super::policy::{Measurement, Policy};
use super::problem::DeploymentProblem;
use super::qp_step::QpStepStatus;
use crate::model::{DeploymentState, ForwardModel, IncrementObserver, RelaxReport, Structure};
use crate::sim::{EffectModel, Plant, ReplayError, Sensor, SensorTarget};

/// The largest measured gap below which the deployment is in its last,
/// corrective phase, m: twice the 30 mm connection tolerance (the issue's
/// "corrective commands, after the first that brings the largest gap below
/// 60 mm").
pub const CORRECTIVE_PHASE_GAP_M: f64 = 0.060;

/// Everything a closed-loop deployment runs with.
#[derive(Debug, Clone, Copy)]
pub struct ClosedLoopSetup<'a> {
    /// The controller's model: what it plans on.
    pub model: &'a ForwardModel,
    /// The problem (start, connection, limits), for controller and truth.
    pub problem: &'a DeploymentProblem,
    /// The policy: planner, margins, command budget, what is measured.
    pub policy: &'a Policy,
    /// The truth: the structure with the effects the real bridge has.
    pub truth: &'a EffectModel,
    /// The sensors read on the truth after the start and every command.
    pub sensors: &'a [Sensor],
    /// Air temperature during the deployment, °C (`None`: unknown, the
    /// truth's reference temperature).
    pub temperature_c: Option<f64>,
    /// Seed of the sensor noise.
    pub seed: u64,
}

/// Why a deployment could not start.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DeployError {
    /// The problem, policy or controller model is unusable (or the model
    /// cannot reach the folded start).
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The truth cannot be built or cannot reach the folded start.
    #[error("the truth plant, reaching the folded start: {0}")]
    TruthStart(ReplayError),
    /// The controller's model and the truth are not the same bridge.
    #[error("the controller's model and the truth differ: {0}")]
    Mismatch(String),
}

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
    /// Limits the truth broke along the command (empty when none).
    pub truth_violations: Vec<String>,
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
fn largest(gaps: &[Option<f64>]) -> Option<f64> {
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
    /// The number of the first command after which the largest measured
    /// gap is below [`CORRECTIVE_PHASE_GAP_M`] (0: already at the start).
    pub first_below_corrective_gap: Option<usize>,
    /// Commands after that one: the corrective commands.
    pub corrective_commands: Option<usize>,
    /// Commands of the first approach: with a feedforward
    /// ([`Guidance::feedforward_m`]), the feedforward commands sent;
    /// otherwise the commands up to the first the controller predicted
    /// would connect (`None`: it never predicted so).
    pub approach_commands: Option<usize>,
    /// The payout scale of each independent part as estimated at the end
    /// (index = part id; empty without an estimator), 1.
    pub final_payout_scale: Vec<f64>,
}

impl Deployment {
    /// The commands sent, per command and motor, m.
    pub fn commands(&self) -> Vec<Vec<f64>> {
        self.records.iter().map(|r| r.command_m.clone()).collect()
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

/// Checks every increment of the truth against limits built on the
/// truth's own structure (its force rows may differ from the model's:
/// effects may append foundation members).
#[derive(Debug, Clone)]
pub struct TruthWatch<'a> {
    model: &'a ForwardModel,
    limits: &'a Limits,
    /// Increments seen.
    pub increments: usize,
    /// Increments checked (the converged ones).
    pub checked: usize,
    /// The worst values and every violation so far (`None` before the
    /// first checked increment).
    pub worst: Option<LimitCheck>,
}

impl<'a> TruthWatch<'a> {
    /// A watch of `limits` on states of `model`.
    pub fn new(model: &'a ForwardModel, limits: &'a Limits) -> Self {
        TruthWatch {
            model,
            limits,
            increments: 0,
            checked: 0,
            worst: None,
        }
    }
}

impl IncrementObserver for TruthWatch<'_> {
    fn on_increment(&mut self, _: usize, _: usize, r: &RelaxReport, state: &DeploymentState) {
        self.increments += 1;
        // A state that is no equilibrium has no meaningful forces; the
        // plant reports the failed solve itself.
        if !r.status.is_converged() {
            return;
        }
        // The solver's tolerance absorbs rounding at a bound, as in the
        // planner's own checks; the truth has no correction.
        let c = self.limits.check(self.model, state, r.tolerance_n, &[]);
        self.checked += 1;
        self.worst = Some(worst_along_path(self.worst.take(), c));
    }
}

/// Gap vector `x_a − x_b` of each midspan pair from a measurement: the
/// six position readings of its two nodes; `None` where any is missing
/// or no sensor reads it.
pub fn measured_gap_vectors(
    structure: &Structure,
    sensors: &[Sensor],
    readings: &[Option<f64>],
) -> Vec<Option<Vector3<f64>>> {
    let position = |node: usize| -> Option<Vector3<f64>> {
        let mut p = Vector3::zeros();
        for axis in 0..3 {
            let s = sensors
                .iter()
                .position(|s| s.target == SensorTarget::Position { node, axis })?;
            p[axis] = (*readings.get(s)?)?;
        }
        Some(p)
    };
    structure
        .midspan_pairs
        .iter()
        .map(|[a, b]| Some(position(*a)? - position(*b)?))
        .collect()
}

/// The force row (members, then segments) a load cell reads on `model`,
/// if the model has it.
fn load_cell_row(
    model: &ForwardModel,
    state: &DeploymentState,
    target: SensorTarget,
) -> Option<usize> {
    let s = model.structure();
    match target {
        SensorTarget::SegmentTension { cable, segment } => {
            let c = s.continuous_cables.get(cable)?;
            (segment < c.segment_count())
                .then(|| s.members.len() + state.segment_offsets[cable] + segment)
        }
        // A member the effects appended to the truth (a foundation bar)
        // has no row in the model.
        SensorTarget::MemberForce { member } => (member < s.members.len()).then_some(member),
        _ => None,
    }
}

/// The correction of `model`'s predictions at `state` from one
/// measurement: for every quantity `measures` lists, measured −
/// predicted (see [`super::correction`]).
///
/// - [`Measurement::MidspanPositions`]: each midspan pair's gap vector
///   from the six position readings of its two nodes; a pair with a
///   missing reading keeps offset 0 (its gap is the model's until it is
///   measured again).
/// - [`Measurement::LoadCells`]: the force row of each load cell's
///   segment or member; a missing reading keeps offset 0.
///
/// Everything else is unmeasured and keeps offset 0.
pub fn model_correction(
    model: &ForwardModel,
    state: &DeploymentState,
    sensors: &[Sensor],
    readings: &[Option<f64>],
    measures: &[Measurement],
) -> ModelCorrection {
    let s = model.structure();
    let mut correction =
        ModelCorrection::none(s.midspan_pairs.len(), s.members.len() + s.segment_count());
    if measures.contains(&Measurement::MidspanPositions) {
        let measured = measured_gap_vectors(s, sensors, readings);
        for ((offset, m), [a, b]) in correction
            .gap_offsets_m
            .iter_mut()
            .zip(measured)
            .zip(&s.midspan_pairs)
        {
            if let Some(m) = m {
                *offset = m - (state.positions_m[*a] - state.positions_m[*b]);
            }
        }
    }
    if measures.contains(&Measurement::LoadCells) {
        let predicted = force_rows(model, state);
        for (sensor, reading) in sensors.iter().zip(readings) {
            if let (Some(row), Some(value)) = (load_cell_row(model, state, sensor.target), reading)
            {
                correction.force_offsets_n[row] = value - predicted[row];
                correction.force_measured[row] = true;
            }
        }
    }
    correction
}

/// Filters `correction`'s load-cell offsets through `filter`: the rows
/// read this time (when `measures` has the load cells) carry their
/// sensor's noise.
pub(super) fn filter_force_offsets(
    filter: &mut ForceOffsetFilter,
    correction: &mut ModelCorrection,
    model: &ForwardModel,
    state: &DeploymentState,
    sensors: &[Sensor],
    readings: &[Option<f64>],
    measures: &[Measurement],
) {
    let predicted = force_rows(model, state);
    let mut noise_sd_n = vec![None; predicted.len()];
    // Load cells the policy does not measure left no offset to filter.
    if measures.contains(&Measurement::LoadCells) {
        for (sensor, reading) in sensors.iter().zip(readings) {
            if let (Some(row), Some(_)) = (load_cell_row(model, state, sensor.target), reading) {
                noise_sd_n[row] = Some(sensor.noise_sd);
            }
        }
    }
    filter.filter(correction, &predicted, &noise_sd_n);
}

/// Refuses a truth that is not the controller's bridge: the same nodes,
/// continuous cables (segment for segment) and midspan pairs, so that
/// commands, sensors and gaps mean the same on both.
fn check_same_bridge(model: &Structure, truth: &Structure) -> Result<(), DeployError> {
    let mismatch = |what: String| Err(DeployError::Mismatch(what));
    if model.nodes.len() != truth.nodes.len() {
        return mismatch(format!(
            "{} nodes in the model, {} in the truth",
            model.nodes.len(),
            truth.nodes.len()
        ));
    }
    let cables = |s: &Structure| -> Vec<(String, usize)> {
        s.continuous_cables
            .iter()
            .map(|c| (c.id.clone(), c.segment_count()))
            .collect()
    };
    if cables(model) != cables(truth) {
        return mismatch("the continuous cables (ids or segment counts) differ".into());
    }
    if model.midspan_pairs != truth.midspan_pairs {
        return mismatch("the midspan pairs differ".into());
    }
    Ok(())
}

/// What past cycles tell a deployment (from the case memory, see
/// `crate::learn`). The default is no guidance: the memoryless controller.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Guidance {
    /// Drum commands to send first, in order, m per motor: the learnt
    /// approach. Each is tried on the controller's model before it is sent
    /// (as cable motion `sent·(1 + ŝ)`); the first the model finds beyond
    /// a limit or a motor's stroke ends the feedforward, and the planner
    /// takes over. The connection test waits until the feedforward is sent
    /// unless the next feedforward command is predicted not to reduce the
    /// largest gap.
    pub feedforward_m: Vec<Vec<f64>>,
    /// Payout scale per independent part to start the estimator from
    /// (index = part id), 1; `None`: start at 0.
    pub payout_scale_prior: Option<Vec<f64>>,
    /// Standard deviation of that prior, 1 (used with `payout_scale_prior`;
    /// 0 or less: the policy's own prior).
    pub payout_scale_prior_sd: f64,
}

/// Deploys the truth from the folded start in closed loop: plan on the
/// model, send to the truth, measure, correct the model's predictions,
/// until the measured gaps are within the connection tolerance less the
/// policy's margin, the command budget is spent or the planner stops.
///
/// Errors only when the run cannot start; a failure during the run (a
/// solver, the truth plant) ends it with a status saying so.
pub fn deploy_closed_loop(
    setup: &ClosedLoopSetup,
    observer: &mut dyn DeployObserver,
) -> Result<Deployment, DeployError> {
    deploy_guided(setup, &Guidance::default(), None, observer)
}

/// [`deploy_closed_loop`] with `guidance` from past cycles, on `plant`
/// where given (a truth as a previous cycle's fold left it; it is left
/// where this deployment ends) or else on a fresh fold of the setup's
/// truth.
pub fn deploy_guided(
    setup: &ClosedLoopSetup,
    guidance: &Guidance,
    plant: Option<&mut Plant>,
    observer: &mut dyn DeployObserver,
) -> Result<Deployment, DeployError> {
    let (model, policy) = (setup.model, setup.policy);
    let s = model.structure();
    check_same_bridge(s, &setup.truth.structure)?;
    let motors = setup
        .problem
        .motor_limits(s.continuous_cables.len())
        .map_err(PlanError::from)?;
    let mut fresh_plant;
    let plant = match plant {
        Some(p) => p,
        None => {
            fresh_plant = Plant::new(
                setup.truth,
                Some(&motors.start_payout_m),
                setup.temperature_c,
            )
            .map_err(DeployError::TruthStart)?;
            &mut fresh_plant
        }
    };
    // The temperature holds for the whole deployment, so the truth's
    // model is the same after every command: one copy serves the watch.
    let truth_model = plant.model().clone();
    let truth_limits = Limits::new(&truth_model, setup.problem, plant.state());
    let truth_structure = truth_model.structure();

    let mut rng = StdRng::seed_from_u64(setup.seed);
    let first = plant.measure(setup.sensors, &mut rng);
    let mut controller = Controller::guided(
        model,
        setup.problem,
        policy,
        setup.sensors,
        &first,
        guidance,
    )?;
    let gaps = |readings: &[Option<f64>]| -> Vec<Option<f64>> {
        measured_gap_vectors(truth_structure, setup.sensors, readings)
            .iter()
            .map(|g| g.map(|g| g.norm()))
            .collect()
    };
    let start = DeployStart {
        start_payout_m: motors.start_payout_m.clone(),
        model_gaps_m: controller.state().midspan_gaps_m(s),
        measured_gaps_m: gaps(&first),
        true_gaps_m: plant.state().midspan_gaps_m(truth_structure),
        max_commands: policy.max_commands,
    };
    observer.on_start(&start);
    let mut readings = vec![first];
    let start_true_state = plant.state().clone();

    let mut records: Vec<DeployRecord> = Vec::new();
    let status = loop {
        let p = match controller.decide() {
            ControllerDecision::Stop(status) => break status,
            ControllerDecision::Send(p) => p,
        };
        let index = records.len() + 1;
        let mut watch = TruthWatch::new(&truth_model, &truth_limits);
        let report = plant.apply(&p.sent_m, setup.temperature_c, &mut watch);
        if let Err(e) = report {
            break PlanStatus::SolverFailure {
                reason: format!("the truth plant failed on command {index}: {e}"),
            };
        }
        let truth_increments = watch.increments;
        let check = watch.worst.unwrap_or_else(|| LimitCheck {
            worst_utilisation: 0.0,
            min_tension_n: f64::INFINITY,
            min_clearance_m: f64::INFINITY,
            violations: Vec::new(),
        });
        let reading = plant.measure(setup.sensors, &mut rng);
        // The controller's own decision: its trial is the prediction, so
        // this cannot fail to follow; a failure would be a bug, reported
        // as the run's end rather than a panic.
        if let Err(e) = controller.observe(&p.sent_m, &reading) {
            break PlanStatus::SolverFailure {
                reason: format!("command {index}: {e}"),
            };
        }
        let record = DeployRecord {
            index,
            command_m: p.sent_m,
            predicted_gaps_m: p.predicted_gaps_m,
            measured_gaps_m: gaps(&reading),
            true_gaps_m: plant.state().midspan_gaps_m(truth_structure),
            truth_worst_utilisation: check.worst_utilisation,
            truth_min_tension_n: check.min_tension_n,
            truth_violations: check.violations,
            truth_increments,
            truth_increments_checked: watch.checked,
            model_worst_utilisation: p.model_worst_utilisation,
            qp_status: p.qp_status,
            trust_region_m: p.trust_region_m,
            rejected_trials: p.rejected_trials,
            active_constraints: p.active_constraints,
            planning_time_s: p.planning_time_s,
        };
        observer.on_command(&record);
        records.push(record);
        readings.push(reading);
    };

    let first_below_corrective_gap =
        if largest(&start.measured_gaps_m).is_some_and(|g| g < CORRECTIVE_PHASE_GAP_M) {
            Some(0)
        } else {
            records
                .iter()
                .find(|r| {
                    r.largest_measured_gap_m()
                        .is_some_and(|g| g < CORRECTIVE_PHASE_GAP_M)
                })
                .map(|r| r.index)
        };
    Ok(Deployment {
        approach_commands: controller.approach_commands(),
        final_payout_scale: controller.part_payout_scale(),
        status,
        truth_limit_violations: records.iter().map(|r| r.truth_violations.len()).sum(),
        corrective_commands: first_below_corrective_gap.map(|k| records.len() - k),
        first_below_corrective_gap,
        start,
        records,
        readings,
        start_true_state,
        final_true_state: plant.state().clone(),
        final_model_state: controller.into_state(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{JointFriction, RelaxSettings};
    use crate::plan::planner::{folded_start, PlanContext};
    use crate::plan::PerMotor;
    use crate::sim::{default_truth, standard_sensors};

    fn frictionless_model() -> ForwardModel {
        ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap()
    }

    /// A 10 cm fold: a few increments, so these tests take a second.
    fn short_fold() -> DeploymentProblem {
        DeploymentProblem {
            start_payout_m: PerMotor::All(0.10),
            ..DeploymentProblem::default()
        }
    }

    #[test]
    fn the_truth_watch_sees_every_increment_and_reports_a_tight_limit() {
        let truth = default_truth(reference_bridge(&BridgeParameters::default()).unwrap());
        let n = truth.structure.continuous_cables.len();
        let mut plant = Plant::new(&truth, Some(&vec![0.10; n]), None).unwrap();
        let model = plant.model().clone();
        // Reeling in 2.5 cm raises the continuous-cable tensions. With the
        // default limits nothing is near a bound; with a 1 N tension limit
        // every tension-only row is widened to its start value, so the
        // rise breaks some of them.
        let loose = Limits::new(&model, &DeploymentProblem::default(), plant.state());
        let tight_problem = DeploymentProblem {
            max_tension_n: 1.0,
            ..DeploymentProblem::default()
        };
        let tight = Limits::new(&model, &tight_problem, plant.state());
        let command = vec![-0.025; n];
        let mut a = plant.clone();
        let mut watch = TruthWatch::new(&model, &loose);
        let report = a.apply(&command, None, &mut watch).unwrap();
        assert_eq!(watch.increments, report.increments);
        assert_eq!(watch.checked, report.increments);
        assert!(report.increments >= 3, "{}", report.increments);
        let w = watch.worst.unwrap();
        assert!(w.ok(), "{:?}", w.violations);
        assert!(w.worst_utilisation > 0.0 && w.min_tension_n > 5.0);

        let mut watch = TruthWatch::new(&model, &tight);
        plant.apply(&command, None, &mut watch).unwrap();
        assert_eq!(watch.checked, report.increments);
        let w = watch.worst.unwrap();
        assert!(!w.ok());
        assert!(
            w.violations.iter().all(|v| v.contains("above")),
            "{:?}",
            w.violations
        );
    }

    #[test]
    fn the_correction_is_measured_minus_predicted_and_brings_the_gaps_onto_the_truth() {
        let model = frictionless_model();
        let problem = short_fold();
        let policy = Policy::default();
        let state = folded_start(&model, &problem, policy.increment_m).unwrap();
        let truth = default_truth(reference_bridge(&BridgeParameters::default()).unwrap());
        let s = model.structure();
        let n = s.continuous_cables.len();
        let plant = Plant::new(&truth, Some(&vec![0.10; n]), None).unwrap();
        let sensors = standard_sensors(&truth.structure);
        let clean = plant.read(&sensors);
        let mut context = PlanContext::new(&model, &problem, &policy, &state).unwrap();
        context.correction = model_correction(&model, &state, &sensors, &clean, &policy.measures);

        // Noise-free positions: the corrected gap vectors are the truth's
        // (to rounding of coordinates of a few metres, 1e-12 m), and the
        // correction is not trivial: friction holds the truth's fold
        // differently from the frictionless model's (0.8 mm at this 10 cm
        // fold, a million times the check's tolerance).
        let truth_x = &plant.state().positions_m;
        let corrected = context.gap_vectors(&state);
        let mut largest_offset = 0.0f64;
        for (p, [a, b]) in s.midspan_pairs.iter().enumerate() {
            let true_gap = truth_x[*a] - truth_x[*b];
            assert!((corrected[p] - true_gap).norm() < 1e-12, "pair {p}");
            largest_offset = largest_offset.max(context.correction.gap_offset_m(p).norm());
        }
        assert!(largest_offset > 1e-4, "offsets {largest_offset} m");

        // Load cells: the four measured rows corrected onto the truth's
        // tensions; every other row untouched.
        let predicted = force_rows(&model, &state);
        let truth_forces = plant.model().member_forces(plant.state());
        let mut corrected_rows = 0;
        for sensor in &sensors {
            if let SensorTarget::SegmentTension { cable, segment } = sensor.target {
                let row = s.members.len() + state.segment_offsets[cable] + segment;
                let t = truth_forces.segment_n[plant.state().segment_offsets[cable] + segment];
                let f = predicted[row] + context.correction.force_offset_n(row);
                assert!((f - t).abs() < 1e-9 * t.abs().max(1.0), "{}", sensor.id);
                corrected_rows += 1;
            }
        }
        assert_eq!(corrected_rows, 4);
        let nonzero = context
            .correction
            .force_offsets_n
            .iter()
            .filter(|o| **o != 0.0)
            .count();
        assert_eq!(nonzero, 4);

        // Noisy readings: the offset is the reading less the prediction,
        // computed here from the readings themselves.
        let mut rng = StdRng::seed_from_u64(3);
        let noisy = plant.measure(&sensors, &mut rng);
        let c = model_correction(&model, &state, &sensors, &noisy, &policy.measures);
        let reading = |node: usize, axis: usize| {
            let k = sensors
                .iter()
                .position(|s| s.target == SensorTarget::Position { node, axis })
                .unwrap();
            noisy[k].unwrap()
        };
        for (p, [a, b]) in s.midspan_pairs.iter().enumerate() {
            for axis in 0..3 {
                let measured = reading(*a, axis) - reading(*b, axis);
                let model_gap = state.positions_m[*a][axis] - state.positions_m[*b][axis];
                assert!((c.gap_offsets_m[p][axis] - (measured - model_gap)).abs() < 1e-15);
            }
        }

        // A missing reading leaves its pair at offset 0, the others as
        // they were; measuring nothing corrects nothing.
        let [a0, _] = s.midspan_pairs[0];
        let k = sensors
            .iter()
            .position(|s| s.target == SensorTarget::Position { node: a0, axis: 1 })
            .unwrap();
        let mut missing = noisy.clone();
        missing[k] = None;
        let m = model_correction(&model, &state, &sensors, &missing, &policy.measures);
        assert_eq!(m.gap_offsets_m[0], Vector3::zeros());
        assert_eq!(m.gap_offsets_m[1..], c.gap_offsets_m[1..]);
        assert_eq!(m.force_offsets_n, c.force_offsets_n);
        let none = model_correction(&model, &state, &sensors, &noisy, &[]);
        assert_eq!(
            none,
            ModelCorrection::none(s.midspan_pairs.len(), predicted.len())
        );
    }

    #[test]
    fn a_truth_that_cannot_fold_or_is_another_bridge_is_an_error_not_a_panic() {
        let model = frictionless_model();
        let problem = short_fold();
        let policy = Policy::default();
        let structure = reference_bridge(&BridgeParameters::default()).unwrap();
        let sensors = standard_sensors(&structure);
        let setup = |truth| ClosedLoopSetup {
            model: &model,
            problem: &problem,
            policy: &policy,
            truth,
            sensors: &sensors,
            temperature_c: None,
            seed: 1,
        };
        // One DR iteration per solve: the as-built state is an
        // equilibrium, the fold is not reached.
        let mut stiff = default_truth(structure.clone());
        stiff.settings.max_iter = 1;
        let e = deploy_closed_loop(&setup(&stiff), &mut ()).unwrap_err();
        assert!(
            matches!(e, DeployError::TruthStart(ReplayError::Solver { .. })),
            "{e:?}"
        );
        let mut other = default_truth(structure);
        other.structure.midspan_pairs.swap(0, 1);
        let e = deploy_closed_loop(&setup(&other), &mut ()).unwrap_err();
        assert_eq!(
            e,
            DeployError::Mismatch("the midspan pairs differ".into()),
            "{e}"
        );
    }
}
