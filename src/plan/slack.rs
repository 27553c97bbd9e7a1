//! A slack continuous cable may not be slackened further.
//!
//! The model reads a slack member as 0 N whether it is slack by a
//! micrometre or by centimetres, and 0 N has no fall to see: a command
//! that pulls the structure in around a slack cable (reeling the other
//! cables in) leaves its force rows at 0 N, admissible. The bridge need
//! not agree. After a large fold the model's slack cable is slack by a
//! few millimetres, while the truth's, built with other stiffnesses and
//! joint masses, may still hang taut at a few newtons: a cable of EA
//! 7·10⁵ N and 4 m of rest length carries 5 N at 29 µm of stretch, far
//! inside the model's error. On `scenarios/wide.toml` (seed 777) the
//! first command of folds of 46–58 cm reeled every cable in by 5 cm but
//! the slack `cc1` or `cc0`, and the truth's cable fell from 0.6–4.8 N to
//! 0 N in all its segments (36, 38 and 20 violations on scenarios 34, 17
//! and 178).
//!
//! So a cable's slack, `S = Σ_k max(0, L0_k − L_k)` over its segments
//! (rest length less length), is held like a start-broken force row, to
//! its value at the command's start: a trial in which a cable gets more
//! than [`slack_growth_tolerance_m`] slacker than that, at any increment,
//! is refused ([`slack_growth`]), a cable taut at the start included,
//! and the trust region shrinks until the QP's step reels that cable in
//! with the others, or the planner stops naming it. The QP itself has no
//! slack row: as a row (`S + (dS/dp)·Δp ≤ S`, its slope geometric) it let
//! the QP reel the slack `cc1` of a 48 cm fold of the default truth in
//! just enough to hold its slack, where without it the QP took the slack
//! up, and the slack segments' corrected −0.1 N (a negative load-cell
//! offset on 0 N, known limitations 18) then failed every trial: the
//! fold that connects stopped. Asking the row to take the slack up
//! (`≤ max(0, S − step)`) stopped it too, its take-up lowering
//! start-broken segments of `cc0` and `cc2`.

use super::limits::LimitViolation;
use crate::model::{DeploymentState, ForwardModel};

/// A segment slack by less than this is taut, m: below the solver's
/// length resolution on a 1 m segment.
pub const SLACK_M: f64 = 1e-6;

/// How much a cable's slack may grow beyond its bound before it counts,
/// m: the length resolution of a sum over its segments, [`SLACK_M`] per
/// segment and one more (5 µm on the reference bridge's four-segment
/// cables), so that rounding never trips it. Anything larger is a real
/// slackening. It is a trade-off, not a guarantee: 5 µm is the stretch of
/// 0.9 N on a 4 m cable of EA 7·10⁵ N, and a cable the truth holds at
/// 0.6 N (seen after 50–58 cm folds) is 3.4 µm from slack; where the
/// joints stick, the change may fall on one segment of a metre, where
/// 5 µm is 3.5 N.
pub fn slack_growth_tolerance_m(segments: usize) -> f64 {
    (segments as f64 + 1.0) * SLACK_M
}

/// Per continuous cable, the length it is slack by at `state`, m: the sum
/// over its segments of rest length less length, where positive (0 for a
/// taut cable). A segment's length is the distance between its path
/// nodes, as the force law reads it; computed from the positions alone,
/// so a trial's increments do not pay a second force pass for it.
pub fn cable_slack_m(model: &ForwardModel, state: &DeploymentState) -> Vec<f64> {
    let x = &state.positions_m;
    model
        .structure()
        .continuous_cables
        .iter()
        .enumerate()
        .map(|(c, cable)| {
            let o = state.segment_offsets[c];
            cable
                .path
                .windows(2)
                .enumerate()
                .map(|(k, w)| {
                    (state.segment_rest_lengths_m[o + k] - (x[w[1]] - x[w[0]]).norm()).max(0.0)
                })
                .sum()
        })
        .collect()
}

/// The cables whose slack `slack_m` (per cable, m) is more than
/// [`slack_growth_tolerance_m`] beyond `bound_m` (per cable, m: its slack
/// at the command's start), as violations. A taut cable's bound is 0: one
/// that goes slack is caught too (a start-broken segment held to about
/// 0 N has no force row that would). The bound is per command, so a
/// cable may creep by the tolerance per command: at most 0.1 mm over 20
/// commands; the take-up that follows a slack cable's refusal removes it.
pub fn slack_growth(model: &ForwardModel, bound_m: &[f64], slack_m: &[f64]) -> Vec<LimitViolation> {
    let s = model.structure();
    bound_m
        .iter()
        .zip(slack_m)
        .zip(&s.continuous_cables)
        .filter(|((&b, &now), cable)| now > b + slack_growth_tolerance_m(cable.segment_count()))
        .map(|((&b, &now), cable)| LimitViolation::SlackGrew {
            cable: cable.id.clone(),
            slack_m: now,
            bound_m: b,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{JointFriction, RelaxSettings};
    use crate::plan::{folded_start, DeploymentProblem, PerMotor, PlanContext, Policy};

    /// The frictionless reference bridge and a problem folding it 55 cm
    /// (its `cc1` cables slack by 4.9 mm, `cc0` by 0.7 mm).
    fn folded_55cm() -> (ForwardModel, DeploymentProblem) {
        let model = ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap();
        let problem = DeploymentProblem {
            start_payout_m: PerMotor::All(0.55),
            max_payout_m: PerMotor::All(0.7),
            ..DeploymentProblem::default()
        };
        (model, problem)
    }

    /// The slack read from positions is the one the force law's segment
    /// lengths give, to rounding (the same subtraction, summed in the
    /// same order).
    #[test]
    fn slack_from_positions_matches_the_force_laws_lengths() {
        let (model, problem) = folded_55cm();
        let state = folded_start(&model, &problem, Policy::default().increment_m).unwrap();
        let lengths = model.member_forces(&state).segment_length_m;
        let by_force_law: Vec<f64> = (0..state.payout_m.len())
            .map(|c| {
                (state.segment_offsets[c]..state.segment_offsets[c + 1])
                    .map(|k| (state.segment_rest_lengths_m[k] - lengths[k]).max(0.0))
                    .sum()
            })
            .collect();
        let from_positions = cable_slack_m(&model, &state);
        assert!(by_force_law.iter().any(|&s| s > 1e-3));
        for (a, b) in from_positions.iter().zip(&by_force_law) {
            assert!((a - b).abs() <= 1e-15, "{a} vs {b}");
        }
    }

    /// Issue 22, item 7: on `scenarios/wide.toml` (seed 777) the first
    /// command after folds of 46–58 cm reeled every cable in but the slack
    /// `cc1` or `cc0`, whose force rows read 0 N before and after; the
    /// truth's cable, taut at a few newtons, went slack. On the model
    /// alone: at the 55 cm fold (`cc1` slack by 4.9 mm, `cc0` by 0.7 mm),
    /// reeling the others in by 2 cm makes the slack ones slacker and the
    /// trial refuses it, naming each; reeling them in with the others does
    /// not.
    #[test]
    fn a_trial_that_slackens_a_slack_cable_further_is_refused() {
        let (model, problem) = folded_55cm();
        let policy = Policy::default();
        let start = folded_start(&model, &problem, policy.increment_m).unwrap();
        let context = PlanContext::new(&model, &problem, &policy, &start).unwrap();
        let slack = cable_slack_m(&model, &start);
        let ids: Vec<&str> = model
            .structure()
            .continuous_cables
            .iter()
            .map(|c| c.id.as_str())
            .collect();
        let slack_cables: Vec<usize> = (0..ids.len()).filter(|&c| slack[c] > SLACK_M).collect();
        assert!(
            !slack_cables.is_empty(),
            "the 55 cm fold leaves no cable slack"
        );
        let others_in: Vec<f64> = (0..ids.len())
            .map(|c| {
                if slack_cables.contains(&c) {
                    0.0
                } else {
                    -0.02
                }
            })
            .collect();
        let trial = context.trial(&start, &others_in);
        let grew: Vec<&str> = trial
            .check
            .violations
            .iter()
            .filter_map(|v| match v {
                LimitViolation::SlackGrew { cable, .. } => Some(cable.as_str()),
                _ => None,
            })
            .collect();
        for &c in &slack_cables {
            assert!(grew.contains(&ids[c]), "{} not refused: {grew:?}", ids[c]);
        }
        let all_in = vec![-0.02; ids.len()];
        let trial = context.trial(&start, &all_in);
        assert!(
            !trial
                .check
                .violations
                .iter()
                .any(|v| matches!(v, LimitViolation::SlackGrew { .. })),
            "{:?}",
            trial.check.violations
        );
    }
}
