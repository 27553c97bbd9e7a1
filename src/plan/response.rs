//! One-sided responses of the state to each motor's payout: what the QP
//! step is linearised on.
//!
//! The QP formulation reads only these plain numbers, not how they were
//! computed. Here they come from one-sided finite differences through the
//! friction-aware forward model: each motor is paid out by `h` and,
//! separately, reeled in by `h` from the current state, each an ordinary
//! command with friction, so sticking joints and sliding onsets are in the
//! response as the model has them. (The analytic sensitivities of
//! `ForwardModel::payout_sensitivities` fill the same type.)

use nalgebra::{DMatrix, Vector3};
use rayon::prelude::*;

use super::limits::force_rows;
use crate::model::{CommandError, DeploymentState, ForwardModel, RelaxStatus, Workspace};

/// The response of the state to one motor moving in one direction,
/// per metre of payout (d/dp, p = payout, positive pays out).
#[derive(Debug, Clone, PartialEq)]
pub struct MotorEffect {
    /// d(node position)/dp per node, m/m.
    pub positions_m_per_m: Vec<Vector3<f64>>,
    /// d(force row)/dp per force row (members, then segments), N/m.
    pub force_n_per_m: Vec<f64>,
}

/// One-sided responses of every motor: a pay-out of `u ≥ 0` changes a
/// quantity by `≈ u·pay_out[c]`, a reel-in of `r ≥ 0` by `≈ −r·reel_in[c]`.
#[derive(Debug, Clone, PartialEq)]
pub struct PayoutResponse {
    /// Derivatives for paying out, one per motor.
    pub pay_out: Vec<MotorEffect>,
    /// Derivatives for reeling in, one per motor.
    pub reel_in: Vec<MotorEffect>,
}

/// Why responses could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResponseError {
    /// A probing command was refused.
    #[error("probing motor {motor}: {source}")]
    Command {
        /// Motor.
        motor: usize,
        /// Cause.
        source: CommandError,
    },
    /// A probing solve did not converge.
    #[error("probing motor {motor}: {}", .status.describe())]
    Solver {
        /// Motor.
        motor: usize,
        /// Status.
        status: RelaxStatus,
    },
}

impl PayoutResponse {
    /// Responses by one-sided finite differences of size `step_m`, each
    /// probe one command from `state` in increments of at most
    /// `increment_m`. The probes are independent and run in parallel; the
    /// result does not depend on the thread count.
    pub fn finite_difference(
        model: &ForwardModel,
        state: &DeploymentState,
        step_m: f64,
        increment_m: f64,
    ) -> Result<Self, ResponseError> {
        let motors = state.payout_m.len();
        let base_forces = force_rows(model, state);
        let probes: Vec<Result<MotorEffect, ResponseError>> = (0..2 * motors)
            .into_par_iter()
            // A fresh workspace per probe: a reused one carries the last
            // solve's force scale into the next solve's tolerances, which
            // would make the result depend on how rayon splits the work.
            .map(|k| {
                let ws = &mut Workspace::default();
                let (motor, sign) = (k % motors, if k < motors { 1.0 } else { -1.0 });
                let mut probe = state.clone();
                let mut delta = vec![0.0; motors];
                delta[motor] = sign * step_m;
                let report = model
                    .apply_payout(&mut probe, ws, &delta, increment_m, &mut ())
                    .map_err(|source| ResponseError::Command { motor, source })?;
                if !report.status.is_converged() {
                    return Err(ResponseError::Solver {
                        motor,
                        status: report.status,
                    });
                }
                let h = sign * step_m;
                Ok(MotorEffect {
                    positions_m_per_m: probe
                        .positions_m
                        .iter()
                        .zip(&state.positions_m)
                        .map(|(a, b)| (a - b) / h)
                        .collect(),
                    force_n_per_m: force_rows(model, &probe)
                        .iter()
                        .zip(&base_forces)
                        .map(|(a, b)| (a - b) / h)
                        .collect(),
                })
            })
            .collect();
        let mut effects = probes.into_iter().collect::<Result<Vec<_>, _>>()?;
        let reel_in = effects.split_off(motors);
        Ok(PayoutResponse {
            pay_out: effects,
            reel_in,
        })
    }

    /// Number of motors.
    pub fn motors(&self) -> usize {
        self.pay_out.len()
    }

    /// d(x_a − x_b)/dp of every node pair, stacked (3 rows per pair), one
    /// column per motor, for one direction.
    pub fn pair_matrix(&self, pairs: &[[usize; 2]], pay_out: bool) -> DMatrix<f64> {
        let effects = if pay_out {
            &self.pay_out
        } else {
            &self.reel_in
        };
        let mut m = DMatrix::zeros(3 * pairs.len(), effects.len());
        for (c, e) in effects.iter().enumerate() {
            for (p, [a, b]) in pairs.iter().enumerate() {
                let d = e.positions_m_per_m[*a] - e.positions_m_per_m[*b];
                for k in 0..3 {
                    m[(3 * p + k, c)] = d[k];
                }
            }
        }
        m
    }
}
