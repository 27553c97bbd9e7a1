//! Whether the memory's learning is borne out on this bridge, so that a
//! refuted update is not sent again (issue 24's aim: learning never
//! makes a cycle worse than the memoryless controller would; measured
//! against that aim in docs/controller.md, "Learning only where it is
//! borne out").
//!
//! The ILC update ([`super::ilc`]) is a linearisation at the case's end on
//! the controller's model, `Δg ≈ G·Δu`. Its prediction of where the next
//! learnt approach ends replaces the prediction of sending the case's
//! commands again unchanged: that they end where they ended. After a
//! learnt cycle both can be scored against the gaps it measured at the
//! end of its learnt approach ([`crate::learn::Case::learnt_approach_error_m`],
//! [`crate::learn::Case::replay_error_m`]):
//!
//! ```text
//!   e_ilc    = max_p |ĝ_p − g_p|        the update's prediction
//!   e_replay = max_p |‖g⁰_p‖ − g_p|     no update (g⁰: the case's end)
//! ```
//!
//! Where `e_ilc > e_replay + k·σ_g` (`σ_g` the noise SD of one measured
//! pair gap, `k` = `[memory] ilc_acceptance_noise_sds`) the update's
//! sensitivities mislead on this bridge: it moved the approach where the
//! model did not predict.
//!
//! Only a learnt cycle that learnt from a learnt cycle is scored. The
//! update's premise, as any iterative learning control's, is the same
//! path repeated with a correction; the first learnt cycle also changes
//! the path (the closed loop of a memoryless cycle becomes the paced
//! feedforward), and with joint friction the path moves the end by as
//! much as the update does. On the default truth the first update
//! predicted 5.3 mm and the cycle ended at 11.1 mm, where the memoryless
//! one had (seed 2), and from the next cycle on the updates were borne
//! out (docs/controller.md, "The learning curve"). On drawn truths with flexible supports, soft
//! cables and sticking joints the updates predicted 10–17 mm and reached
//! 17–32 mm, each cycle, and the third and later learnt approaches ended
//! where the planner's next command slackened the module-0 axial cables
//! the memoryless controller never slackened (`scenarios/wide.toml`,
//! seed 7501, scenario 57). The newest scored cycle under the same
//! conditions decides: refuted, the cycle runs as the memoryless
//! controller would, and so do the later ones (the memoryless cycles are
//! not scored, so the refutation stands until the conditions change).
//!
//! A case that did not connect is not learnt from at all (retrieval skips
//! it, [`super::adaptation::retrieve`]): the update refines an approach
//! that worked, and the end of one that stopped 100 mm short is no
//! linearisation point for the connection.

use std::fmt;

use super::case::CaseConditions;
use super::memory::{distance_squared, CaseMemory, FeatureScales};
use crate::plan::MemorySettings;

/// How well the newest scored learnt cycle's update predicted it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LearningScore {
    /// Index of the learnt cycle's case in the memory (0-based, as
    /// `cycles.csv`'s `learnt_from_case` and the adaptation errors name
    /// cases).
    pub case: usize,
    /// `e_ilc`: the update's prediction error at the end of the learnt
    /// approach, m.
    pub ilc_error_m: f64,
    /// `e_replay`: the error of predicting the case learnt from's end, m.
    pub replay_error_m: f64,
}

impl LearningScore {
    /// Whether the update predicted worse than no update by more than
    /// `tolerance_m`.
    pub fn refutes_learning(&self, tolerance_m: f64) -> bool {
        self.ilc_error_m > self.replay_error_m + tolerance_m
    }
}

/// Why the memory gave a cycle no guidance although it holds cases.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decline {
    /// No case of the memory connected: there is no approach to refine.
    NoConnectedCase {
        /// Cases the memory holds.
        cases: usize,
    },
    /// The newest learnt cycle under these conditions refuted the update
    /// (see the module documentation).
    Refuted {
        /// Its score.
        score: LearningScore,
        /// `k·σ_g`, m.
        tolerance_m: f64,
    },
}

impl fmt::Display for Decline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Decline::NoConnectedCase { cases } => write!(
                f,
                "none of the memory's {cases} case{} connected: no approach to learn from",
                if *cases == 1 { "" } else { "s" }
            ),
            Decline::Refuted { score, tolerance_m } => write!(
                f,
                "the ILC update of case {} predicted its approach's end {:.1} mm off, \
                 no update {:.1} mm (tolerance {:.1} mm): the model's sensitivities \
                 mislead on this bridge, the cycle runs without guidance",
                score.case,
                score.ilc_error_m * 1e3,
                score.replay_error_m * 1e3,
                tolerance_m * 1e3,
            ),
        }
    }
}

/// The score of the newest learnt cycle among `candidates` (case indices)
/// that has one: it learnt from a learnt cycle, sent its whole learnt
/// approach and read a pair's gap.
pub fn newest_learning_score(
    memory: &CaseMemory,
    candidates: impl IntoIterator<Item = usize>,
) -> Option<LearningScore> {
    let mut newest_first: Vec<usize> = candidates.into_iter().collect();
    newest_first.sort_unstable_by(|a, b| b.cmp(a));
    newest_first.into_iter().find_map(|case| {
        let c = memory.cases.get(case)?;
        let from = memory.cases.get(c.learning.as_ref()?.from_case)?;
        from.learning.as_ref()?;
        Some(LearningScore {
            case,
            ilc_error_m: c.learnt_approach_error_m()?,
            replay_error_m: c.replay_error_m(from)?,
        })
    })
}

/// The acceptance check (see the module documentation): the refutation of
/// the update by the newest learnt cycle under `conditions`, if any;
/// `gap_reading_sd_m` is the noise SD of one measured pair gap, m (the
/// tolerance is `ilc_acceptance_noise_sds` of it).
pub fn refutation(
    memory: &CaseMemory,
    conditions: &CaseConditions,
    settings: &MemorySettings,
    scales: &FeatureScales,
    gap_reading_sd_m: f64,
) -> Option<Decline> {
    if !settings.ilc_acceptance_enable {
        return None;
    }
    let same_conditions = (0..memory.cases.len()).filter(|&k| {
        distance_squared(conditions, &memory.cases[k].conditions, scales).sqrt()
            <= settings.match_distance
    });
    let score = newest_learning_score(memory, same_conditions)?;
    let tolerance_m = settings.ilc_acceptance_noise_sds * gap_reading_sd_m;
    score
        .refutes_learning(tolerance_m)
        .then_some(Decline::Refuted { score, tolerance_m })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::case::{Case, CaseConditions, CaseLearning, CaseOutcome};

    /// A cycle that ended `final_gap_m` (all pairs, along x) after three
    /// commands, its approach measured at `approach_gap_m`; learnt from
    /// `from` with the update predicting `predicted_m`.
    fn cycle(
        final_gap_m: f64,
        approach_gap_m: f64,
        learnt: Option<(usize, f64)>,
        status: &str,
    ) -> Case {
        Case {
            conditions: CaseConditions {
                temperature_c: None,
                fold_m: vec![0.4; 2],
                start_gap_m: Some(0.14),
                payout_scale: vec![0.0; 2],
            },
            commands_m: vec![vec![-0.05; 2]; 3],
            take_up_commands: None,
            measured_gaps_m: vec![
                vec![Some(0.1); 2],
                vec![Some(approach_gap_m); 2],
                vec![Some(final_gap_m); 2],
            ],
            final_gap_vectors_m: vec![Some([final_gap_m, 0.0, 0.0]); 2],
            prediction_error_m: vec![Some(0.001); 3],
            outcome: CaseOutcome {
                status: status.into(),
                commands: 3,
                corrective_commands: Some(1),
                final_gap_m: Some(final_gap_m),
                approach_commands: Some(2),
            },
            learning: learnt.map(|(from_case, predicted)| CaseLearning {
                from_case,
                from_gap_m: 0.02,
                predicted_gaps_m: vec![Some(predicted); 2],
                learnt_commands: 2,
                approach_completed: true,
            }),
            model: None,
        }
    }

    #[test]
    fn an_update_that_predicted_worse_than_none_is_refuted_beyond_the_noise() {
        // Case 1 ended at 20 mm; case 2 learnt from it, predicted 12 mm
        // and reached 27 mm: e_ilc 15 mm, e_replay 7 mm.
        let memory = CaseMemory {
            cases: vec![
                cycle(0.030, 0.030, None, "connected"),
                cycle(0.020, 0.020, Some((0, 0.012)), "connected"),
                cycle(0.010, 0.027, Some((1, 0.012)), "connected"),
            ],
        };
        let score = newest_learning_score(&memory, [0, 1, 2]).expect("case 2 is scored");
        assert_eq!(score.case, 2);
        assert!((score.ilc_error_m - 0.015).abs() < 1e-12);
        assert!((score.replay_error_m - 0.007).abs() < 1e-12);
        assert!(score.refutes_learning(0.006));
        assert!(!score.refutes_learning(0.009));
    }

    #[test]
    fn an_update_that_predicted_better_than_none_stands() {
        // Predicted 4 mm from a 20 mm end and reached 5 mm.
        let memory = CaseMemory {
            cases: vec![
                cycle(0.030, 0.030, None, "connected"),
                cycle(0.020, 0.020, Some((0, 0.012)), "connected"),
                cycle(0.004, 0.005, Some((1, 0.004)), "connected"),
            ],
        };
        let score = newest_learning_score(&memory, [0, 1, 2]).expect("scored");
        assert!(!score.refutes_learning(0.0));
    }

    #[test]
    fn the_newest_scored_cycle_decides_and_unguided_cycles_are_not_scored() {
        let memory = CaseMemory {
            cases: vec![
                cycle(0.020, 0.030, None, "connected"),
                cycle(0.010, 0.004, Some((0, 0.005)), "connected"),
                cycle(0.010, 0.040, Some((1, 0.005)), "connected"),
                cycle(0.010, 0.012, None, "connected"),
            ],
        };
        let score = newest_learning_score(&memory, 0..4).expect("scored");
        assert_eq!(score.case, 2, "case 3 ran without guidance");
        assert!(score.refutes_learning(0.005));
        // Only the candidates count: case 2 may be under other conditions.
        assert_eq!(newest_learning_score(&memory, [0, 1, 3]), None);
        assert_eq!(newest_learning_score(&memory, [0, 3]), None);
    }

    #[test]
    fn a_refutation_says_which_case_and_both_errors_in_millimetres() {
        let why = Decline::Refuted {
            score: LearningScore {
                case: 3,
                ilc_error_m: 0.0273,
                replay_error_m: 0.0081,
            },
            tolerance_m: 0.0042,
        };
        assert_eq!(
            why.to_string(),
            "the ILC update of case 3 predicted its approach's end 27.3 mm off, no update 8.1 mm \
             (tolerance 4.2 mm): the model's sensitivities mislead on this bridge, the cycle runs \
             without guidance"
        );
    }

    /// The first learnt cycle changes the path as well as the commands'
    /// totals (the closed loop learnt from becomes the paced feedforward):
    /// it is no test of the update, however far it ended from the
    /// prediction.
    #[test]
    fn a_cycle_that_learnt_from_a_memoryless_one_is_not_scored() {
        let memory = CaseMemory {
            cases: vec![
                cycle(0.011, 0.011, None, "connected"),
                cycle(0.011, 0.011, Some((0, 0.005)), "connected"),
            ],
        };
        assert_eq!(newest_learning_score(&memory, [0, 1]), None);
    }
}
