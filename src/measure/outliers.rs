//! Outliers: single readings far from everything else their sensor read
//! (a spike from a loose connector, a bird on a target), counted and named
//! rather than taken for structure a model should explain.
//!
//! A reading is an outlier when its `z` lies more than
//! [`OutlierSettings::limit_robust_sds`] (default 6) robust SDs from the
//! median `z` of its sensor, the robust SD being
//! `1.4826·MAD` (the median absolute deviation, scaled to the SD of a
//! normal) and never below 1 (the noise). Against the median and MAD, a
//! model error that moves many readings of a sensor widens the scale and
//! is not flagged; a few spikes do not move either. A spike is also
//! *isolated*: the readings just before and after it on the log's clock
//! (the sensor's neighbours in step index) are ordinary, within half the
//! limit of the median. A model error that concentrates in a few readings
//! (the largest fold of a friction truth, where a sensor's `z` climbs to
//! 8–14 over four steps and stays at the next cycle's start) is not: its
//! readings have neighbours as far out as they are, and it stays in as
//! the structure the search must explain. (Without the rule, logs with no
//! spike at all lost 1–2 readings of the hidden effect's own signal.) Two
//! spikes in a row on one sensor are left in too. Half the limit is 3
//! robust SDs by default: an ordinary neighbour passes it 3 times in
//! 1000, so a lone spike is named as often as before the rule. Under pure noise a
//! reading passes 6 SDs once in 500 million: a log of 2000 readings shows
//! one once in 250 000 logs. Outliers are rare: a sensor with more than
//! [`OutlierSettings::max_share`] (default one in ten) of its readings
//! spikes has a fault (a loose connector), left in as structure to be
//! located; a clip or a jump leaves runs, which are no spikes and stay
//! in anyway (and are not counted, so that they hide no real spike).
//!
//! `diagnose` removes the outliers of the model's comparison (as missing
//! readings) before its search and lists them; `compare` lists them and
//! tests the sensors without them.

use serde::{Deserialize, Serialize};

use super::compare::Comparison;
use super::log::MeasurementLog;
use super::settings::OutlierSettings;

/// The SD of a standard normal over its median absolute deviation
/// (`1/Φ⁻¹(3/4)`): what makes the MAD a robust SD. A definition, not a
/// setting.
const MAD_TO_SD: f64 = 1.4826;

/// The robust SD is never below the noise (`z` is in noise SDs): a sensor
/// whose readings agree better than its noise has no outliers for being
/// precise. A definition, not a setting.
const NOISE_SD: f64 = 1.0;

/// One reading found to be an outlier.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Outlier {
    /// Cycle index in the log.
    pub cycle: usize,
    /// Step index within the cycle.
    pub step: usize,
    /// Sensor index in the log's layout.
    pub sensor: usize,
    /// Its residual in noise SDs.
    pub z: f64,
    /// Its distance from the sensor's median `z`, in robust SDs.
    pub robust_z: f64,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The outliers of comparison `c` of a log with `sensors` sensors, in the
/// comparison's order.
pub fn find_outliers(c: &Comparison, sensors: usize, settings: &OutlierSettings) -> Vec<Outlier> {
    let mut z_of: Vec<Vec<f64>> = vec![Vec::new(); sensors];
    for r in &c.residuals {
        if let Some(v) = z_of.get_mut(r.sensor) {
            v.push(r.z);
        }
    }
    let centre_scale: Vec<(f64, f64)> = z_of
        .iter_mut()
        .map(|z| {
            let m = median(z);
            let mut dev: Vec<f64> = z.iter().map(|v| (v - m).abs()).collect();
            (m, (MAD_TO_SD * median(&mut dev)).max(NOISE_SD))
        })
        .collect();
    // Each sensor's readings in the order of the log's clock.
    let mut by_clock: Vec<Vec<(usize, f64)>> = vec![Vec::new(); sensors];
    for r in &c.residuals {
        if let Some(v) = by_clock.get_mut(r.sensor) {
            v.push((r.step_index, r.z));
        }
    }
    for v in &mut by_clock {
        v.sort_by_key(|(k, _)| *k);
    }
    let isolated = |sensor: usize, step_index: usize| {
        let v = &by_clock[sensor];
        let (centre, scale) = centre_scale[sensor];
        let Ok(i) = v.binary_search_by_key(&step_index, |(k, _)| *k) else {
            return true;
        };
        let neighbours = [i.checked_sub(1), Some(i + 1)];
        neighbours
            .into_iter()
            .flatten()
            .filter_map(|j| v.get(j))
            .all(|(_, zn)| ((zn - centre) / scale).abs() <= 0.5 * settings.limit_robust_sds)
    };
    let found: Vec<Outlier> = c
        .residuals
        .iter()
        .filter_map(|r| {
            let (m, s) = *centre_scale.get(r.sensor)?;
            let robust_z = (r.z - m) / s;
            (robust_z.abs() > settings.limit_robust_sds).then_some(Outlier {
                cycle: r.cycle,
                step: r.step,
                sensor: r.sensor,
                z: r.z,
                robust_z,
            })
        })
        .collect();
    let spikes: Vec<Outlier> = found
        .into_iter()
        .filter(|o| {
            let step_index = c
                .residuals
                .iter()
                .find(|r| (r.cycle, r.step, r.sensor) == (o.cycle, o.step, o.sensor))
                .map_or(0, |r| r.step_index);
            isolated(o.sensor, step_index)
        })
        .collect();
    // Spikes are counted, not the runs a model error or a clip leaves:
    // those stay in anyway, and counted they would hide a real spike.
    let count = |s: usize| spikes.iter().filter(|o| o.sensor == s).count();
    let most = |s: usize| ((settings.max_share * z_of[s].len() as f64).floor() as usize).max(1);
    spikes
        .iter()
        .filter(|o| count(o.sensor) <= most(o.sensor))
        .copied()
        .collect()
}

/// `log` with the `outliers`' readings made missing.
pub fn without_outliers(log: &MeasurementLog, outliers: &[Outlier]) -> MeasurementLog {
    let mut out = log.clone();
    for o in outliers {
        if let Some(v) = out
            .cycles
            .get_mut(o.cycle)
            .and_then(|c| c.readings.get_mut(o.step))
            .and_then(|step| step.get_mut(o.sensor))
        {
            *v = None;
        }
    }
    out
}

/// `c` without the `outliers`' readings (statistics recomputed).
pub fn drop_outliers(c: &Comparison, outliers: &[Outlier], sensors: usize) -> Comparison {
    let residuals = c
        .residuals
        .iter()
        .filter(|r| {
            !outliers
                .iter()
                .any(|o| (o.cycle, o.step, o.sensor) == (r.cycle, r.step, r.sensor))
        })
        .copied()
        .collect();
    Comparison::of_residuals(residuals, sensors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::compare::{Direction, Residual};
    use crate::sim::StepFeatures;

    fn comparison(z: impl Fn(usize, usize) -> f64) -> Comparison {
        let mut residuals = Vec::new();
        for k in 0..40 {
            for s in 0..2 {
                let z = z(s, k);
                residuals.push(Residual {
                    cycle: k / 10,
                    step: k % 10,
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
        Comparison::of_residuals(residuals, 2)
    }

    /// A deterministic ±1 pattern: median 0, MAD 1.
    fn pm(k: usize) -> f64 {
        if k.is_multiple_of(2) {
            1.0
        } else {
            -1.0
        }
    }

    #[test]
    fn a_spike_is_an_outlier_and_a_model_error_is_not() {
        // Sensor 0: ±1 with one spike of 10 at k = 7 (robust SD 1.4826,
        // so 10 − 1 = 9 is 6.07 robust SDs out: just beyond the limit, a
        // spike of 9 is not). Sensor 1: a ramp from 0 to 39 (a model
        // error): the MAD grows with it, nothing is flagged.
        let c = comparison(|s, k| match (s, k) {
            (0, 7) => 10.0,
            (0, 21) => 9.0,
            (0, _) => pm(k),
            _ => k as f64,
        });
        let o = find_outliers(&c, 2, &OutlierSettings::default());
        assert_eq!(o.len(), 1, "{o:?}");
        assert_eq!((o[0].cycle, o[0].step, o[0].sensor), (0, 7, 0));
        assert!((o[0].robust_z - 9.0 / 1.4826).abs() < 1e-9);
        let dropped = drop_outliers(&c, &o, 2);
        assert_eq!(dropped.residuals.len(), c.residuals.len() - 1);
        assert_eq!(dropped.per_sensor[0].1.worst, 9.0);
        // Five spikes in 40 readings are more than one in ten: a fault of
        // the sensor, not outliers.
        let faulty = comparison(|s, k| match (s, k) {
            (0, 3 | 9 | 15 | 27 | 33) => 20.0,
            (0, _) => pm(k),
            _ => k as f64,
        });
        assert!(find_outliers(&faulty, 2, &OutlierSettings::default()).is_empty());
        let four = comparison(|s, k| match (s, k) {
            (0, 3 | 9 | 15 | 27) => 20.0,
            (0, _) => pm(k),
            _ => k as f64,
        });
        assert_eq!(
            find_outliers(&four, 2, &OutlierSettings::default()).len(),
            4
        );
    }

    /// Issue 24: logs without a single spike lost readings of the hidden
    /// effect's own signal as "outliers": on a friction truth a sensor's
    /// `z` climbs to 8–14 over the last steps of the largest fold and is
    /// still there at the next cycle's start, while most of its readings
    /// sit near 0. Three such readings in a row are no outliers; the same
    /// values apart, each among noise, are (the rule, not the scale,
    /// decides: each is 7–9 robust SDs out). A spike beside a 2-SD reading
    /// is still named; two spikes in a row are not.
    #[test]
    fn readings_that_follow_their_neighbours_are_no_outliers() {
        let noise = |k: usize| [0.0, 0.6, -0.6, 1.0, -1.0][k % 5];
        let settings = OutlierSettings::default();
        let plateau = comparison(|s, k| match (s, k) {
            (0, 20..=22) => [10.4, 12.9, 11.5][k - 20],
            _ => noise(k),
        });
        let o = find_outliers(&plateau, 2, &settings);
        assert!(o.is_empty(), "{o:?}");
        let apart = comparison(|s, k| match (s, k) {
            (0, 5) => 10.4,
            (0, 20) => 12.9,
            (0, 35) => 11.5,
            _ => noise(k),
        });
        let o = find_outliers(&apart, 2, &settings);
        assert_eq!(o.len(), 3, "{o:?}");
        assert!(o.iter().all(|o| o.robust_z > settings.limit_robust_sds));
        // Beside a reading 2 noise SDs out.
        let lone = comparison(|s, k| match (s, k) {
            (0, 28) => 2.0,
            (0, 29) => 14.1,
            _ => noise(k),
        });
        let o = find_outliers(&lone, 2, &settings);
        assert_eq!(o.len(), 1, "{o:?}");
        assert_eq!((o[0].cycle, o[0].step), (2, 9));
        // The first reading on the clock has one neighbour.
        let first = comparison(|s, k| match (s, k) {
            (0, 0) => 14.1,
            _ => noise(k),
        });
        assert_eq!(find_outliers(&first, 2, &settings).len(), 1);
        // Two in a row, of either sign, stay in.
        let pair = comparison(|s, k| match (s, k) {
            (0, 10) => 20.0,
            (0, 11) => -20.0,
            _ => noise(k),
        });
        assert!(find_outliers(&pair, 2, &settings).is_empty());
        // A run of four readings out (a model error) and one spike: the
        // run is not counted towards the sensor's share of outliers (at
        // most 4 of 40), so the spike is still named (review finding).
        let run_and_spike = comparison(|s, k| match (s, k) {
            (0, 10..=13) => 20.0,
            (0, 30) => 20.0,
            _ => noise(k),
        });
        let o = find_outliers(&run_and_spike, 2, &settings);
        assert_eq!(o.len(), 1, "{o:?}");
        assert_eq!((o[0].cycle, o[0].step), (3, 0));
    }
}
