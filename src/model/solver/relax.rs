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
//!
//! DR converges at the rate of the stiffest to the softest mode, but its
//! return mapping settles the joints' slip states within its first
//! hundred or so iterations, which is where Newton fails (slip states that
//! cycle between its active-set rounds). So at a reset, once enough DR
//! iterations have passed, Newton is tried from the DR iterate with the
//! states DR holds (`RelaxSettings::dr_newton_restart_enable`); its answer
//! meets the same test, and a failed try leaves DR where it was.

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
    /// Dynamic relaxation first (e.g. right after Newton has been tried on
    /// the same increment), handing back to Newton only once DR has
    /// settled the slip states (`RelaxSettings::dr_newton_restart_enable`).
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
        // Newton from a DR iterate (`dr_newton_restart_enable`): when next,
        // and the DR iterations to wait after a failed try.
        let restart_newton = s.dr_newton_restart_enable && self.newton_enabled();
        let mut wait = s.dr_newton_restart_after_iter;
        let mut next_newton = wait;
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
                if restart_newton && report.iterations >= next_newton {
                    // The DR iterate and its residual, to go on from
                    // exactly where DR was if Newton fails.
                    let dr_iterate = (
                        state.clone(),
                        ws.force.clone(),
                        ws.last_max_t,
                        max_t,
                        friction_left,
                    );
                    let tried =
                        self.newton(state, ws, s.tol_force_rel, &mut max_t, &mut friction_left);
                    report.newton_iterations += tried.iterations;
                    // Confirmed by the return mapping, the test at the
                    // loop's top passes; an answer DR would have called a
                    // runaway mechanism is not one.
                    if tried.converged && !self.ran_away(state, ws, max_disp) {
                        ws.counters.restarts_from_dr_converged += 1;
                        continue;
                    }
                    ws.counters.restarts_from_dr_failed += 1;
                    let (positions, force, last_max_t, t, left) = dr_iterate;
                    *state = positions;
                    ws.force.copy_from_slice(&force);
                    ws.last_max_t = last_max_t;
                    (max_t, friction_left) = (t, left);
                    wait = wait.saturating_mul(2);
                    next_newton = report.iterations.saturating_add(wait);
                }
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

#[cfg(test)]
mod tests {
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::solver::NewtonCounters;
    use crate::model::{DeploymentState, ForwardModel, JointFriction, RelaxSettings, Workspace};

    /// The bridge at μ = 0.2 over 2 cm cable seats, folded 40 cm, then
    /// reeled in by two 5 cm commands: the states after each of the three
    /// and the solver's counters over them.
    fn seated_deployment(settings: RelaxSettings) -> (Vec<DeploymentState>, NewtonCounters) {
        let model = ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::constant(0.2).unwrap(),
            settings,
        )
        .unwrap()
        .with_cable_seats(0.02)
        .unwrap();
        let n = model.structure().continuous_cables.len();
        let mut ws = Workspace::default();
        let mut state = model.reference_state();
        let fold = model
            .apply_payout(&mut state, &mut ws, &vec![0.4; n], 0.01, &mut ())
            .unwrap();
        assert!(fold.status.is_converged(), "{fold:?}");
        let mut states = vec![state.clone()];
        for _ in 0..2 {
            let r = model
                .apply_payout(&mut state, &mut ws, &vec![-0.05; n], 0.01, &mut ())
                .unwrap();
            assert!(r.status.is_converged(), "{r:?}");
            states.push(state.clone());
        }
        (states, ws.newton_counters())
    }

    /// Regression (twelfth session): where Newton gave up on an increment,
    /// DR finished it alone at the slow rate of the bridge's stiff and soft
    /// modes, thousands of iterations after its first few hundred had
    /// settled the joints' slip states. Newton tried again from a DR
    /// iterate finishes those solves, with the same answer to the solver's
    /// tolerance. (Since the seat arcs are predicted inside increments,
    /// fourteenth session, the two commands need no DR, where one of their
    /// increments did; three increments of the fold now do, where none
    /// did, so the path checked includes the fold.)
    #[test]
    fn dr_hands_a_solve_back_to_newton_once_its_slip_states_settle() {
        let on = RelaxSettings::default();
        assert!(on.dr_newton_restart_enable);
        let off = RelaxSettings {
            dr_newton_restart_enable: false,
            ..on.clone()
        };
        // The answers' own error: against a solve 1000× tighter.
        let tight = RelaxSettings {
            tol_force_rel: 1e-3 * on.tol_force_rel,
            newton_tol_continuation_rel: 1e-3 * on.tol_force_rel,
            ..off.clone()
        };
        let (with_restart, c_on) = seated_deployment(on);
        let (dr_alone, c_off) = seated_deployment(off);
        let (precise, _) = seated_deployment(tight);
        let (mut worst, mut solver_error, mut restart_error) = (0.0f64, 0.0f64, 0.0f64);
        for ((a, b), c) in with_restart.iter().zip(&dr_alone).zip(&precise) {
            for ((p, q), r) in a.positions_m.iter().zip(&b.positions_m).zip(&c.positions_m) {
                worst = worst.max((p - q).amax());
                solver_error = solver_error.max((q - r).amax());
                restart_error = restart_error.max((p - r).amax());
            }
        }
        eprintln!(
            "difference {worst:e} m, solver error {solver_error:e} m (restart {restart_error:e} m); DR after Newton {} -> {}",
            c_off.dr_iterations_after_newton, c_on.dr_iterations_after_newton
        );
        // Both meet the same force test, so each lies within the solver's
        // error of the exact answer and they within twice it of each other.
        assert!(
            worst <= 2.0 * solver_error,
            "{worst:e} m vs solver error {solver_error:e} m"
        );
        // And the restart's answer, to the same force test, is as close to
        // the exact one as DR's.
        assert!(
            restart_error <= solver_error,
            "{restart_error:e} m vs solver error {solver_error:e} m"
        );
        assert!(solver_error < 1e-5, "{solver_error:e} m");
        // The same increments went to DR; with the restart most of their
        // DR iterations are saved.
        assert!(c_off.increments_to_dr > 0, "{c_off:?}");
        assert_eq!(c_on.increments_to_dr, c_off.increments_to_dr);
        assert_eq!(c_off.restarts_from_dr_converged, 0);
        assert!(c_on.restarts_from_dr_converged > 0, "{c_on:?}");
        assert!(
            2 * c_on.dr_iterations_after_newton < c_off.dr_iterations_after_newton,
            "{} vs {} DR iterations",
            c_on.dr_iterations_after_newton,
            c_off.dr_iterations_after_newton
        );
    }
}
