//! Taking up a slack continuous cable before planning on its response.
//!
//! A segment shorter than its rest length carries no force, and a
//! continuous cable whose segments are slack has a zero tangent response
//! to its motor: reeling it in by a millimetre changes nothing until the
//! slack is gone. A QP on that response sees the motor as useless and the
//! segments' minimum tension as a row it can never meet, so a fold that
//! leaves a cable slack (a 50 cm fold of the reference bridge leaves every
//! segment of `cc1` at 0 N) ends "not reachable" at the start. The
//! response of the slack cable is a *secant* one: nothing, then the cable
//! taut. So before the QP, each motor of a slack cable reels in its
//! geometric slack (Σ over its segments of rest length − length, where
//! positive) plus the stretch that brings the cable to the minimum tension
//! (`min_tension · Σ rest length / EA`), within its step and stroke limits.
//! The command is tried on the model like any other and sent only if the
//! trial keeps every limit; otherwise the QP plans as before.

use super::planner::{PlanContext, PlannedCommand};
use super::slack::{cable_slack_m, SLACK_M};
use crate::model::DeploymentState;

/// The take-up command at `state`: every motor of a slack cable reels in
/// its slack and the stretch to the minimum tension (within its step and
/// stroke), the others stay; `None` when no cable is slack or the model's
/// trial of the command breaks a limit.
pub fn take_up(context: &PlanContext, state: &DeploymentState) -> Option<PlannedCommand> {
    let s = context.model.structure();
    let slack = cable_slack_m(context.model, state);
    if slack.iter().all(|&l| l <= SLACK_M) {
        return None;
    }
    let m = &context.motors;
    let min_tension_n = context.problem.min_tension_n;
    let command: Vec<f64> = s
        .continuous_cables
        .iter()
        .enumerate()
        .map(|(c, cable)| {
            if slack[c] <= SLACK_M {
                return 0.0;
            }
            let o = state.segment_offsets[c];
            let rest: f64 = state.segment_rest_lengths_m[o..o + cable.segment_count()]
                .iter()
                .sum();
            let wanted = slack[c] + min_tension_n * rest / cable.ea_n;
            let room = (state.payout_m[c] - m.min_payout_m[c]).max(0.0);
            -wanted.min(m.max_step_m[c]).min(room)
        })
        .collect();
    if command.iter().all(|&u| u == 0.0) || !context.command_admissible(state, &command) {
        return None;
    }
    let trial = context.trial(state, &command);
    if !trial.admissible() {
        return None;
    }
    let slack_motors = s
        .continuous_cables
        .iter()
        .zip(&slack)
        .filter(|(_, &l)| l > SLACK_M)
        .map(|(cable, _)| format!("{} take-up", cable.id))
        .collect();
    Some(PlannedCommand {
        predicted_gaps_m: Some(context.gaps_m(&trial.state)),
        command_m: command,
        trial,
        active_constraints: slack_motors,
        qp_status: None,
        trust_region_m: None,
        rejected_trials: 0,
        linearisations: 0,
        take_up: true,
    })
}
