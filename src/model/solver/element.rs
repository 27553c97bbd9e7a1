//! Two-node force elements: members and continuous-cable segments, with
//! the one force law the residual, the fictitious masses, the tangent and
//! the member-force report all use.

/// A two-node force element: a member or a continuous-cable segment.
#[derive(Debug, Clone, Copy)]
pub(super) struct Element {
    pub(super) a: usize,
    pub(super) b: usize,
    pub(super) law: ElementLaw,
}

#[derive(Debug, Clone, Copy)]
pub(super) enum ElementLaw {
    /// `T = k·(L − L0)`, tension-only if flagged.
    Linear {
        stiffness_n_per_m: f64,
        rest_m: f64,
        tension_only: bool,
    },
    /// Segment `index` of the flat segment list: `T = EA·(L − s)/s`, tension only.
    Segment { ea_n: f64, index: usize },
}
