//! The figure of a replay (`tdeploy replay`'s `replay.svg`): on the left,
//! every motor's command per logged step, logged (black dots) and what the
//! policy would have sent (blue crosses); on the right, the largest
//! measured gap per command of the log and of the counterfactual run
//! (measured and true), with the connection tolerance.

use plotters::prelude::*;

use super::comparison_figures::range;
use super::drawing::DrawingError;
use crate::control::Deployment;
use crate::studies::log_replay::Replay;

fn err<E: std::fmt::Debug>(e: E) -> DrawingError {
    DrawingError::new(format!("{e:?}"))
}

/// Largest of the known values.
fn largest(gaps: &[Option<f64>]) -> Option<f64> {
    gaps.iter().flatten().copied().reduce(f64::max)
}

/// The replay's figure; `counterfactual` is the run on the calibrated
/// model, if there is one; `tolerance_m` the connection tolerance.
pub fn replay_svg(
    replay: &Replay,
    counterfactual: Option<&Deployment>,
    tolerance_m: f64,
) -> Result<String, DrawingError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 450)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (left, right) = root.split_horizontally(560);

        // Commands, mm, per motor and step (step index 1 = the first
        // command after the start).
        let logged: Vec<(f64, f64)> = replay
            .steps
            .iter()
            .enumerate()
            .flat_map(|(k, s)| {
                s.logged_command_m
                    .iter()
                    .map(move |c| ((k + 1) as f64, 1e3 * c))
            })
            .collect();
        let policy: Vec<(f64, f64)> = replay
            .steps
            .iter()
            .enumerate()
            .flat_map(|(k, s)| {
                s.policy_command_m
                    .iter()
                    .flatten()
                    .map(move |c| ((k + 1) as f64, 1e3 * c))
            })
            .collect();
        let steps = replay.steps.len().max(1) as f64;
        let yr = range(logged.iter().chain(&policy).map(|p| p.1).chain([0.0]));
        let mut chart = ChartBuilder::on(&left)
            .caption(
                "Commands per motor: logged (dots), policy (crosses)",
                ("sans-serif", 15),
            )
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(0.5..steps + 0.5, yr)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("command after the logged start")
            .y_desc("payout change, mm")
            .draw()
            .map_err(err)?;
        chart
            .draw_series(logged.iter().map(|p| Circle::new(*p, 3, BLACK.filled())))
            .map_err(err)?;
        let blue = RGBColor(40, 80, 200);
        chart
            .draw_series(
                policy
                    .iter()
                    .map(|p| Cross::new(*p, 4, blue.stroke_width(1))),
            )
            .map_err(err)?;

        // Largest gaps, mm, per command (0: the start).
        let log_gaps: Vec<(f64, f64)> = std::iter::once(largest(&replay.start_measured_gaps_m))
            .chain(replay.steps.iter().map(|s| largest(&s.measured_gaps_m)))
            .enumerate()
            .filter_map(|(k, g)| g.map(|g| (k as f64, 1e3 * g)))
            .collect();
        let (mut cf_measured, mut cf_true) = (Vec::new(), Vec::new());
        if let Some(d) = counterfactual {
            let true_largest = |g: &[f64]| g.iter().copied().fold(0.0, f64::max);
            if let Some(g) = largest(&d.start.measured_gaps_m) {
                cf_measured.push((0.0, 1e3 * g));
            }
            cf_true.push((0.0, 1e3 * true_largest(&d.start.true_gaps_m)));
            for r in &d.records {
                if let Some(g) = r.largest_measured_gap_m() {
                    cf_measured.push((r.index as f64, 1e3 * g));
                }
                cf_true.push((r.index as f64, 1e3 * true_largest(&r.true_gaps_m)));
            }
        }
        let xr = range(
            log_gaps
                .iter()
                .chain(&cf_measured)
                .chain(&cf_true)
                .map(|p| p.0)
                .chain([0.0, 1.0]),
        );
        let top = log_gaps
            .iter()
            .chain(&cf_measured)
            .chain(&cf_true)
            .map(|p| p.1)
            .fold(1e3 * tolerance_m, f64::max)
            * 1.1;
        let mut chart = ChartBuilder::on(&right)
            .caption(
                "Largest gap: log (black), counterfactual measured (red), true (grey)",
                ("sans-serif", 15),
            )
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(xr.clone(), 0.0..top)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("command (0: the start)")
            .y_desc("largest gap, mm")
            .draw()
            .map_err(err)?;
        let tol = 1e3 * tolerance_m;
        chart
            .draw_series(LineSeries::new(
                [(xr.start, tol), (xr.end, tol)],
                RGBColor(40, 150, 60).stroke_width(1),
            ))
            .map_err(err)?;
        let red = RGBColor(200, 40, 40);
        let grey = RGBColor(150, 150, 150);
        for (points, colour) in [(&log_gaps, BLACK), (&cf_measured, red), (&cf_true, grey)] {
            chart
                .draw_series(LineSeries::new(
                    points.iter().copied(),
                    colour.stroke_width(1),
                ))
                .map_err(err)?;
            chart
                .draw_series(points.iter().map(|p| Circle::new(*p, 3, colour.filled())))
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}
