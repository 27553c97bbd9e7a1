//! What a comparison says in the end: the residuals are sensor noise, or
//! where the model fails worst (the sensor, the direction of motion, the
//! feature the residual goes with), from the comparison and its
//! per-sensor evidence.

use serde::{Deserialize, Serialize};

use super::compare::{noise_rms_limit, Comparison, Direction, FEATURES};
use super::evidence::{Evidence, Subject};
use super::settings::NoiseSettings;

/// What a comparison says in the end: the residuals are sensor noise, or
/// where the model fails.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "verdict")]
pub enum ComparisonVerdict {
    /// No reading could be compared.
    NoReadings,
    /// The overall RMS of `z` is within [`noise_rms_limit`] *and* no
    /// per-sensor or per-group test rejects noise ([`Evidence`]).
    Noise {
        /// Overall RMS of `z`.
        rms_z: f64,
        /// The noise limit for this many readings.
        limit: f64,
    },
    /// The residuals are larger than noise, overall or at some sensor;
    /// where they are worst.
    Fails(WhereItFails),
}

/// Where a model fails worst: the sensor, the direction of motion and the
/// feature its residual goes with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WhereItFails {
    /// The sensor the per-sensor tests point at most (smallest p-value
    /// among the significant ones), else the one with the largest RMS `z`
    /// (index in the log's layout).
    pub sensor: usize,
    /// Its RMS `z`.
    pub sensor_rms_z: f64,
    /// Its mean `z`.
    pub sensor_mean_z: f64,
    /// Per-sensor and per-group tests that reject noise.
    pub significant_tests: usize,
    /// The direction with the largest RMS `z` over all sensors (`None`
    /// where no direction has readings).
    pub direction: Option<Direction>,
    /// That direction's RMS `z`.
    pub direction_rms_z: f64,
    /// The feature of [`FEATURES`] the sensor's `z` correlates with
    /// most, by name (`None` where no feature varies).
    pub feature: Option<String>,
    /// That Pearson correlation, −1 to 1.
    pub correlation: f64,
}

/// The comparison's verdict: noise when the overall RMS of `z` is within
/// [`noise_rms_limit`] (of `settings`) and no test of `evidence` (the
/// comparison's [`evidence`](super::evidence::evidence)) rejects noise,
/// else [`where_it_fails`].
pub fn verdict(c: &Comparison, evidence: &Evidence, settings: &NoiseSettings) -> ComparisonVerdict {
    let limit = noise_rms_limit(c.overall.count, settings);
    match where_it_fails(c, evidence) {
        None => ComparisonVerdict::NoReadings,
        Some(_) if c.overall.rms <= limit && !evidence.any_significant() => {
            ComparisonVerdict::Noise {
                rms_z: c.overall.rms,
                limit,
            }
        }
        Some(w) => ComparisonVerdict::Fails(w),
    }
}

/// Where the model fails worst (`None` if no reading was compared): the
/// sensor the per-sensor tests of `evidence` point at most (else the one
/// with the largest RMS `z`), the direction with the largest RMS `z`, and
/// the feature the sensor's residual correlates with most in magnitude.
pub fn where_it_fails(c: &Comparison, evidence: &Evidence) -> Option<WhereItFails> {
    let largest = c.worst_sensor()?;
    let worst = match evidence.most_significant_sensor().map(|t| t.subject) {
        Some(Subject::Sensor(s)) if s < c.per_sensor.len() => s,
        _ => largest,
    };
    let z = c.per_sensor[worst].1;
    let (direction, direction_rms_z) = c
        .per_direction
        .iter()
        .filter(|(_, s)| s.count > 0)
        .max_by(|a, b| a.1.rms.total_cmp(&b.1.rms))
        .map(|(d, s)| (Some(*d), s.rms))
        .unwrap_or((None, 0.0));
    let (feature, correlation) = c
        .feature_correlations(worst)
        .into_iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .filter(|(_, r)| *r != 0.0)
        .map(|(f, r)| (Some(FEATURES[f].to_string()), r))
        .unwrap_or((None, 0.0));
    Some(WhereItFails {
        sensor: worst,
        sensor_rms_z: z.rms,
        sensor_mean_z: z.mean,
        significant_tests: evidence.significant().count(),
        direction,
        direction_rms_z,
        feature,
        correlation,
    })
}
