//! The cases of many cycles, and the nearest of them to a new cycle's
//! conditions.
//!
//! Retrieval compares conditions by a scaled Euclidean distance over the
//! features of [`CaseConditions`]:
//!
//! ```text
//!   d² = ((T − T')/s_T)² + (mean fold − mean fold')²/s_f²
//!      + ((g₀ − g₀')/s_g)² + Σ_halves ((ŝ − ŝ')/s_s)² / halves
//! ```
//!
//! with the scales of [`FeatureScales`] (what counts as "as different as
//! one unit"); a feature missing on either side adds nothing, so a case
//! without a temperature is as near as its other features say. Ties go to
//! the older case (the lower index), so retrieval is deterministic.

use serde::{Deserialize, Serialize};

use super::case::{Case, CaseConditions};

/// The scale of each retrieval feature: a difference of this much counts
/// as a distance of 1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FeatureScales {
    /// Temperature, °C. Default 5 °C: a steel bridge's 30 m span moves
    /// ~2 mm per 5 K, a tenth of the connection tolerance.
    pub temperature_c: f64,
    /// Mean start fold, m. Default 0.05: one command's largest step.
    pub fold_m: f64,
    /// Largest measured start gap, m. Default 0.01: ten times the
    /// position noise.
    pub start_gap_m: f64,
    /// Payout scale, 1. Default 0.02: the estimator's typical standard
    /// deviation after a deployment.
    pub payout_scale: f64,
}

impl Default for FeatureScales {
    fn default() -> Self {
        FeatureScales {
            temperature_c: 5.0,
            fold_m: 0.05,
            start_gap_m: 0.01,
            payout_scale: 0.02,
        }
    }
}

/// A retrieved case: its index in the memory and its distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbour {
    /// Index of the case in [`CaseMemory::cases`].
    pub index: usize,
    /// Scaled distance (see the module documentation).
    pub distance: f64,
}

/// The cases of past cycles, in the order they were stored.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CaseMemory {
    /// The cases, oldest first.
    pub cases: Vec<Case>,
}

/// Scaled squared distance between two sets of conditions.
pub fn distance_squared(a: &CaseConditions, b: &CaseConditions, s: &FeatureScales) -> f64 {
    let term = |x: Option<f64>, y: Option<f64>, scale: f64| match (x, y) {
        (Some(x), Some(y)) => ((x - y) / scale).powi(2),
        _ => 0.0,
    };
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let halves = a.payout_scale.len().min(b.payout_scale.len());
    let scale_term = if halves == 0 {
        0.0
    } else {
        a.payout_scale
            .iter()
            .zip(&b.payout_scale)
            .map(|(x, y)| ((x - y) / s.payout_scale).powi(2))
            .sum::<f64>()
            / halves as f64
    };
    term(a.temperature_c, b.temperature_c, s.temperature_c)
        + term(mean(&a.fold_m), mean(&b.fold_m), s.fold_m)
        + term(a.start_gap_m, b.start_gap_m, s.start_gap_m)
        + scale_term
}

impl CaseMemory {
    /// The `k` cases nearest to `query`, nearest first (fewer if the
    /// memory holds fewer). One pass over the cases and a partial sort:
    /// O(n + k log k).
    pub fn nearest(&self, query: &CaseConditions, k: usize, s: &FeatureScales) -> Vec<Neighbour> {
        self.nearest_where(query, k, s, |_| true)
    }

    /// [`Self::nearest`] among the cases `keep` accepts.
    pub fn nearest_where(
        &self,
        query: &CaseConditions,
        k: usize,
        s: &FeatureScales,
        keep: impl Fn(&Case) -> bool,
    ) -> Vec<Neighbour> {
        let mut all: Vec<Neighbour> = self
            .cases
            .iter()
            .enumerate()
            .filter(|(_, c)| keep(c))
            .map(|(index, c)| Neighbour {
                index,
                distance: distance_squared(query, &c.conditions, s).sqrt(),
            })
            .filter(|n| n.distance.is_finite())
            .collect();
        let by_distance = |a: &Neighbour, b: &Neighbour| {
            a.distance
                .total_cmp(&b.distance)
                .then(a.index.cmp(&b.index))
        };
        let k = k.min(all.len());
        if k == 0 {
            return Vec::new();
        }
        if k < all.len() {
            all.select_nth_unstable_by(k - 1, by_distance);
            all.truncate(k);
        }
        all.sort_by(by_distance);
        all
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::case::CaseOutcome;

    fn case(temperature_c: f64, scale: f64) -> Case {
        Case {
            conditions: CaseConditions {
                temperature_c: Some(temperature_c),
                fold_m: vec![0.4; 10],
                start_gap_m: Some(0.142),
                payout_scale: vec![scale, scale],
            },
            commands_m: vec![vec![-0.05; 10]],
            take_up_commands: None,
            measured_gaps_m: vec![vec![Some(0.1); 5]],
            final_gap_vectors_m: vec![Some([0.01, 0.0, 0.0]); 5],
            prediction_error_m: vec![Some(0.002)],
            outcome: CaseOutcome {
                status: "connected".into(),
                commands: 1,
                corrective_commands: Some(0),
                final_gap_m: Some(0.01),
                approach_commands: None,
            },
            learning: None,
            model: None,
        }
    }

    /// Two temperatures in the memory: a cold query retrieves the cold
    /// cases, a warm one the warm cases; the distance is the scaled one by
    /// hand.
    #[test]
    fn retrieval_picks_the_case_with_the_matching_conditions() {
        let memory = CaseMemory {
            cases: vec![
                case(5.0, 0.0),
                case(30.0, 0.0),
                case(6.0, 0.01),
                case(29.0, 0.0),
            ],
        };
        let s = FeatureScales::default();
        let cold = memory.nearest(&case(5.5, 0.0).conditions, 2, &s);
        assert_eq!(cold.iter().map(|n| n.index).collect::<Vec<_>>(), vec![0, 2]);
        // (0.5/5)² for case 0; (0.5/5)² + (0.01/0.02)² for case 2.
        assert!((cold[0].distance - 0.1).abs() < 1e-12);
        assert!((cold[1].distance - (0.01f64 + 0.25).sqrt()).abs() < 1e-12);
        let warm = memory.nearest(&case(31.0, 0.0).conditions, 1, &s);
        assert_eq!(warm[0].index, 1);
        assert!(memory.nearest(&case(0.0, 0.0).conditions, 0, &s).is_empty());
        assert_eq!(memory.nearest(&case(0.0, 0.0).conditions, 10, &s).len(), 4);
    }

    /// Equal distances go to the older case, whatever the order the
    /// selection visits them in.
    #[test]
    fn ties_go_to_the_older_case() {
        let memory = CaseMemory {
            cases: vec![case(10.0, 0.0); 5],
        };
        let n = memory.nearest(&case(10.0, 0.0).conditions, 3, &FeatureScales::default());
        assert_eq!(n.iter().map(|n| n.index).collect::<Vec<_>>(), vec![0, 1, 2]);
    }
}
