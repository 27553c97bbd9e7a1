//! How much material each continuous cable really holds: an estimate of
//! each motor's drum zero error from the readings at the folded start.
//!
//! A drum zeroed `δ` off (the fault `drum_zero_error`) leaves its cable
//! holding `δ` more material than the drum's payout says, from the start
//! and for good. To the bridge that is a payout the drum does not know
//! of: at the folded start every reading responds to it as to a payout
//! of that motor, `∂y/∂δ_c = ∂y/∂p_c`, the response the planner computes
//! anyway ([`PayoutResponse::tangent`]). A 15 mm error on `A_cc1` slackens
//! that whole cable in the bridge while the model holds it at 15 N; the
//! controller, planning on the model, then reels the other cables in and
//! breaks the slack cable's limits.
//!
//! The estimate is the linear-Gaussian (Gauss–Newton, one step) posterior
//! of the offsets `δ` and, with the load cells, their common bias `β`
//! (the effect `load_cell_bias`), from the start readings `y` against the
//! model's predictions `h` at the folded start:
//!
//! ```text
//!     y − h = J·δ + β·l + e,   δ ~ N(0, σ_δ²·I),  β ~ N(0, σ_β²),
//!     e_i ~ N(0, σ_i² + m_i²)
//! ```
//!
//! with `J` the pay-out response of each reading to each motor, `l` 1 on
//! the load cells, `σ_i` the sensor noise and `m_i` the model's error the
//! offsets do not explain: on a force the force filter's `fraction·|F| +
//! 1 N` ([`super::ForceOffsetFilter`]); on a position the readings' own
//! excess spread, `m² = max(0, mean(z²) − mean(σ²))` over the position
//! residuals `z` (an empirical-Bayes level; it also holds what the offsets
//! explain, so it errs towards trusting the positions less). The posterior
//! mean and covariance are
//!
//! ```text
//!     Σ = (JᵀR⁻¹J + Σ₀⁻¹)⁻¹,    x̂ = Σ·JᵀR⁻¹(y − h).
//! ```
//!
//! What the readings cannot tell apart (a motor whose cable no sensor
//! sees) keeps its prior: its estimate stays near 0 with standard
//! deviation near `σ_δ`. The model state is then moved to hold the
//! estimated material ([`apply_drum_offsets`]); the drums' own payouts
//! stay what they read.

use nalgebra::{DMatrix, DVector};

use super::force_offset_filter::FORCE_MODEL_ERROR_FLOOR_N;
use crate::model::{CommandError, DeploymentState, ForwardModel, Workspace};
use crate::plan::limits::force_rows;
use crate::plan::response::PayoutResponse;
use crate::sim::{Sensor, SensorTarget};

/// What the estimator knows before the readings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrumOffsetPrior {
    /// Prior standard deviation of each motor's offset, m.
    pub offset_sd_m: f64,
    /// Prior standard deviation of the load cells' common bias, N (`None`:
    /// no bias).
    pub load_cell_bias_sd_n: Option<f64>,
    /// Model-error fraction of a predicted force (the force filter's), 1.
    pub force_error_fraction: f64,
}

/// The estimated drum offsets.
#[derive(Debug, Clone, PartialEq)]
pub struct DrumOffsetEstimate {
    /// Per motor, the material its cable holds beyond what its drum says,
    /// m (posterior mean).
    pub offset_m: Vec<f64>,
    /// Per motor, the posterior standard deviation, m.
    pub offset_sd_m: Vec<f64>,
    /// The load cells' common bias (posterior mean, N) and its standard
    /// deviation; `None` when not estimated.
    pub load_cell_bias_n: Option<(f64, f64)>,
    /// Readings that took part (finite, with a finite variance). Load
    /// cells on members (`MemberForce`) are not used: a drum offset acts
    /// on its continuous cable's segments.
    pub readings_used: usize,
}

/// The drum offsets the `readings` of `sensors` at `state` (the model's
/// folded start) imply, under `prior`; `None` where the model's response
/// at `state` cannot be computed (a singular or unstable tangent) or the
/// posterior is not positive definite.
pub fn estimate_drum_offsets(
    model: &ForwardModel,
    state: &DeploymentState,
    sensors: &[Sensor],
    readings: &[Option<f64>],
    prior: &DrumOffsetPrior,
) -> Option<DrumOffsetEstimate> {
    let response = PayoutResponse::tangent(model, state).ok()?;
    let motors = response.motors();
    let s = model.structure();
    let forces = force_rows(model, state);
    let bias = prior.load_cell_bias_sd_n.is_some();
    let unknowns = motors + bias as usize;
    // Rows: residual, variance, and the response to each unknown.
    let mut rows: Vec<(f64, f64, Vec<f64>)> = Vec::new();
    // Position residuals first, for the level of their model error.
    let mut positions: Vec<(f64, f64, Vec<f64>)> = Vec::new();
    for (sensor, reading) in sensors.iter().zip(readings) {
        let Some(y) = *reading else { continue };
        let noise = sensor.noise_sd * sensor.noise_sd;
        match sensor.target {
            SensorTarget::Position { node, axis } if node < s.nodes.len() => {
                let mut j: Vec<f64> = response
                    .pay_out
                    .iter()
                    .map(|e| e.positions_m_per_m[node][axis.index()])
                    .collect();
                j.extend(bias.then_some(0.0));
                positions.push((y - state.positions_m[node][axis.index()], noise, j));
            }
            SensorTarget::SegmentTension { cable, segment } => {
                let Some(c) = s.continuous_cables.get(cable) else {
                    continue;
                };
                if segment >= c.segment_count() {
                    continue;
                }
                let r = s.members.len() + state.segment_offsets[cable] + segment;
                let mut j: Vec<f64> = response
                    .pay_out
                    .iter()
                    .map(|e| e.force_n_per_m[r])
                    .collect();
                j.extend(bias.then_some(1.0));
                let m = prior.force_error_fraction * forces[r].abs() + FORCE_MODEL_ERROR_FLOOR_N;
                rows.push((y - forces[r], noise + m * m, j));
            }
            _ => {}
        }
    }
    if !positions.is_empty() {
        let count = positions.len() as f64;
        let spread = positions.iter().map(|(z, _, _)| z * z).sum::<f64>() / count;
        let noise = positions.iter().map(|(_, v, _)| v).sum::<f64>() / count;
        let model_error = (spread - noise).max(0.0);
        rows.extend(
            positions
                .into_iter()
                .map(|(z, v, j)| (z, v + model_error, j)),
        );
    }
    let mut information = DMatrix::<f64>::zeros(unknowns, unknowns);
    let mut score = DVector::<f64>::zeros(unknowns);
    rows.retain(|(z, variance, _)| *variance > 0.0 && variance.is_finite() && z.is_finite());
    for (z, variance, j) in &rows {
        for a in 0..unknowns {
            score[a] += j[a] * z / variance;
            for b in 0..unknowns {
                information[(a, b)] += j[a] * j[b] / variance;
            }
        }
    }
    let offset_precision = 1.0 / (prior.offset_sd_m * prior.offset_sd_m);
    for c in 0..motors {
        information[(c, c)] += offset_precision;
    }
    if let Some(sd) = prior.load_cell_bias_sd_n {
        information[(motors, motors)] += 1.0 / (sd * sd);
    }
    let covariance = information.cholesky()?.inverse();
    let mean = &covariance * score;
    Some(DrumOffsetEstimate {
        offset_m: (0..motors).map(|c| mean[c]).collect(),
        offset_sd_m: (0..motors).map(|c| covariance[(c, c)].sqrt()).collect(),
        load_cell_bias_n: bias.then(|| (mean[motors], covariance[(motors, motors)].sqrt())),
        readings_used: rows.len(),
    })
}

/// `state` with `offset_m` more material in each motor's cable, relaxed
/// (in increments of at most `increment_m`), its drums' payouts as they
/// were.
pub fn apply_drum_offsets(
    model: &ForwardModel,
    state: &DeploymentState,
    offset_m: &[f64],
    increment_m: f64,
) -> Result<DeploymentState, CommandError> {
    let mut moved = state.clone();
    model.apply_payout(
        &mut moved,
        &mut Workspace::default(),
        offset_m,
        increment_m,
        &mut (),
    )?;
    moved.payout_m.clone_from(&state.payout_m);
    Ok(moved)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::fixtures::frictionless_model;
    use crate::sim::standard_sensors;

    /// Noise-free readings of `sensors` at `state` of `model`.
    fn exact(
        model: &ForwardModel,
        sensors: &[Sensor],
        state: &DeploymentState,
    ) -> Vec<Option<f64>> {
        let forces = force_rows(model, state);
        let s = model.structure();
        sensors
            .iter()
            .map(|sensor| match sensor.target {
                SensorTarget::Position { node, axis } => {
                    Some(state.positions_m[node][axis.index()])
                }
                SensorTarget::SegmentTension { cable, segment } => {
                    Some(forces[s.members.len() + state.segment_offsets[cable] + segment])
                }
                _ => None,
            })
            .collect()
    }

    /// A cable holding 6 mm less material than its drum says (motor 1,
    /// `A_cc1`, read by a load cell) and a 20 N load-cell bias, read
    /// exactly at a 30 cm fold: the estimate finds the offset within 3
    /// standard deviations and within 1.5 mm, every other motor within 3
    /// of its own, and the bias within 3. The half-B motors, which no load
    /// cell reads, are hardly identified by the midspan positions alone:
    /// their standard deviations stay above 0.7 of the prior's.
    #[test]
    fn recovers_one_drums_offset_and_the_load_cell_bias_from_the_start_readings() {
        let model = frictionless_model();
        let n = model.structure().continuous_cables.len();
        let sensors = standard_sensors(model.structure());
        let mut ws = Workspace::default();
        let mut start = model.reference_state();
        model
            .apply_payout(&mut start, &mut ws, &vec![0.30; n], 0.01, &mut ())
            .unwrap();
        let mut offset = vec![0.0; n];
        offset[1] = -0.006;
        let truth = apply_drum_offsets(&model, &start, &offset, 0.01).unwrap();
        let mut readings = exact(&model, &sensors, &truth);
        for (r, s) in readings.iter_mut().zip(&sensors) {
            if matches!(s.target, SensorTarget::SegmentTension { .. }) {
                *r = r.map(|v| v + 20.0);
            }
        }
        let prior = DrumOffsetPrior {
            offset_sd_m: 0.0087,
            load_cell_bias_sd_n: Some(28.9),
            force_error_fraction: 0.2,
        };
        let e = estimate_drum_offsets(&model, &start, &sensors, &readings, &prior).unwrap();
        for c in 0..n {
            let (x, sd) = (e.offset_m[c], e.offset_sd_m[c]);
            assert!((x - offset[c]).abs() < 3.0 * sd, "motor {c}: {x} ± {sd}");
        }
        assert!((e.offset_m[1] + 0.006).abs() < 0.0015, "{:?}", e.offset_m);
        for c in 5..n {
            assert!(e.offset_sd_m[c] > 0.7 * 0.0087, "{:?}", e.offset_sd_m);
        }
        let (bias, bias_sd) = e.load_cell_bias_n.unwrap();
        assert!((bias - 20.0).abs() < 3.0 * bias_sd, "{bias} ± {bias_sd}");
        let moved = apply_drum_offsets(&model, &start, &e.offset_m, 0.01).unwrap();
        assert_eq!(moved.payout_m, start.payout_m);
        // The offset hardly moves the midspans (0.5 mm) but tightens the
        // cable's segments: the moved model carries the truth's forces.
        let s = model.structure();
        let segments = s.members.len() + start.segment_offsets[1];
        let cable = segments..segments + s.continuous_cables[1].segment_count();
        let worst = |state: &DeploymentState| {
            let (f, t) = (force_rows(&model, state), force_rows(&model, &truth));
            cable
                .clone()
                .map(|r| (f[r] - t[r]).abs())
                .fold(0.0, f64::max)
        };
        assert!(worst(&start) > 3.0, "{} N", worst(&start));
        assert!(
            worst(&moved) < 0.3 * worst(&start),
            "{} {}",
            worst(&moved),
            worst(&start)
        );
    }

    /// Readings the model predicts exactly give offsets of 0.
    #[test]
    fn readings_the_model_predicts_give_no_offset() {
        let model = frictionless_model();
        let n = model.structure().continuous_cables.len();
        let sensors = standard_sensors(model.structure());
        let mut start = model.reference_state();
        model
            .apply_payout(
                &mut start,
                &mut Workspace::default(),
                &vec![0.30; n],
                0.01,
                &mut (),
            )
            .unwrap();
        let readings = exact(&model, &sensors, &start);
        let prior = DrumOffsetPrior {
            offset_sd_m: 0.0087,
            load_cell_bias_sd_n: None,
            force_error_fraction: 0.2,
        };
        let e = estimate_drum_offsets(&model, &start, &sensors, &readings, &prior).unwrap();
        assert!(
            e.offset_m.iter().all(|x| x.abs() < 1e-9),
            "{:?}",
            e.offset_m
        );
        assert!(e.offset_sd_m.iter().all(|sd| *sd > 0.0 && *sd <= 0.0087));
        assert_eq!(e.load_cell_bias_n, None);
    }
}
