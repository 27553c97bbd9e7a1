//! SVG figures of a model-versus-log comparison:
//! - `measured_vs_predicted.svg`: each load cell's measured (dots) and
//!   predicted (line) value over the log's steps;
//! - `residuals_over_steps.svg`: every residual in noise SDs over the
//!   steps, coloured by direction (folding red, deploying blue, start grey);
//! - `residuals_vs_features.svg`: residuals in noise SDs against each
//!   candidate feature (payout, command, joint angle, temperature,
//!   predicted value).

use plotters::prelude::*;

use super::drawing::DrawingError;
use crate::measure::compare::{Comparison, Direction, FEATURES};
use crate::measure::log::MeasurementLog;
use crate::sim::SensorTarget;

fn err<E: std::fmt::Debug>(e: E) -> DrawingError {
    DrawingError::new(format!("{e:?}"))
}

fn colour(d: Direction) -> RGBColor {
    match d {
        Direction::Start => RGBColor(150, 150, 150),
        Direction::Folding => RGBColor(200, 40, 40),
        Direction::Deploying => RGBColor(40, 80, 200),
    }
}

/// Global step index of each cycle's first step.
fn step_offsets(log: &MeasurementLog) -> Vec<usize> {
    let mut offsets = Vec::with_capacity(log.cycles.len());
    let mut k = 0;
    for c in &log.cycles {
        offsets.push(k);
        k += c.readings.len();
    }
    offsets
}

/// A padded range of `values` (0..1 when there are none).
pub(super) fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo <= hi) {
        return 0.0..1.0;
    }
    let pad = 0.05 * (hi - lo).max(1e-9);
    (lo - pad)..(hi + pad)
}

/// Measured and predicted values of every load cell over the steps.
pub fn measured_vs_predicted_svg(
    log: &MeasurementLog,
    comparison: &Comparison,
) -> Result<String, DrawingError> {
    let cells: Vec<usize> = (0..log.sensors.len())
        .filter(|&s| {
            matches!(
                log.sensors[s].target,
                SensorTarget::SegmentTension { .. } | SensorTarget::MemberForce { .. }
            )
        })
        .collect();
    let offsets = step_offsets(log);
    let mut svg = String::new();
    {
        let height = 60 + 260 * cells.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut svg, (1100, height)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let areas = root.split_evenly((cells.len().max(1), 1));
        for (area, &s) in areas.iter().zip(&cells) {
            let mine: Vec<_> = comparison
                .residuals
                .iter()
                .filter(|r| r.sensor == s)
                .collect();
            let x = |r: &&crate::measure::compare::Residual| (offsets[r.cycle] + r.step) as f64;
            let xr = range(mine.iter().map(x));
            let yr = range(mine.iter().flat_map(|r| [r.measured, r.predicted]));
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!(
                        "{}: measured (dots) and predicted (line), N",
                        log.sensors[s].id
                    ),
                    ("sans-serif", 15),
                )
                .margin(8)
                .x_label_area_size(28)
                .y_label_area_size(55)
                .build_cartesian_2d(xr, yr)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("step (all cycles in order)")
                .draw()
                .map_err(err)?;
            chart
                .draw_series(LineSeries::new(
                    mine.iter().map(|r| (x(r), r.predicted)),
                    BLACK.stroke_width(1),
                ))
                .map_err(err)?;
            chart
                .draw_series(
                    mine.iter()
                        .map(|r| Circle::new((x(r), r.measured), 2, colour(r.direction).filled())),
                )
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Residuals in noise SDs over the steps, coloured by direction.
pub fn residuals_over_steps_svg(
    log: &MeasurementLog,
    comparison: &Comparison,
) -> Result<String, DrawingError> {
    let offsets = step_offsets(log);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let xr = range(
            comparison
                .residuals
                .iter()
                .map(|r| (offsets[r.cycle] + r.step) as f64),
        );
        let yr = range(comparison.residuals.iter().map(|r| r.z).chain([-3.0, 3.0]));
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Residuals in noise SDs (folding red, deploying blue, start grey)",
                ("sans-serif", 15),
            )
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(45)
            .build_cartesian_2d(xr.clone(), yr)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("step (all cycles in order)")
            .y_desc("z")
            .draw()
            .map_err(err)?;
        for band in [-1.0, 1.0] {
            chart
                .draw_series(LineSeries::new(
                    [(xr.start, band), (xr.end, band)],
                    RGBColor(200, 200, 200).stroke_width(1),
                ))
                .map_err(err)?;
        }
        chart
            .draw_series(comparison.residuals.iter().map(|r| {
                Circle::new(
                    ((offsets[r.cycle] + r.step) as f64, r.z),
                    2,
                    colour(r.direction).filled(),
                )
            }))
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Residuals in noise SDs against each candidate feature.
pub fn residuals_vs_features_svg(comparison: &Comparison) -> Result<String, DrawingError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1400, 700)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let areas = root.split_evenly((2, 4));
        for (f, area) in areas.iter().enumerate().take(FEATURES.len()) {
            let points: Vec<(f64, f64, Direction)> = comparison
                .residuals
                .iter()
                .filter_map(|r| r.feature(f).map(|x| (x, r.z, r.direction)))
                .collect();
            let xr = range(points.iter().map(|p| p.0));
            let yr = range(points.iter().map(|p| p.1).chain([-3.0, 3.0]));
            let mut chart = ChartBuilder::on(area)
                .caption(format!("z against {}", FEATURES[f]), ("sans-serif", 14))
                .margin(8)
                .x_label_area_size(26)
                .y_label_area_size(40)
                .build_cartesian_2d(xr, yr)
                .map_err(err)?;
            chart.configure_mesh().draw().map_err(err)?;
            chart
                .draw_series(
                    points
                        .iter()
                        .map(|(x, z, d)| Circle::new((*x, *z), 2, colour(*d).filled())),
                )
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}
