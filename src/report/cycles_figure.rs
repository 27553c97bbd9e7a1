//! `cycles.svg`: the learning curve of repeated deployment-fold cycles,
//! per cycle the largest measured gap after the first approach and at the
//! end, mm (0 where there is none).

use super::bar_chart::grouped_bars_svg;
use super::drawing::DrawingError;
use crate::studies::cycles::CycleResult;

/// The learning curve of `results`, cycles 1 to `cycles` of the policy
/// named `policy`.
pub fn cycles_svg(
    policy: &str,
    cycles: usize,
    results: &[CycleResult],
) -> Result<String, DrawingError> {
    let labels: Vec<String> = results.iter().map(|r| r.cycle.to_string()).collect();
    let series = [
        (
            "largest gap after the first approach",
            results
                .iter()
                .map(|r| r.approach_gap_m.unwrap_or(0.0) * 1e3)
                .collect(),
        ),
        (
            "final gap",
            results
                .iter()
                .map(|r| r.final_gap_m.unwrap_or(0.0) * 1e3)
                .collect(),
        ),
    ];
    grouped_bars_svg(
        &format!("Learning curve: policy {policy} (cycles 1–{cycles})"),
        "largest measured gap, mm",
        &labels,
        &series,
    )
}
