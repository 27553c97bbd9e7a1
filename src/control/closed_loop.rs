//! The closed-loop deployment: a planner on the controller's model, a
//! truth plant that stands in for the real bridge, and the sensors
//! between them.
//!
//! The controller never reads the truth's state. It holds its own model
//! state (the folded start on its model, then each command's confirmed
//! trial, see [`crate::plan::Trial`]) and, after the start and after
//! every command, one noisy measurement of the plant. Model and
//! measurement are reconciled in three ways:
//! - the payout scale of each bridge half is estimated from the measured
//!   midspan motion ([`super::estimation`]); commands are sent scaled by
//!   it, and after each command the model state is re-solved to where the
//!   command really took the bridge;
//! - for every quantity the policy measures
//!   ([`crate::plan::ControlSettings::measures`]), the offset
//!   measured − predicted is added to every later prediction of it, until
//!   the next measurement ([`super::measured_offsets::model_correction`], [`crate::plan::correction`]);
//!   with midspan positions measured, the connection test therefore reads
//!   the *measured* gaps;
//! - the load-cell offsets are filtered across measurements
//!   ([`super::force_offset_filter::ForceOffsetFilter`]), so that one noisy reading
//!   does not move a force limit.
//!
//! The truth is checked too, as a supervisor would on the real bridge:
//! every increment of every command is checked against the problem's
//! limits built on the truth's own structure and start ([`super::truth_watch::TruthWatch`]).
//! A violation does not stop the run (the controller cannot see it); it
//! is recorded and counted, and decides the run's verdict
//! ([`Deployment::verdict`]). A limit the truth's start already broke is
//! held to its start value until a command ends with it met (restored),
//! then to its bound; the deployment lists each such limit with whether
//! the end meets it.
//!
//! Randomness: the sensor noise only, from one `StdRng` seeded with the
//! setup's seed and drawn in a fixed order (one measurement of every
//! sensor per step), so a seed gives the same deployment at any thread
//! count. Planning times are the only values that are not a function of
//! the inputs.

use rand::rngs::StdRng;
use rand::SeedableRng;
use thiserror::Error;

use super::controller::{Controller, ControllerDecision};
use super::deployment::{
    largest, DeployObserver, DeployRecord, DeployStart, Deployment, CORRECTIVE_PHASE_GAP_M,
};
use super::guidance::Guidance;
use super::measured_offsets::measured_gap_vectors;
use super::truth_watch::{as_built_breaches, TruthWatch};
use crate::model::flexible_supports::is_support_node;
use crate::model::{ForwardModel, Structure};
use crate::plan::limits::{force_rows, LimitCheck, Limits};
use crate::plan::verdict::AS_BUILT_PREFIX;
use crate::plan::{DeploymentProblem, PlanError, PlanStatus, Policy, SolverFailure};
use crate::sim::{EffectModel, Plant, PlantError, Sensor};

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
    TruthStart(PlantError),
    /// The controller's model and the truth are not the same bridge.
    #[error("the controller's model and the truth differ: {}", .0.describe())]
    Mismatch(BridgeMismatch),
}

impl DeployError {
    /// What kept the deployment from starting, as `runs.csv`'s `binds`
    /// names it for a run that did not start: one short line (the truth
    /// as built, the truth's fold, the controller's model, or the two
    /// bridges differing), with the solver status where one failed.
    pub fn start_binds(&self) -> String {
        match self {
            DeployError::TruthStart(e) => match e {
                PlantError::AsBuilt { status } => format!("{AS_BUILT_PREFIX}{}", status.as_str()),
                PlantError::Solver { status, .. } => format!("truth fold: {}", status.as_str()),
                PlantError::SeatsUnsettled { .. } => "truth fold: seats_unsettled".into(),
                PlantError::Command { .. } => "truth fold: command_refused".into(),
                PlantError::Structure(_) | PlantError::Settings(_) => {
                    "truth effects: invalid".into()
                }
            },
            DeployError::Plan(_) => "controller model start".into(),
            DeployError::Mismatch(_) => "bridge mismatch".into(),
        }
    }
}

/// How the truth's bridge differs from the controller's model's.
#[derive(Debug, Clone, PartialEq)]
pub enum BridgeMismatch {
    /// Different node counts (of the bridge: nodes a structure over
    /// flexible supports appends for them do not count).
    NodeCount {
        /// Nodes in the model.
        model: usize,
        /// Nodes in the truth.
        truth: usize,
    },
    /// The same count, another node at an index.
    NodeId {
        /// The first index where they differ.
        index: usize,
        /// The model's node there.
        model: String,
        /// The truth's node there.
        truth: String,
    },
    /// Different continuous cables: ids or segment counts.
    ContinuousCables,
    /// Different midspan pairs.
    MidspanPairs,
}

impl BridgeMismatch {
    /// Plain words.
    pub fn describe(&self) -> String {
        match self {
            BridgeMismatch::NodeCount { model, truth } => {
                format!("{model} nodes in the model, {truth} in the truth")
            }
            BridgeMismatch::NodeId {
                index,
                model,
                truth,
            } => format!("node {index} is {model} in the model, {truth} in the truth"),
            BridgeMismatch::ContinuousCables => {
                "the continuous cables (ids or segment counts) differ".into()
            }
            BridgeMismatch::MidspanPairs => "the midspan pairs differ".into(),
        }
    }
}

/// Refuses a truth that is not the controller's bridge: the same nodes,
/// continuous cables (segment for segment) and midspan pairs, so that
/// commands, sensors and gaps mean the same on both. `truth` is the
/// truth's bridge before its effects; a model over flexible supports
/// (`model::flexible_supports`) has the bridge's nodes first and its
/// bearings and ground nodes after them, which nothing reads by index.
pub fn check_same_bridge(model: &Structure, truth: &Structure) -> Result<(), DeployError> {
    let mismatch = |what| Err(DeployError::Mismatch(what));
    // A structure over flexible supports has the bridge's nodes first and
    // its bearings and ground nodes after them: the bridge's node count,
    // `None` where a support node comes before a bridge node.
    let bridge_nodes = |s: &Structure| -> Option<usize> {
        let n = s
            .nodes
            .iter()
            .take_while(|node| !is_support_node(&node.id))
            .count();
        s.nodes[n..]
            .iter()
            .all(|node| is_support_node(&node.id))
            .then_some(n)
    };
    let (m, t) = (bridge_nodes(model), bridge_nodes(truth));
    let (Some(m), Some(t)) = (m, t) else {
        return mismatch(BridgeMismatch::NodeCount {
            model: m.unwrap_or(model.nodes.len()),
            truth: t.unwrap_or(truth.nodes.len()),
        });
    };
    if m != t {
        return mismatch(BridgeMismatch::NodeCount { model: m, truth: t });
    }
    if let Some(index) = (0..m).find(|&i| model.nodes[i].id != truth.nodes[i].id) {
        return mismatch(BridgeMismatch::NodeId {
            index,
            model: model.nodes[index].id.clone(),
            truth: truth.nodes[index].id.clone(),
        });
    }
    let cables = |s: &Structure| -> Vec<(String, usize)> {
        s.continuous_cables
            .iter()
            .map(|c| (c.id.clone(), c.segment_count()))
            .collect()
    };
    if cables(model) != cables(truth) {
        return mismatch(BridgeMismatch::ContinuousCables);
    }
    if model.midspan_pairs != truth.midspan_pairs {
        return mismatch(BridgeMismatch::MidspanPairs);
    }
    Ok(())
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

/// The setup's truth folded to its problem's start: the fold
/// [`deploy_guided`] makes when it is given no plant, after the same
/// checks in the same order (the two bridges alike, the problem's motors,
/// then the fold), so that a caller deploying several policies on one
/// truth can fold it once and give each a copy.
pub fn fold_truth(setup: &ClosedLoopSetup) -> Result<Plant, DeployError> {
    let s = setup.model.structure();
    check_same_bridge(s, &setup.truth.structure)?;
    let motors = setup
        .problem
        .motor_limits(s.continuous_cables.len())
        .map_err(PlanError::from)?;
    Plant::new(
        setup.truth,
        Some(&motors.start_payout_m),
        setup.temperature_c,
    )
    .map_err(DeployError::TruthStart)
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
            fresh_plant = fold_truth(setup)?;
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
    // Start-broken truth limits that a command has ended meeting.
    let mut restored = vec![false; truth_limits.required.len()];
    let mut end_rows = (force_rows(&truth_model, plant.state()), 0.0);

    let mut records: Vec<DeployRecord> = Vec::new();
    let status = loop {
        let p = match controller.decide() {
            ControllerDecision::Stop(status) => break status,
            ControllerDecision::Send(p) => p,
        };
        let index = records.len() + 1;
        let mut watch = TruthWatch::new(&truth_model, &truth_limits, &restored);
        let report = plant.apply(&p.sent_m, setup.temperature_c, &mut watch);
        if let Err(error) = report {
            break PlanStatus::SolverFailure {
                cause: SolverFailure::TruthPlant {
                    command: index,
                    error,
                },
            };
        }
        let truth_increments = watch.increments;
        if let Some((rows, tolerance_n)) = watch.last_rows.take() {
            for (k, meets) in truth_limits
                .meets_required(&rows, tolerance_n)
                .into_iter()
                .enumerate()
            {
                restored[k] |= meets;
            }
            end_rows = (rows, tolerance_n);
        }
        let truth_violation_increments = watch.breaches.iter().map(|(k, _)| *k).collect();
        let check = watch.worst.unwrap_or_else(LimitCheck::empty);
        let reading = plant.measure(setup.sensors, &mut rng);
        // The controller's own decision: its trial is the prediction, so
        // this cannot fail to follow; a failure would be a bug, reported
        // as the run's end rather than a panic.
        if let Err(error) = controller.observe(&p.sent_m, &reading) {
            break PlanStatus::SolverFailure {
                cause: SolverFailure::Controller {
                    command: index,
                    error,
                },
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
            truth_violation_increments,
            truth_increments,
            truth_increments_checked: watch.checked,
            model_worst_utilisation: p.model_worst_utilisation,
            qp_status: p.qp_status,
            trust_region_m: p.trust_region_m,
            rejected_trials: p.rejected_trials,
            active_constraints: p.active_constraints,
            take_up: p.take_up,
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
    let truth_limit_violations = records.iter().map(|r| r.truth_violations.len()).sum();
    let truth_start_broken =
        truth_limits.start_broken_limits(truth_structure, &end_rows.0, end_rows.1);
    // Context for a run that broke a limit or left one broken; the others
    // have nothing to explain, and say they were not checked.
    let truth_as_built_broken = (truth_limit_violations > 0
        || truth_start_broken.iter().any(|l| !l.restored))
    .then(|| as_built_breaches(plant, setup.problem));
    Ok(Deployment {
        // A command counts into the approach when it is decided; one the
        // truth could not take was never recorded.
        approach_commands: controller.approach_commands().map(|k| k.min(records.len())),
        learnt_approach_completed: controller.learnt_approach_completed(),
        final_payout_scale: controller.part_payout_scale(),
        final_load_cell_bias_n: controller.load_cell_bias_n(),
        status,
        truth_limit_violations,
        truth_as_built_broken,
        truth_start_broken,
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

    #[test]
    fn bridge_mismatches_read_as_before() {
        let cases = [
            (
                BridgeMismatch::NodeCount {
                    model: 50,
                    truth: 52,
                },
                "50 nodes in the model, 52 in the truth",
            ),
            (
                BridgeMismatch::ContinuousCables,
                "the continuous cables (ids or segment counts) differ",
            ),
            (BridgeMismatch::MidspanPairs, "the midspan pairs differ"),
            (
                BridgeMismatch::NodeId {
                    index: 3,
                    model: "A_r0_n3".into(),
                    truth: "A_r0_n4".into(),
                },
                "node 3 is A_r0_n3 in the model, A_r0_n4 in the truth",
            ),
        ];
        for (m, text) in cases {
            assert_eq!(m.describe(), text);
            assert_eq!(
                DeployError::Mismatch(m).to_string(),
                format!("the controller's model and the truth differ: {text}")
            );
        }
    }
    use crate::control::fixtures::{frictionless_model, short_fold};
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::sim::{default_truth, standard_sensors};

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
            matches!(e, DeployError::TruthStart(PlantError::Solver { .. })),
            "{e:?}"
        );
        let mut fewer_nodes = default_truth(structure.clone());
        fewer_nodes.structure.nodes.pop();
        let e = deploy_closed_loop(&setup(&fewer_nodes), &mut ()).unwrap_err();
        assert_eq!(
            e,
            DeployError::Mismatch(BridgeMismatch::NodeCount {
                model: structure.nodes.len(),
                truth: structure.nodes.len() - 1,
            }),
            "{e}"
        );
        // A model over flexible supports appends bearings and ground nodes
        // to the bridge's (known limitation 20: it was refused); any other
        // node appended is another bridge.
        let supported =
            crate::model::flexible_supports::with_flexible_supports(&structure, 2e-5).unwrap();
        assert!(supported.nodes.len() > structure.nodes.len());
        assert_eq!(check_same_bridge(&supported, &structure), Ok(()));
        let mut extra = supported.clone();
        extra.nodes.push(structure.nodes[0].clone());
        assert!(matches!(
            check_same_bridge(&extra, &structure),
            Err(DeployError::Mismatch(BridgeMismatch::NodeCount { .. }))
        ));
        let mut interleaved = supported.clone();
        let last = interleaved.nodes.len() - 1;
        interleaved.nodes.swap(0, last);
        assert!(check_same_bridge(&interleaved, &structure).is_err());
        // Either side may be over supports; a node renamed is another bridge.
        assert_eq!(check_same_bridge(&structure, &supported), Ok(()));
        let mut renamed = supported;
        renamed.nodes[2].id.push_str("_other");
        assert!(matches!(
            check_same_bridge(&renamed, &structure),
            Err(DeployError::Mismatch(BridgeMismatch::NodeId {
                index: 2,
                ..
            }))
        ));
        let mut other = default_truth(structure);
        other.structure.midspan_pairs.swap(0, 1);
        let e = deploy_closed_loop(&setup(&other), &mut ()).unwrap_err();
        assert_eq!(
            e,
            DeployError::Mismatch(BridgeMismatch::MidspanPairs),
            "{e}"
        );
    }
}
