//! The synthetic lab: deployment-fold cycles run on a "truth" model with
//! any effects on, read by sensors with noise, as the seed's tests were.
//!
//! Standard layout ([`crate::sim::standard_sensors`]), after the seed's instrumentation:
//! in-line load cells on four continuous cables of half A in the segment
//! that ends at the midspan node (noise 7 N), the 3-D positions of all
//! midspan nodes (1 mm), and a temperature channel (0.1 °C). Standard
//! cycles ([`standard_cycles`]): for each amplitude (1, 5, 10 and 40 cm by
//! default), every cable paid out by the amplitude in equal steps and reeled
//! back in, while the temperature follows a slow daily swing.
//!
//! Noise is Gaussian, drawn from a seeded generator in a fixed order (cycle,
//! step, sensor), so the same seed gives the same log.

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::log::{Cycle, MeasurementLog};
use crate::sim::{CycleSchedule, EffectModel, PlantError, Sensor};

/// Temperature swing of the standard cycles, K: a day's swing outdoors.
pub const DAILY_SWING_K: f64 = 12.0;

/// Cycles of every cable paid out by each amplitude in `steps` equal steps
/// and reeled back in as many, for `cables` cables. The temperature swings
/// as `20 + swing_k·sin(2π·k/period)` °C over the global step index `k`,
/// with `period` four cycles long: a day's swing over a day's tests
/// ([`DAILY_SWING_K`] by default).
pub fn standard_cycles(
    cables: usize,
    amplitudes_m: &[f64],
    steps: usize,
    swing_k: f64,
) -> Vec<CycleSchedule> {
    let per_cycle = 2 * steps + 1;
    let period = (4 * per_cycle) as f64;
    let mut k = 0usize;
    amplitudes_m
        .iter()
        .map(|&a| {
            let d = a / steps as f64;
            let commands = (0..2 * steps)
                .map(|s| vec![if s < steps { d } else { -d }; cables])
                .collect();
            let temperature_c = (0..per_cycle)
                .map(|_| {
                    let t = 20.0 + swing_k * (2.0 * std::f64::consts::PI * k as f64 / period).sin();
                    k += 1;
                    Some(t)
                })
                .collect();
            CycleSchedule {
                commands,
                temperature_c,
            }
        })
        .collect()
}

/// Runs `cycles` on the truth and returns the log its sensors would write,
/// with Gaussian noise of each sensor's standard deviation drawn from
/// `seed`.
pub fn run_lab(
    truth: &EffectModel,
    sensors: &[Sensor],
    cycles: &[CycleSchedule],
    seed: u64,
) -> Result<MeasurementLog, PlantError> {
    let clean = truth.run(cycles, sensors)?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let noises: Vec<Normal<f64>> = sensors
        .iter()
        .map(|s| Normal::new(0.0, s.noise_sd).expect("noise SDs are validated non-negative"))
        .collect();
    let log_cycles = cycles
        .iter()
        .zip(&clean)
        .enumerate()
        .map(|(c, (schedule, readings))| Cycle {
            label: c as u64 + 1,
            step_labels: (1..=schedule.commands.len() as u64).collect(),
            commands: schedule.commands.clone(),
            readings: readings
                .iter()
                .map(|step| {
                    step.iter()
                        .zip(&noises)
                        .map(|(v, noise)| {
                            let e = noise.sample(&mut rng);
                            v.map(|v| v + e)
                        })
                        .collect()
                })
                .collect(),
        })
        .collect();
    Ok(MeasurementLog {
        structure: truth.structure.name.clone(),
        sensors: sensors.to_vec(),
        cycles: log_cycles,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{Effects, RelaxSettings};
    use crate::sim::{standard_sensors, SensorTarget};

    fn truth() -> EffectModel {
        EffectModel {
            structure: reference_bridge(&BridgeParameters::default()).unwrap(),
            effects: Effects::default(),
            settings: RelaxSettings::default(),
            increment_m: 0.01,
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_log_and_another_seed_another() {
        let t = truth();
        let sensors = standard_sensors(&t.structure);
        let cycles = standard_cycles(
            t.structure.continuous_cables.len(),
            &[0.01],
            2,
            DAILY_SWING_K,
        );
        let a = run_lab(&t, &sensors, &cycles, 7).unwrap();
        let b = run_lab(&t, &sensors, &cycles, 7).unwrap();
        let c = run_lab(&t, &sensors, &cycles, 8).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn noise_has_the_stated_spread() {
        // Residuals against the noise-free run, in units of each sensor's
        // SD: their RMS is 1 within sampling error, whose SD is 1/√(2n);
        // four of those is the tolerance.
        let t = truth();
        let sensors = standard_sensors(&t.structure);
        let cycles = standard_cycles(
            t.structure.continuous_cables.len(),
            &[0.01, 0.01],
            5,
            DAILY_SWING_K,
        );
        let clean = t.run(&cycles, &sensors).unwrap();
        let log = run_lab(&t, &sensors, &cycles, 3).unwrap();
        let mut sum = 0.0;
        let mut n = 0.0;
        for (c, cycle) in log.cycles.iter().enumerate() {
            for (k, step) in cycle.readings.iter().enumerate() {
                for (s, v) in step.iter().enumerate() {
                    if let SensorTarget::Position { .. } = sensors[s].target {
                        let e = (v.unwrap() - clean[c][k][s].unwrap()) / sensors[s].noise_sd;
                        sum += e * e;
                        n += 1.0;
                    }
                }
            }
        }
        let rms = (sum / n).sqrt();
        assert!(
            (rms - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
            "RMS {rms} of {n} draws"
        );
    }
}
