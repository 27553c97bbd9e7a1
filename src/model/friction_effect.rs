//! The joint-friction effect: one μ for every joint, or μ tabulated over
//! the interior angle, the seed's main finding (its rig gave μ ≈ 0.14 at
//! 117°, 0.10 at 146° and 0.05 at 170°: the less a cable turns over a
//! joint, the less it grips).
//!
//! One parameter, `mu`, is what calibration fits and diagnosis reports
//! (see [`super::effects::EffectKind::parameters`]). With a table it is
//! the table's level, the mean of its μ, and the table's *shape* (each
//! μ over that mean) is held: a fit scales the whole table and keeps how
//! μ falls with the angle, which a single log cannot resolve angle by
//! angle. Files give and get the table as absolute μ (the table given,
//! bit for bit, while its level is unchanged).

use serde::{Deserialize, Serialize};

use super::friction::{AngleConvention, FrictionCoefficient, JointFriction};

/// Capstan friction at every joint of every continuous cable (see
/// [`super::friction`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "JointFrictionDoc", into = "JointFrictionDoc")]
pub struct JointFrictionEffect {
    /// Friction coefficient μ, ≥ 0: at every joint, or with
    /// `angle_shape` the mean of the tabulated μ.
    pub mu: f64,
    /// Angle in the capstan exponent. Default: the wrap angle.
    pub convention: AngleConvention,
    /// How μ varies over the interior angle, scaled with `mu`; `None`:
    /// the same μ at every angle.
    pub angle_shape: Option<AngleShape>,
}

/// μ over the interior angle as given, and the level it was given at: at
/// level `mu` the table is `mu_as_given · mu / given_level` (exactly the
/// table given while the level is unchanged), interpolated linearly and
/// held beyond the first and last angles (as
/// [`FrictionCoefficient::Table`]).
#[derive(Debug, Clone, PartialEq)]
pub struct AngleShape {
    /// Interior angles θ, degrees, strictly increasing within [0, 180].
    pub interior_angle_deg: Vec<f64>,
    /// μ at each angle as given, ≥ 0.
    pub mu_as_given: Vec<f64>,
    /// The mean of `mu_as_given`: the level the table was given at.
    pub given_level: f64,
}

impl JointFrictionEffect {
    /// One μ at every joint.
    pub fn constant(mu: f64, convention: AngleConvention) -> Self {
        JointFrictionEffect {
            mu,
            convention,
            angle_shape: None,
        }
    }

    /// μ tabulated at `interior_angle_deg` (see [`AngleShape`]); the
    /// level is the table's mean. Errors name what is wrong with the table.
    pub fn tabulated(
        interior_angle_deg: Vec<f64>,
        mu: Vec<f64>,
        convention: AngleConvention,
    ) -> Result<Self, String> {
        check_table(&interior_angle_deg, &mu)?;
        let level = mu.iter().sum::<f64>() / mu.len() as f64;
        if !level.is_finite() {
            return Err("`mu_over_angle.mu`: their mean is not a finite number".into());
        }
        Ok(JointFrictionEffect {
            mu: level,
            convention,
            angle_shape: Some(AngleShape {
                interior_angle_deg,
                mu_as_given: mu,
                given_level: level,
            }),
        })
    }

    /// The same effect at level `mu` (the table, if any, scaled with it).
    pub fn with_level(&self, mu: f64) -> Self {
        JointFrictionEffect { mu, ..self.clone() }
    }

    /// μ at each tabulated angle at the effect's level (empty without a
    /// table). A table given as all zeros has no shape: at another level
    /// it is that level at every angle.
    pub fn tabulated_mu(&self) -> Vec<f64> {
        self.angle_shape.as_ref().map_or(Vec::new(), |s| {
            if s.given_level > 0.0 {
                let scale = self.mu / s.given_level;
                s.mu_as_given.iter().map(|m| m * scale).collect()
            } else {
                vec![self.mu; s.mu_as_given.len()]
            }
        })
    }

    /// The friction law of the joints: static and kinetic μ alike.
    pub fn law(&self) -> JointFriction {
        let coefficient = match &self.angle_shape {
            None => FrictionCoefficient::Constant(self.mu),
            Some(s) => FrictionCoefficient::Table {
                interior_angle_rad: s
                    .interior_angle_deg
                    .iter()
                    .map(|a| a.to_radians())
                    .collect(),
                mu: self.tabulated_mu(),
            },
        };
        JointFriction {
            static_mu: coefficient.clone(),
            kinetic_mu: coefficient,
            convention: self.convention,
        }
    }
}

/// Checks a μ table: at least one point, as many μ as angles, angles
/// finite, within [0, 180] and strictly increasing, μ finite and ≥ 0.
fn check_table(angles_deg: &[f64], mu: &[f64]) -> Result<(), String> {
    if angles_deg.is_empty() {
        return Err("`mu_over_angle.interior_angle_deg`: an empty table".into());
    }
    if angles_deg.len() != mu.len() {
        return Err(format!(
            "`mu_over_angle`: {} angles but {} values of mu",
            angles_deg.len(),
            mu.len()
        ));
    }
    for (i, &a) in angles_deg.iter().enumerate() {
        if !(0.0..=180.0).contains(&a) {
            return Err(format!(
                "`mu_over_angle.interior_angle_deg[{i}]`: {a} is outside 0–180"
            ));
        }
        if i > 0 && !(a > angles_deg[i - 1]) {
            return Err(format!(
                "`mu_over_angle.interior_angle_deg[{i}]`: {a} does not increase on {}",
                angles_deg[i - 1]
            ));
        }
    }
    for (i, &m) in mu.iter().enumerate() {
        if !(m >= 0.0 && m.is_finite()) {
            return Err(format!(
                "`mu_over_angle.mu[{i}]`: must be finite and ≥ 0, got {m}"
            ));
        }
    }
    Ok(())
}

/// The effect as files write it: `mu`, or `mu_over_angle` with absolute μ.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JointFrictionDoc {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    mu: Option<f64>,
    #[serde(default)]
    convention: AngleConvention,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    mu_over_angle: Option<MuOverAngleDoc>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MuOverAngleDoc {
    interior_angle_deg: Vec<f64>,
    mu: Vec<f64>,
}

impl TryFrom<JointFrictionDoc> for JointFrictionEffect {
    type Error = String;

    fn try_from(doc: JointFrictionDoc) -> Result<Self, String> {
        match (doc.mu, doc.mu_over_angle) {
            (Some(mu), None) => Ok(JointFrictionEffect::constant(mu, doc.convention)),
            (None, Some(t)) => {
                JointFrictionEffect::tabulated(t.interior_angle_deg, t.mu, doc.convention)
            }
            (Some(_), Some(_)) => {
                Err("give `mu` (one μ) or `mu_over_angle` (a table), not both".into())
            }
            (None, None) => Err("missing `mu` (or a `mu_over_angle` table)".into()),
        }
    }
}

impl From<JointFrictionEffect> for JointFrictionDoc {
    fn from(e: JointFrictionEffect) -> Self {
        let table = e.tabulated_mu();
        match e.angle_shape {
            None => JointFrictionDoc {
                mu: Some(e.mu),
                convention: e.convention,
                mu_over_angle: None,
            },
            Some(s) => JointFrictionDoc {
                mu: None,
                convention: e.convention,
                mu_over_angle: Some(MuOverAngleDoc {
                    interior_angle_deg: s.interior_angle_deg,
                    mu: table,
                }),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The seed's rig table.
    fn seed_table() -> JointFrictionEffect {
        JointFrictionEffect::tabulated(
            vec![117.0, 146.0, 170.0],
            vec![0.14, 0.10, 0.05],
            AngleConvention::Wrap,
        )
        .unwrap()
    }

    #[test]
    fn a_table_keeps_its_values_and_its_level_is_their_mean() {
        let e = seed_table();
        assert!((e.mu - 0.29 / 3.0).abs() < 1e-15);
        for (a, b) in e.tabulated_mu().iter().zip([0.14, 0.10, 0.05]) {
            assert!((a - b).abs() < 1e-15, "{a} vs {b}");
        }
        // The law interpolates the table over the interior angle.
        let law = e.law();
        let at = |deg: f64| law.static_mu.at(f64::to_radians(deg));
        assert!((at(117.0) - 0.14).abs() < 1e-12);
        assert!((at(131.5) - 0.12).abs() < 1e-12);
        assert!((at(180.0) - 0.05).abs() < 1e-12);
        assert!((at(90.0) - 0.14).abs() < 1e-12);
        assert_eq!(law.static_mu, law.kinetic_mu);
    }

    #[test]
    fn a_new_level_scales_the_table_and_keeps_its_shape() {
        let e = seed_table().with_level(0.2);
        let t = e.tabulated_mu();
        let mean = t.iter().sum::<f64>() / 3.0;
        assert!((mean - 0.2).abs() < 1e-15);
        assert!((t[0] / t[2] - 0.14 / 0.05).abs() < 1e-12);
    }

    #[test]
    fn files_round_trip_the_table_as_absolute_mu() {
        let e = seed_table();
        let text = toml::to_string(&e).unwrap();
        assert!(text.contains("mu_over_angle"), "{text}");
        let back: JointFrictionEffect = toml::from_str(&text).unwrap();
        // Bit for bit: the table given is the table written.
        assert_eq!(back, e);
        assert_eq!(back.tabulated_mu(), vec![0.14, 0.10, 0.05]);
        let json: JointFrictionEffect =
            serde_json::from_str(&serde_json::to_string(&e).unwrap()).unwrap();
        assert_eq!(json, e);
        let one: JointFrictionEffect = toml::from_str("mu = 0.2").unwrap();
        assert_eq!(
            one,
            JointFrictionEffect::constant(0.2, AngleConvention::Wrap)
        );
    }

    #[test]
    fn a_bad_table_is_refused_naming_the_entry() {
        let refuse = |text: &str, says: &str| {
            let e = toml::from_str::<JointFrictionEffect>(text).unwrap_err();
            assert!(e.to_string().contains(says), "{e}");
        };
        refuse(
            "mu = 0.1\nmu_over_angle = { interior_angle_deg = [90], mu = [0.1] }",
            "not both",
        );
        refuse("convention = \"wrap\"", "missing `mu`");
        refuse(
            "mu_over_angle = { interior_angle_deg = [90, 80], mu = [0.1, 0.2] }",
            "interior_angle_deg[1]",
        );
        refuse(
            "mu_over_angle = { interior_angle_deg = [90, 190], mu = [0.1, 0.2] }",
            "outside 0–180",
        );
        refuse(
            "mu_over_angle = { interior_angle_deg = [90], mu = [0.1, 0.2] }",
            "1 angles but 2",
        );
        refuse(
            "mu_over_angle = { interior_angle_deg = [90], mu = [-0.1] }",
            "mu[0]",
        );
        refuse(
            "mu_over_angle = { interior_angle_deg = [], mu = [] }",
            "empty",
        );
        refuse(
            "mu_over_angle = { interior_angle_deg = [90, 100], mu = [1e308, 1e308] }",
            "mean is not a finite number",
        );
        refuse("mu = 0.1\nangle = 3", "unknown field");
    }
}
