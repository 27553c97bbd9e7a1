//! `deployment.svg`: a closed-loop deployment at a glance. Left, the gap
//! of every midspan pair as measured after each command (command 0: the
//! folded start), over the connection tolerance shaded in green; dashed,
//! the largest true gap (which the controller never saw). Right, the
//! truth's final state over its folded start (grey), as
//! [`super::drawing`] draws states.

use plotters::prelude::*;

use super::drawing::{draw_state_views, DrawingError, DrawnState};
use crate::control::Deployment;
use crate::model::ForwardModel;

fn err<E: std::fmt::Debug>(e: E) -> DrawingError {
    DrawingError::new(format!("{e:?}"))
}

/// One colour per midspan pair (cycled beyond five).
const PAIR_COLOURS: [RGBColor; 5] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
];
const BAND: RGBColor = RGBColor(200, 235, 200);

/// The figure for `deployment` of the truth `truth`: its gaps, and the
/// truth's final state drawn over its folded start, each with the member
/// forces `truth` gives it, connecting within `tolerance_m`.
pub fn deployment_svg(
    truth: &ForwardModel,
    deployment: &Deployment,
    tolerance_m: f64,
    title: &str,
) -> Result<String, DrawingError> {
    let (start_forces, end_forces) = (
        truth.member_forces(&deployment.start_true_state),
        truth.member_forces(&deployment.final_true_state),
    );
    let end = DrawnState {
        state: &deployment.final_true_state,
        forces: &end_forces,
        label: "truth at the end",
    };
    let start = DrawnState {
        state: &deployment.start_true_state,
        forces: &start_forces,
        label: "truth folded at the start",
    };
    let structure = truth.structure();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1900, 980)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (left, right) = root.split_horizontally(700);
        gaps_chart(&left, deployment, tolerance_m, title)?;
        draw_state_views(&right, structure, end, Some(start), &structure.name)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Measured gaps (mm) per pair over the command index, the tolerance band
/// shaded, the largest true gap dashed.
fn gaps_chart(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    d: &Deployment,
    tolerance_m: f64,
    title: &str,
) -> Result<(), DrawingError> {
    // Steps: 0 the start, k after command k.
    let measured: Vec<&Vec<Option<f64>>> = std::iter::once(&d.start.measured_gaps_m)
        .chain(d.records.iter().map(|r| &r.measured_gaps_m))
        .collect();
    let true_largest: Vec<f64> = std::iter::once(&d.start.true_gaps_m)
        .chain(d.records.iter().map(|r| &r.true_gaps_m))
        .map(|g| g.iter().copied().fold(0.0, f64::max))
        .collect();
    let steps = measured.len();
    let top_mm = measured
        .iter()
        .flat_map(|g| g.iter().flatten())
        .chain(&true_largest)
        .fold(tolerance_m, |a, g| a.max(*g))
        * 1e3
        * 1.08;
    let tol_mm = 1e3 * tolerance_m;
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{title}: measured midspan gaps"),
            ("sans-serif", 16),
        )
        .margin(12)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(-0.3..(steps as f64 - 0.7).max(1.0), 0.0..top_mm)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("command (0: folded start)")
        .y_desc("gap (mm)")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y:.0}"))
        .light_line_style(WHITE)
        .draw()
        .map_err(err)?;
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(-0.3, 0.0), ((steps as f64 - 0.7).max(1.0), tol_mm)],
            BAND.filled(),
        )))
        .map_err(err)?
        .label(format!("connector tolerance ±{tol_mm:.0} mm"))
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], BAND.filled()));
    let pairs = d.start.measured_gaps_m.len();
    for p in 0..pairs {
        let colour = PAIR_COLOURS[p % PAIR_COLOURS.len()];
        let points: Vec<(f64, f64)> = measured
            .iter()
            .enumerate()
            .filter_map(|(k, g)| g.get(p).copied().flatten().map(|v| (k as f64, 1e3 * v)))
            .collect();
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
            .map_err(err)?
            .label(format!("pair {p}, measured"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 15, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(points.iter().map(|&pt| Circle::new(pt, 3, colour.filled())))
            .map_err(err)?;
    }
    // Dashed: short segments on every other half step.
    let dashes = true_largest.windows(2).enumerate().flat_map(|(k, w)| {
        (0..4).filter(|j| j % 2 == 0).map(move |j| {
            let (t0, t1) = (j as f64 / 4.0, (j + 1) as f64 / 4.0);
            let at = |t: f64| (k as f64 + t, 1e3 * (w[0] + t * (w[1] - w[0])));
            PathElement::new(vec![at(t0), at(t1)], BLACK.stroke_width(1))
        })
    });
    chart
        .draw_series(dashes)
        .map_err(err)?
        .label("largest true gap (not seen by the controller)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 6, y)], BLACK.stroke_width(1)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;
    Ok(())
}
