//! An evaluation's outcomes by how deep the bridge was folded: where the
//! controller works and where it stops.
//!
//! On `scenarios/wide.toml` the success rate hides a dependence on the
//! fold that decides it, and on which half was folded: on 200 scenarios of
//! seed 7401 (release build, the default policy) 124 of the 137 runs
//! whose halves were both folded less than 48 cm connected, 6 of the 48
//! where half A was folded 48 cm or more (37 of those stopped before
//! their first command on a segment of `A_cc0` or `A_cc1` the fold left
//! slack, which half A's load cells read; known limitations, item 18),
//! and 10 of the 15 where only half B was. So each policy's runs are
//! counted in bands of each half's fold: once by half A's, once by half
//! B's (by the one fold where the halves fold alike).
//!
//! A band is `(k·w, (k+1)·w]`, `w` = [`FOLD_BAND_WIDTH_M`], the first
//! `[0, w]`: closed at the top, so that the end of a distribution's range
//! (a fold of 60 cm in `scenarios/wide.toml`, where the uneven folds are
//! clamped) falls in the band below it, not alone in a band of its own.

use std::collections::BTreeMap;

use super::evaluation::RunResult;

/// Width of a fold band, m: `scenarios/wide.toml`'s folds of 10 to 60 cm
/// make five bands.
pub const FOLD_BAND_WIDTH_M: f64 = 0.1;

/// Whose fold a band counts the runs by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FoldOf {
    /// Both halves folded alike: the one fold.
    BothHalves,
    /// Half A's fold (`fold_m`).
    HalfA,
    /// Half B's fold (`fold_b_m`).
    HalfB,
}

impl FoldOf {
    /// As written in `by_fold.csv`'s `half` column: `both`, `A`, `B`.
    pub fn label(self) -> &'static str {
        match self {
            FoldOf::BothHalves => "both",
            FoldOf::HalfA => "A",
            FoldOf::HalfB => "B",
        }
    }
}

/// One policy's runs whose fold (of [`Self::fold_of`]) lies in
/// `(from_m, to_m]` (`[0, to_m]` for the first band).
#[derive(Debug, Clone, PartialEq)]
pub struct FoldBand {
    /// The policy (index into the evaluation's policies).
    pub policy: usize,
    /// Whose fold.
    pub fold_of: FoldOf,
    /// The band's lower end (excluded, but for the first band), m.
    pub from_m: f64,
    /// The band's upper end (included), m.
    pub to_m: f64,
    /// Runs in the band.
    pub runs: usize,
    /// Of those, the runs that succeeded (connected, every limit kept).
    pub succeeded: usize,
    /// Of those, the runs whose truth broke a limit.
    pub broke_limits: usize,
}

impl FoldBand {
    /// The runs that failed without breaking a limit: stopped short (not
    /// reachable safely, out of commands), never started, ended with a
    /// limit the fold broke not restored, or called connected with the
    /// true gap out of tolerance.
    pub fn other_failures(&self) -> usize {
        self.runs - self.succeeded - self.broke_limits
    }
}

/// The band number `k` of a fold `fold_m` (m, ≥ 0): `(k·w, (k+1)·w]`, and
/// 0 for a fold of 0.
fn band_of(fold_m: f64) -> i64 {
    // A fold computed as a multiple of the width can land a hair above it
    // (3.0 × 0.1 = 0.30000000000000004): a relative nanometre decides
    // nothing.
    (((fold_m / FOLD_BAND_WIDTH_M) * (1.0 - 1e-12)).ceil() as i64 - 1).max(0)
}

/// The bands of `policies` policies' `results`. `folds_m(scenario)` gives
/// a scenario's folds, m: half A's, and half B's where the halves fold
/// differently; results whose folds are unknown are left out. If any
/// scenario folds its halves differently, each policy's runs are banded
/// by half A's fold and then by half B's (a scenario without a fold of
/// its own for half B counting half A's), else by the one fold. Per
/// policy in order, the bands that hold a run, shallowest first.
pub fn fold_bands(
    results: &[RunResult],
    policies: usize,
    folds_m: impl Fn(usize) -> Option<(f64, Option<f64>)>,
) -> Vec<FoldBand> {
    let uneven = results
        .iter()
        .any(|r| folds_m(r.scenario).is_some_and(|(_, b)| b.is_some()));
    let halves: &[FoldOf] = if uneven {
        &[FoldOf::HalfA, FoldOf::HalfB]
    } else {
        &[FoldOf::BothHalves]
    };
    let mut bands = Vec::new();
    for policy in 0..policies {
        for &fold_of in halves {
            // Per band number: runs, succeeded, broke limits.
            let mut counts: BTreeMap<i64, [usize; 3]> = BTreeMap::new();
            for r in results.iter().filter(|r| r.policy == policy) {
                let Some((a, b)) = folds_m(r.scenario) else {
                    continue;
                };
                let fold = match fold_of {
                    FoldOf::HalfB => b.unwrap_or(a),
                    FoldOf::HalfA | FoldOf::BothHalves => a,
                };
                if !fold.is_finite() {
                    continue;
                }
                let c = counts.entry(band_of(fold)).or_default();
                c[0] += 1;
                if r.succeeded {
                    c[1] += 1;
                } else if r.truth_violations > 0 {
                    c[2] += 1;
                }
            }
            bands.extend(
                counts
                    .into_iter()
                    .map(|(k, [runs, succeeded, broke_limits])| FoldBand {
                        policy,
                        fold_of,
                        from_m: k as f64 * FOLD_BAND_WIDTH_M,
                        to_m: (k + 1) as f64 * FOLD_BAND_WIDTH_M,
                        runs,
                        succeeded,
                        broke_limits,
                    }),
            );
        }
    }
    bands
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(scenario: usize, policy: usize, succeeded: bool, violations: usize) -> RunResult {
        RunResult {
            scenario,
            policy,
            status: if succeeded { "connected" } else { "stopped" }.into(),
            succeeded,
            commands: 1,
            corrective_commands: None,
            final_measured_gap_m: None,
            final_true_gap_m: None,
            cable_travel_m: 0.0,
            worst_utilisation: 0.0,
            truth_violations: violations,
            largest_force_breach_n: None,
            approach_gap_m: None,
            binds: Vec::new(),
            planning_time_median_s: None,
        }
    }

    #[test]
    fn a_band_is_closed_at_its_top() {
        assert_eq!(band_of(0.1), 0);
        assert_eq!(band_of(0.10000001), 1);
        assert_eq!(band_of(0.3), 2);
        assert_eq!(band_of(3.0 * 0.1), 2);
        assert_eq!(band_of(0.35), 3);
        assert_eq!(band_of(0.6), 5);
        assert_eq!(band_of(0.05), 0);
        assert_eq!(band_of(0.0), 0);
    }

    /// (policy, half, band number, runs, succeeded, broke limits, other).
    fn summary(bands: &[FoldBand]) -> Vec<(usize, &'static str, i64, usize, usize, usize, usize)> {
        bands
            .iter()
            .map(|b| {
                (
                    b.policy,
                    b.fold_of.label(),
                    (10.0 * b.from_m).round() as i64,
                    b.runs,
                    b.succeeded,
                    b.broke_limits,
                    b.other_failures(),
                )
            })
            .collect()
    }

    #[test]
    fn runs_are_counted_per_policy_and_band_by_outcome() {
        let folds = [0.12, 0.18, 0.55, 0.6, 0.6];
        let results = vec![
            run(0, 0, true, 0),
            run(0, 1, false, 3),
            run(1, 0, false, 0),
            run(1, 1, true, 0),
            run(2, 0, false, 2),
            run(2, 1, false, 0),
            run(3, 0, true, 0),
            run(3, 1, true, 0),
            // Scenario 4's fold is unknown: left out.
            run(4, 0, true, 0),
        ];
        let bands = fold_bands(&results, 2, |s| (s < 4).then(|| (folds[s], None)));
        assert_eq!(
            summary(&bands),
            [
                (0, "both", 1, 2, 1, 0, 1),
                (0, "both", 5, 2, 1, 1, 0),
                (1, "both", 1, 2, 1, 1, 0),
                (1, "both", 5, 2, 1, 0, 1),
            ]
        );
        assert!((bands[1].to_m - 0.6).abs() < 1e-12);
    }

    #[test]
    fn uneven_folds_are_banded_by_each_half() {
        // Scenario 0: A 15 cm, B 55 cm; scenario 1: A 55 cm, B 45 cm;
        // scenario 2 folds its halves alike (no fold of its own for B).
        let folds = [(0.15, Some(0.55)), (0.55, Some(0.45)), (0.25, None)];
        let results = vec![run(0, 0, true, 0), run(1, 0, false, 0), run(2, 0, false, 4)];
        let bands = fold_bands(&results, 1, |s| Some(folds[s]));
        assert_eq!(
            summary(&bands),
            [
                (0, "A", 1, 1, 1, 0, 0),
                (0, "A", 2, 1, 0, 1, 0),
                (0, "A", 5, 1, 0, 0, 1),
                (0, "B", 2, 1, 0, 1, 0),
                (0, "B", 4, 1, 0, 0, 1),
                (0, "B", 5, 1, 1, 0, 0),
            ]
        );
    }
}
