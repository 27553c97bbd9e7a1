//! The QP planner's trust region on each motor's move: its parameters,
//! their ranges, and the rule that updates the radius after each trial
//! (kept with its parameters, as argmin's trust-region method keeps its
//! radius update with its own).
//!
//! A trial step with reduction ratio ρ (actual over predicted reduction of
//! the gap merit) is accepted when ρ ≥ η (`acceptance_ratio`); an accepted
//! step that did as predicted (ρ ≥ `grow_ratio`) on the region's edge
//! grows the radius by `grow`, up to `max_m`; a rejected one shrinks it by
//! `shrink`; below `min_m` the region has collapsed.

use serde::{Deserialize, Serialize};

use crate::numerics::{check_ranges, FieldError, NumberRange, Ranged};

/// A step whose largest motor move is at least this fraction of the
/// radius is on the region's edge (the QP's bound, up to its tolerance).
const EDGE_FRACTION: f64 = 0.99;

/// The QP planner's trust region on each motor's move, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrustRegion {
    /// Radius at the first command, m; between `min_m` and `max_m`.
    /// Default 0.05 (one full step).
    pub initial_m: f64,
    /// Below this the region has collapsed: the linear model cannot be
    /// trusted for any move the motors can make, m. Default 0.002.
    pub min_m: f64,
    /// Largest radius, m. Default 0.05.
    pub max_m: f64,
    /// Factor on a rejected step, in (0, 1). Default 0.5.
    pub shrink: f64,
    /// Factor after a step that did as predicted (ratio ≥ `grow_ratio`)
    /// on the region's edge, in [1, 10]. Default 2.
    pub grow: f64,
    /// Smallest ratio of actual to predicted reduction of the gap
    /// objective for a step to be accepted (η), in (0, 1). Default 0.1.
    pub acceptance_ratio: f64,
    /// Ratio above which the region grows, in [`acceptance_ratio`, 1].
    /// Default 0.75.
    pub grow_ratio: f64,
}

impl TrustRegion {
    /// Every number of the region with its admissible range.
    pub fn ranges(&self) -> [Ranged; 7] {
        let radius = NumberRange::positive_up_to(1.0);
        let fraction = NumberRange::open(0.0, 1.0);
        [
            Ranged::real("initial_m", self.initial_m, radius),
            Ranged::real("min_m", self.min_m, radius),
            Ranged::real("max_m", self.max_m, radius),
            Ranged::real("shrink", self.shrink, fraction),
            Ranged::real("grow", self.grow, NumberRange::closed(1.0, 10.0)),
            Ranged::real("acceptance_ratio", self.acceptance_ratio, fraction),
            Ranged::real(
                "grow_ratio",
                self.grow_ratio,
                NumberRange::positive_up_to(1.0),
            ),
        ]
    }
}

impl Default for TrustRegion {
    fn default() -> Self {
        TrustRegion {
            initial_m: 0.05,
            min_m: 0.002,
            max_m: 0.05,
            shrink: 0.5,
            grow: 2.0,
            acceptance_ratio: 0.1,
            grow_ratio: 0.75,
        }
    }
}

impl TrustRegion {
    /// Checks every field against its range, the initial radius between
    /// the smallest and the largest, and the growth ratio not below the
    /// acceptance ratio.
    pub fn validate(&self) -> Result<(), FieldError> {
        check_ranges(&self.ranges())?;
        if !(self.min_m <= self.initial_m && self.initial_m <= self.max_m) {
            return Err(FieldError::new(
                "initial_m",
                format!(
                    "must lie between min_m ({}) and max_m ({}), got {}",
                    self.min_m, self.max_m, self.initial_m
                ),
            ));
        }
        if self.grow_ratio < self.acceptance_ratio {
            return Err(FieldError::new(
                "grow_ratio",
                format!(
                    "must be at least acceptance_ratio ({}), got {}",
                    self.acceptance_ratio, self.grow_ratio
                ),
            ));
        }
        Ok(())
    }

    /// Whether a trial step with reduction ratio `ratio` is accepted
    /// (ρ ≥ η; a NaN ratio is not).
    pub fn accepts(&self, ratio: f64) -> bool {
        ratio >= self.acceptance_ratio
    }

    /// The radius after an accepted step from radius `radius_m` whose
    /// largest motor move was `step_m`, with reduction ratio `ratio`:
    /// grown by `grow` (up to `max_m`) when the step did as predicted on
    /// the region's edge, else the same.
    pub fn after_accepted(&self, radius_m: f64, step_m: f64, ratio: f64) -> f64 {
        if ratio >= self.grow_ratio && step_m >= EDGE_FRACTION * radius_m {
            (radius_m * self.grow).min(self.max_m)
        } else {
            radius_m
        }
    }

    /// The radius after a rejected step from radius `radius_m`.
    pub fn after_rejected(&self, radius_m: f64) -> f64 {
        radius_m * self.shrink
    }

    /// Whether a region of radius `radius_m` has collapsed (below `min_m`).
    pub fn collapsed(&self, radius_m: f64) -> bool {
        radius_m < self.min_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_radius_grows_on_the_edge_shrinks_on_rejection_and_collapses() {
        let t = TrustRegion::default();
        t.validate().unwrap();
        assert!(t.accepts(0.1) && !t.accepts(0.09) && !t.accepts(f64::NAN));
        assert_eq!(t.after_accepted(0.02, 0.02, 0.8), 0.04);
        assert_eq!(t.after_accepted(0.04, 0.04, 0.8), 0.05);
        assert_eq!(t.after_accepted(0.02, 0.01, 0.8), 0.02);
        assert_eq!(t.after_accepted(0.02, 0.02, 0.5), 0.02);
        assert_eq!(t.after_rejected(0.05), 0.025);
        assert!(t.collapsed(0.0019) && !t.collapsed(0.002));
    }

    #[test]
    fn bad_parameters_are_named() {
        let bad = |edit: fn(&mut TrustRegion)| {
            let mut t = TrustRegion::default();
            edit(&mut t);
            t.validate().unwrap_err().field
        };
        assert_eq!(bad(|t| t.shrink = 1.0), "shrink");
        assert_eq!(bad(|t| t.shrink = 0.0), "shrink");
        assert_eq!(bad(|t| t.initial_m = 0.2), "initial_m");
        assert_eq!(bad(|t| t.min_m = f64::NAN), "min_m");
        assert_eq!(bad(|t| t.grow = 0.9), "grow");
        assert_eq!(bad(|t| t.acceptance_ratio = 1.0), "acceptance_ratio");
        assert_eq!(bad(|t| t.grow_ratio = 0.05), "grow_ratio");
    }
}
