//! A schedule run: a model with effects run through a logged or planned
//! schedule of deployment-fold cycles, its sensors read after every step
//! (what `lab`, `compare` and `diagnose` replay).
//!
//! The structure carries its history from cycle to cycle: the first cycle
//! starts at the as-built payout (where logs start), settled into the
//! model's own equilibrium there under its effects and at the first
//! logged temperature (a model with, say, heavier joints hangs lower than
//! the as-built geometry), so its first readings are fair; every later
//! cycle starts from where the previous one ended, as on the real bridge. A [`Plant`] steps it: before each step
//! the temperature of that step (if the schedule has one) sets the thermal
//! strain; commands go through the motor model (slip, backlash) and are
//! applied in increments; the cable-seat arcs are followed (see
//! [`crate::sim::plant`]).

use super::effect_model::{EffectModel, PlantError};
use super::plant::Plant;
use super::sensors::Sensor;
use crate::model::sliding::interior_angle;
use crate::model::{DeploymentState, Structure};

/// One cycle to run: commands per step, and the temperature at each step
/// (step 0 first), °C, where known.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleSchedule {
    /// Payout change per step and cable, m.
    pub commands: Vec<Vec<f64>>,
    /// Temperature per step including step 0 (`commands.len() + 1`
    /// entries), or empty when none was logged.
    pub temperature_c: Vec<Option<f64>>,
}

/// The sensor values of one run: per cycle, per step (step 0 first), per
/// sensor; `None` where the model gives no value (temperature unknown).
pub type Readings = Vec<Vec<Vec<Option<f64>>>>;

/// What the model state was at a step: the candidate explanatory features
/// a comparison plots residuals against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepFeatures {
    /// Mean motor payout over the cables since the as-built state, m.
    pub payout_m: f64,
    /// Sum of the step's commanded payout changes, m: positive folding,
    /// negative deploying, zero for step 0.
    pub command_m: f64,
    /// Mean interior angle of the continuous cables' joints, rad.
    pub joint_angle_rad: f64,
    /// Temperature, °C, where known.
    pub temperature_c: Option<f64>,
}

/// A run: sensor values and state features per cycle and step.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Sensor values.
    pub readings: Readings,
    /// Features, same indexing by cycle and step.
    pub features: Vec<Vec<StepFeatures>>,
}

impl EffectModel {
    /// Runs every cycle and returns what the sensors would read (noise-free;
    /// load-cell bias included).
    pub fn run(
        &self,
        cycles: &[CycleSchedule],
        sensors: &[Sensor],
    ) -> Result<Readings, PlantError> {
        Ok(self.run_with_features(cycles, sensors)?.readings)
    }

    /// [`Self::run`], with the state features of every step.
    ///
    /// A [`Plant`] steps through the schedule: built (and settled) at the
    /// first cycle's step-0 temperature, held at every later cycle's step 0,
    /// one command per later step.
    pub fn run_with_features(
        &self,
        cycles: &[CycleSchedule],
        sensors: &[Sensor],
    ) -> Result<Run, PlantError> {
        let temperature =
            |cycle: &CycleSchedule, step: usize| cycle.temperature_c.get(step).copied().flatten();
        let start_c = cycles.first().and_then(|c| temperature(c, 0));
        let mut plant = Plant::new(self, None, start_c)?;
        let mut out = Vec::with_capacity(cycles.len());
        let mut features = Vec::with_capacity(cycles.len());
        for (ci, cycle) in cycles.iter().enumerate() {
            let mut per_step = Vec::with_capacity(cycle.commands.len() + 1);
            let mut step_features = Vec::with_capacity(cycle.commands.len() + 1);
            for step in 0..=cycle.commands.len() {
                let temperature_c = temperature(cycle, step);
                let command_m = if step == 0 {
                    // The first cycle starts where the plant was built.
                    if ci > 0 {
                        plant.hold(temperature_c).map_err(|e| e.at(ci, step))?;
                    }
                    0.0
                } else {
                    let command = &cycle.commands[step - 1];
                    plant
                        .apply(command, temperature_c, &mut ())
                        .map_err(|e| e.at(ci, step))?;
                    command.iter().sum()
                };
                per_step.push(plant.read(sensors));
                let state = plant.state();
                step_features.push(StepFeatures {
                    payout_m: state.payout_m.iter().sum::<f64>()
                        / state.payout_m.len().max(1) as f64,
                    command_m,
                    joint_angle_rad: mean_joint_angle(plant.model().structure(), state),
                    temperature_c,
                });
            }
            out.push(per_step);
            features.push(step_features);
        }
        Ok(Run {
            readings: out,
            features,
        })
    }
}

/// Mean interior angle over all joints of all continuous cables, rad.
fn mean_joint_angle(structure: &Structure, state: &DeploymentState) -> f64 {
    let x = &state.positions_m;
    let (mut sum, mut n) = (0.0, 0usize);
    for c in &structure.continuous_cables {
        for w in c.path.windows(3) {
            let a = (x[w[1]] - x[w[0]]).normalize();
            let b = (x[w[2]] - x[w[1]]).normalize();
            sum += interior_angle(&a, &b);
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{EffectKind, Effects, RelaxSettings};
    use crate::sim::{Axis, SensorTarget};

    fn schedule(n: usize) -> Vec<CycleSchedule> {
        let out_in = |d: f64| {
            (0..4)
                .map(|k| vec![if k < 2 { d } else { -d }; n])
                .collect::<Vec<_>>()
        };
        vec![
            CycleSchedule {
                commands: out_in(0.01),
                temperature_c: vec![Some(20.0); 5],
            },
            CycleSchedule {
                commands: out_in(0.01),
                temperature_c: vec![Some(45.0); 5],
            },
        ]
    }

    fn sensors() -> Vec<Sensor> {
        vec![
            Sensor {
                id: "lc".into(),
                target: SensorTarget::SegmentTension {
                    cable: 0,
                    segment: 3,
                },
                noise_sd: 7.0,
            },
            Sensor {
                id: "z".into(),
                target: SensorTarget::Position {
                    node: 22,
                    axis: Axis::Z,
                },
                noise_sd: 0.001,
            },
            // Thermal growth shows along the span.
            Sensor {
                id: "x".into(),
                target: SensorTarget::Position {
                    node: 22,
                    axis: Axis::X,
                },
                noise_sd: 0.001,
            },
        ]
    }

    fn model(effects: Effects) -> EffectModel {
        EffectModel {
            structure: reference_bridge(&BridgeParameters::default()).unwrap(),
            effects,
            settings: RelaxSettings::default(),
            increment_m: 0.005,
        }
    }

    #[test]
    fn without_effects_a_closed_cycle_returns_to_its_start() {
        let m = model(Effects::default());
        let r = m.run(&schedule(10)[..1], &sensors()).unwrap();
        let (first, last) = (&r[0][0], &r[0][4]);
        assert!((first[0].unwrap() - last[0].unwrap()).abs() < 1e-3);
        assert!((first[1].unwrap() - last[1].unwrap()).abs() < 1e-7);
    }

    #[test]
    fn each_effect_changes_what_the_sensors_read() {
        let base = model(Effects::default())
            .run(&schedule(10), &sensors())
            .unwrap();
        for kind in EffectKind::ALL {
            let values: Vec<f64> = kind.parameters().iter().map(|p| p.plausible.1).collect();
            let m = model(Effects::default().with_parameters(kind, &values));
            let r = m.run(&schedule(10), &sensors()).unwrap();
            let mut biggest = 0.0f64;
            for (a, b) in base.iter().flatten().zip(r.iter().flatten()) {
                for (s, sensor) in sensors().iter().enumerate() {
                    let change = (a[s].unwrap() - b[s].unwrap()).abs();
                    biggest = biggest.max(change / sensor.noise_sd);
                }
            }
            // At the top of its plausible range (and a 25 K temperature
            // swing) every effect moves some sensor by more than its noise
            // somewhere in two cycles; thermal growth, the weakest, by more
            // than half of it (0.7 mm, see the next test).
            let least = if kind == EffectKind::Thermal {
                0.5
            } else {
                1.0
            };
            assert!(
                biggest > least,
                "{}: at most {biggest} noise SDs",
                kind.name()
            );
        }
    }

    #[test]
    fn warming_grows_each_half_out_from_its_abutment() {
        // Free thermal growth of a half held at its abutment ring moves a
        // midspan node along the span by α·ΔT·(its distance from the ring);
        // the ring's own restraint takes a few per cent off.
        let alpha = 1.2e-5;
        let m = model(Effects::default().with_parameters(EffectKind::Thermal, &[alpha]));
        let s = &m.structure;
        let nodes: Vec<usize> = s.midspan_pairs.iter().flatten().copied().collect();
        let sensors: Vec<Sensor> = nodes
            .iter()
            .map(|&node| Sensor {
                id: s.nodes[node].id.clone(),
                target: SensorTarget::Position {
                    node,
                    axis: Axis::X,
                },
                noise_sd: 0.001,
            })
            .collect();
        let at = |t: f64| CycleSchedule {
            commands: vec![],
            temperature_c: vec![Some(t)],
        };
        let r = m.run(&[at(20.0), at(45.0)], &sensors).unwrap();
        for (k, &node) in nodes.iter().enumerate() {
            let x = s.nodes[node].position_m.x;
            // The abutment of this node's half (ids start with the half).
            let half = &s.nodes[node].id[..1];
            let abutment = s
                .nodes
                .iter()
                .find(|n| n.fixed[0] && n.id.starts_with(half))
                .unwrap()
                .position_m
                .x;
            let want = alpha * 25.0 * (x - abutment);
            let got = r[1][0][k].unwrap() - r[0][0][k].unwrap();
            assert!(
                (got - want).abs() < 0.1 * want.abs(),
                "{}: {got} m vs {want} m",
                s.nodes[node].id
            );
        }
    }
}
