//! How soft the abutment is: the support compliance that best explains
//! the measured midspan motion of a deployment (issue 22, item 4).
//!
//! The controller's reference model stands on rigid supports. A real
//! abutment gives by `c·ΔR` under a change `ΔR` of its reactions
//! ([`crate::model::flexible_supports`]), and the midspan nodes, at the
//! end of a 5 m cantilever, move by that give times the lever: on
//! `scenarios/wide.toml` the runs lost to a tighter stop are the ones on
//! soft supports (docs/known-limitations.md, item 16). The payout-scale
//! estimator ([`super::estimation`]) reads most of that give as a payout
//! scale (−47 % per half at 5e-5 m/N), which is right in size for the last
//! command and wrong in shape: the give follows the reactions, not the
//! payout.
//!
//! # The fit
//! Each candidate compliance `c` is a model over flexible supports; it is
//! folded to the problem's start and the sent drum commands are replayed
//! on it, giving predicted positions `p_kj(c)` of every measured midspan
//! coordinate `j` after command `k` (`k = 0`: the start). The measured
//! readings `m_kj` are explained as
//!
//! ```text
//!     m_kj = p_kj(c) + b_j + ε_h·q_kj(c) + noise,
//!     q_kj(c) = Σ_motors ∂p_j/∂payout_m · U_km   (the tangent at step k),
//! ```
//!
//! with a free offset `b_j` per coordinate (sensor zero and every constant
//! model error, as the output-bias correction treats them) and a free
//! payout scale `ε_h` per independent part `h` (a half: drum slip, and the
//! stiffness and weight errors that need more payout for the same
//! motion), `U_km` being motor `m`'s payout commanded since the start
//! (the sum runs over every motor: a motor moves only the nodes of its
//! own part, which is what makes the parts independent,
//! [`IndependentParts`]). A
//! scale acts at the current payout, so its signature is the tangent
//! there, not the motion since the start: near the design a gap closes
//! faster per metre than on the way, and the secant `p_kj − p_0j` read a
//! 3 % drum overshoot as +5 % and biased the compliance by 4 standard
//! errors (the test's second truth). Both enter linearly and are
//! eliminated in closed form, leaving
//! the residual sum of squares `RSS(c)`. The estimate is the minimum of
//! the parabola through the best candidate and its neighbours; its
//! standard error is the least-squares one, `σ̂·(½·RSS'')^(-1/2)`, with
//! `σ̂² = RSS_min/(n − parameters)` read from the residuals, so that model
//! errors the fit does not carry widen it instead of hiding in a sensor
//! noise figure. At the end of the candidate range there is no parabola:
//! the estimate is that candidate and no standard error is claimed.
//!
//! The residuals are correlated in time wherever another hidden effect
//! (friction, a faulty member) bends the motion, so the standard error is
//! a lower bound there; on a truth whose only effect is its supports it is
//! the statistical error of the readings
//! (test `a_drawn_compliance_is_recovered_within_three_standard_errors`).
//!
//! # What it is for
//! A study of what the readings identify
//! (`examples/support_identification.rs`); the controller does not plan on
//! it. With the supports the only hidden effect it finds the compliance
//! to 0.8e-6 m/N (the prior spans 1e-5 to 5e-5); with every effect of
//! `scenarios/wide.toml` hidden it is biased by +7e-6 and no better than
//! the prior, and planning on it connects fewer runs than the rigid
//! reference model (docs/known-limitations.md, item 20).

use rayon::prelude::*;

use crate::model::flexible_supports::with_flexible_supports;
use crate::model::{ForwardModel, MotorDirection, SlipOnset, StructureError, Workspace};
use crate::plan::response::IndependentParts;
use crate::plan::{folded_start, DeploymentProblem, PlanError};
use crate::sim::{Axis, Sensor, SensorTarget};

/// Why a compliance could not be fitted.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SupportFitError {
    /// Fewer than three candidates, or candidates not finite, negative or
    /// not ascending.
    #[error("support compliance candidates must be three or more, finite, ≥ 0 and ascending")]
    Candidates,
    /// The readings are not one per sensor per step, or there is not one
    /// more step of readings than commands.
    #[error("readings: expected {expected_steps} steps of {expected_sensors} readings each")]
    Readings {
        /// Steps expected (commands + 1).
        expected_steps: usize,
        /// Readings per step expected (sensors).
        expected_sensors: usize,
    },
    /// Too few position readings for the parameters.
    #[error("{readings} position readings cannot fit {parameters} parameters")]
    TooFewReadings {
        /// Position readings used.
        readings: usize,
        /// Parameters fitted (offsets, payout scales, compliance).
        parameters: usize,
    },
    /// Every candidate's model failed to fold or to follow the commands.
    #[error("no candidate model followed the commands: {0}")]
    NoCandidate(String),
}

/// The compliance fit of a deployment.
#[derive(Debug, Clone, PartialEq)]
pub struct SupportComplianceFit {
    /// Candidate compliances, m/N, ascending.
    pub candidates_m_per_n: Vec<f64>,
    /// Residual sum of squares per candidate, m² (`None`: its model did
    /// not fold or did not follow a command).
    pub rss_m2: Vec<Option<f64>>,
    /// Position readings fitted.
    pub readings: usize,
    /// Parameters fitted: one offset per coordinate read, one payout scale
    /// per part with a coordinate read, the compliance.
    pub parameters: usize,
    /// The estimate, m/N (within the candidates' range).
    pub compliance_m_per_n: f64,
    /// Its standard error, m/N; `None` where the best candidate is at the
    /// end of the range, a neighbour failed or the three do not curve
    /// upward (no curvature to read).
    pub standard_error_m_per_n: Option<f64>,
    /// Residual standard deviation at the estimate, m (at the best
    /// candidate where there is no parabola).
    pub residual_sd_m: f64,
    /// Payout scale `ε` per part at the best candidate (index = part id).
    pub payout_scale: Vec<f64>,
}

/// The model `model` over supports of compliance `compliance_m_per_n`
/// (the model itself at 0), with its friction, settings and cable seats.
pub fn model_on_supports(
    model: &ForwardModel,
    compliance_m_per_n: f64,
) -> Result<ForwardModel, String> {
    if !(compliance_m_per_n.is_finite() && compliance_m_per_n >= 0.0) {
        return Err(format!(
            "support compliance {compliance_m_per_n:e} m/N must be finite and ≥ 0"
        ));
    }
    if compliance_m_per_n == 0.0 {
        return Ok(model.clone());
    }
    let structure = with_flexible_supports(model.structure(), compliance_m_per_n)
        .map_err(|e: StructureError| e.to_string())?;
    let supported = ForwardModel::new(
        structure,
        model.friction().clone(),
        model.settings().clone(),
    )
    .map_err(|e| e.to_string())?;
    match model.cable_seat_radius_m() {
        Some(r) => supported.with_cable_seats(r).map_err(|e| e.to_string()),
        None => Ok(supported),
    }
}

/// One candidate's predictions of the measured coordinates per step
/// (step 0 the folded start): the positions, and their derivative with
/// respect to a payout scale of the commands so far.
struct Replay {
    /// Predicted position per step and coordinate, m.
    positions_m: Vec<Vec<f64>>,
    /// d(position)/d(scale) per step and coordinate, m: the payout
    /// sensitivities at the step's state applied to the payout commanded
    /// since the start. The tangent, not the motion since the start: near
    /// the design a gap closes faster per metre than on the way there, and
    /// a scale acts at the current payout. On a model with friction, the
    /// slip-onset tangent ([`SlipOnset::Loaded`]): a scale error of a
    /// percent of the payout is centimetres, far past the millimetres a
    /// joint sticks for.
    scale_response_m: Vec<Vec<f64>>,
}

/// Replays the sent commands on `model` from its folded start.
fn replay(
    model: &ForwardModel,
    problem: &DeploymentProblem,
    increment_m: f64,
    coordinates: &[(usize, Axis)],
    sent_m: &[Vec<f64>],
) -> Result<Replay, String> {
    let mut state =
        folded_start(model, problem, increment_m).map_err(|e: PlanError| e.to_string())?;
    let mut ws = Workspace::default();
    let motors = sent_m.first().map_or(0, Vec::len);
    let mut commanded = vec![0.0; motors];
    let mut out = Replay {
        positions_m: Vec::with_capacity(sent_m.len() + 1),
        scale_response_m: Vec::with_capacity(sent_m.len() + 1),
    };
    let mut record = |state: &crate::model::DeploymentState,
                      ws: &mut Workspace,
                      commanded: &[f64]|
     -> Result<(), String> {
        out.positions_m.push(
            coordinates
                .iter()
                .map(|&(node, axis)| state.positions_m[node][axis.index()])
                .collect(),
        );
        let mut response = vec![0.0; coordinates.len()];
        if commanded.iter().any(|u| *u != 0.0) {
            let s = model
                .payout_sensitivities_with(state, ws, SlipOnset::Loaded)
                .map_err(|e| e.to_string())?;
            for (m, &u) in commanded.iter().enumerate() {
                let direction = if u >= 0.0 {
                    MotorDirection::PayOut
                } else {
                    MotorDirection::ReelIn
                };
                if let Some(r) = s.response(m, direction) {
                    for (q, &(node, axis)) in response.iter_mut().zip(coordinates) {
                        *q += r.positions_m_per_m[node][axis.index()] * u;
                    }
                }
            }
        }
        out.scale_response_m.push(response);
        Ok(())
    };
    record(&state, &mut ws, &commanded)?;
    for (k, command) in sent_m.iter().enumerate() {
        let r = model
            .apply_payout(&mut state, &mut ws, command, increment_m, &mut ())
            .map_err(|e| format!("command {}: {e}", k + 1))?;
        if !r.status.is_converged() {
            return Err(format!("command {}: {}", k + 1, r.status.describe()));
        }
        for (c, u) in commanded.iter_mut().zip(command) {
            *c += u;
        }
        record(&state, &mut ws, &commanded)?;
    }
    Ok(out)
}

/// Residual sum of squares of the readings against one candidate's
/// predictions, with the offsets and per-part payout scales eliminated,
/// and those scales.
fn offset_and_scale_rss(
    predicted: &[Vec<f64>],
    scale_response: &[Vec<f64>],
    measured: &[Vec<Option<f64>>],
    part_of_coordinate: &[usize],
    parts: usize,
) -> (f64, Vec<f64>) {
    // Per coordinate, the available steps' misfit d = m − p and scale
    // response g, centred over those steps (which eliminates the offset).
    let mut centred: Vec<(usize, Vec<(f64, f64)>)> = Vec::new();
    for (j, &part) in part_of_coordinate.iter().enumerate() {
        let pairs: Vec<(f64, f64)> = measured
            .iter()
            .zip(predicted.iter().zip(scale_response))
            .filter_map(|(m, (p, q))| m[j].map(|m| (m - p[j], q[j])))
            .collect();
        if pairs.is_empty() {
            continue;
        }
        let n = pairs.len() as f64;
        let (dm, gm) = pairs
            .iter()
            .fold((0.0, 0.0), |(a, b), (d, g)| (a + d / n, b + g / n));
        centred.push((part, pairs.iter().map(|(d, g)| (d - dm, g - gm)).collect()));
    }
    let mut dg = vec![0.0; parts];
    let mut gg = vec![0.0; parts];
    for (part, pairs) in &centred {
        for (d, g) in pairs {
            dg[*part] += d * g;
            gg[*part] += g * g;
        }
    }
    let scale: Vec<f64> = dg
        .iter()
        .zip(&gg)
        .map(|(dg, gg)| if *gg > 0.0 { dg / gg } else { 0.0 })
        .collect();
    let rss = centred
        .iter()
        .flat_map(|(part, pairs)| {
            let s = scale[*part];
            pairs.iter().map(move |(d, g)| (d - s * g).powi(2))
        })
        .sum();
    (rss, scale)
}

/// Fits the support compliance of a deployment on `model` (the
/// controller's model on rigid supports) from the drum commands sent
/// (`sent_m`, one per command) and the readings of `sensors` at the start
/// and after each command (`readings`, one more step than commands; only
/// the position sensors of free nodes are read), trying each of
/// `candidates_m_per_n` (ascending, ≥ 0; see the module notes). The
/// candidates' models are folded and replayed in parallel; the result
/// does not depend on the thread count.
pub fn fit_support_compliance(
    model: &ForwardModel,
    problem: &DeploymentProblem,
    increment_m: f64,
    candidates_m_per_n: &[f64],
    sensors: &[Sensor],
    sent_m: &[Vec<f64>],
    readings: &[Vec<Option<f64>>],
) -> Result<SupportComplianceFit, SupportFitError> {
    if candidates_m_per_n.len() < 3
        || candidates_m_per_n
            .iter()
            .any(|c| !c.is_finite() || *c < 0.0)
        || candidates_m_per_n.windows(2).any(|w| w[1] <= w[0])
    {
        return Err(SupportFitError::Candidates);
    }
    if readings.len() != sent_m.len() + 1 || readings.iter().any(|r| r.len() != sensors.len()) {
        return Err(SupportFitError::Readings {
            expected_steps: sent_m.len() + 1,
            expected_sensors: sensors.len(),
        });
    }
    let parts_of = IndependentParts::of(model);
    // The position sensors of free nodes, with their part.
    let mut sensor_index = Vec::new();
    let mut coordinates = Vec::new();
    let mut part_of_coordinate = Vec::new();
    for (i, s) in sensors.iter().enumerate() {
        if let SensorTarget::Position { node, axis } = s.target {
            if let Some(Some(part)) = parts_of.of_node.get(node) {
                sensor_index.push(i);
                coordinates.push((node, axis));
                part_of_coordinate.push(*part);
            }
        }
    }
    let parts = part_of_coordinate.iter().max().map_or(0, |p| p + 1);
    // A reading that is not a finite number is a missing one.
    let measured: Vec<Vec<Option<f64>>> = readings
        .iter()
        .map(|step| {
            sensor_index
                .iter()
                .map(|&i| step[i].filter(|v| v.is_finite()))
                .collect()
        })
        .collect();
    let used = measured.iter().flatten().flatten().count();
    let observed: Vec<usize> = (0..coordinates.len())
        .filter(|&j| measured.iter().any(|m| m[j].is_some()))
        .collect();
    let mut observed_parts: Vec<usize> = observed.iter().map(|&j| part_of_coordinate[j]).collect();
    observed_parts.sort_unstable();
    observed_parts.dedup();
    let parameters = observed.len() + observed_parts.len() + 1;
    if used <= parameters {
        return Err(SupportFitError::TooFewReadings {
            readings: used,
            parameters,
        });
    }
    let fits: Vec<Result<(f64, Vec<f64>), String>> = candidates_m_per_n
        .par_iter()
        .map(|&c| {
            let m = model_on_supports(model, c)?;
            let r = replay(&m, problem, increment_m, &coordinates, sent_m)?;
            Ok(offset_and_scale_rss(
                &r.positions_m,
                &r.scale_response_m,
                &measured,
                &part_of_coordinate,
                parts,
            ))
        })
        .collect();
    let rss_m2: Vec<Option<f64>> = fits.iter().map(|f| f.as_ref().ok().map(|f| f.0)).collect();
    let best = rss_m2
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.map(|r| (i, r)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    let Some(best) = best else {
        let first = fits.into_iter().find_map(Result::err).unwrap_or_default();
        return Err(SupportFitError::NoCandidate(first));
    };
    let estimate = grid_estimate(candidates_m_per_n, &rss_m2, best, used - parameters);
    let payout_scale = fits[best].as_ref().map(|f| f.1.clone()).unwrap_or_default();
    Ok(SupportComplianceFit {
        candidates_m_per_n: candidates_m_per_n.to_vec(),
        rss_m2,
        readings: used,
        parameters,
        compliance_m_per_n: estimate.value,
        standard_error_m_per_n: estimate.standard_error,
        residual_sd_m: estimate.residual_sd,
        payout_scale,
    })
}

/// The estimate a grid of residual sums of squares gives.
#[derive(Debug, Clone, Copy, PartialEq)]
struct GridEstimate {
    value: f64,
    standard_error: Option<f64>,
    residual_sd: f64,
}

/// The estimate from the residual sums of squares `rss` of candidates `x`
/// (`None`: failed), their smallest at `best`, with `dof` residual
/// degrees of freedom: the vertex of the parabola through `best` and its
/// neighbours, and its least-squares standard error
/// `(σ̂²/a)^½` with `σ̂² = r/dof`, `a` the parabola's half curvature and
/// `r` its value at the vertex (the grid's smallest RSS overstates it
/// when the vertex lies between candidates). At the grid's end, beside a
/// failed candidate, or where the parabola does not open upward, the
/// estimate is the best candidate, without a standard error.
fn grid_estimate(x: &[f64], rss: &[Option<f64>], best: usize, dof: usize) -> GridEstimate {
    let at_best = rss[best].unwrap_or(0.0);
    let neighbours = best
        .checked_sub(1)
        .and_then(|lo| Some((rss[lo]?, rss.get(best + 1).copied().flatten()?)));
    let vertex = neighbours.and_then(|(lo, hi)| {
        parabola_minimum([(x[best - 1], lo), (x[best], at_best), (x[best + 1], hi)])
    });
    match vertex {
        Some((value, a)) => {
            let r = (at_best - a * (x[best] - value).powi(2)).max(0.0);
            let variance = r / dof as f64;
            GridEstimate {
                value,
                standard_error: Some((variance / a).sqrt()),
                residual_sd: variance.sqrt(),
            }
        }
        None => GridEstimate {
            value: x[best],
            standard_error: None,
            residual_sd: (at_best / dof as f64).sqrt(),
        },
    }
}

/// The vertex `x` and the half curvature `a` of the parabola
/// `a·(x − x̂)² + r` through three points; `None` where it opens downward
/// or is flat.
fn parabola_minimum(p: [(f64, f64); 3]) -> Option<(f64, f64)> {
    let [(x0, y0), (x1, y1), (x2, y2)] = p;
    // Divided differences: y = y0 + f01·(x − x0) + a·(x − x0)(x − x1).
    let f01 = (y1 - y0) / (x1 - x0);
    let f12 = (y2 - y1) / (x2 - x1);
    let a = (f12 - f01) / (x2 - x0);
    if !(a > 0.0) || !a.is_finite() {
        return None;
    }
    // dy/dx = f01 + a·(2x − x0 − x1) = 0.
    let x = 0.5 * (x0 + x1) - f01 / (2.0 * a);
    Some((x, a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::effects::{MotorEffect, SupportFlexibilityEffect};
    use crate::model::Effects;
    use crate::plan::PerMotor;
    use crate::sim::{standard_sensors, EffectModel, Plant};
    use rand::SeedableRng;

    #[test]
    fn a_parabolas_vertex_and_curvature_are_read_from_three_points() {
        // y = 3·(x − 0.4)² + 2
        let y = |x: f64| 3.0 * (x - 0.4) * (x - 0.4) + 2.0;
        let (x, a) = parabola_minimum([(0.0, y(0.0)), (0.5, y(0.5)), (1.5, y(1.5))]).unwrap();
        assert!((x - 0.4).abs() < 1e-12 && (a - 3.0).abs() < 1e-12);
        assert_eq!(parabola_minimum([(0.0, 1.0), (1.0, 2.0), (2.0, 1.0)]), None);
    }

    #[test]
    fn an_exact_parabola_gives_its_vertex_and_the_least_squares_standard_error() {
        // RSS(x) = a·(x − 2.3)² + r on a unit grid, 40 residual degrees of
        // freedom: Var = σ̂²/a with σ̂² = r/40, r the vertex's value and
        // not the grid's smallest (which is 0.09·a larger).
        let (a, r, dof) = (5.0, 8.0, 40);
        let x: Vec<f64> = (0..6).map(f64::from).collect();
        let rss: Vec<Option<f64>> = x
            .iter()
            .map(|x| Some(a * (x - 2.3f64).powi(2) + r))
            .collect();
        let e = grid_estimate(&x, &rss, 2, dof);
        assert!((e.value - 2.3).abs() < 1e-12, "{e:?}");
        let sd = (r / dof as f64).sqrt();
        assert!((e.residual_sd - sd).abs() < 1e-12, "{e:?}");
        assert!(
            (e.standard_error.unwrap() - sd / a.sqrt()).abs() < 1e-12,
            "{e:?}"
        );
        // At the grid's end, or beside a failed candidate: the candidate,
        // no standard error.
        let at_end = grid_estimate(&x, &rss, 0, dof);
        assert_eq!((at_end.value, at_end.standard_error), (0.0, None));
        let mut failed = rss.clone();
        failed[3] = None;
        let beside = grid_estimate(&x, &failed, 2, dof);
        assert_eq!((beside.value, beside.standard_error), (2.0, None));
    }

    #[test]
    fn each_part_has_its_own_payout_scale() {
        // Two coordinates of part 0 with scale 0.1, one of part 1 with −0.2.
        let predicted = vec![
            vec![0.0, 1.0, 2.0],
            vec![0.1, 1.2, 2.1],
            vec![0.3, 1.1, 2.5],
        ];
        let response = vec![
            vec![0.0, 0.0, 0.0],
            vec![0.1, 0.2, 0.3],
            vec![0.3, 0.1, 0.2],
        ];
        let scale = [0.1, 0.1, -0.2];
        let measured: Vec<Vec<Option<f64>>> = predicted
            .iter()
            .zip(&response)
            .map(|(p, q)| {
                (0..3)
                    .map(|j| Some(p[j] + 0.01 * j as f64 + scale[j] * q[j]))
                    .collect()
            })
            .collect();
        let (rss, fitted) = offset_and_scale_rss(&predicted, &response, &measured, &[0, 0, 1], 2);
        assert!(rss < 1e-28, "{rss}");
        assert!((fitted[0] - 0.1).abs() < 1e-12 && (fitted[1] + 0.2).abs() < 1e-12);
    }

    #[test]
    fn missing_and_non_finite_readings_are_left_out() {
        let full = measured_deployment(2.5e-5, 0.0, 1);
        let mut gaps = full.readings.clone();
        // One coordinate never read (sensor 4 is the first position), a
        // few readings lost.
        for step in &mut gaps {
            step[4] = None;
        }
        gaps[2][7] = None;
        gaps[3][20] = None;
        let dropped = Measured {
            readings: gaps.clone(),
            ..measured_deployment(2.5e-5, 0.0, 1)
        };
        let fit = dropped.fit(&CANDIDATES).unwrap();
        assert_eq!(fit.readings, 5 * 30 - 5 - 2);
        assert_eq!(fit.parameters, 29 + 2 + 1);
        let se = fit.standard_error_m_per_n.unwrap();
        assert!((fit.compliance_m_per_n - 2.5e-5).abs() < 3.0 * se);
        // A reading that is no number is one lost, not a reason to read
        // rigid supports.
        let mut nan = gaps;
        nan[2][7] = Some(f64::NAN);
        nan[3][20] = Some(f64::INFINITY);
        let with_nan = Measured {
            readings: nan,
            ..measured_deployment(2.5e-5, 0.0, 1)
        };
        assert_eq!(with_nan.fit(&CANDIDATES), Ok(fit));
    }

    #[test]
    fn offsets_and_a_payout_scale_are_eliminated_exactly() {
        // Readings made of the predictions, an offset per coordinate and a
        // scale times its response fit with no residual.
        let predicted = vec![vec![0.0, 1.0], vec![0.1, 1.2], vec![0.3, 1.1]];
        let response = vec![vec![0.0, 0.0], vec![0.1, 0.2], vec![0.3, 0.1]];
        let measured: Vec<Vec<Option<f64>>> = predicted
            .iter()
            .zip(&response)
            .map(|(p, q)| {
                vec![
                    Some(p[0] + 0.05 + 0.1 * q[0]),
                    Some(p[1] - 0.02 + 0.1 * q[1]),
                ]
            })
            .collect();
        let (rss, scale) = offset_and_scale_rss(&predicted, &response, &measured, &[0, 0], 1);
        assert!(rss < 1e-28, "{rss}");
        assert!((scale[0] - 0.1).abs() < 1e-12);
    }

    /// A deployment of a truth, as the fit takes it.
    struct Measured {
        model: ForwardModel,
        problem: DeploymentProblem,
        sensors: Vec<Sensor>,
        sent: Vec<Vec<f64>>,
        readings: Vec<Vec<Option<f64>>>,
    }

    impl Measured {
        fn fit(&self, candidates: &[f64]) -> Result<SupportComplianceFit, SupportFitError> {
            fit_support_compliance(
                &self.model,
                &self.problem,
                0.01,
                candidates,
                &self.sensors,
                &self.sent,
                &self.readings,
            )
        }
    }

    /// A truth on supports of compliance `c` (and a drum payout scale),
    /// commanded from a 20 cm fold in four 5 cm steps, measured with 1 mm
    /// position noise.
    fn measured_deployment(compliance: f64, slip_fraction: f64, seed: u64) -> Measured {
        let bridge = reference_bridge(&BridgeParameters::default()).unwrap();
        let model = ForwardModel::new(
            bridge.clone(),
            crate::model::JointFriction::frictionless(),
            crate::model::RelaxSettings::default(),
        )
        .unwrap();
        let problem = DeploymentProblem {
            start_payout_m: PerMotor::All(0.20),
            ..DeploymentProblem::default()
        };
        let effects = Effects {
            support_flexibility: (compliance > 0.0).then_some(SupportFlexibilityEffect {
                compliance_m_per_n: compliance,
            }),
            motor: (slip_fraction != 0.0).then_some(MotorEffect {
                slip_fraction,
                backlash_m: 0.0,
            }),
            ..Default::default()
        };
        let truth = EffectModel::for_measurement(bridge.clone(), effects);
        let sensors = standard_sensors(&bridge);
        let motors = problem
            .motor_limits(model.structure().continuous_cables.len())
            .unwrap();
        let mut plant = Plant::new(&truth, Some(&motors.start_payout_m), None).unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let mut readings = vec![plant.measure(&sensors, &mut rng)];
        let command = vec![-0.05; motors.start_payout_m.len()];
        let mut sent = Vec::new();
        for _ in 0..4 {
            plant.apply(&command, None, &mut ()).unwrap();
            readings.push(plant.measure(&sensors, &mut rng));
            sent.push(command.clone());
        }
        Measured {
            model,
            problem,
            sensors,
            sent,
            readings,
        }
    }

    const CANDIDATES: [f64; 7] = [0.0, 1e-5, 2e-5, 3e-5, 4e-5, 5e-5, 6e-5];

    #[test]
    fn a_drawn_compliance_is_recovered_within_three_standard_errors() {
        for (c, slip, seed) in [(2.5e-5, 0.0, 1), (3.7e-5, -0.03, 2), (1.4e-5, 0.04, 3)] {
            let fit = measured_deployment(c, slip, seed).fit(&CANDIDATES).unwrap();
            let se = fit.standard_error_m_per_n.expect("an interior minimum");
            assert!(
                (fit.compliance_m_per_n - c).abs() < 3.0 * se,
                "c {c}: estimate {} ± {se}",
                fit.compliance_m_per_n
            );
            // The fit is informative: well inside the prior's 1e-5–5e-5.
            assert!(se < 0.5e-5, "c {c}: standard error {se}");
            // The drums' slip is read as the payout scale, apart from the
            // supports' give: a cable that slips by f moves by 1 − f.
            for scale in &fit.payout_scale {
                assert!(
                    (scale + slip).abs() < 0.01,
                    "c {c}: slip {slip} read as {scale}"
                );
            }
        }
    }

    #[test]
    fn the_fit_is_the_same_at_one_and_two_threads() {
        let m = measured_deployment(3.0e-5, 0.01, 6);
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| m.fit(&CANDIDATES))
        };
        assert_eq!(on(1), on(2));
    }

    #[test]
    fn rigid_supports_are_read_as_the_first_candidate() {
        let fit = measured_deployment(0.0, 0.02, 4).fit(&CANDIDATES).unwrap();
        assert_eq!(fit.compliance_m_per_n, 0.0);
        assert_eq!(fit.standard_error_m_per_n, None);
    }

    #[test]
    fn bad_candidates_and_readings_are_refused() {
        let mut m = measured_deployment(0.0, 0.0, 5);
        for bad in [
            &[0.0, 1e-5][..],
            &[0.0, 2e-5, 1e-5],
            &[-1e-5, 0.0, 1e-5],
            &[0.0, f64::NAN, 1.0],
        ] {
            assert_eq!(m.fit(bad), Err(SupportFitError::Candidates));
        }
        m.readings.remove(0);
        assert!(matches!(
            m.fit(&CANDIDATES),
            Err(SupportFitError::Readings { .. })
        ));
        // The start alone: 30 readings cannot fit 30 offsets, 2 scales and
        // the compliance.
        m.readings.truncate(1);
        m.sent.clear();
        assert_eq!(
            m.fit(&CANDIDATES),
            Err(SupportFitError::TooFewReadings {
                readings: 30,
                parameters: 33
            })
        );
    }
}
