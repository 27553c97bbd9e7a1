//! `evaluation.svg`: the policies of an evaluation side by side, per
//! policy its success rate (%), median commands to connection, median
//! corrective commands (over successful runs) and median final largest
//! gap (mm, over all started runs).

use super::bar_chart::grouped_bars_svg;
use super::drawing::DrawingError;
use crate::studies::evaluation::PolicySummary;

/// The figure of `summaries` (one per policy, named `names`) over
/// `scenarios` scenarios.
pub fn evaluation_svg(
    names: &[String],
    summaries: &[PolicySummary],
    scenarios: usize,
) -> Result<String, DrawingError> {
    let bars: Vec<(&str, Vec<f64>)> = names
        .iter()
        .zip(summaries)
        .map(|(name, s)| {
            (
                name.as_str(),
                vec![
                    100.0 * s.success_rate(),
                    s.commands_median.unwrap_or(0.0),
                    s.corrective_median.unwrap_or(0.0),
                    s.final_gap_median_m.map_or(0.0, |g| 1e3 * g),
                ],
            )
        })
        .collect();
    grouped_bars_svg(
        &format!(
            "{} policies on {scenarios} scenarios (median over successes; gap over all runs)",
            names.len(),
        ),
        "value",
        &[
            "success rate, %".to_string(),
            "commands to connection".into(),
            "corrective commands".into(),
            "final largest gap, mm".into(),
        ],
        &bars,
    )
}
