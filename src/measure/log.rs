//! A measurement log in memory: what was commanded and what the sensors
//! read, cycle by cycle and step by step. The file format is in
//! [`crate::io::log`].

use crate::sim::Sensor;

/// The commands of one step: a payout change per continuous cable, m.
pub type StepCommand = Vec<f64>;

/// One deployment-fold cycle: its steps' commands and readings.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    /// Cycle number as logged.
    pub label: u64,
    /// Step numbers as logged (step 0, the state before any command, has no
    /// command and is not listed).
    pub step_labels: Vec<u64>,
    /// Commands per step (same order as `step_labels`).
    pub commands: Vec<StepCommand>,
    /// Readings per step, step 0 first then `step_labels` order; one
    /// `Option` per sensor (layout order).
    pub readings: Vec<Vec<Option<f64>>>,
}

/// A whole log.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementLog {
    /// Name of the structure it was made on.
    pub structure: String,
    /// Sensor layout.
    pub sensors: Vec<Sensor>,
    /// Cycles in order.
    pub cycles: Vec<Cycle>,
}

/// Why a log cannot be compared with a model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LogProblem {
    /// A sensor's noise SD is zero, negative or not finite: its residuals
    /// could not be put in noise SDs.
    #[error("sensor \"{sensor}\": noise_sd {noise_sd:e} must be positive and finite")]
    BadNoise {
        /// The sensor's id.
        sensor: String,
        /// Its noise SD as given, in its unit.
        noise_sd: f64,
    },
    /// No reading of any compared sensor (all but the thermometer, which
    /// drives the model) in the whole log.
    #[error("no comparable reading in the log (every reading is missing, or only temperatures were read)")]
    NoComparableReading,
    /// A cycle without a single compared reading.
    #[error("cycle {cycle} has no comparable reading (every reading is missing, or only temperatures were read)")]
    CycleWithoutReadings {
        /// The cycle's label as logged.
        cycle: u64,
    },
}

impl MeasurementLog {
    /// Checks that the log can be compared with a model: every sensor's
    /// noise SD is positive and finite, and every cycle has at least one
    /// reading of a compared sensor (every sensor but the thermometer).
    pub fn check_comparable(&self) -> Result<(), LogProblem> {
        if let Some(s) = self
            .sensors
            .iter()
            .find(|s| !(s.noise_sd.is_finite() && s.noise_sd > 0.0))
        {
            return Err(LogProblem::BadNoise {
                sensor: s.id.clone(),
                noise_sd: s.noise_sd,
            });
        }
        let compared = |s: usize| self.sensors[s].target != crate::sim::SensorTarget::Temperature;
        let has_reading = |c: &Cycle| {
            c.readings.iter().any(|step| {
                step.iter()
                    .enumerate()
                    .any(|(s, v)| v.is_some() && compared(s))
            })
        };
        let empty: Vec<&Cycle> = self.cycles.iter().filter(|c| !has_reading(c)).collect();
        if empty.len() == self.cycles.len() {
            return Err(LogProblem::NoComparableReading);
        }
        match empty.first() {
            Some(c) => Err(LogProblem::CycleWithoutReadings { cycle: c.label }),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::SensorTarget;

    fn log() -> MeasurementLog {
        let sensor = |id: &str, target, noise_sd| Sensor {
            id: id.into(),
            target,
            noise_sd,
        };
        let cycle = |label, readings| Cycle {
            label,
            step_labels: vec![1],
            commands: vec![vec![0.01]],
            readings,
        };
        MeasurementLog {
            structure: "b".into(),
            sensors: vec![
                sensor("load", SensorTarget::MemberForce { member: 0 }, 7.0),
                sensor("temperature", SensorTarget::Temperature, 0.1),
            ],
            cycles: vec![
                cycle(1, vec![vec![Some(1.0), Some(20.0)], vec![None, None]]),
                cycle(2, vec![vec![None, None], vec![Some(2.0), None]]),
            ],
        }
    }

    #[test]
    fn a_log_with_readings_in_every_cycle_is_comparable() {
        assert_eq!(log().check_comparable(), Ok(()));
    }

    #[test]
    fn zero_or_infinite_noise_is_refused() {
        for bad in [0.0, -1.0, f64::INFINITY, f64::NAN] {
            let mut l = log();
            l.sensors[1].noise_sd = bad;
            assert!(
                matches!(l.check_comparable(), Err(LogProblem::BadNoise { ref sensor, .. }) if sensor == "temperature"),
                "{bad}"
            );
        }
    }

    #[test]
    fn a_cycle_or_a_log_without_compared_readings_is_refused() {
        let mut l = log();
        // Only the thermometer read in cycle 2: it drives the model and is
        // not compared.
        l.cycles[1].readings = vec![vec![None, Some(20.0)], vec![None, None]];
        assert_eq!(
            l.check_comparable(),
            Err(LogProblem::CycleWithoutReadings { cycle: 2 })
        );
        l.cycles[0].readings = vec![vec![None, None], vec![None, None]];
        assert_eq!(l.check_comparable(), Err(LogProblem::NoComparableReading));
    }
}
