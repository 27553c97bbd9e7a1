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
use crate::model::{
    CommandError, DeploymentState, ForwardModel, JointFriction, MotorResponse, RelaxStatus,
    SensitivityError, SlipOnset, Workspace,
};

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

/// Parts of a structure that move independently: the DOF blocks no
/// member couples, joined where a continuous cable runs through more than
/// one (material slides along a cable over a fixed node).
#[derive(Debug, Clone, PartialEq)]
pub struct IndependentParts {
    /// Part of each node; `None` for a fully fixed node.
    pub of_node: Vec<Option<usize>>,
    /// Part of each continuous cable (motor); `None` if none of its nodes
    /// is free.
    pub of_cable: Vec<Option<usize>>,
    /// Part of each force row (members, then segments).
    pub of_force_row: Vec<Option<usize>>,
}

impl IndependentParts {
    /// The parts of `model`'s structure.
    pub fn of(model: &ForwardModel) -> Self {
        let s = model.structure();
        let dofs = model.free_dofs();
        let blocks = model.dof_blocks();
        let mut block_of_dof = vec![0; dofs.count];
        for (b, list) in blocks.iter().enumerate() {
            for &d in list {
                block_of_dof[d] = b;
            }
        }
        let block_of_node: Vec<Option<usize>> = dofs
            .index
            .iter()
            .map(|ix| ix.iter().flatten().next().map(|&d| block_of_dof[d]))
            .collect();
        // Union-find over blocks, joined along each cable.
        let mut root: Vec<usize> = (0..blocks.len()).collect();
        fn find(root: &mut [usize], mut b: usize) -> usize {
            while root[b] != b {
                root[b] = root[root[b]];
                b = root[b];
            }
            b
        }
        for cable in &s.continuous_cables {
            let mut on: Option<usize> = None;
            for &n in &cable.path {
                if let Some(b) = block_of_node[n] {
                    let rb = find(&mut root, b);
                    match on {
                        None => on = Some(rb),
                        Some(ra) => {
                            let ra = find(&mut root, ra);
                            root[rb] = ra;
                        }
                    }
                }
            }
        }
        let of_node: Vec<Option<usize>> = block_of_node
            .iter()
            .map(|b| b.map(|b| find(&mut root, b)))
            .collect();
        let of_cable: Vec<Option<usize>> = s
            .continuous_cables
            .iter()
            .map(|c| c.path.iter().find_map(|&n| of_node[n]))
            .collect();
        let mut of_force_row: Vec<Option<usize>> = s
            .members
            .iter()
            .map(|m| of_node[m.nodes[0]].or(of_node[m.nodes[1]]))
            .collect();
        for (c, cable) in s.continuous_cables.iter().enumerate() {
            of_force_row.extend(std::iter::repeat_n(of_cable[c], cable.segment_count()));
        }
        IndependentParts {
            of_node,
            of_cable,
            of_force_row,
        }
    }

    /// Groups of motors to probe together: at most one motor of each part
    /// per group, in motor order (a motor with no part probes alone).
    pub fn probe_groups(&self, motors: usize) -> Vec<Vec<usize>> {
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for m in 0..motors {
            let part = self.of_cable.get(m).copied().flatten();
            let slot = part.and_then(|p| {
                groups
                    .iter()
                    .position(|g| g.iter().all(|&o| self.of_cable[o].is_some_and(|q| q != p)))
            });
            match slot {
                Some(g) => groups[g].push(m),
                None => groups.push(vec![m]),
            }
        }
        groups
    }
}

impl PayoutResponse {
    /// Responses by one-sided finite differences of size `step_m`, each
    /// probe one command from `state` in increments of at most
    /// `increment_m`. Motors in parts of the structure that nothing
    /// couples (the two halves of the bridge before connection; see
    /// [`IndependentParts`]) are probed in the same solve, one motor per
    /// part, and each part's change is credited to its own motor; this
    /// halves the solves for the bridge. (With friction, a solve that falls
    /// back to dynamic relaxation for one part takes the other part along,
    /// whose equilibrium may then differ within the friction cone from the
    /// one a solve of its own would find; the planner confirms every step
    /// by its own trial, so the response only needs to be close.) The
    /// probes are independent and run in parallel; the result does not
    /// depend on the thread count.
    pub fn finite_difference(
        model: &ForwardModel,
        state: &DeploymentState,
        step_m: f64,
        increment_m: f64,
    ) -> Result<Self, ResponseError> {
        let motors = state.payout_m.len();
        let parts = IndependentParts::of(model);
        let groups = parts.probe_groups(motors);
        let base_forces = force_rows(model, state);
        let probes: Vec<Result<Vec<(usize, MotorEffect)>, ResponseError>> = (0..2 * groups.len())
            .into_par_iter()
            // A fresh workspace per probe: a reused one carries the last
            // solve's force scale into the next solve's tolerances, which
            // would make the result depend on how rayon splits the work.
            .map(|k| {
                let ws = &mut Workspace::default();
                let (group, sign) = if k < groups.len() {
                    (&groups[k], 1.0)
                } else {
                    (&groups[k - groups.len()], -1.0)
                };
                let first = group[0];
                let mut probe = state.clone();
                let mut delta = vec![0.0; motors];
                for &m in group {
                    delta[m] = sign * step_m;
                }
                let report = model
                    .apply_payout(&mut probe, ws, &delta, increment_m, &mut ())
                    .map_err(|source| ResponseError::Command {
                        motor: first,
                        source,
                    })?;
                if !report.status.is_converged() {
                    return Err(ResponseError::Solver {
                        motor: first,
                        status: report.status,
                    });
                }
                let h = sign * step_m;
                let forces = force_rows(model, &probe);
                Ok(group
                    .iter()
                    .map(|&m| {
                        let part = parts.of_cable[m];
                        let mine = |p: Option<usize>| p.is_some() && p == part;
                        let effect = MotorEffect {
                            positions_m_per_m: (0..state.positions_m.len())
                                .map(|n| {
                                    if mine(parts.of_node[n]) {
                                        (probe.positions_m[n] - state.positions_m[n]) / h
                                    } else {
                                        Vector3::zeros()
                                    }
                                })
                                .collect(),
                            force_n_per_m: (0..forces.len())
                                .map(|r| {
                                    if mine(parts.of_force_row[r]) {
                                        (forces[r] - base_forces[r]) / h
                                    } else {
                                        0.0
                                    }
                                })
                                .collect(),
                        };
                        (m, effect)
                    })
                    .collect())
            })
            .collect();
        let mut pay_out: Vec<Option<MotorEffect>> = vec![None; motors];
        let mut reel_in: Vec<Option<MotorEffect>> = vec![None; motors];
        for (k, probe) in probes.into_iter().enumerate() {
            let side = if k < groups.len() {
                &mut pay_out
            } else {
                &mut reel_in
            };
            for (m, effect) in probe? {
                side[m] = Some(effect);
            }
        }
        // Every motor is in exactly one group, so every slot is filled.
        let complete = |v: Vec<Option<MotorEffect>>| v.into_iter().flatten().collect::<Vec<_>>();
        Ok(PayoutResponse {
            pay_out: complete(pay_out),
            reel_in: complete(reel_in),
        })
    }

    /// Responses from the consistent tangent of `state`
    /// ([`ForwardModel::payout_sensitivities`]): exact one-sided
    /// derivatives, one factorisation per bridge half for all motors and
    /// both directions. Local: they say what the first millimetre of a
    /// move does, which at a state where every joint sticks is not what a
    /// 5 cm move does (see [`Self::finite_difference`]).
    pub fn tangent(
        model: &ForwardModel,
        state: &DeploymentState,
    ) -> Result<Self, SensitivityError> {
        Self::tangent_with(model, state, SlipOnset::AtState)
    }

    /// Responses from the tangent of `state` with the joints that may
    /// slide chosen by `onset` ([`ForwardModel::payout_sensitivities_with`]).
    pub fn tangent_with(
        model: &ForwardModel,
        state: &DeploymentState,
        onset: SlipOnset,
    ) -> Result<Self, SensitivityError> {
        let s = model.payout_sensitivities_with(state, &mut Workspace::default(), onset)?;
        let effect = |r: MotorResponse| MotorEffect {
            positions_m_per_m: r.positions_m_per_m,
            force_n_per_m: r
                .member_force_n_per_m
                .into_iter()
                .chain(r.segment_tension_n_per_m)
                .collect(),
        };
        Ok(PayoutResponse {
            pay_out: s.pay_out.into_iter().map(effect).collect(),
            reel_in: s.reel_in.into_iter().map(effect).collect(),
        })
    }

    /// Responses of the sliding limit: the exact tangent of `model` with
    /// its joint friction removed, at the equilibrium that model relaxes
    /// `state` to (material redistributed over the joints, the geometry
    /// within millimetres of the state's). A move long against the
    /// millimetres a joint sticks for slides the joints it loads; the
    /// frictionless tangent lets every joint slide both ways and, being
    /// one linear map, superposes motors exactly (the slip-onset tangent
    /// decides each joint's slide per motor, which a mix of motors pulling
    /// a joint both ways does not keep). Measured from the 40 cm fold with
    /// μ = 0.2 along a deployment (`examples/friction_responses.rs`): the
    /// model's own 1–5 cm trials predicted with a median gap error of
    /// 11 % (worst 62 %), force rows within 43 N (worst 193 N), ~1 ms.
    pub fn sliding_tangent(
        model: &ForwardModel,
        state: &DeploymentState,
    ) -> Result<Self, SensitivityError> {
        let frictionless = ForwardModel::new(
            model.structure().clone(),
            JointFriction::frictionless(),
            model.settings().clone(),
        )
        .expect("the settings of a built model are valid");
        let mut relaxed = state.clone();
        frictionless.relax(&mut relaxed, &mut Workspace::default());
        Self::tangent(&frictionless, &relaxed)
    }

    /// Broyden's rank-one secant update for a command `command_m` (m per
    /// motor, positive pays out) that moved the node positions by
    /// `position_change_m` and the force rows by `force_change_n`: each
    /// moved motor's column in the direction it moved is corrected by
    /// `e·u_c/‖u‖²`, where `e` is the observed change less the predicted
    /// one, so that the updated responses predict exactly the change seen
    /// and are unchanged for every column `u` did not move (another motor,
    /// or the other direction).
    pub fn broyden_update(
        &mut self,
        command_m: &[f64],
        position_change_m: &[Vector3<f64>],
        force_change_n: &[f64],
    ) {
        let norm2: f64 = command_m.iter().map(|u| u * u).sum();
        if !(norm2 > 0.0) {
            return;
        }
        let (predicted_dx, predicted_df) = self.predicted_change(command_m);
        let dx: Vec<Vector3<f64>> = position_change_m
            .iter()
            .zip(&predicted_dx)
            .map(|(o, p)| o - p)
            .collect();
        let df: Vec<f64> = force_change_n
            .iter()
            .zip(&predicted_df)
            .map(|(o, p)| o - p)
            .collect();
        for (c, &u) in command_m.iter().enumerate() {
            if u == 0.0 {
                continue;
            }
            let e = if u > 0.0 {
                &mut self.pay_out[c]
            } else {
                &mut self.reel_in[c]
            };
            let w = u / norm2;
            for (p, d) in e.positions_m_per_m.iter_mut().zip(&dx) {
                *p += w * d;
            }
            for (f, d) in e.force_n_per_m.iter_mut().zip(&df) {
                *f += w * d;
            }
        }
    }

    /// The change this response predicts for `command_m`: node positions,
    /// m, and force rows, N.
    pub fn predicted_change(&self, command_m: &[f64]) -> (Vec<Vector3<f64>>, Vec<f64>) {
        let nodes = self
            .pay_out
            .first()
            .map_or(0, |e| e.positions_m_per_m.len());
        let rows = self.pay_out.first().map_or(0, |e| e.force_n_per_m.len());
        let mut dx = vec![Vector3::zeros(); nodes];
        let mut df = vec![0.0; rows];
        for (c, &u) in command_m.iter().enumerate() {
            if u == 0.0 {
                continue;
            }
            let e = if u > 0.0 {
                &self.pay_out[c]
            } else {
                &self.reel_in[c]
            };
            for (d, p) in dx.iter_mut().zip(&e.positions_m_per_m) {
                *d += u * p;
            }
            for (d, f) in df.iter_mut().zip(&e.force_n_per_m) {
                *d += u * f;
            }
        }
        (dx, df)
    }

    /// Number of motors.
    pub fn motors(&self) -> usize {
        self.pay_out.len()
    }

    /// d(x_a − x_b)/dp of every node pair, stacked (3 rows per pair), one
    /// column per motor, for one direction.
    pub fn pair_matrix(&self, pairs: &[[usize; 2]], pay_out: bool) -> DMatrix<f64> {
        self.pair_rows(pairs, pay_out, |a, b| a - b)
    }

    /// d(½(x_a + x_b))/dp of every node pair, stacked (3 rows per pair),
    /// one column per motor, for one direction.
    pub fn midpoint_matrix(&self, pairs: &[[usize; 2]], pay_out: bool) -> DMatrix<f64> {
        self.pair_rows(pairs, pay_out, |a, b| 0.5 * (a + b))
    }

    /// `combine` of each pair's two node responses, stacked (3 rows per
    /// pair), one column per motor, for one direction.
    fn pair_rows(
        &self,
        pairs: &[[usize; 2]],
        pay_out: bool,
        combine: impl Fn(Vector3<f64>, Vector3<f64>) -> Vector3<f64>,
    ) -> DMatrix<f64> {
        let effects = if pay_out {
            &self.pay_out
        } else {
            &self.reel_in
        };
        let mut m = DMatrix::zeros(3 * pairs.len(), effects.len());
        for (c, e) in effects.iter().enumerate() {
            for (p, [a, b]) in pairs.iter().enumerate() {
                let d = combine(e.positions_m_per_m[*a], e.positions_m_per_m[*b]);
                for k in 0..3 {
                    m[(3 * p + k, c)] = d[k];
                }
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn effect(seed: f64, nodes: usize, rows: usize) -> MotorEffect {
        MotorEffect {
            positions_m_per_m: (0..nodes)
                .map(|i| Vector3::new(seed + i as f64, seed * 0.5 - i as f64, 0.1 * seed))
                .collect(),
            force_n_per_m: (0..rows).map(|r| 100.0 * seed - r as f64).collect(),
        }
    }

    #[test]
    fn broyden_update_reproduces_the_observed_change_and_keeps_orthogonal_moves() {
        let (nodes, rows) = (4, 3);
        let mut response = PayoutResponse {
            pay_out: (0..3)
                .map(|c| effect(c as f64 + 1.0, nodes, rows))
                .collect(),
            reel_in: (0..3)
                .map(|c| effect(-(c as f64) - 0.5, nodes, rows))
                .collect(),
        };
        // Motor 0 pays out, motor 1 reels in, motor 2 holds.
        let u = [0.03, -0.04, 0.0];
        let observed_dx: Vec<Vector3<f64>> = (0..nodes)
            .map(|i| Vector3::new(0.01 * i as f64, -0.02, 0.005))
            .collect();
        let observed_df = vec![3.0, -7.0, 1.5];
        // Each motor moving the other way (and motor 2 paying out): only
        // columns the update must leave alone.
        let v = [-0.04, 0.03, 0.02];
        let before_v = response.predicted_change(&v);
        let before_hold = response.predicted_change(&[0.0, 0.0, 0.02]);
        response.broyden_update(&u, &observed_dx, &observed_df);
        let (dx, df) = response.predicted_change(&u);
        for (a, b) in dx.iter().zip(&observed_dx) {
            assert!((a - b).norm() < 1e-12, "{a} vs {b}");
        }
        for (a, b) in df.iter().zip(&observed_df) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        let after_v = response.predicted_change(&v);
        for (a, b) in after_v.0.iter().zip(&before_v.0) {
            assert!((a - b).norm() < 1e-12);
        }
        for (a, b) in after_v.1.iter().zip(&before_v.1) {
            assert!((a - b).abs() < 1e-12);
        }
        // A motor that did not move keeps its columns.
        assert_eq!(response.predicted_change(&[0.0, 0.0, 0.02]), before_hold);
    }
}
