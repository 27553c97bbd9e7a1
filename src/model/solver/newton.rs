//! Newton–Raphson solution of a relaxation, ahead of DR.
//!
//! DR converges at a rate set by the ratio of the stiffest to the softest
//! mode, and a deployable tensegrity has both (steel struts, soft springs,
//! prestress-stabilised mechanisms): a 1 cm command takes thousands of DR
//! iterations. Newton's method on the same residual, with the tangent of
//! [`super::stiffness`] in [`JointMode::AsMapped`] (the consistent tangent of
//! the friction return mapping), takes a handful. Whatever Newton leaves, DR
//! continues from (and hands back to Newton once its iterates have settled
//! the slip states, [`super::relax`]), and convergence is judged by the
//! same residual test.
//!
//! Each Newton step solves `K·Δx = R` on the free DOFs and is shortened to
//! `newton_max_step_rel` of the structure size. The full step is taken
//! unless it multiplies the residual norm by more than `newton_watchdog`: a
//! correct step along a soft mode stretches the stiff struts to second order
//! and raises the residual for one iteration, so a monotone line search would
//! stall. Newton gives up when a step is not a descent direction (`Δx·R ≤ 0`:
//! an unstable tangent), when the factorisation fails, or at
//! `newton_max_iter`.
//!
//! Friction makes the residual non-smooth where joints change between
//! sticking and sliding, and Newton iterates far from the answer (struts
//! stretched to second order) would flip those states at every step. So
//! Newton works on active sets: the joints' slip states are held fixed and
//! the material is distributed for them ([`super::sliding::map_cable_with_slip`]),
//! a smooth problem whose consistent tangent is exactly
//! [`JointMode::AsMapped`]; when it has converged, the return mapping at
//! that geometry either agrees (the answer) or supplies the next slip
//! states (at most `newton_max_active_set_rounds` times).
//!
//! A payout increment is solved by continuation in its size
//! ([`ForwardModel::newton_increment`]): the problem "apply λ of the increment
//! from the start state" is solved for growing λ, each solution with a
//! linear predictor from the last, whose probe also gives the slip states
//! to start from. A failed step is halved, down to
//! `newton_min_continuation_step`; then DR solves the increment from the farthest
//! partial solution. Every partial problem starts from the same start state
//! with stuck joints, so the continuation only supplies initial guesses:
//! the answer is that of the full increment (backward Euler), as with DR.

use nalgebra::DVector;

use super::counters::NewtonGaveUp;
use super::residual::SlipMapping;
use super::workspace::KeptTangent;
use super::{ForwardModel, Workspace};
use crate::model::state::{DeploymentState, JointSlip};
use crate::model::stiffness::{assemble_tangent_stiffness, tangent_layout, JointMode};
use crate::numerics::{BlockLayout, BlockLu};

/// Payout fraction of the probe that finds the predictor's load.
const PROBE: f64 = 1e-6;

/// Time of one DR iteration per element, ns: measured with
/// `cargo run --release --example factor_timing` (256 iterations of
/// each; release build, 2026-11-24), 8–11 ns on the 5×5 to 31×31 nets,
/// 12–17 ns on the bridges of 2 to 16 modules per half (their continuous
/// cables' friction mapping costs more). In the units of the factorisation
/// estimate ([`crate::numerics::block_matrix::cost`], same machine and
/// date), so their ratio carries to other machines.
const DR_NS_PER_ELEMENT: f64 = 10.0;

/// How far (relative to the structure size) the state a kept tangent was
/// assembled at may be from the one a predictor needs: 1e-4 of the 4 m
/// bridge is 0.4 mm, a tenth of the smallest continuation step's motion
/// (1/16 of 1 cm) and far more than Newton's last steps.
const KEPT_TANGENT_REL: f64 = 1e-4;

/// Where a tangent was assembled: joint slip states, node positions (m)
/// and segment rest lengths (m), kept with its factorisation.
type AssembledAt = (Vec<JointSlip>, Vec<nalgebra::Vector3<f64>>, Vec<f64>);

/// How a Newton solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct NewtonOutcome {
    /// Residual and friction within the force tolerance.
    pub converged: bool,
    /// Newton iterations taken (factorisations, predictors included).
    pub iterations: usize,
}

impl ForwardModel {
    pub(super) fn newton_enabled(&self) -> bool {
        let s = &self.settings;
        let free = self.free_dof_count();
        s.newton_max_iter > 0
            && free > 0
            && self.largest_dense_block() <= s.newton_max_dofs
            && self.newton_cost_ratio() <= s.newton_max_cost_ratio
    }

    /// How this model's tangents are stored and factorised: each DOF block
    /// dense or sparse, whichever is estimated to be faster (made once, at
    /// the first call, with the sparse blocks' symbolic analyses).
    fn tangent_layout(&self) -> &BlockLayout {
        self.tangent_layout.get_or_init(|| tangent_layout(self))
    }

    /// Rows of the largest block stored dense (whose memory grows with
    /// their square).
    fn largest_dense_block(&self) -> usize {
        let layout = self.tangent_layout();
        (0..layout.blocks().len())
            .filter(|&b| layout.pattern(b).is_none())
            .map(|b| layout.blocks()[b].len())
            .max()
            .unwrap_or(0)
    }

    /// Estimated cost of one Newton factorisation in DR iterations: the
    /// assembly and factorisation of each block by the kernel it uses
    /// ([`BlockLayout::factorisation_cost_ns`]: ⅔·b³ flops for a dense
    /// block, the flops of its symbolic Cholesky factor and its entries for
    /// a sparse one), over one DR iteration at [`DR_NS_PER_ELEMENT`].
    /// Depends on the structure's topology only, so the choice of method
    /// is the same for every solve of a model (deterministic whatever the
    /// history).
    pub(super) fn newton_cost_ratio(&self) -> f64 {
        let dr = DR_NS_PER_ELEMENT * self.elements.len().max(1) as f64;
        self.tangent_layout().factorisation_cost_ns() / dr
    }

    /// Solves one increment from the equilibrium `state` by Newton with
    /// continuation: the payout `delta_payout_m` and a change of every
    /// segment's material `delta_rest_m` (m, flat as the segments; empty:
    /// none; what the cable seats move, [`super::seats`]) ramped together.
    /// Leaves `state` with the increment applied (payout added to the
    /// first segments, joints stuck): on success, with the increment's
    /// solution; on failure, at the farthest partial solution reached (the
    /// best start for DR, which solves the same increment from there).
    pub(super) fn newton_increment_with_material(
        &self,
        state: &mut DeploymentState,
        ws: &mut Workspace,
        delta_payout_m: &[f64],
        delta_rest_m: &[f64],
    ) -> NewtonOutcome {
        let mut outcome = NewtonOutcome::default();
        let start = state.clone();
        let partial = |lambda: f64, positions: &DeploymentState| {
            let mut s = start.clone();
            s.positions_m.copy_from_slice(&positions.positions_m);
            for (c, d) in delta_payout_m.iter().enumerate() {
                s.segment_rest_lengths_m[s.segment_offsets[c]] += lambda * d;
                s.payout_m[c] += lambda * d;
            }
            for (r, d) in s.segment_rest_lengths_m.iter_mut().zip(delta_rest_m) {
                *r += lambda * d;
            }
            s.stick_all_joints();
            s
        };
        if !self.newton_enabled() {
            *state = partial(1.0, &start);
            return outcome;
        }
        let mut solved = start.clone();
        // Start from the step size that worked last time: successive
        // increments of a command behave alike.
        if ws.continuation_step == 0.0 {
            // Without friction no joint changes state within an increment.
            ws.continuation_step = if self.friction.is_frictionless() {
                1.0
            } else {
                self.settings.newton_first_continuation_step
            };
        }
        let (mut done, mut step) = (
            0.0,
            ws.continuation_step
                .clamp(self.settings.newton_min_continuation_step, 1.0),
        );
        while done < 1.0 {
            let lambda = f64::min(done + step, 1.0);
            let mut trial = partial(lambda, &solved);
            let (dx, labels) = self.linear_prediction(&partial(done, &solved), &trial, ws);
            if let Some(dx) = dx {
                outcome.iterations += 1;
                self.free_dofs()
                    .scatter_add(&mut trial.positions_m, &dx, 1.0);
            }
            ws.start_increment(&trial);
            // The joints that slide as this step begins: the active set to
            // solve with; the step is halved if the answer contradicts it.
            trial.joint_slip = labels;
            let (mut max_t, mut friction_left) = (0.0, 0.0);
            // Only the last step's answer is the increment's: the partial
            // problems only supply its initial guess and slip states, so
            // they are solved to the looser continuation tolerance.
            let tol_rel = if lambda < 1.0 {
                self.continuation_tol_rel()
            } else {
                self.settings.tol_force_rel
            };
            let inner = self.newton(&mut trial, ws, tol_rel, &mut max_t, &mut friction_left);
            outcome.iterations += inner.iterations;
            if inner.converged {
                ws.counters.steps_converged += 1;
                solved = trial;
                done = lambda;
                ws.continuation_step = step;
                step = f64::min(2.0 * step, 1.0);
            } else {
                ws.counters.steps_failed += 1;
                step *= 0.5;
                if step < self.settings.newton_min_continuation_step {
                    ws.counters.increments_to_dr += 1;
                    *state = partial(1.0, &solved);
                    return outcome;
                }
            }
        }
        *state = solved;
        ws.counters.increments_by_newton += 1;
        outcome.converged = true;
        outcome
    }

    /// Displacement from the solution `from` (of its own increment) to the
    /// solution of `to`, which differs only in its start rest lengths:
    /// `K⁻¹·(∂R/∂start)·Δstart`, the load by a forward difference of the
    /// mapped residual over [`PROBE`] of the change. `None` where the tangent
    /// is singular or predicts motion against the load (unstable).
    fn linear_prediction(
        &self,
        from: &DeploymentState,
        to: &DeploymentState,
        ws: &mut Workspace,
    ) -> (Option<DVector<f64>>, Vec<JointSlip>) {
        let mut base = from.clone();
        ws.start_increment(&base);
        self.residual(&mut base, ws);
        let base_force = ws.force.clone();
        let mut probe = from.clone();
        for (r, (a, b)) in probe.segment_rest_lengths_m.iter_mut().zip(
            from.segment_rest_lengths_m
                .iter()
                .zip(&to.segment_rest_lengths_m),
        ) {
            *r = a + PROBE * (b - a);
        }
        ws.start_increment(&probe);
        self.residual(&mut probe, ws);
        let dofs = self.free_dofs();
        let mut load = DVector::zeros(dofs.count);
        for (i, rows) in dofs.index.iter().enumerate() {
            for (a, row) in rows.iter().enumerate() {
                if let Some(r) = row {
                    load[*r] = (ws.force[i][a] - base_force[i][a]) / PROBE;
                }
            }
        }
        let lu = match ws.kept_tangent.take() {
            Some(kept) if self.tangent_still_fits(&kept, &probe) => kept.factors,
            stale => {
                ws.recycle(stale.map(|k| k.factors));
                let Some(lu) = self.factorise_tangent(&probe, ws) else {
                    return (None, probe.joint_slip);
                };
                lu
            }
        };
        let labels = probe.joint_slip;
        let mut step = lu.solve(&load);
        ws.recycle(Some(lu));
        if !(step.dot(&load) > 0.0) {
            return (None, labels);
        }
        let longest = step.amax();
        let max_step = self.settings.newton_max_step_rel * self.size_m();
        if longest > max_step {
            step *= max_step / longest;
        }
        (Some(step), labels)
    }

    /// The force tolerance of the partial problems of a continuation
    /// (λ < 1), relative to the largest member force: the continuation
    /// setting, never tighter than the solve's own tolerance.
    fn continuation_tol_rel(&self) -> f64 {
        self.settings
            .newton_tol_continuation_rel
            .max(self.settings.tol_force_rel)
    }

    /// Newton on the increment whose start `ws` holds, from `state` (whose
    /// mapped residual is in `ws.force`), to the force tolerance `tol_rel`
    /// relative to the largest member force (with the absolute floor
    /// `tol_force_abs`), by active sets: Newton on the
    /// smooth problem of the current joint slip states; once that converges
    /// the states are revised against the result ([`super::sliding::revise_slip`])
    /// and Newton goes on, until a revision changes nothing (at most
    /// `newton_max_active_set_rounds` revisions). The answer is confirmed with the
    /// return mapping itself. On failure `state` is restored. Updates
    /// `max_t` and `friction_left`.
    ///
    /// A factorisation is reused while each step at least halves the
    /// residual norm (a chord step costs a back substitution, not a
    /// factorisation), and refreshed otherwise or when slip states change.
    pub(super) fn newton(
        &self,
        state: &mut DeploymentState,
        ws: &mut Workspace,
        tol_rel: f64,
        max_t: &mut f64,
        friction_left: &mut f64,
    ) -> NewtonOutcome {
        let mut outcome = NewtonOutcome::default();
        if !self.newton_enabled() {
            return outcome;
        }
        let entry = state.clone();
        let max_step = self.settings.newton_max_step_rel * self.size_m();
        let fixed = SlipMapping::Fixed;
        (*max_t, *friction_left) = self.residual_as(state, ws, fixed);
        let mut norm = self.free_residual_norm(ws);
        // The iterate with the smallest residual so far: DR's start if
        // Newton gives up (see `newton_max_iter` in the settings).
        let mut best = (norm, state.positions_m.clone());
        let mut factor: Option<BlockLu> = None;
        // Where the factorisation in use was assembled (kept with it).
        let mut factor_at: Option<AssembledAt> = None;
        let dofs = self.free_dofs();
        let mut fresh = false;
        let mut revisions = 0;
        let failed = loop {
            let tol = self.tolerance_rel(*max_t, tol_rel);
            if self.max_free_residual(ws) <= tol {
                // The return mapping at this geometry says which joints
                // slide; if it agrees, this is the answer.
                (*max_t, *friction_left) = self.residual(state, ws);
                let tol = self.tolerance_rel(*max_t, tol_rel);
                if self.max_free_residual(ws) <= tol && *friction_left <= tol {
                    outcome.converged = true;
                    ws.counters.slip_state_revisions += revisions;
                    break None;
                }
                // The mapping disagrees with the slip states solved for:
                // adopt its states (an active-set step) and solve again.
                revisions += 1;
                if revisions > self.settings.newton_max_active_set_rounds {
                    break Some(NewtonGaveUp::SlipStateRounds);
                }
                (*max_t, *friction_left) = self.residual_as(state, ws, fixed);
                norm = self.free_residual_norm(ws);
                ws.recycle(factor.take());
                continue;
            }
            if outcome.iterations >= self.settings.newton_max_iter {
                break Some(NewtonGaveUp::IterationLimit);
            }
            let lu = match factor.take() {
                Some(lu) => lu,
                None => {
                    let Some(lu) = self.factorise_tangent(state, ws) else {
                        break Some(NewtonGaveUp::Singular);
                    };
                    fresh = true;
                    factor_at = Some((
                        state.joint_slip.clone(),
                        state.positions_m.clone(),
                        state.segment_rest_lengths_m.clone(),
                    ));
                    lu
                }
            };
            let rhs = dofs.gather(&ws.force);
            let step = lu.solve(&rhs);
            if !(step.dot(&rhs) > 0.0) {
                ws.recycle(Some(lu));
                if fresh {
                    break Some(NewtonGaveUp::NotDescent);
                }
                continue;
            }
            factor = Some(lu);
            let mut step = step;
            let longest = step.amax();
            if longest > max_step {
                step *= max_step / longest;
            }
            outcome.iterations += 1;
            let before = state.positions_m.clone();
            let mut accepted = None;
            let mut alpha = 1.0;
            for _ in 0..=self.settings.newton_max_halvings {
                state.positions_m.copy_from_slice(&before);
                dofs.scatter_add(&mut state.positions_m, &step, alpha);
                (*max_t, *friction_left) = self.residual_as(state, ws, fixed);
                let trial = self.free_residual_norm(ws);
                if trial < self.settings.newton_watchdog * norm {
                    accepted = Some(trial);
                    break;
                }
                alpha *= 0.5;
            }
            let Some(trial) = accepted else {
                if fresh {
                    break Some(NewtonGaveUp::LineSearch);
                }
                state.positions_m.copy_from_slice(&before);
                (*max_t, *friction_left) = self.residual_as(state, ws, fixed);
                ws.recycle(factor.take());
                continue;
            };
            if trial > 0.5 * norm {
                ws.recycle(factor.take());
            }
            fresh = false;
            norm = trial;
            if norm < best.0 {
                best = (norm, state.positions_m.clone());
            }
        };
        match (outcome.converged, factor, factor_at) {
            (true, Some(factors), Some((slip, positions_m, rest_m))) => {
                ws.drop_kept_tangent();
                ws.kept_tangent = Some(KeptTangent {
                    factors,
                    slip,
                    positions_m,
                    rest_m,
                });
            }
            (_, factor, _) => ws.recycle(factor),
        }
        if let Some(why) = failed {
            ws.counters.gave_up(why);
            // Hand DR the best iterate, unless the physical (return-mapped)
            // residual says the entry state is the better start.
            state.positions_m.copy_from_slice(&best.1);
            state.joint_slip.copy_from_slice(&entry.joint_slip);
            state
                .segment_rest_lengths_m
                .copy_from_slice(&entry.segment_rest_lengths_m);
            self.residual(state, ws);
            let best_norm = self.free_residual_norm(ws);
            let mut at_entry = entry.clone();
            self.residual(&mut at_entry, ws);
            if !(best_norm < self.free_residual_norm(ws)) {
                *state = at_entry;
            }
            (*max_t, *friction_left) = self.residual(state, ws);
        }
        outcome
    }

    /// The consistent tangent of `state`, assembled straight into the
    /// workspace's per-block storage and factorised there; `None` if
    /// singular.
    fn factorise_tangent(&self, state: &DeploymentState, ws: &mut Workspace) -> Option<BlockLu> {
        ws.counters.factorisations += 1;
        let mut k = ws.tangent_storage(self.tangent_layout());
        assemble_tangent_stiffness(self, state, JointMode::AsMapped, &mut k);
        BlockLu::factorise(k)
    }

    /// Whether a kept factorisation may stand in for the tangent of
    /// `state` in a predictor: assembled with the same joint slip states,
    /// at positions and rest lengths within [`KEPT_TANGENT_REL`] of the
    /// structure size. The predictor only supplies Newton's initial guess,
    /// so a tangent from the last Newton iterate instead of the converged
    /// state (they differ by Newton's last steps, micrometres) changes the
    /// guess at second order, and the answer not at all beyond the solver
    /// tolerance.
    fn tangent_still_fits(&self, kept: &KeptTangent, state: &DeploymentState) -> bool {
        let tol = KEPT_TANGENT_REL * self.size_m();
        kept.slip == state.joint_slip
            && kept
                .positions_m
                .iter()
                .zip(&state.positions_m)
                .all(|(a, b)| (a - b).amax() <= tol)
            && kept
                .rest_m
                .iter()
                .zip(&state.segment_rest_lengths_m)
                .all(|(a, b)| (a - b).abs() <= tol)
    }

    /// Euclidean norm of the out-of-balance force over the free DOFs, N.
    fn free_residual_norm(&self, ws: &Workspace) -> f64 {
        ws.force
            .iter()
            .zip(&self.structure.nodes)
            .map(|(r, n)| {
                (0..3)
                    .filter(|&a| !n.fixed[a])
                    .map(|a| r[a] * r[a])
                    .sum::<f64>()
            })
            .sum::<f64>()
            .sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::friction::JointFriction;
    use crate::model::stiffness::tangent_stiffness;
    use crate::model::RelaxSettings;
    use nalgebra::DMatrix;

    /// K = −∂R/∂x of the mapped residual, by central differences.
    fn finite_difference(model: &ForwardModel, state: &DeploymentState, h: f64) -> DMatrix<f64> {
        let mut ws = Workspace::default();
        // Prime the workspace: start of increment = `state`'s material.
        let mut probe = state.clone();
        model.prime(&mut probe, &mut ws);
        let dofs = model.free_dofs().clone();
        let mut k = DMatrix::zeros(dofs.count, dofs.count);
        for (node, rows) in dofs.index.iter().enumerate() {
            for a in 0..3 {
                let Some(col) = rows[a] else { continue };
                let mut f = [Vec::new(), Vec::new()];
                for (side, sign) in [1.0, -1.0].iter().enumerate() {
                    let mut s = probe.clone();
                    s.positions_m[node][a] += sign * h;
                    model.residual(&mut s, &mut ws);
                    f[side] = ws.force.clone();
                }
                for (i, r) in dofs.index.iter().enumerate() {
                    for b in 0..3 {
                        if let Some(row) = r[b] {
                            k[(row, col)] = -(f[0][i][b] - f[1][i][b]) / (2.0 * h);
                        }
                    }
                }
            }
        }
        k
    }

    /// The peer benchmark's N×N net (perimeter pinned, 1 m grid).
    fn square_net(n: usize) -> ForwardModel {
        let net = crate::design::square_net(&crate::design::SquareNetParameters {
            nodes_per_side: n,
            ..Default::default()
        })
        .unwrap();
        ForwardModel::new(net, JointFriction::frictionless(), RelaxSettings::default()).unwrap()
    }

    #[test]
    fn newton_is_chosen_by_the_cost_of_its_factorisation() {
        // The 11×11 net: one block of 9·9·3 = 243 DOFs, 2·11·10 = 220
        // cables, stored sparse. By hand: each free node couples to itself
        // and its free neighbours, 3×3 entries per pair; interior nodes
        // (7·7) have 4 free neighbours, edge nodes (4·7) 3, corners (4) 2.
        let net = square_net(11);
        let pairs = 7 * 7 * 5 + 4 * 7 * 4 + 4 * 3;
        let layout = net.tangent_layout();
        let pattern = layout.pattern(0).expect("the 11×11 net's block is sparse");
        assert_eq!(pattern.nonzeros(), 9 * pairs);
        let sparse = 0.06 * pattern.cholesky_flops() + 30.0 * (9 * pairs) as f64;
        let dense = 0.009 * 2.0 / 3.0 * 243f64.powi(3) + 2.0 * 243f64.powi(2) + 100.0 * 243.0;
        assert!(sparse < dense);
        let by_hand = sparse / (10.0 * 220.0);
        assert!((net.newton_cost_ratio() - by_hand).abs() < 1e-9 * by_hand);
        // The Cholesky flops lie between the no-fill bound (the lower
        // triangle's columns as they are) and the dense n³/3.
        let no_fill = 243.0 * (((9 * pairs + 243) / 2) as f64 / 243.0).powi(2);
        assert!(
            pattern.cholesky_flops() > no_fill && pattern.cholesky_flops() < 243f64.powi(3) / 3.0
        );
        assert!(!net.newton_enabled());
        // Its solve is then DR alone, and still converges.
        let mut state = net.reference_state();
        let r = net.relax(&mut state, &mut Workspace::default());
        assert!(r.status.is_converged());
        assert_eq!(r.newton_iterations, 0);
        // Newton where it wins by far (measured: the bridge increment 20×,
        // the 5×5 net 3.5× faster than DR) and where it is even (7×7).
        let bridge = ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap();
        for model in [&bridge, &square_net(5), &square_net(7)] {
            assert!(model.newton_enabled(), "{}", model.newton_cost_ratio());
        }
    }

    #[test]
    fn consistent_tangent_matches_finite_differences_of_the_mapped_residual() {
        let structure = reference_bridge(&BridgeParameters::default()).unwrap();
        for mu in [0.0, 0.2] {
            let model = ForwardModel::new(
                structure.clone(),
                JointFriction::constant(mu).unwrap(),
                RelaxSettings::default(),
            )
            .unwrap();
            // Reel cable 0 in by 5 mm with joints stuck: its first joint must slide.
            let mut state = model.reference_state();
            let first = state.segment_offsets[0];
            state.segment_rest_lengths_m[first] -= 0.005;
            let mut ws = Workspace::default();
            let mut mapped = state.clone();
            model.prime(&mut mapped, &mut ws);
            assert!(mapped
                .joint_slip
                .iter()
                .any(|s| *s != crate::model::JointSlip::Stuck));
            let (k, _) = tangent_stiffness(&model, &mapped, JointMode::AsMapped);
            let fd = finite_difference(&model, &state, 1e-6);
            // Entry-wise: 1e-3 relative (truncation error of the central
            // difference over h = 1e-6 m on members whose stiffness changes
            // over millimetres), plus the noise of the friction mapping,
            // which stops within 1e-2 of the force tolerance (~1e-5 N):
            // 1e-5 N / 2e-6 m = 5 N/m; 20 N/m with margin.
            let mut worst = 0.0f64;
            for (a, b) in k.iter().zip(fd.iter()) {
                worst = worst.max((a - b).abs() / (1e-3 * b.abs() + 20.0));
            }
            assert!(worst <= 1.0, "μ = {mu}: error {worst} of the allowance");
        }
    }

    /// Applies `commands` in turn (1 cm increments) from the reference
    /// state of the μ = 0.2 bridge with `settings`: the state after each
    /// command, and the Newton iterations, residual evaluations and
    /// increments handed to DR over all.
    fn run_commands(
        settings: RelaxSettings,
        commands: &[Vec<f64>],
    ) -> (Vec<DeploymentState>, usize, usize, usize) {
        let model = ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::constant(0.2).unwrap(),
            settings,
        )
        .unwrap();
        let mut ws = Workspace::default();
        let mut state = model.reference_state();
        let mut states = Vec::new();
        let mut newton = 0;
        for cmd in commands {
            let r = model
                .apply_payout(&mut state, &mut ws, cmd, 0.01, &mut ())
                .unwrap();
            assert!(r.status.is_converged(), "{r:?}");
            newton += r.newton_iterations;
            states.push(state.clone());
        }
        let counters = ws.newton_counters();
        (
            states,
            newton,
            counters.residual_evaluations,
            counters.increments_to_dr,
        )
    }

    #[test]
    fn loose_intermediate_steps_give_the_same_answer_in_fewer_iterations() {
        let n = 10;
        let one = |c: usize, d: f64| {
            let mut v = vec![0.0; n];
            v[c] = d;
            v
        };
        // Reel-ins, which Newton solves with several continuation steps
        // and slip-state revisions (a single-cable payout goes to DR).
        let commands = vec![one(0, -0.01), vec![-0.01; n], one(7, -0.01), one(4, -0.01)];
        // Slip-event sub-steps off (whatever the default): they locate a
        // reversal to a sub-step
        // (1.25 mm here), and a 1000× tighter solve may find it one
        // sub-step apart (64 µm measured), a path difference, not the
        // solver error this test compares with.
        let defaults = RelaxSettings {
            slip_event_substeps_enable: false,
            ..RelaxSettings::default()
        };
        assert!(defaults.newton_tol_continuation_rel > defaults.tol_force_rel);
        // The feature off: every continuation step to the full tolerance.
        let full = RelaxSettings {
            newton_tol_continuation_rel: defaults.tol_force_rel,
            ..defaults.clone()
        };
        // The answers' own error: against a solve 1000× tighter.
        let tight = RelaxSettings {
            tol_force_rel: 1e-3 * defaults.tol_force_rel,
            newton_tol_continuation_rel: 1e-3 * defaults.tol_force_rel,
            ..defaults.clone()
        };
        let (reference, newton_full, residuals_full, dr_full) = run_commands(full, &commands);
        let (precise, ..) = run_commands(tight, &commands);
        let (loose, newton_loose, residuals_loose, dr_loose) = run_commands(defaults, &commands);
        let (mut worst, mut solver_error) = (0.0f64, 0.0f64);
        for ((a, b), c) in loose.iter().zip(&reference).zip(&precise) {
            for ((p, q), r) in a.positions_m.iter().zip(&b.positions_m).zip(&c.positions_m) {
                worst = worst.max((p - q).amax());
                solver_error = solver_error.max((q - r).amax());
            }
        }
        eprintln!("newton {newton_full} -> {newton_loose}, residuals {residuals_full} -> {residuals_loose}, dr {dr_full} -> {dr_loose}, diff {worst:e}, solver error {solver_error:e}");
        // Both answers meet the same force tolerance, so each lies within
        // the solver's error of the exact answer (estimated by the tight
        // solve), and they within twice it of each other.
        assert!(
            worst <= 2.0 * solver_error,
            "{worst:e} m vs solver error {solver_error:e} m"
        );
        assert!(solver_error < 1e-5, "{solver_error:e} m");
        // Fewer iterations, and no increment lost to DR.
        assert_eq!(dr_loose, dr_full);
        assert!(
            newton_loose < newton_full,
            "{newton_loose} vs {newton_full}"
        );
        assert!(
            residuals_loose < residuals_full,
            "{residuals_loose} vs {residuals_full}"
        );
    }
}
