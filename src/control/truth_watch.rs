//! The truth's supervisor: every increment of every command checked
//! against the problem's limits on the truth's own structure, as a
//! supervisor would on the real bridge. A violation does not stop the run
//! (the controller cannot see it); it is recorded and counted.

use crate::model::{DeploymentState, ForwardModel, IncrementObserver, RelaxReport};
use crate::plan::limits::{LimitCheck, Limits};
use crate::plan::worst_along_path;

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
            w.violations
                .iter()
                .all(|v| matches!(v, LimitViolation::AboveUpper { .. })),
            "{:?}",
            w.violations
        );
    }
}
