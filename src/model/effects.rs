//! Physical effects beyond the baseline model: each one named,
//! parameterised and switchable, so that the same code can make "measured"
//! data with an effect on and be diagnosed with it off.
//!
//! An effect acts at one of six places:
//! - **the structure** (member stiffness error, joint mass error, support
//!   flexibility): a transformed [`Structure`]
//!   ([`Effects::apply_to_structure`]);
//! - **the cable path** (joint eccentricity): material held on the cable
//!   seats as the wrap angles change ([`Effects::forward_model_of`],
//!   [`crate::model::solver::seats`]);
//! - **the joints** (friction): the [`JointFriction`] of the model
//!   ([`Effects::joint_friction`]);
//! - **the motors** (drum slip, backlash): commanded payouts become actual
//!   ones through a stateful [`MotorModel`];
//! - **the temperature** (thermal length change): rest lengths of cables
//!   follow a logged temperature ([`Effects::thermal_strain`]);
//! - **the sensors** (load-cell bias): what a sensor reads
//!   ([`Effects::load_cell_reading_n`]).
//!
//! Beside the effects, [`Effects::faults`] holds the local faults of
//! [`super::faults`] (one drum zeroed off, one member off, one half
//! differing), which act on the structure too but are not effect kinds.
//!
//! Every effect is `None` when off. [`EffectKind`] lists them with their
//! parameters, units and plausible ranges ([`EffectKind::parameters`]);
//! [`Effects::with_parameters`] and [`Effects::parameters`] give the uniform
//! view a fitting routine needs.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::faults::Faults;
use super::flexible_supports::with_flexible_supports;
use super::friction::JointFriction;
pub use super::friction_effect::{AngleShape, JointFrictionEffect};
pub use super::parameter_spec::ParameterSpec;
use super::solver::{ForwardModel, RelaxSettings, SettingsError};
use super::structure::{Structure, StructureError};

/// The effects of the library, in a fixed order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// Capstan friction at the joints of continuous cables.
    JointFriction,
    /// Motor drum slip and backlash: actual payout differs from the command.
    Motor,
    /// Axial stiffness of struts, cables and springs off their nominal value.
    StiffnessError,
    /// Steel length change with temperature.
    Thermal,
    /// Joint masses off their nominal value.
    JointMassError,
    /// A constant offset in every load cell.
    LoadCellBias,
    /// Cable seats of finite size: the cable wraps an arc at each joint.
    JointEccentricity,
    /// Supports that give elastically under changing reactions.
    SupportFlexibility,
}

const FRICTION_PARAMETERS: [ParameterSpec; 1] = [ParameterSpec {
    name: "mu",
    unit: "1",
    neutral: 0.0,
    plausible: (0.02, 0.3),
    admissible: (0.0, f64::INFINITY),
}];
const MOTOR_PARAMETERS: [ParameterSpec; 2] = [
    ParameterSpec {
        name: "slip_fraction",
        unit: "1",
        neutral: 0.0,
        plausible: (-0.05, 0.05),
        admissible: (-1.0, 0.999),
    },
    ParameterSpec {
        name: "backlash_m",
        unit: "m",
        neutral: 0.0,
        plausible: (0.0, 0.005),
        admissible: (0.0, f64::INFINITY),
    },
];
const STIFFNESS_PARAMETERS: [ParameterSpec; 3] = [
    ParameterSpec {
        name: "strut_scale",
        unit: "1",
        neutral: 1.0,
        plausible: (0.8, 1.2),
        admissible: (1e-3, f64::INFINITY),
    },
    ParameterSpec {
        name: "cable_scale",
        unit: "1",
        neutral: 1.0,
        plausible: (0.6, 1.2),
        admissible: (1e-3, f64::INFINITY),
    },
    ParameterSpec {
        name: "spring_scale",
        unit: "1",
        neutral: 1.0,
        plausible: (0.8, 1.2),
        admissible: (1e-3, f64::INFINITY),
    },
];
const THERMAL_PARAMETERS: [ParameterSpec; 1] = [ParameterSpec {
    name: "expansion_per_k",
    unit: "1/K",
    neutral: 0.0,
    plausible: (1.0e-5, 1.4e-5),
    admissible: (f64::NEG_INFINITY, f64::INFINITY),
}];
const MASS_PARAMETERS: [ParameterSpec; 1] = [ParameterSpec {
    name: "scale",
    unit: "1",
    neutral: 1.0,
    plausible: (0.7, 1.5),
    admissible: (1e-3, f64::INFINITY),
}];
const BIAS_PARAMETERS: [ParameterSpec; 1] = [ParameterSpec {
    name: "bias_n",
    unit: "N",
    neutral: 0.0,
    plausible: (-50.0, 50.0),
    admissible: (f64::NEG_INFINITY, f64::INFINITY),
}];
const ECCENTRICITY_PARAMETERS: [ParameterSpec; 1] = [ParameterSpec {
    name: "seat_radius_m",
    unit: "m",
    neutral: 0.0,
    // The seed's seats sit on joints of 28 mm tubes: a seat a little wider
    // than the tube, radius 5 to 30 mm.
    plausible: (0.005, 0.03),
    admissible: (0.0, f64::INFINITY),
}];
const SUPPORT_PARAMETERS: [ParameterSpec; 1] = [ParameterSpec {
    name: "compliance_m_per_n",
    unit: "m/N",
    neutral: 0.0,
    // A bolted steel abutment frame of the 1/4-scale rig: 20 to 100 kN/m.
    plausible: (1.0e-5, 5.0e-5),
    admissible: (0.0, 1.0e-2),
}];

impl EffectKind {
    /// All effects, in order.
    pub const ALL: [EffectKind; 8] = [
        EffectKind::JointFriction,
        EffectKind::Motor,
        EffectKind::StiffnessError,
        EffectKind::Thermal,
        EffectKind::JointMassError,
        EffectKind::LoadCellBias,
        EffectKind::JointEccentricity,
        EffectKind::SupportFlexibility,
    ];

    /// Name, as in model files (`[effects.<name>]`).
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::JointFriction => "joint_friction",
            EffectKind::Motor => "motor",
            EffectKind::StiffnessError => "stiffness_error",
            EffectKind::Thermal => "thermal",
            EffectKind::JointMassError => "joint_mass_error",
            EffectKind::LoadCellBias => "load_cell_bias",
            EffectKind::JointEccentricity => "joint_eccentricity",
            EffectKind::SupportFlexibility => "support_flexibility",
        }
    }

    /// The effect's parameters.
    pub fn parameters(self) -> &'static [ParameterSpec] {
        match self {
            EffectKind::JointFriction => &FRICTION_PARAMETERS,
            EffectKind::Motor => &MOTOR_PARAMETERS,
            EffectKind::StiffnessError => &STIFFNESS_PARAMETERS,
            EffectKind::Thermal => &THERMAL_PARAMETERS,
            EffectKind::JointMassError => &MASS_PARAMETERS,
            EffectKind::LoadCellBias => &BIAS_PARAMETERS,
            EffectKind::JointEccentricity => &ECCENTRICITY_PARAMETERS,
            EffectKind::SupportFlexibility => &SUPPORT_PARAMETERS,
        }
    }
}

/// The motor drum does not pay out exactly what it is told. Slip: the drum
/// turns but the cable creeps, so the actual payout change is
/// `(1 − slip_fraction)·command`. Backlash: the gear train has play, so when
/// a cable's command reverses direction the first `backlash_m` of motion
/// only takes up the play.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorEffect {
    /// Fraction of every command lost to slip (negative: overshoot).
    #[serde(default)]
    pub slip_fraction: f64,
    /// Play taken up on each reversal of a cable's direction, m, ≥ 0.
    #[serde(default)]
    pub backlash_m: f64,
}

/// Axial stiffness off nominal, per member type: EA of struts, EA of
/// cables (discontinuous and continuous: the same 4 mm rope), k of
/// springs, each scaled. Braided rope's effective modulus in particular is
/// uncertain and load dependent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StiffnessErrorEffect {
    /// Scale on strut EA.
    #[serde(default = "one")]
    pub strut_scale: f64,
    /// Scale on cable EA (discontinuous and continuous).
    #[serde(default = "one")]
    pub cable_scale: f64,
    /// Scale on spring stiffness.
    #[serde(default = "one")]
    pub spring_scale: f64,
}

fn one() -> f64 {
    1.0
}

/// The bridge's steel follows the logged temperature `T`: the rest lengths
/// of every member (struts, cables, springs) and the continuous-cable
/// material are scaled by `1 + expansion_per_k·(T − reference_temperature_c)`.
/// The foundation does not: supports stay where they are (and support bars,
/// see [`super::flexible_supports`], keep their length).
///
/// A free pin-jointed frame would only grow similar to itself; held at its
/// abutment ring, each half grows out from the ring, so the midspan nodes
/// move apart by about `α·ΔT` times their distance from the abutment (0.3 mm
/// for 12 K on the reference bridge) and the members next to the abutment
/// take small forces. It is the weakest effect of the library: a log shows
/// it only over a wide temperature swing and many readings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalEffect {
    /// Linear expansion coefficient, 1/K. Steel: 1.2e-5.
    pub expansion_per_k: f64,
    /// Temperature at which the structure was built (rest lengths as
    /// designed), °C.
    pub reference_temperature_c: f64,
}

/// Joint bodies heavier or lighter than assumed: every node's lumped mass
/// scaled (so the self-weight and the prestress needed against it change).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointMassErrorEffect {
    /// Scale on node masses.
    pub scale: f64,
}

/// Every load cell reads the true tension plus a constant offset (zeroing
/// error).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadCellBiasEffect {
    /// Offset added to every tension reading, N.
    pub bias_n: f64,
}

/// The continuous cables run over cable seats of radius `seat_radius_m`
/// around the joint centres and wrap an arc of `seat_radius_m·φ` on each
/// (see [`super::cable_seats`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointEccentricityEffect {
    /// Radius of the cable's arc on a seat, m, ≥ 0.
    pub seat_radius_m: f64,
}

/// Every supported degree of freedom gives like a spring of compliance
/// `compliance_m_per_n` under changes of its reaction (see
/// [`super::flexible_supports`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupportFlexibilityEffect {
    /// Support compliance, m/N, ≥ 0 (0: rigid).
    pub compliance_m_per_n: f64,
}

/// The effects switched on, each with its parameters; `None` is off.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    /// Joint friction.
    pub joint_friction: Option<JointFrictionEffect>,
    /// Motor slip and backlash.
    pub motor: Option<MotorEffect>,
    /// Member stiffness error.
    pub stiffness_error: Option<StiffnessErrorEffect>,
    /// Thermal length change.
    pub thermal: Option<ThermalEffect>,
    /// Joint mass error.
    pub joint_mass_error: Option<JointMassErrorEffect>,
    /// Load-cell bias.
    pub load_cell_bias: Option<LoadCellBiasEffect>,
    /// Joint eccentricity (cable seats).
    pub joint_eccentricity: Option<JointEccentricityEffect>,
    /// Support flexibility.
    pub support_flexibility: Option<SupportFlexibilityEffect>,
    /// Local faults (one drum, one member, one half; see
    /// [`super::faults`]), applied with the structural effects. Not an
    /// effect kind: [`Self::enabled`], [`Self::parameters`] and
    /// [`Self::validate`] leave them alone, and model files write them as
    /// `[faults.*]` tables naming their parts by id, outside `[effects]`.
    #[serde(skip)]
    pub faults: Faults,
}

/// An effect parameter that makes no sense.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("effect `{effect}`, parameter `{parameter}`: {reason}")]
pub struct EffectError {
    /// The effect.
    pub effect: &'static str,
    /// The parameter.
    pub parameter: &'static str,
    /// What is wrong.
    pub reason: String,
}

impl Effects {
    /// Checks every parameter of the effects that are on against its
    /// admissible range ([`ParameterSpec::admissible`]).
    pub fn validate(&self) -> Result<(), EffectError> {
        for kind in EffectKind::ALL {
            let Some(values) = self.parameters(kind) else {
                continue;
            };
            for (spec, v) in kind.parameters().iter().zip(values) {
                let Some(reason) = spec.admissible_reason(v) else {
                    continue;
                };
                return Err(EffectError {
                    effect: kind.name(),
                    parameter: spec.name,
                    reason,
                });
            }
        }
        Ok(())
    }

    /// The parameter values of effect `kind`, in [`EffectKind::parameters`]
    /// order; `None` if it is off.
    pub fn parameters(&self, kind: EffectKind) -> Option<Vec<f64>> {
        match kind {
            EffectKind::JointFriction => self.joint_friction.as_ref().map(|f| vec![f.mu]),
            EffectKind::Motor => self.motor.map(|m| vec![m.slip_fraction, m.backlash_m]),
            EffectKind::StiffnessError => self
                .stiffness_error
                .map(|s| vec![s.strut_scale, s.cable_scale, s.spring_scale]),
            EffectKind::Thermal => self.thermal.map(|t| vec![t.expansion_per_k]),
            EffectKind::JointMassError => self.joint_mass_error.map(|m| vec![m.scale]),
            EffectKind::LoadCellBias => self.load_cell_bias.map(|b| vec![b.bias_n]),
            EffectKind::JointEccentricity => self.joint_eccentricity.map(|e| vec![e.seat_radius_m]),
            EffectKind::SupportFlexibility => {
                self.support_flexibility.map(|e| vec![e.compliance_m_per_n])
            }
        }
    }

    /// These effects with `kind` switched on at `values` (in
    /// [`EffectKind::parameters`] order; a thermal effect keeps its
    /// reference temperature, 20 °C if it was off).
    ///
    /// # Panics
    /// If `values` has the wrong length: a programming error.
    pub fn with_parameters(&self, kind: EffectKind, values: &[f64]) -> Effects {
        assert_eq!(values.len(), kind.parameters().len(), "{}", kind.name());
        let mut out = self.clone();
        match kind {
            EffectKind::JointFriction => {
                out.joint_friction = Some(match &self.joint_friction {
                    Some(f) => f.with_level(values[0]),
                    None => JointFrictionEffect::constant(values[0], Default::default()),
                })
            }
            EffectKind::Motor => {
                out.motor = Some(MotorEffect {
                    slip_fraction: values[0],
                    backlash_m: values[1],
                })
            }
            EffectKind::StiffnessError => {
                out.stiffness_error = Some(StiffnessErrorEffect {
                    strut_scale: values[0],
                    cable_scale: values[1],
                    spring_scale: values[2],
                })
            }
            EffectKind::Thermal => {
                out.thermal = Some(ThermalEffect {
                    expansion_per_k: values[0],
                    reference_temperature_c: self
                        .thermal
                        .map(|t| t.reference_temperature_c)
                        .unwrap_or(20.0),
                })
            }
            EffectKind::JointMassError => {
                out.joint_mass_error = Some(JointMassErrorEffect { scale: values[0] })
            }
            EffectKind::LoadCellBias => {
                out.load_cell_bias = Some(LoadCellBiasEffect { bias_n: values[0] })
            }
            EffectKind::JointEccentricity => {
                out.joint_eccentricity = Some(JointEccentricityEffect {
                    seat_radius_m: values[0],
                })
            }
            EffectKind::SupportFlexibility => {
                out.support_flexibility = Some(SupportFlexibilityEffect {
                    compliance_m_per_n: values[0],
                })
            }
        }
        out
    }

    /// The effects that are on.
    pub fn enabled(&self) -> Vec<EffectKind> {
        EffectKind::ALL
            .into_iter()
            .filter(|k| self.parameters(*k).is_some())
            .collect()
    }

    /// The structure with stiffness and mass errors, the local faults and
    /// support flexibility applied, in that order (a half difference
    /// scales on top of the bridge-wide errors; support bars are neither
    /// scaled nor weighed). Errors if `structure` itself is invalid for
    /// the transformation (a validated structure always passes without
    /// faults) or a fault does not fit it ([`Faults::apply`]).
    pub fn apply_to_structure(&self, structure: &Structure) -> Result<Structure, StructureError> {
        let mut s = structure.clone();
        if let Some(e) = self.stiffness_error {
            for m in &mut s.members {
                m.kind = m
                    .kind
                    .with_stiffness_scaled(e.strut_scale, e.cable_scale, e.spring_scale);
            }
            for c in &mut s.continuous_cables {
                c.ea_n *= e.cable_scale;
            }
        }
        if let Some(e) = self.joint_mass_error {
            for n in &mut s.nodes {
                n.mass_kg *= e.scale;
            }
        }
        let s = self.faults.apply(&s)?;
        match self.support_flexibility {
            // Last, so that the support bars are neither scaled nor weighed.
            Some(e) => with_flexible_supports(&s, e.compliance_m_per_n),
            None => Ok(s),
        }
    }

    /// The forward model of `structure` (these effects already applied to
    /// it, [`Self::apply_to_structure`]) with these effects' joint
    /// friction and cable seats, and solver `settings`.
    pub fn forward_model_of(
        &self,
        structure: Structure,
        settings: RelaxSettings,
    ) -> Result<ForwardModel, SettingsError> {
        let model = ForwardModel::new(structure, self.joint_friction(), settings)?;
        match self.joint_eccentricity {
            Some(e) => model.with_cable_seats(e.seat_radius_m),
            None => Ok(model),
        }
    }

    /// The structure at thermal strain `strain` (from
    /// [`Self::thermal_strain`]): rest lengths of the first
    /// `bridge_members` members (the bridge's own; members
    /// [`Self::apply_to_structure`] appended after them belong to the
    /// foundation) and of continuous-cable material scaled by `1 + strain`
    /// (see [`ThermalEffect`]).
    /// The material already in a deployment state's segments must be
    /// scaled by the same factor (relative to the last temperature).
    pub fn structure_at_strain(
        &self,
        structure: &Structure,
        strain: f64,
        bridge_members: usize,
    ) -> Structure {
        let mut s = structure.clone();
        if strain == 0.0 {
            return s;
        }
        for m in s.members.iter_mut().take(bridge_members) {
            m.rest_length_m *= 1.0 + strain;
        }
        for c in &mut s.continuous_cables {
            for r in &mut c.segment_rest_lengths_m {
                *r *= 1.0 + strain;
            }
        }
        s
    }

    /// Joint friction (frictionless when off).
    pub fn joint_friction(&self) -> JointFriction {
        self.joint_friction
            .as_ref()
            .map_or_else(JointFriction::frictionless, JointFrictionEffect::law)
    }

    /// Thermal strain of steel at `temperature_c` (0 when off or when no
    /// temperature is known).
    pub fn thermal_strain(&self, temperature_c: Option<f64>) -> f64 {
        match (self.thermal, temperature_c) {
            (Some(t), Some(temp)) => t.expansion_per_k * (temp - t.reference_temperature_c),
            _ => 0.0,
        }
    }

    /// What a load cell on a member of tension `tension_n` reads, N.
    pub fn load_cell_reading_n(&self, tension_n: f64) -> f64 {
        tension_n + self.load_cell_bias.map(|b| b.bias_n).unwrap_or(0.0)
    }

    /// A motor model for `cables` continuous cables with these effects.
    pub fn motor_model(&self, cables: usize) -> MotorModel {
        MotorModel {
            effect: self.motor.unwrap_or(MotorEffect {
                slip_fraction: 0.0,
                backlash_m: 0.0,
            }),
            last_direction: vec![0; cables],
            play_left_m: vec![0.0; cables],
        }
    }
}

/// Commanded payouts to actual ones, cable by cable, remembering each
/// cable's last direction for backlash. The first motion of a cable takes
/// up no play (the drum starts engaged).
#[derive(Debug, Clone, PartialEq)]
pub struct MotorModel {
    effect: MotorEffect,
    last_direction: Vec<i8>,
    play_left_m: Vec<f64>,
}

impl MotorModel {
    /// The payout changes the drums actually make for commanded changes
    /// `command_m` (one per cable), m.
    pub fn actual_payout(&mut self, command_m: &[f64]) -> Vec<f64> {
        command_m
            .iter()
            .enumerate()
            .map(|(c, &cmd)| {
                if cmd == 0.0 {
                    return 0.0;
                }
                let direction = if cmd > 0.0 { 1 } else { -1 };
                if self.last_direction[c] != 0 && direction != self.last_direction[c] {
                    self.play_left_m[c] = self.effect.backlash_m;
                }
                self.last_direction[c] = direction;
                let taken = self.play_left_m[c].min(cmd.abs());
                self.play_left_m[c] -= taken;
                let moved = cmd.abs() - taken;
                direction as f64 * moved * (1.0 - self.effect.slip_fraction)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::structure::MemberKind;

    #[test]
    fn every_effect_round_trips_through_its_parameter_vector() {
        for kind in EffectKind::ALL {
            let values: Vec<f64> = kind
                .parameters()
                .iter()
                .map(|p| 0.5 * (p.plausible.0 + p.plausible.1))
                .collect();
            let e = Effects::default().with_parameters(kind, &values);
            assert_eq!(e.parameters(kind), Some(values), "{}", kind.name());
            assert_eq!(e.enabled(), vec![kind]);
            e.validate().unwrap();
        }
    }

    #[test]
    fn neutral_parameters_leave_the_model_unchanged() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        for kind in EffectKind::ALL {
            let neutral: Vec<f64> = kind.parameters().iter().map(|p| p.neutral).collect();
            let e = Effects::default().with_parameters(kind, &neutral);
            assert_eq!(e.apply_to_structure(&s).unwrap(), s, "{}", kind.name());
            assert_eq!(e.thermal_strain(Some(35.0)), 0.0);
            assert_eq!(e.load_cell_reading_n(500.0), 500.0);
            assert_eq!(
                e.motor_model(2).actual_payout(&[0.01, -0.02]),
                vec![0.01, -0.02]
            );
            assert!(e.joint_friction().static_mu.is_zero());
            let model = e
                .forward_model_of(s.clone(), RelaxSettings::default())
                .unwrap();
            let arcs = model.reference_state().seat_material_m;
            assert!(arcs.iter().all(|v| *v == 0.0));
        }
    }

    #[test]
    fn stiffness_and_mass_errors_scale_what_they_name() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let e = Effects {
            stiffness_error: Some(StiffnessErrorEffect {
                strut_scale: 1.1,
                cable_scale: 0.8,
                spring_scale: 1.2,
            }),
            joint_mass_error: Some(JointMassErrorEffect { scale: 1.5 }),
            ..Effects::default()
        };
        let t = e.apply_to_structure(&s).unwrap();
        for (a, b) in s.members.iter().zip(&t.members) {
            let ratio = b.kind.axial_stiffness(1.0) / a.kind.axial_stiffness(1.0);
            let want = match a.kind {
                MemberKind::Strut { .. } => 1.1,
                MemberKind::Cable { .. } => 0.8,
                MemberKind::Spring { .. } => 1.2,
            };
            assert!((ratio - want).abs() < 1e-12);
        }
        assert!((t.continuous_cables[0].ea_n / s.continuous_cables[0].ea_n - 0.8).abs() < 1e-12);
        assert!((t.nodes[7].mass_kg / s.nodes[7].mass_kg - 1.5).abs() < 1e-12);
    }

    #[test]
    fn backlash_is_taken_up_on_each_reversal_and_slip_scales_the_rest() {
        let e = Effects {
            motor: Some(MotorEffect {
                slip_fraction: 0.1,
                backlash_m: 0.003,
            }),
            ..Effects::default()
        };
        let mut m = e.motor_model(1);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
        // First motion: drum engaged, only slip.
        assert!(close(m.actual_payout(&[0.01])[0], 0.009));
        assert!(close(m.actual_payout(&[0.01])[0], 0.009));
        // Reversal: 3 mm of play first, over two commands.
        assert!(close(m.actual_payout(&[-0.002])[0], 0.0));
        assert!(close(m.actual_payout(&[-0.002])[0], -0.001 * 0.9));
        assert!(close(m.actual_payout(&[-0.01])[0], -0.009));
        // And back again.
        assert!(close(m.actual_payout(&[0.005])[0], 0.002 * 0.9));
    }

    #[test]
    fn warming_lengthens_the_bridge_but_not_its_foundation() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let e = Effects::default()
            .with_parameters(EffectKind::Thermal, &[1.2e-5])
            .with_parameters(EffectKind::SupportFlexibility, &[2e-5]);
        let strain = e.thermal_strain(Some(30.0));
        assert!((strain - 1.2e-4).abs() < 1e-18);
        let flexible = e.apply_to_structure(&s).unwrap();
        let t = e.structure_at_strain(&flexible, strain, s.members.len());
        for (k, (a, b)) in flexible.members.iter().zip(&t.members).enumerate() {
            let ratio = b.rest_length_m / a.rest_length_m;
            let want = if k < s.members.len() {
                1.0 + strain
            } else {
                1.0
            };
            assert!((ratio - want).abs() < 1e-14, "{}", a.id);
        }
        for (a, b) in s.continuous_cables.iter().zip(&t.continuous_cables) {
            for (ra, rb) in a
                .segment_rest_lengths_m
                .iter()
                .zip(&b.segment_rest_lengths_m)
            {
                assert!((rb / ra - 1.0 - strain).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn bad_parameters_name_effect_and_parameter() {
        let e = Effects {
            motor: Some(MotorEffect {
                slip_fraction: 0.0,
                backlash_m: -0.001,
            }),
            ..Effects::default()
        };
        let msg = e.validate().unwrap_err().to_string();
        assert_eq!(
            msg,
            "effect `motor`, parameter `backlash_m`: must be ≥ 0, got -0.001"
        );
        let e = Effects::default().with_parameters(EffectKind::JointFriction, &[f64::NAN]);
        assert!(e.validate().unwrap_err().to_string().contains("`mu`"));
    }
}
