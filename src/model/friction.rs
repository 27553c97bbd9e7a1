//! Joint friction of continuous cables: the capstan (segment-method) law.
//!
//! At an interior joint with neighbouring segment tensions `T_a`, `T_b`, the
//! interior angle `θ` between the two segments (π for a straight cable) and
//! the wrap angle `φ = π − θ`, the joint sticks while
//!
//! ```text
//!     e^(−μ·α) ≤ T_b / T_a ≤ e^(μ·α)
//! ```
//!
//! with `α = φ` (the physically consistent wrap angle, default) or `α = θ`
//! (the seed paper's Eq. 6 written with the interior angle). While sliding the
//! ratio sits on the bound. `μ` may depend on the interior angle.

use thiserror::Error;

/// Which angle multiplies μ in the capstan exponent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AngleConvention {
    /// `α = φ = π − θ`: the angle the cable turns through. Default.
    #[default]
    Wrap,
    /// `α = θ`: the interior angle, as the seed paper writes its Eq. 6.
    Interior,
}

impl AngleConvention {
    /// The capstan exponent angle α for an interior angle θ (rad).
    pub fn capstan_angle(self, interior_angle_rad: f64) -> f64 {
        match self {
            AngleConvention::Wrap => std::f64::consts::PI - interior_angle_rad,
            AngleConvention::Interior => interior_angle_rad,
        }
    }
}

/// Friction coefficient μ as a function of the interior angle.
#[derive(Debug, Clone, PartialEq)]
pub enum FrictionCoefficient {
    /// The same μ at every angle.
    Constant(f64),
    /// μ interpolated linearly over the interior angle θ (rad), held constant
    /// beyond the first and last points. Angles strictly increasing.
    Table {
        /// Interior angles θ, rad, strictly increasing.
        interior_angle_rad: Vec<f64>,
        /// μ at each angle, ≥ 0.
        mu: Vec<f64>,
    },
}

impl FrictionCoefficient {
    /// μ at interior angle θ (rad).
    pub fn at(&self, interior_angle_rad: f64) -> f64 {
        match self {
            FrictionCoefficient::Constant(mu) => *mu,
            FrictionCoefficient::Table {
                interior_angle_rad: angles,
                mu,
            } => {
                let last = angles.len() - 1;
                if interior_angle_rad <= angles[0] {
                    return mu[0];
                }
                if interior_angle_rad >= angles[last] {
                    return mu[last];
                }
                let k = angles.partition_point(|&a| a <= interior_angle_rad);
                let (a0, a1) = (angles[k - 1], angles[k]);
                let w = (interior_angle_rad - a0) / (a1 - a0);
                mu[k - 1] + w * (mu[k] - mu[k - 1])
            }
        }
    }

    /// `true` when μ is zero at every angle (the frictionless clustered cable).
    pub fn is_zero(&self) -> bool {
        match self {
            FrictionCoefficient::Constant(mu) => *mu == 0.0,
            FrictionCoefficient::Table { mu, .. } => mu.iter().all(|&m| m == 0.0),
        }
    }
}

/// A friction description that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FrictionError {
    /// μ negative or not finite.
    #[error("friction coefficient must be finite and ≥ 0, got {0}")]
    BadCoefficient(f64),
    /// Table malformed.
    #[error("friction table: {0}")]
    BadTable(String),
}

/// Friction at the joints of every continuous cable.
///
/// `static_mu` decides whether a sticking joint starts to slide;
/// `kinetic_mu` sets the bound the tension ratio sits on while it slides.
/// The seed found no significant difference, so [`JointFriction::new`] uses
/// one law for both.
#[derive(Debug, Clone, PartialEq)]
pub struct JointFriction {
    /// μ that must be overcome for a sticking joint to start sliding.
    pub static_mu: FrictionCoefficient,
    /// μ while sliding.
    pub kinetic_mu: FrictionCoefficient,
    /// Which angle enters the exponent.
    pub convention: AngleConvention,
}

impl Default for JointFriction {
    /// Frictionless joints: the classic clustered cable.
    fn default() -> Self {
        JointFriction::frictionless()
    }
}

impl JointFriction {
    /// Same μ for sticking and sliding, with a given convention.
    pub fn new(
        mu: FrictionCoefficient,
        convention: AngleConvention,
    ) -> Result<Self, FrictionError> {
        Self::with_kinetic(mu.clone(), mu, convention)
    }

    /// Separate static and kinetic μ.
    pub fn with_kinetic(
        static_mu: FrictionCoefficient,
        kinetic_mu: FrictionCoefficient,
        convention: AngleConvention,
    ) -> Result<Self, FrictionError> {
        for law in [&static_mu, &kinetic_mu] {
            validate(law)?;
        }
        Ok(JointFriction {
            static_mu,
            kinetic_mu,
            convention,
        })
    }

    /// Constant μ with the wrap-angle convention.
    pub fn constant(mu: f64) -> Result<Self, FrictionError> {
        Self::new(FrictionCoefficient::Constant(mu), AngleConvention::Wrap)
    }

    /// μ = 0 everywhere.
    pub fn frictionless() -> Self {
        JointFriction {
            static_mu: FrictionCoefficient::Constant(0.0),
            kinetic_mu: FrictionCoefficient::Constant(0.0),
            convention: AngleConvention::Wrap,
        }
    }

    /// `true` when both the static and the kinetic μ are zero everywhere:
    /// no joint ever sticks, and a state depends on the payout alone, not
    /// on the path to it.
    pub fn is_frictionless(&self) -> bool {
        self.static_mu.is_zero() && self.kinetic_mu.is_zero()
    }

    /// Largest admissible tension ratio `e^(μ·α)` at interior angle θ (rad).
    pub fn ratio_bound(&self, interior_angle_rad: f64, sliding: bool) -> f64 {
        let law = if sliding {
            &self.kinetic_mu
        } else {
            &self.static_mu
        };
        let mu = law.at(interior_angle_rad);
        if mu == 0.0 {
            return 1.0;
        }
        (mu * self.convention.capstan_angle(interior_angle_rad).max(0.0)).exp()
    }
}

impl JointFriction {
    /// A floor of [`Self::ratio_bound`] at the interior angle whose cosine
    /// is `cos_interior` (clamped to [−1, 1]), cheap to compute (no `acos`,
    /// no `exp`): `1 + μ_min·α_chord`, with `μ_min` the smallest μ of the
    /// law (a table's interpolation stays within its values),
    /// `α_chord = √(2(1 − cos α)) ≤ α` (the chord of an arc is shorter than
    /// the arc) and `1 + x ≤ eˣ`, shrunk by 1e-12 relative to cover the
    /// rounding of the bound's own evaluation.
    pub fn ratio_bound_floor(&self, cos_interior: f64, sliding: bool) -> f64 {
        let law = if sliding {
            &self.kinetic_mu
        } else {
            &self.static_mu
        };
        let mu_min = match law {
            FrictionCoefficient::Constant(mu) => *mu,
            FrictionCoefficient::Table { mu, .. } => {
                mu.iter().copied().fold(f64::INFINITY, f64::min)
            }
        };
        let c = cos_interior.clamp(-1.0, 1.0);
        // cos α for α = π − θ is −cos θ; for α = θ it is cos θ.
        let cos_alpha = match self.convention {
            AngleConvention::Wrap => -c,
            AngleConvention::Interior => c,
        };
        let chord = (2.0 * (1.0 - cos_alpha)).max(0.0).sqrt();
        (1.0 + mu_min * chord) * (1.0 - 1e-12)
    }
}

fn validate(law: &FrictionCoefficient) -> Result<(), FrictionError> {
    match law {
        FrictionCoefficient::Constant(mu) => {
            if !(mu.is_finite() && *mu >= 0.0) {
                return Err(FrictionError::BadCoefficient(*mu));
            }
        }
        FrictionCoefficient::Table {
            interior_angle_rad,
            mu,
        } => {
            if interior_angle_rad.is_empty() || interior_angle_rad.len() != mu.len() {
                return Err(FrictionError::BadTable(format!(
                    "{} angles and {} coefficients; need the same non-zero number",
                    interior_angle_rad.len(),
                    mu.len()
                )));
            }
            if interior_angle_rad.windows(2).any(|w| !(w[1] > w[0])) {
                return Err(FrictionError::BadTable(
                    "angles must be strictly increasing".into(),
                ));
            }
            if let Some(bad) = interior_angle_rad.iter().find(|a| !a.is_finite()) {
                return Err(FrictionError::BadTable(format!(
                    "angle {bad} is not finite"
                )));
            }
            for &m in mu {
                if !(m.is_finite() && m >= 0.0) {
                    return Err(FrictionError::BadCoefficient(m));
                }
            }
        }
    }
    Ok(())
}

/// The friction coefficient that the seed's segment method back-calculates
/// from a measured slip: `μ = ln(T_high/T_low) / α`.
pub fn back_calculated_mu(tension_ratio: f64, capstan_angle_rad: f64) -> f64 {
    tension_ratio.ln() / capstan_angle_rad
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn frictionless_bound_is_one() {
        assert_eq!(JointFriction::frictionless().ratio_bound(2.0, false), 1.0);
    }

    #[test]
    fn wrap_convention_uses_pi_minus_theta() {
        let f = JointFriction::constant(0.3).unwrap();
        let theta = 146f64.to_radians();
        assert!((f.ratio_bound(theta, false) - (0.3 * (PI - theta)).exp()).abs() < 1e-15);
    }

    #[test]
    fn interior_convention_uses_theta() {
        let f = JointFriction::new(
            FrictionCoefficient::Constant(0.1),
            AngleConvention::Interior,
        )
        .unwrap();
        let theta = 117f64.to_radians();
        assert!((f.ratio_bound(theta, false) - (0.1 * theta).exp()).abs() < 1e-15);
    }

    #[test]
    fn table_interpolates_linearly_and_clamps() {
        let t = FrictionCoefficient::Table {
            interior_angle_rad: vec![1.0, 2.0, 3.0],
            mu: vec![0.3, 0.2, 0.1],
        };
        assert!((t.at(1.5) - 0.25).abs() < 1e-15);
        assert!((t.at(2.75) - 0.125).abs() < 1e-15);
        assert_eq!(t.at(0.0), 0.3);
        assert_eq!(t.at(9.0), 0.1);
        assert_eq!(t.at(2.0), 0.2);
    }

    #[test]
    fn rejects_negative_mu_and_unsorted_table() {
        assert!(JointFriction::constant(-0.1).is_err());
        let t = FrictionCoefficient::Table {
            interior_angle_rad: vec![2.0, 1.0],
            mu: vec![0.1, 0.1],
        };
        assert!(JointFriction::new(t, AngleConvention::Wrap).is_err());
    }

    proptest::proptest! {
        /// The cheap floor never exceeds the bound it stands in for, for
        /// either convention, constant or tabulated μ, sticking or sliding,
        /// and is within second order of it for small μ·α.
        #[test]
        fn bound_floor_is_below_the_bound(
            theta in 0.0f64..=PI,
            mu in 0.0f64..1.0,
            table_mu in proptest::collection::vec(0.0f64..1.0, 3),
            interior in proptest::bool::ANY,
            sliding in proptest::bool::ANY,
        ) {
            let convention = if interior { AngleConvention::Interior } else { AngleConvention::Wrap };
            let table = FrictionCoefficient::Table {
                interior_angle_rad: vec![0.5, 1.5, 2.5],
                mu: table_mu,
            };
            for law in [FrictionCoefficient::Constant(mu), table] {
                let f = JointFriction::with_kinetic(law.clone(), FrictionCoefficient::Constant(0.5 * mu), convention).unwrap();
                // The cosine as the mapping computes it, from unit vectors.
                let cos = theta.cos();
                let bound = f.ratio_bound(cos.clamp(-1.0, 1.0).acos(), sliding);
                let floor = f.ratio_bound_floor(cos, sliding);
                proptest::prop_assert!(floor <= bound, "{floor} > {bound}");
            }
            // With constant μ it is close, so that it decides most joints:
            // eˣ − 1 − x ≤ x²·eˣ/2 (x = μα) and α − chord ≤ α³/24.
            let f = JointFriction::new(FrictionCoefficient::Constant(mu), convention).unwrap();
            let bound = f.ratio_bound(theta.cos().clamp(-1.0, 1.0).acos(), sliding);
            let alpha = convention.capstan_angle(theta);
            let x = mu * alpha;
            let gap = bound - f.ratio_bound_floor(theta.cos(), sliding);
            proptest::prop_assert!(gap <= 0.5 * x * x * bound + mu * alpha.powi(3) / 24.0 + 1e-11, "gap {gap}");
        }
    }

    #[test]
    fn back_calculation_inverts_the_bound() {
        let alpha = 0.7;
        let ratio = (0.25f64 * alpha).exp();
        assert!((back_calculated_mu(ratio, alpha) - 0.25).abs() < 1e-14);
    }
}
