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
//! (rest length less length), is held like a start-broken force row: a
//! trial in which a cable slack at its start gets more than
//! [`SLACK_GROWTH_TOLERANCE_M`] slacker, at any increment, is refused ([`slack_growth`]),
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

/// How much a cable's slack may grow in a trial before it counts, m. The
/// bridge's cable may be taut by only a few newtons where the model's is
/// slack (5 N is 29 µm of stretch on the reference bridge's 4 m cables
/// of EA 7·10⁵ N), so the tolerance sits well below that: 10 µm, the
/// stretch of 1.75 N. It is ten times [`SLACK_M`], the length resolution
/// per segment, so that rounding never trips it.
pub const SLACK_GROWTH_TOLERANCE_M: f64 = 10.0 * SLACK_M;

/// Per continuous cable, the length it is slack by at `state`, m: the sum
/// over its segments of rest length less length, where positive (0 for a
/// taut cable).
pub fn cable_slack_m(model: &ForwardModel, state: &DeploymentState) -> Vec<f64> {
    let s = model.structure();
    let forces = model.member_forces(state);
    s.continuous_cables
        .iter()
        .enumerate()
        .map(|(c, cable)| {
            let o = state.segment_offsets[c];
            (o..o + cable.segment_count())
                .map(|k| (state.segment_rest_lengths_m[k] - forces.segment_length_m[k]).max(0.0))
                .sum()
        })
        .collect()
}

/// The cables whose slack `slack_m` (per cable, m) grew by more than
/// [`SLACK_GROWTH_TOLERANCE_M`] from `start_slack_m`, as violations.
pub fn slack_growth(
    model: &ForwardModel,
    start_slack_m: &[f64],
    slack_m: &[f64],
) -> Vec<LimitViolation> {
    let s = model.structure();
    start_slack_m
        .iter()
        .zip(slack_m)
        .zip(&s.continuous_cables)
        .filter(|((&s0, &s1), _)| s0 > SLACK_M && s1 > s0 + SLACK_GROWTH_TOLERANCE_M)
        .map(|((&s0, &s1), cable)| LimitViolation::SlackGrew {
            cable: cable.id.clone(),
            slack_m: s1,
            start_slack_m: s0,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{JointFriction, RelaxSettings};
    use crate::plan::{folded_start, DeploymentProblem, PerMotor, PlanContext, Policy};

    /// Issue 22, item 7: on `scenarios/wide.toml` (seed 777) the first
    /// command after folds of 50 cm and more reeled every cable in but the
    /// slack `cc1` (or `cc0`), whose force rows read 0 N before and after;
    /// the truth's cable, taut at a few newtons, went slack. On the model
    /// alone: at the 55 cm fold, reeling the others in by 2 cm makes `cc1`
    /// slacker and the trial refuses it, naming the cable; reeling `cc1`
    /// in with them does not.
    #[test]
    fn a_trial_that_slackens_a_slack_cable_further_is_refused() {
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
        assert!(!slack_cables.is_empty(), "the 55 cm fold leaves no cable slack");
        let others_in: Vec<f64> = (0..ids.len())
            .map(|c| if slack_cables.contains(&c) { 0.0 } else { -0.02 })
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
