//! Two-node force elements: members and continuous-cable segments, with
//! the one force law the residual, the fictitious masses, the tangent and
//! the member-force report all use.

use crate::model::sliding::segment_tension;

/// A two-node force element: a member or a continuous-cable segment.
#[derive(Debug, Clone, Copy)]
pub(in crate::model) struct Element {
    pub(in crate::model) a: usize,
    pub(in crate::model) b: usize,
    pub(in crate::model) law: ElementLaw,
}

#[derive(Debug, Clone, Copy)]
pub(in crate::model) enum ElementLaw {
    /// `T = k·(L − L0)`, tension-only if flagged.
    Linear {
        stiffness_n_per_m: f64,
        rest_m: f64,
        tension_only: bool,
    },
    /// Segment `index` of the flat segment list: `T = EA·(L − s)/s`, tension only.
    Segment { ea_n: f64, index: usize },
}

/// An element's axial state at a length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(in crate::model) struct AxialState {
    /// Axial force, tension positive (zero for a slack tension-only
    /// element), N.
    pub tension_n: f64,
    /// Elastic force `k·(L − L0)` before the tension-only cut-off, N: the
    /// fictitious masses use it so that a slack member about to turn taut
    /// keeps its geometric term (for segments it equals `tension_n`).
    pub elastic_n: f64,
    /// Axial stiffness, N/m.
    pub stiffness_n_per_m: f64,
}

impl ElementLaw {
    /// The one force law: the axial state at length `length_m`, with the
    /// segments' current rest lengths `segment_rest_m` (flat, as the state).
    pub(in crate::model) fn at(&self, length_m: f64, segment_rest_m: &[f64]) -> AxialState {
        match *self {
            ElementLaw::Linear {
                stiffness_n_per_m,
                rest_m,
                tension_only,
            } => {
                let elastic_n = stiffness_n_per_m * (length_m - rest_m);
                AxialState {
                    tension_n: if tension_only && elastic_n < 0.0 {
                        0.0
                    } else {
                        elastic_n
                    },
                    elastic_n,
                    stiffness_n_per_m,
                }
            }
            ElementLaw::Segment { ea_n, index } => {
                let rest = segment_rest_m[index];
                let t = segment_tension(ea_n, length_m, rest);
                AxialState {
                    tension_n: t,
                    elastic_n: t,
                    stiffness_n_per_m: ea_n / rest,
                }
            }
        }
    }
}
