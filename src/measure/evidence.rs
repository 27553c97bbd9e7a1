//! Per-sensor evidence: is each sensor's residual, and each sensor group's,
//! consistent with its noise? The overall RMS dilutes a local failure (one
//! load cell 10 standard errors off among 35 sensors moves the overall RMS
//! by a few per cent); these tests do not.
//!
//! For each sensor with `n` readings of `z` (residual in noise SDs; pure
//! noise makes them independent standard normal draws):
//! - **mean**: `t = z̄·√n` is standard normal, two-sided p-value;
//! - **spread**: `Σ(z − z̄)²` is χ² with `n − 1` degrees of freedom,
//!   upper-tail p-value (a spread too large: a drift, spikes, a gain).
//!
//! A group is every sensor of one kind (load cells, positions along x, y
//! or z): its mean test pools all its readings, its spread test the
//! within-sensor deviations (`n − sensors` degrees of freedom).
//!
//! All p-values are one family, controlled by Holm's step-down method at
//! family-wise error [`NoiseSettings::family_alpha`] (default 1e-3): under
//! pure noise, the chance that
//! *any* test is significant is at most that, whatever the dependence
//! between the tests.

use serde::{Deserialize, Serialize};

use super::compare::Comparison;
use super::settings::NoiseSettings;
use super::tail_probability::{chi_squared_upper, normal_two_sided};
use crate::sim::{Axis, Sensor, SensorTarget};

/// A group of sensors of one kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorGroup {
    /// Load cells (segment tensions and member forces), N.
    LoadCells,
    /// Positions along x, m.
    PositionX,
    /// Positions along y, m.
    PositionY,
    /// Positions along z, m.
    PositionZ,
}

impl SensorGroup {
    /// The group of `sensor` (`None` for the thermometer, not compared).
    pub fn of(sensor: &Sensor) -> Option<SensorGroup> {
        match sensor.target {
            SensorTarget::SegmentTension { .. } | SensorTarget::MemberForce { .. } => {
                Some(SensorGroup::LoadCells)
            }
            SensorTarget::Position { axis: Axis::X, .. } => Some(SensorGroup::PositionX),
            SensorTarget::Position { axis: Axis::Y, .. } => Some(SensorGroup::PositionY),
            SensorTarget::Position { .. } => Some(SensorGroup::PositionZ),
            SensorTarget::Temperature => None,
        }
    }

    /// Name for tables and files.
    pub fn name(self) -> &'static str {
        match self {
            SensorGroup::LoadCells => "load_cells",
            SensorGroup::PositionX => "positions_x",
            SensorGroup::PositionY => "positions_y",
            SensorGroup::PositionZ => "positions_z",
        }
    }
}

/// What a test is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Subject {
    /// One sensor (index in the log's layout).
    Sensor(usize),
    /// A group of sensors.
    Group(SensorGroup),
}

/// Which statistic is tested.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Statistic {
    /// The mean of `z` against 0.
    Mean,
    /// The spread of `z` about its mean against 1.
    Spread,
}

/// One test of a residual against noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NoiseTest {
    /// What it is about.
    pub subject: Subject,
    /// What it tests.
    pub statistic: Statistic,
    /// Readings.
    pub count: usize,
    /// The statistic: for the mean, `z̄·√n` (standard errors from 0); for
    /// the spread, the SD of `z` about its mean (1 for noise).
    pub value: f64,
    /// p-value under pure noise.
    pub p_value: f64,
    /// Whether Holm's procedure rejects "pure noise" for it.
    pub significant: bool,
}

/// Every per-sensor and per-group test of a comparison.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Evidence {
    /// The tests, sensors in layout order then groups, mean before spread.
    pub tests: Vec<NoiseTest>,
    /// The family-wise error rate they are controlled at.
    pub family_alpha: f64,
}

impl Evidence {
    /// The test of `statistic` about `subject`, if it was made.
    pub fn test_of(&self, subject: Subject, statistic: Statistic) -> Option<&NoiseTest> {
        self.tests
            .iter()
            .find(|t| t.subject == subject && t.statistic == statistic)
    }

    /// The tests that reject pure noise.
    pub fn significant(&self) -> impl Iterator<Item = &NoiseTest> {
        self.tests.iter().filter(|t| t.significant)
    }

    /// Whether any test rejects pure noise.
    pub fn any_significant(&self) -> bool {
        self.significant().next().is_some()
    }

    /// The significant sensor test with the smallest p-value (the sensor
    /// the evidence points at most), if any.
    pub fn most_significant_sensor(&self) -> Option<&NoiseTest> {
        self.significant()
            .filter(|t| matches!(t.subject, Subject::Sensor(_)))
            .min_by(|a, b| a.p_value.total_cmp(&b.p_value))
    }
}

/// Mean and spread tests of one set of `z` (the spread about per-sensor
/// means, given as `(sum of squared deviations, sensors)`).
fn tests_of(subject: Subject, z: &[f64], deviations: (f64, usize)) -> [NoiseTest; 2] {
    let n = z.len();
    let mean = z.iter().sum::<f64>() / n.max(1) as f64;
    let t = mean * (n as f64).sqrt();
    let (ss, groups) = deviations;
    let dof = n.saturating_sub(groups);
    let test = |statistic, value, p_value| NoiseTest {
        subject,
        statistic,
        count: n,
        value,
        p_value,
        significant: false,
    };
    [
        test(Statistic::Mean, t, normal_two_sided(t)),
        test(
            Statistic::Spread,
            (ss / dof.max(1) as f64).sqrt(),
            if dof == 0 {
                1.0
            } else {
                chi_squared_upper(ss, dof)
            },
        ),
    ]
}

fn sum_of_squared_deviations(z: &[f64]) -> f64 {
    let mean = z.iter().sum::<f64>() / z.len().max(1) as f64;
    z.iter().map(|v| (v - mean).powi(2)).sum()
}

/// Holm's step-down procedure: sort the p-values, compare the `i`-th
/// smallest (from 0) with `alpha/(m − i)`, and reject until the first that
/// passes.
pub fn holm(p_values: &[f64], alpha: f64) -> Vec<bool> {
    let m = p_values.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p_values[a].total_cmp(&p_values[b]));
    let mut reject = vec![false; m];
    for (i, &j) in order.iter().enumerate() {
        if p_values[j] <= alpha / (m - i) as f64 {
            reject[j] = true;
        } else {
            break;
        }
    }
    reject
}

/// The per-sensor and per-group tests of comparison `c` of a log with
/// sensor layout `sensors`, at the family-wise error of `settings`.
pub fn evidence(c: &Comparison, sensors: &[Sensor], settings: &NoiseSettings) -> Evidence {
    let mut z_of: Vec<Vec<f64>> = vec![Vec::new(); sensors.len()];
    for r in &c.residuals {
        if let Some(v) = z_of.get_mut(r.sensor) {
            v.push(r.z);
        }
    }
    let mut tests = Vec::new();
    for (s, z) in z_of.iter().enumerate() {
        if !z.is_empty() {
            tests.extend(tests_of(
                Subject::Sensor(s),
                z,
                (sum_of_squared_deviations(z), 1),
            ));
        }
    }
    for group in [
        SensorGroup::LoadCells,
        SensorGroup::PositionX,
        SensorGroup::PositionY,
        SensorGroup::PositionZ,
    ] {
        let members: Vec<usize> = (0..sensors.len())
            .filter(|&s| SensorGroup::of(&sensors[s]) == Some(group) && !z_of[s].is_empty())
            .collect();
        // A group of one sensor is that sensor, already tested.
        if members.len() < 2 {
            continue;
        }
        let z: Vec<f64> = members.iter().flat_map(|&s| z_of[s].clone()).collect();
        let ss = members
            .iter()
            .map(|&s| sum_of_squared_deviations(&z_of[s]))
            .sum();
        tests.extend(tests_of(Subject::Group(group), &z, (ss, members.len())));
    }
    let p: Vec<f64> = tests.iter().map(|t| t.p_value).collect();
    for (t, reject) in tests.iter_mut().zip(holm(&p, settings.family_alpha)) {
        t.significant = reject;
    }
    Evidence {
        tests,
        family_alpha: settings.family_alpha,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::compare::{Direction, Residual, Stats};
    use crate::sim::StepFeatures;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn noise() -> NoiseSettings {
        NoiseSettings::default()
    }

    fn sensors() -> Vec<Sensor> {
        (0..6)
            .map(|i| Sensor {
                id: format!("s{i}"),
                target: if i < 3 {
                    SensorTarget::MemberForce { member: i }
                } else {
                    SensorTarget::Position {
                        node: i,
                        axis: Axis::Z,
                    }
                },
                noise_sd: 1.0,
            })
            .collect()
    }

    /// 40 readings per sensor of standard normal noise, plus `shift(s, k)`.
    fn comparison(seed: u64, shift: impl Fn(usize, usize) -> f64) -> Comparison {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let mut residuals = Vec::new();
        for k in 0..40 {
            for s in 0..6 {
                let z = normal.sample(&mut rng) + shift(s, k);
                residuals.push(Residual {
                    cycle: 0,
                    step: k,
                    step_index: k,
                    sensor: s,
                    measured: z,
                    predicted: 0.0,
                    residual: z,
                    z,
                    direction: Direction::Folding,
                    features: StepFeatures {
                        payout_m: 0.0,
                        command_m: 0.0,
                        joint_angle_rad: 0.0,
                        temperature_c: None,
                    },
                });
            }
        }
        Comparison {
            overall: Stats::of(residuals.iter().map(|r| r.z)),
            residuals,
            per_sensor: vec![],
            per_direction: vec![],
        }
    }

    #[test]
    fn holm_matches_a_hand_worked_case() {
        // m = 4, α = 0.05: thresholds 0.0125, 0.0167, 0.025, 0.05. The two
        // smallest pass theirs; 0.03 > 0.025 stops the procedure, so 0.04
        // is not rejected although it is below 0.05.
        let reject = holm(&[0.04, 0.01, 0.03, 0.005], 0.05);
        assert_eq!(reject, vec![false, true, false, true]);
    }

    #[test]
    fn pure_noise_is_rarely_significant() {
        // Family-wise error 1e-3: of 200 noise-only comparisons, the
        // expected number with any rejection is 0.2; 3 or more has
        // probability ~1e-3.
        let alarms = (0..200)
            .filter(|&seed| {
                evidence(&comparison(seed, |_, _| 0.0), &sensors(), &noise()).any_significant()
            })
            .count();
        assert!(alarms <= 2, "{alarms} of 200");
    }

    #[test]
    fn one_sensor_offset_by_six_standard_errors_is_found() {
        // Offset 6/√40 per reading: its mean is 6 standard errors from 0
        // (p ≈ 2e-9 ≪ 1e-3/16), while the overall RMS moves by only
        // √(1 + 0.9/6) − 1 ≈ 7 %.
        let shift = 6.0 / 40f64.sqrt();
        let e = evidence(
            &comparison(5, |s, _| if s == 4 { shift } else { 0.0 }),
            &sensors(),
            &noise(),
        );
        let worst = e.most_significant_sensor().unwrap();
        assert_eq!(worst.subject, Subject::Sensor(4));
        assert_eq!(worst.statistic, Statistic::Mean);
        assert!(e
            .significant()
            .all(|t| matches!(t.subject, Subject::Sensor(4) | Subject::Group(_))));
    }

    #[test]
    fn a_drifting_sensor_fails_its_spread_test() {
        // A ramp from −3 to +3 SDs over the log, zero mean: the mean test
        // cannot see it, the spread (√(1 + 3) ≈ 2 SDs) can.
        let e = evidence(
            &comparison(6, |s, k| {
                if s == 1 {
                    -3.0 + 6.0 * k as f64 / 39.0
                } else {
                    0.0
                }
            }),
            &sensors(),
            &noise(),
        );
        assert!(e.tests.iter().any(|t| t.subject == Subject::Sensor(1)
            && t.statistic == Statistic::Spread
            && t.significant));
    }
}
