//! The correction a planner adds to its model's predictions: an
//! output-bias correction, as offset-free model-predictive control does.
//! What it holds is computed from measurements in `crate::control`
//! (`measured_offsets`, `force_offset_filter`); open-loop plans use none.
//!
//! After each command the controller holds two states: its model's
//! prediction (the command applied to the model's previous state, with
//! friction) and the plant's noisy measurement of some of it (midspan node
//! positions, load cells). It does not move its model state onto the
//! measurement (a set of node coordinates is no equilibrium of the model,
//! and most of the structure is not measured). Instead it keeps its model
//! state and records, for every measured quantity, the offset
//!
//! ```text
//!     offset = measured − predicted
//! ```
//!
//! and adds that offset to every prediction of the same quantity until the
//! next measurement: to the midspan gap vectors the QP closes and the
//! connection test reads, and to the force rows the member limits bound.
//! The planner therefore closes the *measured* gaps and keeps the
//! *measured* forces inside their limits, using the model only for how
//! they change with a command (its sensitivities), which is what a model
//! with missing effects still gets roughly right. Quantities that are not
//! measured keep a zero offset.

use nalgebra::Vector3;

/// Offsets added to the model's predictions (measured − predicted at the
/// last measurement); zeros when planning open loop.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelCorrection {
    /// Offset of each midspan pair's gap vector `x_a − x_b`, m.
    pub gap_offsets_m: Vec<Vector3<f64>>,
    /// Offset of each force row (members, then segments), N.
    pub force_offsets_n: Vec<f64>,
    /// Whether a sensor read each force row at the last measurement
    /// (members, then segments; missing rows count as unmeasured): the
    /// planner keeps a wider margin on the forces no sensor sees.
    pub force_measured: Vec<bool>,
}

impl ModelCorrection {
    /// No correction, for `pairs` midspan pairs and `force_rows` rows.
    pub fn none(pairs: usize, force_rows: usize) -> Self {
        ModelCorrection {
            gap_offsets_m: vec![Vector3::zeros(); pairs],
            force_offsets_n: vec![0.0; force_rows],
            force_measured: vec![false; force_rows],
        }
    }

    /// The offset of force row `row`, N (zero where none is recorded).
    pub fn force_offset_n(&self, row: usize) -> f64 {
        self.force_offsets_n.get(row).copied().unwrap_or(0.0)
    }

    /// Whether a sensor read force row `row` at the last measurement.
    pub fn force_row_measured(&self, row: usize) -> bool {
        self.force_measured.get(row).copied().unwrap_or(false)
    }

    /// The offset of midspan pair `pair`'s gap vector, m.
    pub fn gap_offset_m(&self, pair: usize) -> Vector3<f64> {
        self.gap_offsets_m
            .get(pair)
            .copied()
            .unwrap_or_else(Vector3::zeros)
    }
}
