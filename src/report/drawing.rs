//! SVG drawings of a state: elevation (x–z), plan (x–y) and cross-section
//! (y–z, looking along the bridge), members coloured by type with line
//! weight growing with force; optionally a second state drawn beneath in
//! grey, as the seed's Fig. 11 overlays the deflected shapes with and without
//! friction.
//!
//! Colours: struts red, cables blue, springs green, continuous-cable
//! segments purple; a member twice as loaded is drawn twice as wide
//! (0.5 to 4 px over the drawing's force range); slack members are dotted.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::model::{DeploymentState, ForwardModel, MemberForces, MemberKind, Structure};

/// A state to draw, with its forces.
#[derive(Debug, Clone, Copy)]
pub struct DrawnState<'a> {
    /// The state.
    pub state: &'a DeploymentState,
    /// Its member and segment forces.
    pub forces: &'a MemberForces,
    /// Legend text.
    pub label: &'a str,
}

/// What went wrong drawing (a plotters backend error, as text).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("drawing failed: {0}")]
pub struct DrawingError(String);

impl DrawingError {
    pub(crate) fn new(message: String) -> Self {
        DrawingError(message)
    }
}

fn err<E: std::fmt::Debug>(e: E) -> DrawingError {
    DrawingError(format!("{e:?}"))
}

const STRUT: RGBColor = RGBColor(200, 30, 30);
const CABLE: RGBColor = RGBColor(30, 80, 200);
const SPRING: RGBColor = RGBColor(20, 150, 60);
const CONTINUOUS: RGBColor = RGBColor(130, 40, 160);
const OVERLAY: RGBColor = RGBColor(170, 170, 170);

/// One line of the drawing in 3-D with its colour and weight.
struct Line {
    a: [f64; 3],
    b: [f64; 3],
    color: RGBColor,
    width: u32,
    slack: bool,
}

fn lines(structure: &Structure, drawn: &DrawnState<'_>, max_force: f64, grey: bool) -> Vec<Line> {
    let x = &drawn.state.positions_m;
    let width = |f: f64| {
        if grey {
            1
        } else {
            (0.5 + 3.5 * f.abs() / max_force).round().max(1.0) as u32
        }
    };
    let mut out = Vec::new();
    for (m, f) in structure.members.iter().zip(&drawn.forces.member_n) {
        let color = match m.kind {
            MemberKind::Strut { .. } => STRUT,
            MemberKind::Cable { .. } => CABLE,
            MemberKind::Spring { .. } => SPRING,
        };
        let [a, b] = m.nodes;
        out.push(Line {
            a: x[a].into(),
            b: x[b].into(),
            color: if grey { OVERLAY } else { color },
            width: width(*f),
            slack: m.kind.is_tension_only() && *f <= 0.0,
        });
    }
    let mut seg = 0;
    for c in &structure.continuous_cables {
        for w in c.path.windows(2) {
            let f = drawn.forces.segment_n[seg];
            seg += 1;
            out.push(Line {
                a: x[w[0]].into(),
                b: x[w[1]].into(),
                color: if grey { OVERLAY } else { CONTINUOUS },
                width: width(f),
                slack: f <= 0.0,
            });
        }
    }
    out
}

/// Ranges of the two projected axes over all drawn states, padded, and
/// widened so that one metre has the same length on both axes in an area of
/// `pixels` (width, height).
fn equal_ranges(
    all: &[&Vec<Line>],
    (h, v): (usize, usize),
    pixels: (u32, u32),
) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let (mut h0, mut h1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for set in all {
        for l in set.iter() {
            for p in [l.a, l.b] {
                h0 = h0.min(p[h]);
                h1 = h1.max(p[h]);
                v0 = v0.min(p[v]);
                v1 = v1.max(p[v]);
            }
        }
    }
    let pad = 0.05 * (h1 - h0).max(v1 - v0).max(1e-3);
    let (mut h0, mut h1, mut v0, mut v1) = (h0 - pad, h1 + pad, v0 - pad, v1 + pad);
    let per_px = ((h1 - h0) / pixels.0 as f64).max((v1 - v0) / pixels.1 as f64);
    let (hw, vw) = (per_px * pixels.0 as f64, per_px * pixels.1 as f64);
    let (hc, vc) = (0.5 * (h0 + h1), 0.5 * (v0 + v1));
    h0 = hc - 0.5 * hw;
    h1 = hc + 0.5 * hw;
    v0 = vc - 0.5 * vw;
    v1 = vc + 0.5 * vw;
    (h0..h1, v0..v1)
}

fn view(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    title: &str,
    axes: (usize, usize),
    labels: (&str, &str),
    sets: &[&Vec<Line>],
) -> Result<(), DrawingError> {
    let (w, h) = area.dim_in_pixel();
    let plot_px = (w.saturating_sub(70).max(10), h.saturating_sub(70).max(10));
    let (hr, vr) = equal_ranges(sets, axes, plot_px);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(hr, vr)
        .map_err(err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(labels.0)
        .y_desc(labels.1)
        .draw()
        .map_err(err)?;
    for set in sets {
        for l in set.iter() {
            let pts = vec![(l.a[axes.0], l.a[axes.1]), (l.b[axes.0], l.b[axes.1])];
            let style = ShapeStyle::from(&l.color).stroke_width(l.width);
            if l.slack {
                let dots = (0..=8).map(|k| {
                    let t = k as f64 / 8.0;
                    (
                        pts[0].0 + t * (pts[1].0 - pts[0].0),
                        pts[0].1 + t * (pts[1].1 - pts[0].1),
                    )
                });
                chart
                    .draw_series(dots.map(|p| Circle::new(p, 1, style.filled())))
                    .map_err(err)?;
            } else {
                chart
                    .draw_series(std::iter::once(PathElement::new(pts, style)))
                    .map_err(err)?;
            }
        }
    }
    Ok(())
}

/// The three views of `primary` (and `overlay`, in grey beneath it) as an
/// SVG document.
pub fn state_views_svg(
    structure: &Structure,
    primary: DrawnState<'_>,
    overlay: Option<DrawnState<'_>>,
    title: &str,
) -> Result<String, DrawingError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 980)).into_drawing_area();
        draw_state_views(&root, structure, primary, overlay, title)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// `state.svg` of a simulation (`tdeploy simulate`): its `last` state
/// over its `first`, each with the member forces `model` gives it, titled
/// by the structure's name.
pub fn simulation_svg(
    model: &ForwardModel,
    first: &DeploymentState,
    last: &DeploymentState,
) -> Result<String, DrawingError> {
    let (f0, f1) = (model.member_forces(first), model.member_forces(last));
    state_views_svg(
        model.structure(),
        DrawnState {
            state: last,
            forces: &f1,
            label: "final state",
        },
        Some(DrawnState {
            state: first,
            forces: &f0,
            label: "initial state",
        }),
        &model.structure().name,
    )
}

/// Draws the three views of `primary` (and `overlay`, in grey beneath it)
/// with their legend into `area` (1200 × 980 pixels suit it), so that a
/// figure can put them beside its own charts.
pub fn draw_state_views(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    structure: &Structure,
    primary: DrawnState<'_>,
    overlay: Option<DrawnState<'_>>,
    title: &str,
) -> Result<(), DrawingError> {
    let max_force = primary
        .forces
        .member_n
        .iter()
        .chain(&primary.forces.segment_n)
        .fold(1e-9f64, |a, f| a.max(f.abs()));
    let coloured = lines(structure, &primary, max_force, false);
    let grey = overlay.map(|o| lines(structure, &o, max_force, true));
    let mut sets: Vec<&Vec<Line>> = Vec::new();
    if let Some(g) = &grey {
        sets.push(g);
    }
    sets.push(&coloured);

    area.fill(&WHITE).map_err(err)?;
    let legend = match overlay {
        Some(o) => format!(
            "{title} — coloured: {}; grey: {}. Struts red, cables blue, springs green, continuous cables purple; width ∝ |force| (max {:.0} N); dotted = slack",
            primary.label, o.label, max_force
        ),
        None => format!(
            "{title} — {}. Struts red, cables blue, springs green, continuous cables purple; width ∝ |force| (max {:.0} N); dotted = slack",
            primary.label, max_force
        ),
    };
    let (head, body) = area.split_vertically(30);
    head.draw(&Text::new(legend, (10, 8), ("sans-serif", 13)))
        .map_err(err)?;
    let (elevation, rest) = body.split_vertically(330);
    let (plan, section) = rest.split_vertically(330);
    view(&elevation, "Elevation", (0, 2), ("x (m)", "z (m)"), &sets)?;
    view(&plan, "Plan", (0, 1), ("x (m)", "y (m)"), &sets)?;
    let (section, _) = section.split_horizontally(420);
    view(
        &section,
        "Cross-section (looking along x)",
        (1, 2),
        ("y (m)", "z (m)"),
        &sets,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{ForwardModel, JointFriction, RelaxSettings};

    #[test]
    fn draws_every_member_in_each_of_three_views() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let m =
            ForwardModel::new(s, JointFriction::frictionless(), RelaxSettings::default()).unwrap();
        let state = m.reference_state();
        let forces = m.member_forces(&state);
        let drawn = DrawnState {
            state: &state,
            forces: &forces,
            label: "designed",
        };
        let one = state_views_svg(m.structure(), drawn, None, "bridge").unwrap();
        let two = state_views_svg(m.structure(), drawn, Some(drawn), "bridge").unwrap();
        let lines = m.structure().members.len() + m.structure().segment_count();
        // The designed state has no slack member: one polyline per line per
        // view, plus the axes plotters draws (the same count in both).
        let count = |svg: &str| svg.matches("<polyline").count();
        assert_eq!(count(&two) - count(&one), 3 * lines);
        for caption in ["Elevation", "Plan", "Cross-section"] {
            assert!(one.contains(caption), "missing {caption}");
        }
    }
}
