//! Model against a log: replay the logged commands (and temperatures)
//! through the model, and summarise the residuals `measured − predicted`.
//!
//! Residuals are also given in units of each sensor's noise SD (`z`), so
//! that sensors of different kinds compare: a model that explains the log
//! leaves `z` with RMS about 1 and mean about 0 everywhere.

use serde::{Deserialize, Serialize};

use crate::measure::log::MeasurementLog;
use crate::measure::settings::NoiseSettings;
use crate::sim::SensorTarget;

use crate::sim::{CycleSchedule, EffectModel, PlantError, Run, StepFeatures};

/// Which way the cables moved in a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Step 0 of a cycle: no command yet.
    Start,
    /// Cables paid out (net), the structure folding.
    Folding,
    /// Cables reeled in (net), the structure deploying.
    Deploying,
}

impl Direction {
    /// Lowercase name for files and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            Direction::Start => "start",
            Direction::Folding => "folding",
            Direction::Deploying => "deploying",
        }
    }

    fn of(command_m: f64, step: usize) -> Self {
        if step == 0 {
            Direction::Start
        } else if command_m > 0.0 {
            Direction::Folding
        } else {
            Direction::Deploying
        }
    }
}

/// One reading with its prediction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Residual {
    /// Cycle index in the log.
    pub cycle: usize,
    /// Step index within the cycle (0 = before the first command).
    pub step: usize,
    /// Steps since the log started, every cycle's step 0 counted: the
    /// log's clock (logs carry no time stamps).
    pub step_index: usize,
    /// Sensor index in the log's layout.
    pub sensor: usize,
    /// Measured value.
    pub measured: f64,
    /// Predicted value.
    pub predicted: f64,
    /// `measured − predicted`, in the sensor's unit.
    pub residual: f64,
    /// Residual over the sensor's noise SD.
    pub z: f64,
    /// Direction of the step.
    pub direction: Direction,
    /// Model state features at the step.
    #[serde(with = "StepFeaturesFields")]
    pub features: StepFeatures,
}

/// [`StepFeatures`]' fields for serde (the type lives in `sim`, which has
/// no serde of its own).
#[derive(Serialize, Deserialize)]
#[serde(remote = "StepFeatures")]
struct StepFeaturesFields {
    payout_m: f64,
    command_m: f64,
    joint_angle_rad: f64,
    temperature_c: Option<f64>,
}

/// Statistics of a set of residuals.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Stats {
    /// Readings.
    pub count: usize,
    /// Mean residual.
    pub mean: f64,
    /// Standard deviation.
    pub sd: f64,
    /// Root mean square.
    pub rms: f64,
    /// Largest magnitude.
    pub worst: f64,
}

impl Stats {
    /// Statistics of `values`.
    pub fn of(values: impl Iterator<Item = f64>) -> Stats {
        let v: Vec<f64> = values.collect();
        let count = v.len();
        if count == 0 {
            return Stats::default();
        }
        let n = count as f64;
        let mean = v.iter().sum::<f64>() / n;
        let rms = (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        let worst = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        Stats {
            count,
            mean,
            sd,
            rms,
            worst,
        }
    }
}

/// A comparison of a model with a log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Every reading with its prediction.
    pub residuals: Vec<Residual>,
    /// Per sensor (log layout order): statistics of the residual in its
    /// unit, and of `z`.
    pub per_sensor: Vec<(Stats, Stats)>,
    /// Statistics of `z` per direction (start, folding, deploying).
    pub per_direction: Vec<(Direction, Stats)>,
    /// Statistics of `z` over everything.
    pub overall: Stats,
}

/// The candidate explanatory features, by name, of a residual: the model
/// state, the prediction, and the log's clock (step index since the log
/// started, and cycle), so that a trend over the log is seen as one. What
/// a residual is correlated with, fixed by what a log holds: not a
/// setting.
pub const FEATURES: [&str; 7] = [
    "payout_m",
    "command_m",
    "joint_angle_deg",
    "temperature_c",
    "predicted",
    "step_index",
    "cycle",
];

impl Residual {
    /// Feature `i` of [`FEATURES`] at this reading (`None` if unknown).
    pub fn feature(&self, i: usize) -> Option<f64> {
        match i {
            0 => Some(self.features.payout_m),
            1 => Some(self.features.command_m),
            2 => Some(self.features.joint_angle_rad.to_degrees()),
            3 => self.features.temperature_c,
            4 => Some(self.predicted),
            5 => Some(self.step_index as f64),
            _ => Some(self.cycle as f64),
        }
    }
}

/// Pearson correlation of `pairs`; 0 when either side does not vary.
pub fn correlation(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len() as f64;
    if pairs.len() < 3 {
        return 0.0;
    }
    let (mx, my) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in pairs {
        sxy += (x - mx) * (y - my);
        sxx += (x - mx).powi(2);
        syy += (y - my).powi(2);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        0.0
    } else {
        sxy / (sxx * syy).sqrt()
    }
}

impl Comparison {
    /// Correlation of the residuals (`z`) of `sensor` with each feature of
    /// [`FEATURES`].
    pub fn feature_correlations(&self, sensor: usize) -> Vec<f64> {
        (0..FEATURES.len())
            .map(|f| {
                let pairs: Vec<(f64, f64)> = self
                    .residuals
                    .iter()
                    .filter(|r| r.sensor == sensor)
                    .filter_map(|r| r.feature(f).map(|x| (x, r.z)))
                    .collect();
                correlation(&pairs)
            })
            .collect()
    }

    /// The sensor with the largest RMS `z`, if any reading was compared.
    pub fn worst_sensor(&self) -> Option<usize> {
        (0..self.per_sensor.len())
            .filter(|&s| self.per_sensor[s].1.count > 0)
            .max_by(|&a, &b| {
                self.per_sensor[a]
                    .1
                    .rms
                    .total_cmp(&self.per_sensor[b].1.rms)
            })
    }
}

/// The largest RMS of `z` that `n` readings of pure sensor noise reach
/// but for a small chance: [`NoiseSettings::rms_limit_sds`] sampling SDs
/// above 1 (the RMS of `n` standard normal draws has SD ≈ 1/√(2n)); at
/// the default four, a one-in-30 000 chance.
pub fn noise_rms_limit(n: usize, settings: &NoiseSettings) -> f64 {
    1.0 + settings.rms_limit_sds / (2.0 * n.max(1) as f64).sqrt()
}

/// The log's cycles as a schedule for the model: its commands, and the
/// temperature its temperature sensor read (if it has one).
pub fn schedule_of(log: &MeasurementLog) -> Vec<CycleSchedule> {
    let thermometer = log
        .sensors
        .iter()
        .position(|s| s.target == SensorTarget::Temperature);
    log.cycles
        .iter()
        .map(|c| CycleSchedule {
            commands: c.commands.clone(),
            temperature_c: match thermometer {
                Some(t) => c.readings.iter().map(|r| r[t]).collect(),
                None => vec![],
            },
        })
        .collect()
}

/// Replays the log through the model and compares.
pub fn compare(model: &EffectModel, log: &MeasurementLog) -> Result<Comparison, PlantError> {
    let run = model.run_with_features(&schedule_of(log), &log.sensors)?;
    Ok(residuals_of(log, &run))
}

/// The comparison of a log with a model run made from it.
pub fn residuals_of(log: &MeasurementLog, run: &Run) -> Comparison {
    let mut residuals = Vec::new();
    let mut step_index = 0;
    for (c, cycle) in log.cycles.iter().enumerate() {
        for (k, readings) in cycle.readings.iter().enumerate() {
            step_index += 1;
            let features = run.features[c][k];
            let direction = Direction::of(features.command_m, k);
            for (s, sensor) in log.sensors.iter().enumerate() {
                // The thermometer drives the model; it is not compared.
                if sensor.target == SensorTarget::Temperature {
                    continue;
                }
                let (Some(measured), Some(predicted)) = (readings[s], run.readings[c][k][s]) else {
                    continue;
                };
                let residual = measured - predicted;
                residuals.push(Residual {
                    cycle: c,
                    step: k,
                    step_index: step_index - 1,
                    sensor: s,
                    measured,
                    predicted,
                    residual,
                    z: residual / sensor.noise_sd.max(f64::MIN_POSITIVE),
                    direction,
                    features,
                });
            }
        }
    }
    Comparison::of_residuals(residuals, log.sensors.len())
}

impl Comparison {
    /// The comparison made of `residuals` of a log with `sensors` sensors:
    /// statistics per sensor, per direction and overall.
    pub fn of_residuals(residuals: Vec<Residual>, sensors: usize) -> Comparison {
        let per_sensor = (0..sensors)
            .map(|s| {
                let mine = || residuals.iter().filter(move |r| r.sensor == s);
                (
                    Stats::of(mine().map(|r| r.residual)),
                    Stats::of(mine().map(|r| r.z)),
                )
            })
            .collect();
        let per_direction = [Direction::Start, Direction::Folding, Direction::Deploying]
            .into_iter()
            .map(|d| {
                (
                    d,
                    Stats::of(residuals.iter().filter(|r| r.direction == d).map(|r| r.z)),
                )
            })
            .collect();
        let overall = Stats::of(residuals.iter().map(|r| r.z));
        Comparison {
            residuals,
            per_sensor,
            per_direction,
            overall,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::measure::comparison_verdict::{verdict, where_it_fails, ComparisonVerdict};
    use crate::measure::evidence::{Evidence, Subject};
    use crate::measure::lab::{run_lab, standard_cycles, DAILY_SWING_K};
    use crate::model::{EffectKind, Effects, RelaxSettings};
    use crate::sim::standard_sensors;

    fn model(effects: Effects) -> EffectModel {
        EffectModel {
            structure: reference_bridge(&BridgeParameters::default()).unwrap(),
            effects,
            settings: RelaxSettings::default(),
            increment_m: 0.01,
        }
    }

    #[test]
    fn the_truth_leaves_only_noise_and_a_wrong_model_does_not() {
        let truth = model(Effects::default().with_parameters(EffectKind::JointFriction, &[0.15]));
        let sensors = standard_sensors(&truth.structure);
        let cycles = standard_cycles(
            truth.structure.continuous_cables.len(),
            &[0.05, 0.05],
            5,
            DAILY_SWING_K,
        );
        let log = run_lab(&truth, &sensors, &cycles, 11).unwrap();
        let right = compare(&truth, &log).unwrap();
        // z of pure noise: RMS 1 within sampling error 1/√(2n) (four SDs).
        let n = right.overall.count as f64;
        assert!(
            (right.overall.rms - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
            "RMS z {} over {n}",
            right.overall.rms
        );
        let wrong = compare(&model(Effects::default()), &log).unwrap();
        assert!(wrong.overall.rms > 2.0, "RMS z {}", wrong.overall.rms);
    }

    #[test]
    fn correlation_of_a_line_is_one() {
        let pairs: Vec<(f64, f64)> = (0..10).map(|i| (i as f64, 3.0 - 2.0 * i as f64)).collect();
        assert!((correlation(&pairs) + 1.0).abs() < 1e-12);
        assert_eq!(correlation(&[(1.0, 2.0), (1.0, 3.0), (1.0, 4.0)]), 0.0);
    }

    #[test]
    fn stats_match_hand_values() {
        let s = Stats::of([1.0, -1.0, 3.0].into_iter());
        assert_eq!(s.count, 3);
        assert!((s.mean - 1.0).abs() < 1e-15);
        assert!((s.rms - (11.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert!((s.sd - (8.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert_eq!(s.worst, 3.0);
    }

    /// A hand-made comparison: sensor 0 pure small noise, sensor 1 a
    /// residual proportional to the payout, larger while deploying.
    fn hand_made() -> Comparison {
        let mut residuals = Vec::new();
        for k in 0..20 {
            let payout_m = 0.001 * k as f64;
            let direction = if k < 10 {
                Direction::Folding
            } else {
                Direction::Deploying
            };
            for sensor in 0..2 {
                let z = if sensor == 0 {
                    if k % 2 == 0 {
                        0.5
                    } else {
                        -0.5
                    }
                } else {
                    1000.0 * payout_m
                };
                residuals.push(Residual {
                    cycle: 0,
                    step: k + 1,
                    // The clock scrambled: only the payout is linear in k.
                    step_index: (7 * k) % 20,
                    sensor,
                    measured: z,
                    predicted: 0.0,
                    residual: z,
                    z,
                    direction,
                    features: StepFeatures {
                        payout_m,
                        command_m: 0.0,
                        joint_angle_rad: 2.0,
                        temperature_c: None,
                    },
                });
            }
        }
        let per_sensor = (0..2)
            .map(|s| {
                let z = Stats::of(residuals.iter().filter(|r| r.sensor == s).map(|r| r.z));
                (z, z)
            })
            .collect();
        let per_direction = [Direction::Folding, Direction::Deploying]
            .into_iter()
            .map(|d| {
                (
                    d,
                    Stats::of(residuals.iter().filter(|r| r.direction == d).map(|r| r.z)),
                )
            })
            .collect();
        let overall = Stats::of(residuals.iter().map(|r| r.z));
        Comparison {
            residuals,
            per_sensor,
            per_direction,
            overall,
        }
    }

    #[test]
    fn where_it_fails_finds_the_sensor_direction_and_feature() {
        let c = hand_made();
        let w = where_it_fails(&c, &Evidence::default()).unwrap();
        assert_eq!(w.sensor, 1);
        // Sensor 1's z is 0, 1, …, 19: RMS √(Σk²/20), mean 9.5.
        let rms = ((0..20).map(|k| (k * k) as f64).sum::<f64>() / 20.0).sqrt();
        assert!((w.sensor_rms_z - rms).abs() < 1e-12);
        assert!((w.sensor_mean_z - 9.5).abs() < 1e-12);
        assert_eq!(w.direction, Some(Direction::Deploying));
        // z is an exact linear function of the payout: r = 1 (the other
        // features do not vary, so their correlation is 0).
        assert_eq!(w.feature.as_deref(), Some("payout_m"));
        assert!((w.correlation - 1.0).abs() < 1e-12);
        assert!(matches!(
            verdict(&c, &Evidence::default(), &NoiseSettings::default()),
            ComparisonVerdict::Fails(_)
        ));
        let empty = Comparison {
            residuals: vec![],
            per_sensor: vec![(Stats::default(), Stats::default())],
            per_direction: vec![],
            overall: Stats::default(),
        };
        assert_eq!(
            verdict(&empty, &Evidence::default(), &NoiseSettings::default()),
            ComparisonVerdict::NoReadings
        );
    }

    #[test]
    fn residuals_within_the_noise_limit_are_noise() {
        let mut c = hand_made();
        c.residuals.retain(|r| r.sensor == 0);
        c.per_sensor[1] = (Stats::default(), Stats::default());
        c.overall = Stats::of(c.residuals.iter().map(|r| r.z));
        // z = ±0.5: RMS 0.5, below the limit 1 + 4/√(2·20).
        assert_eq!(
            verdict(&c, &Evidence::default(), &NoiseSettings::default()),
            ComparisonVerdict::Noise {
                rms_z: 0.5,
                limit: noise_rms_limit(20, &NoiseSettings::default())
            }
        );
        // The same RMS with one sensor test rejecting noise is a failure.
        let mut e = Evidence::default();
        e.tests.push(crate::measure::evidence::NoiseTest {
            subject: Subject::Sensor(0),
            statistic: crate::measure::evidence::Statistic::Mean,
            count: 20,
            value: 6.0,
            p_value: 2e-9,
            significant: true,
        });
        assert!(
            matches!(verdict(&c, &e, &NoiseSettings::default()), ComparisonVerdict::Fails(w) if w.sensor == 0 && w.significant_tests == 1)
        );
    }

    #[test]
    fn a_comparison_round_trips_through_json() {
        let c = hand_made();
        let text = serde_json::to_string(&c).unwrap();
        let back: Comparison = serde_json::from_str(&text).unwrap();
        assert_eq!(back, c);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["residuals"][0]["direction"], "folding");
        assert_eq!(
            v["residuals"][0]["features"]["temperature_c"],
            serde_json::Value::Null
        );
    }
}
