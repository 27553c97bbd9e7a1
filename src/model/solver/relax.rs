//! Dynamic relaxation with kinetic damping (Barnes), friction-aware.
//!
//! Pseudo-dynamics on fictitious masses: `v += Δt·R/m`, `x += Δt·v`, where
//! `R` is the out-of-balance force on each free degree of freedom. Kinetic
//! damping: when the kinetic energy stops rising, the state steps back to the
//! estimated energy peak, velocities are zeroed and the motion restarts.
//! Continuous-cable sliding is relaxed every iteration by the return mapping
//! of [`crate::model::sliding`], so material moves only when a joint's capstan cone
//! is exceeded.
//!
//! Fictitious masses make the explicit step stable by Gershgorin's bound on
//! the tangent stiffness: per node `m = Δt²/2 · Σ 2·(k·‖e‖∞·‖e‖₁ + 2|T|/L)`
//! over the attached members (axial stiffness `k`, unit direction `e`,
//! tension `T`, length `L`), so `Δt²·λ_max(M⁻¹K) ≤ 2`, a margin of 2 on the
//! central-difference limit of 4. The same mass serves all three axes.

use nalgebra::Vector3;

use super::forward_model::ForwardModel;
use super::status::{RelaxReport, RelaxStatus};
use super::workspace::Workspace;
use crate::model::state::DeploymentState;

/// Which methods a solve uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolveMode {
    /// Newton with the consistent friction tangent (up to
    /// `newton_max_iter` iterations, where the structure is small enough),
    /// then DR from its best iterate: the default.
    NewtonThenDr,
    /// Dynamic relaxation alone (e.g. right after Newton has been tried on
    /// the same increment).
    DrOnly,
}

impl ForwardModel {
    /// Relaxes `state` to equilibrium in place, warm-started from it.
    ///
    /// Joints keep their slip state; callers applying a new command increment
    /// first call [`DeploymentState::stick_all_joints`]. A state that is
    /// already in equilibrium returns after zero iterations.
    pub fn relax(&self, state: &mut DeploymentState, ws: &mut Workspace) -> RelaxReport {
        self.relax_with(state, ws, SolveMode::NewtonThenDr)
    }

    /// [`Self::relax`] in an explicit [`SolveMode`].
    pub fn relax_with(
        &self,
        state: &mut DeploymentState,
        ws: &mut Workspace,
        mode: SolveMode,
    ) -> RelaxReport {
        let n_nodes = self.structure.nodes.len();
        ws.fit(n_nodes, state.segment_rest_lengths_m.len());
        let s = &self.settings;
        let dt = s.time_step;
        let max_disp = s.max_displacement_rel * self.size_m;
        ws.start.copy_from_slice(&state.positions_m);
        ws.start_increment(state);
        ws.velocity.fill(Vector3::zeros());

        let (mut max_t, mut friction_left) = self.residual(state, ws);
        let newton_iterations = if mode == SolveMode::NewtonThenDr {
            self.newton(state, ws, s.tol_force_rel, &mut max_t, &mut friction_left)
                .iterations
        } else {
            0
        };
        self.update_masses(state, ws);
        let mut report = RelaxReport {
            status: RelaxStatus::IterationLimit,
            iterations: 0,
            newton_iterations,
            resets: 0,
            max_residual_n: 0.0,
            max_friction_residual_n: friction_left,
            tolerance_n: 0.0,
        };
        let mut restart = true;
        let mut ke_prev = 0.0;
        let mut resets_since_mass = 0;
        loop {
            let tol = self.tolerance(max_t);
            let max_r = self.max_free_residual(ws);
            report.max_residual_n = max_r;
            report.max_friction_residual_n = friction_left;
            report.tolerance_n = tol;
            // Converged means finite: a NaN or infinite residual, member
            // force or friction residual (e.g. a node at 1e300 m) is a
            // divergence, never a pass of the test below.
            if !(max_r.is_finite() && max_t.is_finite() && friction_left.is_finite()) {
                report.status = RelaxStatus::Diverged;
                return report;
            }
            if max_r <= tol && friction_left <= tol {
                report.status = if self.strain_is_plausible(state) {
                    RelaxStatus::Converged
                } else {
                    RelaxStatus::ImplausibleStrain
                };
                return report;
            }
            if report.iterations >= s.max_iter {
                report.status = RelaxStatus::IterationLimit;
                return report;
            }
            report.iterations += 1;

            // Leapfrog step; after a restart the first step is a half step.
            let h = if restart { 0.5 * dt } else { dt };
            restart = false;
            let mut ke = 0.0;
            for i in 0..n_nodes {
                let m = &ws.mass[i];
                let v = &mut ws.velocity[i];
                let r = ws.force[i];
                *v += h * r.component_div(m).component_mul(&self.free_mask[i]);
                ke += m.component_mul(v).dot(v);
                state.positions_m[i] += dt * *v;
            }
            if ke < ke_prev {
                // Past the kinetic-energy peak: step back to it (Barnes'
                // quadratic estimate) and restart from rest.
                for i in 0..n_nodes {
                    let back = 1.5 * dt * ws.velocity[i]
                        - 0.5
                            * dt
                            * dt
                            * ws.force[i]
                                .component_div(&ws.mass[i])
                                .component_mul(&self.free_mask[i]);
                    state.positions_m[i] -= back;
                    ws.velocity[i] = Vector3::zeros();
                }
                report.resets += 1;
                resets_since_mass += 1;
                restart = true;
                ke_prev = 0.0;
                (max_t, friction_left) = self.residual(state, ws);
                if resets_since_mass >= s.mass_update_resets {
                    self.update_masses(state, ws);
                    resets_since_mass = 0;
                }
                if self.ran_away(state, ws, max_disp) {
                    report.status = RelaxStatus::UnstableMechanism;
                    report.max_residual_n = self.max_free_residual(ws);
                    return report;
                }
            } else {
                ke_prev = ke;
                (max_t, friction_left) = self.residual(state, ws);
                if report.iterations.is_multiple_of(256) && self.ran_away(state, ws, max_disp) {
                    report.status = RelaxStatus::UnstableMechanism;
                    report.max_residual_n = self.max_free_residual(ws);
                    return report;
                }
            }
        }
    }

    /// The converged report of an increment with no command, if `state`
    /// (joints stuck) is in equilibrium as it is: the residual with the
    /// return mapping, one evaluation, no factorisation. `state` then holds
    /// what that mapping left (material moved within the tolerance), as
    /// [`Self::relax`] would after zero iterations. `None`, with `state`
    /// untouched, where there is work to do.
    pub(super) fn balanced_as_is(
        &self,
        state: &mut DeploymentState,
        ws: &mut Workspace,
    ) -> Option<RelaxReport> {
        let mut probe = state.clone();
        probe.stick_all_joints();
        ws.fit(
            self.structure.nodes.len(),
            probe.segment_rest_lengths_m.len(),
        );
        ws.start_increment(&probe);
        let (max_t, friction_left) = self.residual(&mut probe, ws);
        let tol = self.tolerance(max_t);
        let max_r = self.max_free_residual(ws);
        // `!(… > …)` would let a NaN through; these comparisons do not.
        let balanced = max_t.is_finite() && max_r <= tol && friction_left <= tol;
        if !(balanced && self.strain_is_plausible(&probe)) {
            return None;
        }
        *state = probe;
        Some(RelaxReport {
            status: RelaxStatus::Converged,
            iterations: 0,
            newton_iterations: 0,
            resets: 0,
            max_residual_n: max_r,
            max_friction_residual_n: friction_left,
            tolerance_n: tol,
        })
    }

    fn update_masses(&self, state: &DeploymentState, ws: &mut Workspace) {
        let x = &state.positions_m;
        ws.mass.fill(Vector3::zeros());
        for e in &self.elements {
            let d = x[e.b] - x[e.a];
            let l = d.norm();
            let axial = e.law.at(l, &state.segment_rest_lengths_m);
            let (k, t) = (axial.stiffness_n_per_m, axial.elastic_n);
            let u = (d / l).abs();
            // Worst axis of the Gershgorin row sum, used on all three axes:
            // members rotate during a solve, and a mass that suited the old
            // direction (zero out of plane for a flat net) would go unstable.
            let row = k * (u.x + u.y + u.z) * u.max() + 2.0 * t.abs() / l;
            ws.mass[e.a] += Vector3::repeat(row);
            ws.mass[e.b] += Vector3::repeat(row);
        }
        // m = Δt²/2 · Σ 2·(…) = Δt² · Σ(…); a tiny floor keeps a node whose
        // members are all axis-aligned from having a zero mass on an axis.
        let dt2 = self.settings.time_step * self.settings.time_step * self.settings.mass_factor;
        let mut largest = 0.0f64;
        for m in ws.mass.iter() {
            largest = largest.max(m.max());
        }
        let floor = 1e-9 * largest.max(1e-12);
        for m in ws.mass.iter_mut() {
            *m = (dt2 * *m).map(|v| v.max(floor * dt2));
        }
    }
}
