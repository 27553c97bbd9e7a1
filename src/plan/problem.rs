//! The deployment problem: where the bridge starts, when it counts as
//! connected, and the limits no command may break.
//!
//! Defaults are for the reference bridge (`design::reference_bridge`) and
//! say where each value comes from. Every length is relative to the
//! designed (as-built) state: payout 0 is the designed cable length.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::numerics::{NumberRange, Ranged};

/// A value given once for every motor or once per motor (in the order of
/// the structure's continuous cables).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum PerMotor {
    /// The same value for every motor.
    All(f64),
    /// One value per motor.
    Each(Vec<f64>),
}

impl PerMotor {
    /// The value for motor `c`; `None` if a per-motor list is too short.
    pub fn get(&self, c: usize) -> Option<f64> {
        match self {
            PerMotor::All(v) => Some(*v),
            PerMotor::Each(v) => v.get(c).copied(),
        }
    }

    /// The values for `motors` motors; `None` if a per-motor list has the
    /// wrong length.
    pub fn expand(&self, motors: usize) -> Option<Vec<f64>> {
        match self {
            PerMotor::All(v) => Some(vec![*v; motors]),
            PerMotor::Each(v) if v.len() == motors => Some(v.clone()),
            PerMotor::Each(_) => None,
        }
    }

    fn values(&self) -> Vec<f64> {
        match self {
            PerMotor::All(v) => vec![*v],
            PerMotor::Each(v) => v.clone(),
        }
    }
}

/// What a deployment must achieve and must never do.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeploymentProblem {
    /// Payout of every motor from the designed state at the start, m
    /// (positive: paid out, the bridge folded). Default 0.40 m: the seed's
    /// largest actuation (its 40 cm deployment-fold cycles), which folds
    /// the reference halves about 71 mm each away from midspan.
    pub start_payout_m: PerMotor,
    /// Largest 3-D distance between the nodes of a midspan pair at the
    /// connection, m. Default 0.030: the 30 mm cone of the seed's
    /// cone-and-rod connector (±30 mm allowable discrepancy).
    pub connection_tolerance_m: f64,
    /// Smallest tension in any cable, spring or continuous-cable segment, N.
    /// Default 5 N: a 4 mm rope (0.64 N/m) over a 0.54 m segment sags
    /// wL²/8T ≈ 4.6 mm at 5 N, still taut against the 30 mm tolerance; the
    /// folded reference bridge's softest segments carry 9 N (μ = 0.2), so
    /// the start meets it. A member the start already holds below the
    /// limit may not go lower than its start value.
    pub min_tension_n: f64,
    /// Largest tension in any cable, spring or segment, N. Default 3000 N:
    /// a third of the ~9 kN breaking load of a 4 mm 7×19 steel rope (the
    /// designed state's largest is 1.3 kN, in a ring spring).
    pub max_tension_n: f64,
    /// Largest strut compression over its Euler load π²EI/L². Default 0.5:
    /// a factor two on the ideal load for the imperfections of real tubes
    /// (the designed state uses 0.13).
    pub max_strut_buckling_utilisation: f64,
    /// Smallest motor payout from the designed state, m. Default −0.10:
    /// the planner may reel in 10 cm past the design to make up for
    /// friction, no further.
    pub min_payout_m: PerMotor,
    /// Largest motor payout from the designed state, m. Default 0.50: the
    /// fold plus 10 cm.
    pub max_payout_m: PerMotor,
    /// Largest payout change of one motor in one command, m. Default 0.05:
    /// the seed's 5 cm actuation tests.
    pub max_step_m: PerMotor,
    /// Smallest centre-line distance between two struts that share no
    /// node, m (collision check of Sychterz & Smith 2018); 0 switches the
    /// check off. Default 0: the reference generator's geometry is
    /// schematic, its struts cross in the designed state (0 mm apart) and
    /// pass within 9 mm at the fold, so no physical clearance (28 mm
    /// tubes: at least 0.028) can hold on it. Structures with real strut
    /// offsets should set e.g. 0.040 (tube plus joint hardware).
    pub min_strut_clearance_m: f64,
}

impl DeploymentProblem {
    /// Every single-valued field with its admissible range.
    pub fn ranges(&self) -> [Ranged; 5] {
        [
            Ranged::real(
                "connection_tolerance_m",
                self.connection_tolerance_m,
                NumberRange::positive_up_to(1.0),
            ),
            Ranged::real(
                "min_tension_n",
                self.min_tension_n,
                NumberRange::at_least(0.0),
            ),
            Ranged::real("max_tension_n", self.max_tension_n, NumberRange::above(0.0)),
            Ranged::real(
                "max_strut_buckling_utilisation",
                self.max_strut_buckling_utilisation,
                NumberRange::positive_up_to(1.0),
            ),
            Ranged::real(
                "min_strut_clearance_m",
                self.min_strut_clearance_m,
                NumberRange::non_negative_up_to(1.0).excluding_max(),
            ),
        ]
    }

    /// Every per-motor field with the range of each of its values, m.
    pub fn per_motor_ranges(&self) -> [(&'static str, &PerMotor, NumberRange); 4] {
        let within_10_m = NumberRange::closed(-10.0, 10.0);
        [
            ("start_payout_m", &self.start_payout_m, within_10_m),
            ("min_payout_m", &self.min_payout_m, within_10_m),
            ("max_payout_m", &self.max_payout_m, within_10_m),
            (
                "max_step_m",
                &self.max_step_m,
                NumberRange::positive_up_to(10.0),
            ),
        ]
    }
}

impl Default for DeploymentProblem {
    fn default() -> Self {
        DeploymentProblem {
            start_payout_m: PerMotor::All(0.40),
            connection_tolerance_m: 0.030,
            min_tension_n: 5.0,
            max_tension_n: 3000.0,
            max_strut_buckling_utilisation: 0.5,
            min_payout_m: PerMotor::All(-0.10),
            max_payout_m: PerMotor::All(0.50),
            max_step_m: PerMotor::All(0.05),
            min_strut_clearance_m: 0.0,
        }
    }
}

/// A problem field outside its admissible range.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("problem field `{field}`: {reason}")]
pub struct ProblemError {
    /// The field, as named in [`DeploymentProblem`].
    pub field: &'static str,
    /// What is wrong.
    pub reason: String,
}

/// Per-motor limits of a problem for a structure with a given motor count.
#[derive(Debug, Clone, PartialEq)]
pub struct MotorLimits {
    /// Start payout per motor, m.
    pub start_payout_m: Vec<f64>,
    /// Smallest payout per motor, m.
    pub min_payout_m: Vec<f64>,
    /// Largest payout per motor, m.
    pub max_payout_m: Vec<f64>,
    /// Largest change per command per motor, m.
    pub max_step_m: Vec<f64>,
}

impl MotorLimits {
    /// The largest step limit of any motor, m (0 without motors).
    pub fn largest_step_m(&self) -> f64 {
        self.max_step_m.iter().copied().fold(0.0, f64::max)
    }
}

impl DeploymentProblem {
    /// Checks every field against its range and the maximum tension
    /// above the minimum (the start inside the stroke and the list lengths
    /// are checked against a structure in [`Self::motor_limits`]).
    pub fn validate(&self) -> Result<(), ProblemError> {
        for row in self.ranges() {
            row.check().map_err(|e| ProblemError {
                field: row.field(),
                reason: e.reason,
            })?;
        }
        if !(self.max_tension_n > self.min_tension_n) {
            return Err(ProblemError {
                field: "max_tension_n",
                reason: format!(
                    "must be above min_tension_n ({} N), got {}",
                    self.min_tension_n, self.max_tension_n
                ),
            });
        }
        for (field, values, range) in self.per_motor_ranges() {
            let v = values.values();
            if v.is_empty() {
                return Err(ProblemError {
                    field,
                    reason: "an empty list; give one value or one per motor".into(),
                });
            }
            for x in v {
                range
                    .check(x)
                    .map_err(|reason| ProblemError { field, reason })?;
            }
        }
        Ok(())
    }

    /// The per-motor limits for `motors` motors, checked against each
    /// other: minimum below maximum and the start inside the stroke.
    pub fn motor_limits(&self, motors: usize) -> Result<MotorLimits, ProblemError> {
        self.validate()?;
        let expand = |field: &'static str, v: &PerMotor| {
            v.expand(motors).ok_or_else(|| ProblemError {
                field,
                reason: format!("give one value or {motors} (one per motor)"),
            })
        };
        let limits = MotorLimits {
            start_payout_m: expand("start_payout_m", &self.start_payout_m)?,
            min_payout_m: expand("min_payout_m", &self.min_payout_m)?,
            max_payout_m: expand("max_payout_m", &self.max_payout_m)?,
            max_step_m: expand("max_step_m", &self.max_step_m)?,
        };
        for c in 0..motors {
            let (lo, hi, p) = (
                limits.min_payout_m[c],
                limits.max_payout_m[c],
                limits.start_payout_m[c],
            );
            if !(lo < hi) {
                return Err(ProblemError {
                    field: "min_payout_m",
                    reason: format!("motor {c}: minimum {lo} m is not below maximum {hi} m"),
                });
            }
            if !(lo <= p && p <= hi) {
                return Err(ProblemError {
                    field: "start_payout_m",
                    reason: format!("motor {c}: start {p} m is outside the stroke [{lo}, {hi}] m"),
                });
            }
        }
        Ok(limits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_start_inside_the_stroke() {
        let p = DeploymentProblem::default();
        p.validate().unwrap();
        let m = p.motor_limits(10).unwrap();
        assert_eq!(m.start_payout_m, vec![0.4; 10]);
    }

    #[test]
    fn rejects_a_start_outside_the_stroke_and_wrong_list_lengths() {
        let p = DeploymentProblem {
            max_payout_m: PerMotor::All(0.3),
            ..Default::default()
        };
        assert_eq!(p.motor_limits(10).unwrap_err().field, "start_payout_m");
        let p = DeploymentProblem {
            max_step_m: PerMotor::Each(vec![0.01; 3]),
            ..Default::default()
        };
        assert_eq!(p.motor_limits(10).unwrap_err().field, "max_step_m");
        let p = DeploymentProblem {
            connection_tolerance_m: f64::NAN,
            ..Default::default()
        };
        assert_eq!(p.validate().unwrap_err().field, "connection_tolerance_m");
    }
}
