//! Open-loop planning: the folded start on a model, and a whole command
//! sequence planned on the model as its own truth.

use std::time::Instant;

use super::outcome::{CommandRecord, Plan, PlanError, PlanStatus};
use super::planner::{Decision, PlanContext};
use super::planners::planner_for;
use super::policy::Policy;
use super::problem::DeploymentProblem;
use crate::model::{DeploymentState, ForwardModel, Workspace};

/// The folded start: the designed state relaxed, then every motor paid
/// out by the problem's start payout through the model.
pub fn folded_start(
    model: &ForwardModel,
    problem: &DeploymentProblem,
    increment_m: f64,
) -> Result<DeploymentState, PlanError> {
    let motors = problem.motor_limits(model.structure().continuous_cables.len())?;
    let mut ws = Workspace::default();
    let mut state = model.reference_state();
    let r = model.relax(&mut state, &mut ws);
    if !r.status.is_converged() {
        return Err(PlanError::Start(r.status));
    }
    // As the truth's plant starts: the arcs followed after the relax (a
    // model with seats; nothing otherwise), then the fold.
    let r = model.follow_seats(&mut state, &mut ws)?;
    if !r.status.is_converged() {
        return Err(PlanError::Start(r.status));
    }
    let r = model.apply_payout(
        &mut state,
        &mut ws,
        &motors.start_payout_m,
        increment_m,
        &mut (),
    )?;
    if !r.status.is_converged() {
        return Err(PlanError::Start(r.status));
    }
    Ok(state)
}

/// Plans an open-loop command sequence on `model` from `start` (the model
/// is its own truth): each command is the planner's confirmed trial.
pub fn plan_open_loop(
    model: &ForwardModel,
    problem: &DeploymentProblem,
    policy: &Policy,
    start: &DeploymentState,
) -> Result<Plan, PlanError> {
    let mut context = PlanContext::new(model, problem, policy, start)?;
    let mut planner = planner_for(&context, start);
    let mut state = start.clone();
    let mut records = Vec::new();
    let status = loop {
        if context.connected(&state) {
            break PlanStatus::Connected;
        }
        if records.len() >= policy.max_commands {
            break PlanStatus::CommandLimit;
        }
        let clock = Instant::now();
        match planner.next_command(&context, &state) {
            Decision::Stop(status) => break status,
            Decision::Command(c) => {
                let gaps_m = c.trial.state.midspan_gaps_m(model.structure());
                records.push(CommandRecord {
                    command_m: c.command_m,
                    predicted_gaps_m: c.predicted_gaps_m,
                    gaps_m,
                    worst_utilisation: c.trial.check.worst_utilisation,
                    min_tension_n: c.trial.check.min_tension_n,
                    min_clearance_m: c.trial.check.min_clearance_m,
                    active_constraints: c.active_constraints,
                    qp_status: c.qp_status,
                    trust_region_m: c.trust_region_m,
                    rejected_trials: c.rejected_trials,
                    planning_time_s: clock.elapsed().as_secs_f64(),
                });
                state = c.trial.state;
                context.hold_restored(&state);
            }
        }
    };
    Ok(Plan {
        status,
        start_gaps_m: start.midspan_gaps_m(model.structure()),
        records,
        final_state: state,
    })
}
