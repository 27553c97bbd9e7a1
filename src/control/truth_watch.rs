//! The truth's supervisor: every increment of every command checked
//! against the problem's limits on the truth's own structure, as a
//! supervisor would on the real bridge. A violation does not stop the run
//! (the controller cannot see it); it is recorded and counted, with the
//! increment it happened at.
//!
//! The bounds are the problem's own ([`Limits::required`]), never
//! widened; a limit the truth's start already broke is held to its start
//! value until a command restores it ([`Limits::held_bounds`], see
//! [`crate::plan::limits`]).

use crate::model::{DeploymentState, ForwardModel, IncrementObserver, RelaxReport};
use crate::plan::limits::force_rows;
use crate::plan::limits::{ForceBounds, LimitCheck, LimitViolation, Limits, StateBreach};
use crate::plan::{worst_along_path, DeploymentProblem};
use crate::sim::Plant;

/// The force limits of `problem` (not the clearances) that the truth of
/// `plant` breaks in its own as-built state ([`Plant::as_built_state`]:
/// zero commanded payout, before any fold, the state the halves are built
/// to meet at; with a drum zeroed off, its cable that much off the
/// design), on its own structure
/// (effects may append foundation members), against the required
/// bounds. A truth with a member cut off its length can be outside its
/// limits there, where every deployment is meant to end; the verdict of a
/// run that broke limits names them
/// ([`crate::plan::RunVerdict::as_built_broken`]). The model is the
/// plant's as it is now: the same as built while the temperature holds.
pub fn as_built_breaches(plant: &Plant, problem: &DeploymentProblem) -> Vec<StateBreach> {
    let model = plant.model();
    Limits::new(model, problem, plant.as_built_state()).broken_at_construction(model.structure())
}

/// Checks every increment of the truth against limits built on the
/// truth's own structure (its force rows may differ from the model's:
/// effects may append foundation members).
#[derive(Debug, Clone)]
pub struct TruthWatch<'a> {
    model: &'a ForwardModel,
    limits: &'a Limits,
    held: Vec<ForceBounds>,
    /// Increments seen.
    pub increments: usize,
    /// Increments checked (the converged ones).
    pub checked: usize,
    /// The worst values and every violation so far (`None` before the
    /// first checked increment).
    pub worst: Option<LimitCheck>,
    /// Every violation with the increment (1 for the first) it happened
    /// at, in order; the state the seats settle into after the payout
    /// (joint eccentricity) is the command's last increment.
    pub breaches: Vec<(usize, LimitViolation)>,
    /// The force rows of the last checked increment (the state the
    /// command ends in, the seats settled, when every increment
    /// converged), N, with the solver's force tolerance there, N.
    pub last_rows: Option<(Vec<f64>, f64)>,
}

impl<'a> TruthWatch<'a> {
    /// A watch of `limits` on states of `model`, with the start-broken
    /// rows a previous command `restored` (one flag per force row; none:
    /// nothing restored yet) held to their required bounds.
    pub fn new(model: &'a ForwardModel, limits: &'a Limits, restored: &[bool]) -> Self {
        TruthWatch {
            model,
            limits,
            held: limits.held_bounds(restored),
            increments: 0,
            checked: 0,
            worst: None,
            breaches: Vec::new(),
            last_rows: None,
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
        let rows = force_rows(self.model, state);
        let c = self
            .limits
            .check_rows_held(self.model, state, &rows, r.tolerance_n, &self.held);
        self.checked += 1;
        self.breaches
            .extend(c.violations.iter().map(|v| (self.increments, v.clone())));
        self.worst = Some(worst_along_path(self.worst.take(), c));
        self.last_rows = Some((rows, r.tolerance_n));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::plan::{DeploymentProblem, LimitViolation};
    use crate::sim::{default_truth, Plant};

    #[test]
    fn the_truth_watch_sees_every_increment_and_reports_a_tight_limit() {
        let truth = default_truth(reference_bridge(&BridgeParameters::default()).unwrap());
        let n = truth.structure.continuous_cables.len();
        let mut plant = Plant::new(&truth, Some(&vec![0.10; n]), None).unwrap();
        let model = plant.model().clone();
        // Reeling in 2.5 cm raises the continuous-cable tensions. With the
        // default limits nothing is near a bound; with a 1 N tension limit
        // every tension-only row is start-broken and held to its start
        // value, so the rise makes some of them worse than at the start.
        let loose = Limits::new(&model, &DeploymentProblem::default(), plant.state());
        let tight_problem = DeploymentProblem {
            max_tension_n: 1.0,
            ..DeploymentProblem::default()
        };
        let tight = Limits::new(&model, &tight_problem, plant.state());
        let command = vec![-0.025; n];
        let mut a = plant.clone();
        let mut watch = TruthWatch::new(&model, &loose, &[]);
        let report = a.apply(&command, None, &mut watch).unwrap();
        assert_eq!(watch.increments, report.increments);
        assert_eq!(watch.checked, report.increments);
        assert!(report.increments >= 3, "{}", report.increments);
        let w = watch.worst.unwrap();
        assert!(w.ok(), "{:?}", w.violations);
        assert!(w.worst_utilisation > 0.0 && w.min_tension_n > 5.0);

        let mut watch = TruthWatch::new(&model, &tight, &[]);
        plant.apply(&command, None, &mut watch).unwrap();
        assert_eq!(watch.checked, report.increments);
        let w = watch.worst.unwrap();
        assert!(!w.ok());
        assert!(
            w.violations
                .iter()
                .all(|v| matches!(v, LimitViolation::WorseThanStart { lower: false, .. })),
            "{:?}",
            w.violations
        );
    }

    /// The reference bridge with μ 0.2 and 20 mm cable seats, folded
    /// 40 cm: its plant, truth model, default limits and motor count.
    fn folded_on_seats() -> (Plant, ForwardModel, Limits, usize) {
        use crate::model::{EffectKind, Effects, RelaxSettings};
        use crate::sim::EffectModel;
        let truth = EffectModel {
            effects: Effects::default()
                .with_parameters(EffectKind::JointFriction, &[0.2])
                .with_parameters(EffectKind::JointEccentricity, &[0.02]),
            structure: reference_bridge(&BridgeParameters::default()).unwrap(),
            settings: RelaxSettings::default(),
            increment_m: 0.01,
        };
        let n = truth.structure.continuous_cables.len();
        let plant = Plant::new(&truth, Some(&vec![0.40; n]), None).unwrap();
        let model = plant.model().clone();
        let limits = Limits::new(&model, &DeploymentProblem::default(), plant.state());
        (plant, model, limits, n)
    }

    /// Regression (issue 22, tenth session): with joint eccentricity the
    /// plant settles the cables over their seat arcs after a command's
    /// payout, re-solving the bridge; those solves were run unobserved, so
    /// the state a command ends in went unjudged. On `scenarios/wide.toml`
    /// (seed 9090, scenario 27) a continuous-cable segment ended a
    /// command at 0 N, held to 5 N, with no violation reported. The watch
    /// now sees the settled state as the command's last increment, and
    /// its last rows are the forces of the state the plant ends in.
    #[test]
    fn the_truth_watch_judges_the_state_the_seats_settle_into() {
        let (mut plant, model, limits, n) = folded_on_seats();
        let mut watch = TruthWatch::new(&model, &limits, &[]);
        let report = plant.apply(&vec![-0.03; n], None, &mut watch).unwrap();
        // The seats moved material, so the bridge was solved again after
        // the payout's increments, and the watch saw the settled state.
        assert_eq!(watch.increments, report.increments + 1);
        assert_eq!(watch.checked, watch.increments);
        // The settled state is the one the plant ends in, exactly.
        let (rows, _) = watch.last_rows.unwrap();
        assert_eq!(rows, force_rows(&model, plant.state()));
    }

    /// Regression (independent review, tenth session): the fold moved
    /// material over the seats, but the plant followed the seat arcs only
    /// before folding, so the folded start (from which the start-broken
    /// limits are taken) was not settled and the first command's settled
    /// state carried the fold's settling: a zero command changed segment
    /// forces by up to 8.7 N. The folded start is now settled: a zero
    /// command moves no material and shows no settled increment.
    #[test]
    fn the_folded_start_is_settled_on_its_seats() {
        let (mut plant, model, limits, n) = folded_on_seats();
        let mut watch = TruthWatch::new(&model, &limits, &[]);
        let report = plant.apply(&vec![0.0; n], None, &mut watch).unwrap();
        assert_eq!(watch.increments, report.increments);
    }
}
