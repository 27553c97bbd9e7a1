//! The figures of the experiments: `overlay.svg` of the friction-effect
//! study (the state after a fold-deploy cycle with friction over the one
//! without, as [`super::drawing`] draws states) and `average_tension.svg`
//! of the friction-vs-measurement study (the seed's Fig. 16: average
//! tension per load cell, simulated without and with friction and
//! measured, kN).

use super::bar_chart::grouped_bars_svg;
use super::drawing::{state_views_svg, DrawingError, DrawnState};
use crate::model::Structure;
use crate::studies::friction_vs_measurement::{CellComparison, FrictionVsMeasurement};
use crate::studies::FrictionEffect;

/// `overlay.svg` of the friction-effect study `r` on `structure`.
pub fn friction_effect_svg(
    structure: &Structure,
    r: &FrictionEffect,
) -> Result<String, DrawingError> {
    state_views_svg(
        structure,
        DrawnState {
            state: &r.with_friction.state,
            forces: &r.with_friction.forces,
            label: "with friction",
        },
        Some(DrawnState {
            state: &r.frictionless.state,
            forces: &r.frictionless.forces,
            label: "without friction",
        }),
        "Friction effect after a fold-deploy cycle",
    )
}

/// `average_tension.svg` of `study`, a deployment of `actuation_m`.
pub fn average_tension_svg(
    study: &FrictionVsMeasurement,
    actuation_m: f64,
) -> Result<String, DrawingError> {
    let labels: Vec<String> = study.cells.iter().map(|c| c.sensor.clone()).collect();
    let averages = |f: fn(&CellComparison) -> &Vec<f64>| -> Vec<f64> {
        study
            .cells
            .iter()
            .map(|c| CellComparison::average(f(c)) / 1000.0)
            .collect()
    };
    grouped_bars_svg(
        &format!(
            "Average tension over a {} cm deployment (seed Fig. 16)",
            100.0 * actuation_m
        ),
        "tension, kN",
        &labels,
        &[
            (
                "simulation without friction",
                averages(|c| &c.no_friction_n),
            ),
            ("simulation with friction", averages(|c| &c.friction_n)),
            ("measurement", averages(|c| &c.measured_n)),
        ],
    )
}
