//! Dynamic relaxation with kinetic damping (Barnes), friction-aware.
//!
//! Pseudo-dynamics on fictitious masses: `v += Δt·R/m`, `x += Δt·v`, where
//! `R` is the out-of-balance force on each free degree of freedom. Kinetic
//! damping: when the kinetic energy stops rising, the state steps back to the
//! estimated energy peak, velocities are zeroed and the motion restarts.
//! Continuous-cable sliding is relaxed every iteration by the return mapping
//! of [`super::sliding`], so material moves only when a joint's capstan cone
//! is exceeded.
//!
//! Fictitious masses make the explicit step stable by Gershgorin's bound on
//! the tangent stiffness: per node `m = Δt²/2 · Σ 2·(k·‖e‖∞·‖e‖₁ + 2|T|/L)`
//! over the attached members (axial stiffness `k`, unit direction `e`,
//! tension `T`, length `L`), so `Δt²·λ_max(M⁻¹K) ≤ 2`, a margin of 2 on the
//! central-difference limit of 4. The same mass serves all three axes.

use nalgebra::Vector3;

use crate::model::friction::JointFriction;
use crate::model::sliding::{map_cable, map_cable_with_slip, segment_tension, IncrementStart};
use crate::model::state::{DeploymentState, JointSlip};
use crate::model::structure::Structure;
#[allow(unused_imports)] // named in docs
use crate::numerics::BlockLu;
use crate::numerics::FreeDofs;

/// Settings of the DR solver. Defaults are what the reference bridge needs
/// for 0.01 mm-level positions; every field says what changing it does.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RelaxSettings {
    /// Largest number of DR iterations per solve. Default 200 000.
    /// A solve that reaches it reports [`RelaxStatus::IterationLimit`].
    pub max_iter: usize,
    /// Out-of-balance force tolerance relative to the largest member force.
    /// Default 1e-6. Smaller: more accurate, more iterations (about a
    /// constant number per decade).
    pub tol_force_rel: f64,
    /// Absolute floor of the force tolerance, N. Default 1e-9, so that an
    /// unloaded structure still has a finite tolerance.
    pub tol_force_abs: f64,
    /// Fictitious time step Δt, s. Default 1. Masses scale with Δt², so this
    /// only rescales velocities; it is kept for readers of Barnes' papers.
    pub time_step: f64,
    /// Safety factor on the Gershgorin fictitious masses. Default 1.0 (which
    /// already holds a factor two of margin). Raise it if a solve diverges.
    pub mass_factor: f64,
    /// Fictitious masses are recomputed after this many kinetic-damping
    /// resets, because geometry and tensions change. Default 16.
    pub mass_update_resets: usize,
    /// A solve that moves any node farther than this fraction of the
    /// structure's bounding-box diagonal stops with
    /// [`RelaxStatus::UnstableMechanism`]. Default 0.5.
    pub max_displacement_rel: f64,
    /// Newton–Raphson iterations per solve before DR takes over, with the
    /// consistent tangent of the friction mapping ([`super::stiffness`]).
    /// Default 12 (a converging solve takes 3 to 9);
    /// 0 gives pure DR. Newton reaches the tolerance in a few iterations
    /// where DR needs thousands; DR takes over from the best Newton iterate
    /// whenever Newton stalls (slackening members, loss of stability), and
    /// the convergence test is the same either way.
    pub newton_max_iter: usize,
    /// Newton is skipped on structures with more free degrees of freedom
    /// than this (its dense factorisation grows with their cube). Default
    /// 1500.
    pub newton_max_dofs: usize,
    /// Largest Newton step, as a fraction of the bounding-box diagonal;
    /// longer steps are shortened. Default 0.05: one step may not fold the
    /// structure into another equilibrium.
    pub newton_max_step_rel: f64,
}

impl Default for RelaxSettings {
    fn default() -> Self {
        RelaxSettings {
            max_iter: 200_000,
            tol_force_rel: 1e-6,
            tol_force_abs: 1e-9,
            time_step: 1.0,
            mass_factor: 1.0,
            mass_update_resets: 16,
            max_displacement_rel: 0.5,
            newton_max_iter: 12,
            newton_max_dofs: 1500,
            newton_max_step_rel: 0.05,
        }
    }
}

/// A setting outside its admissible range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("solver setting `{field}` = {value}: {expected}")]
pub struct SettingsError {
    /// The field, as named in [`RelaxSettings`].
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// What it must be.
    pub expected: &'static str,
}

impl RelaxSettings {
    /// Checks every field against its admissible range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let check = |field: &'static str, value: f64, ok: bool, expected: &'static str| {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(SettingsError {
                    field,
                    value,
                    expected,
                })
            }
        };
        check("max_iter", self.max_iter as f64, true, "a count")?;
        check(
            "tol_force_rel",
            self.tol_force_rel,
            self.tol_force_rel > 0.0 && self.tol_force_rel <= 1e-2,
            "in (0, 1e-2]: a looser tolerance is no equilibrium",
        )?;
        check(
            "tol_force_abs",
            self.tol_force_abs,
            self.tol_force_abs > 0.0 && self.tol_force_abs <= 1.0,
            "in (0, 1] N",
        )?;
        check(
            "time_step",
            self.time_step,
            self.time_step > 0.0,
            "positive",
        )?;
        check(
            "mass_factor",
            self.mass_factor,
            self.mass_factor >= 1.0,
            "at least 1 (below 1 the explicit step is unstable)",
        )?;
        check(
            "mass_update_resets",
            self.mass_update_resets as f64,
            self.mass_update_resets >= 1,
            "at least 1",
        )?;
        check(
            "max_displacement_rel",
            self.max_displacement_rel,
            self.max_displacement_rel > 0.0,
            "positive",
        )?;
        check(
            "newton_max_step_rel",
            self.newton_max_step_rel,
            self.newton_max_step_rel > 0.0 && self.newton_max_step_rel <= 1.0,
            "in (0, 1]",
        )?;
        Ok(())
    }
}

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RelaxStatus {
    /// Node out-of-balance forces and joint friction residuals are within
    /// tolerance.
    Converged,
    /// `max_iter` reached before convergence; the state is the last iterate.
    IterationLimit,
    /// A position or force became NaN or infinite; the state is unusable.
    Diverged,
    /// Nodes moved farther than `max_displacement_rel` allows: the structure
    /// is a mechanism in this configuration (lost prestress, slack cables).
    UnstableMechanism,
}

impl RelaxStatus {
    /// `true` only for [`RelaxStatus::Converged`].
    pub fn is_converged(self) -> bool {
        self == RelaxStatus::Converged
    }

    /// Short name, as in result files: `converged`, `iteration_limit`,
    /// `diverged`, `unstable_mechanism`.
    pub fn as_str(self) -> &'static str {
        match self {
            RelaxStatus::Converged => "converged",
            RelaxStatus::IterationLimit => "iteration_limit",
            RelaxStatus::Diverged => "diverged",
            RelaxStatus::UnstableMechanism => "unstable_mechanism",
        }
    }

    /// Plain words for the command line.
    pub fn describe(self) -> &'static str {
        match self {
            RelaxStatus::Converged => "converged",
            RelaxStatus::IterationLimit => "iteration limit reached before convergence",
            RelaxStatus::Diverged => "diverged (non-finite positions or forces)",
            RelaxStatus::UnstableMechanism => {
                "unstable mechanism (nodes ran away: prestress lost or cables slack)"
            }
        }
    }

    /// Severity order: converged < iteration limit < mechanism < diverged.
    pub fn severity(self) -> u8 {
        match self {
            RelaxStatus::Converged => 0,
            RelaxStatus::IterationLimit => 1,
            RelaxStatus::UnstableMechanism => 2,
            RelaxStatus::Diverged => 3,
        }
    }
}

/// The outcome of one solve, with its final residuals.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RelaxReport {
    /// How it ended.
    pub status: RelaxStatus,
    /// DR iterations taken.
    pub iterations: usize,
    /// Newton iterations taken before DR.
    pub newton_iterations: usize,
    /// Kinetic-damping resets.
    pub resets: usize,
    /// Largest out-of-balance force on a free node at the end, N.
    pub max_residual_n: f64,
    /// Largest unbalanced joint friction (capstan violation) at the end, N.
    pub max_friction_residual_n: f64,
    /// The force tolerance that applied, N.
    pub tolerance_n: f64,
}

/// A structure with its joint friction and solver settings: the forward model.
#[derive(Debug, Clone)]
///
/// Its parts are read-only once built, so the element list and other
/// caches derived from them can never go stale; build a new model to change
/// one.
pub struct ForwardModel {
    pub(in crate::model) structure: Structure,
    pub(in crate::model) friction: JointFriction,
    pub(in crate::model) settings: RelaxSettings,
    elements: Vec<Element>,
    external_n: Vec<Vector3<f64>>,
    free_mask: Vec<Vector3<f64>>,
    size_m: f64,
    free_dofs: FreeDofs,
    dof_blocks: Vec<Vec<usize>>,
}

/// A two-node force element: a member or a continuous-cable segment.
#[derive(Debug, Clone, Copy)]
struct Element {
    a: usize,
    b: usize,
    law: ElementLaw,
}

#[derive(Debug, Clone, Copy)]
enum ElementLaw {
    /// `T = k·(L − L0)`, tension-only if flagged.
    Linear {
        stiffness_n_per_m: f64,
        rest_m: f64,
        tension_only: bool,
    },
    /// Segment `index` of the flat segment list: `T = EA·(L − s)/s`, tension only.
    Segment { ea_n: f64, index: usize },
}

/// Reusable buffers for [`ForwardModel::relax`]; one per thread.
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    pub(super) force: Vec<Vector3<f64>>,
    velocity: Vec<Vector3<f64>>,
    mass: Vec<Vector3<f64>>,
    start: Vec<Vector3<f64>>,
    seg_len: Vec<f64>,
    seg_dir: Vec<Vector3<f64>>,
    rest_start: Vec<f64>,
    slip_start: Vec<JointSlip>,
    /// Largest member force at the last residual evaluation, N.
    last_max_t: f64,
    /// When set, [`ForwardModel::residual`] keeps the state's joint slip
    /// states and solves the material distribution for them (Newton's
    /// active-set phase) instead of running the return mapping.
    pub(super) slip_fixed: bool,
    /// Continuation step (fraction of an increment) that last succeeded.
    pub(super) continuation_step: f64,
}

impl Workspace {
    /// Records `state`'s material and slip as the start of an increment.
    pub(super) fn start_increment(&mut self, state: &DeploymentState) {
        self.fit(state.positions_m.len(), state.segment_rest_lengths_m.len());
        self.rest_start
            .copy_from_slice(&state.segment_rest_lengths_m);
        self.slip_start.copy_from_slice(&state.joint_slip);
    }

    pub(super) fn fit(&mut self, nodes: usize, segments: usize) {
        self.force.resize(nodes, Vector3::zeros());
        self.velocity.resize(nodes, Vector3::zeros());
        self.mass.resize(nodes, Vector3::zeros());
        self.start.resize(nodes, Vector3::zeros());
        self.seg_len.resize(segments, 0.0);
        self.seg_dir.resize(segments, Vector3::zeros());
        self.rest_start.resize(segments, 0.0);
        self.slip_start.resize(segments, JointSlip::Stuck);
    }
}

/// Forces in every member and segment of a state.
#[derive(Debug, Clone, PartialEq)]
pub struct MemberForces {
    /// Axial force of each member (tension positive), N, as [`Structure::members`].
    pub member_n: Vec<f64>,
    /// Tension of each continuous-cable segment, N, flat as the state's segments.
    pub segment_n: Vec<f64>,
    /// Current length of each member, m.
    pub member_length_m: Vec<f64>,
    /// Current length of each segment, m.
    pub segment_length_m: Vec<f64>,
    /// Support reaction at each node (zero on free DOFs), N.
    pub reaction_n: Vec<Vector3<f64>>,
}

impl ForwardModel {
    /// Builds the model; cheap, and it precomputes the element list. The
    /// structure and friction are valid by construction; the settings are
    /// checked here.
    pub fn new(
        structure: Structure,
        friction: JointFriction,
        settings: RelaxSettings,
    ) -> Result<Self, SettingsError> {
        settings.validate()?;
        let mut elements = Vec::with_capacity(structure.members.len() + structure.segment_count());
        for m in &structure.members {
            elements.push(Element {
                a: m.nodes[0],
                b: m.nodes[1],
                law: ElementLaw::Linear {
                    stiffness_n_per_m: m.kind.axial_stiffness(m.rest_length_m),
                    rest_m: m.rest_length_m,
                    tension_only: m.kind.is_tension_only(),
                },
            });
        }
        let mut index = 0;
        for c in &structure.continuous_cables {
            for w in c.path.windows(2) {
                elements.push(Element {
                    a: w[0],
                    b: w[1],
                    law: ElementLaw::Segment {
                        ea_n: c.ea_n,
                        index,
                    },
                });
                index += 1;
            }
        }
        let external_n = structure
            .nodes
            .iter()
            .map(|n| n.mass_kg * structure.gravity_m_per_s2 + n.load_n)
            .collect();
        let free_mask = structure
            .nodes
            .iter()
            .map(|n| n.fixed.map(|f| if f { 0.0 } else { 1.0 }).into())
            .collect();
        let (mut lo, mut hi) = (Vector3::repeat(f64::MAX), Vector3::repeat(f64::MIN));
        for n in &structure.nodes {
            lo = lo.inf(&n.position_m);
            hi = hi.sup(&n.position_m);
        }
        let size_m = (hi - lo).norm().max(1e-3);
        let free_dofs = FreeDofs::from_fixed(structure.nodes.iter().map(|n| &n.fixed));
        let dof_blocks = free_dofs.blocks(
            structure.members.iter().map(|m| m.nodes).chain(
                structure
                    .continuous_cables
                    .iter()
                    .flat_map(|c| c.path.windows(2).map(|w| [w[0], w[1]])),
            ),
        );
        Ok(ForwardModel {
            structure,
            friction,
            settings,
            elements,
            external_n,
            free_mask,
            size_m,
            free_dofs,
            dof_blocks,
        })
    }

    /// The structure.
    pub fn structure(&self) -> &Structure {
        &self.structure
    }

    /// Joint friction of all continuous cables.
    pub fn friction(&self) -> &JointFriction {
        &self.friction
    }

    /// Solver settings.
    pub fn settings(&self) -> &RelaxSettings {
        &self.settings
    }

    /// The as-built state of this model's structure.
    pub fn reference_state(&self) -> DeploymentState {
        DeploymentState::reference(&self.structure)
    }

    /// Relaxes `state` to equilibrium in place, warm-started from it.
    ///
    /// Joints keep their slip state; callers applying a new command increment
    /// first call [`DeploymentState::stick_all_joints`]. A state that is
    /// already in equilibrium returns after zero iterations.
    pub fn relax(&self, state: &mut DeploymentState, ws: &mut Workspace) -> RelaxReport {
        self.relax_from(state, ws, true)
    }

    /// [`Self::relax`], with the Newton phase optional (skipped by callers
    /// that have just tried Newton on the same increment).
    pub(super) fn relax_from(
        &self,
        state: &mut DeploymentState,
        ws: &mut Workspace,
        try_newton: bool,
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
        let newton_iterations = if try_newton {
            self.newton(state, ws, &mut max_t, &mut friction_left)
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
            if !max_r.is_finite() {
                report.status = RelaxStatus::Diverged;
                return report;
            }
            if max_r <= tol && friction_left <= tol {
                report.status = RelaxStatus::Converged;
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
                if report.iterations % 256 == 0 && self.ran_away(state, ws, max_disp) {
                    report.status = RelaxStatus::UnstableMechanism;
                    report.max_residual_n = self.max_free_residual(ws);
                    return report;
                }
            }
        }
    }

    /// Makes `state` the start of an increment in `ws` and maps sliding for
    /// its geometry, leaving its residual in `ws.force` (for tests).
    #[cfg(test)]
    pub(super) fn prime(&self, state: &mut DeploymentState, ws: &mut Workspace) {
        ws.start_increment(state);
        self.residual(state, ws);
    }

    /// Number of free degrees of freedom.
    pub(super) fn free_dof_count(&self) -> usize {
        self.structure
            .nodes
            .iter()
            .map(|n| n.fixed.iter().filter(|f| !**f).count())
            .sum()
    }

    /// Numbering of the free degrees of freedom, as in every matrix the
    /// model builds.
    pub fn free_dofs(&self) -> &FreeDofs {
        &self.free_dofs
    }

    /// Free DOFs in blocks that no member couples (see [`BlockLu`]).
    pub(super) fn dof_blocks(&self) -> &[Vec<usize>] {
        &self.dof_blocks
    }

    /// Bounding-box diagonal of the as-built structure, m.
    pub(super) fn size_m(&self) -> f64 {
        self.size_m
    }

    /// The force tolerance for the largest member force `max_t`, N.
    pub(super) fn tolerance(&self, max_t: f64) -> f64 {
        self.settings
            .tol_force_abs
            .max(self.settings.tol_force_rel * max_t)
    }

    pub(super) fn ran_away(&self, state: &DeploymentState, ws: &Workspace, max_disp: f64) -> bool {
        state
            .positions_m
            .iter()
            .zip(&ws.start)
            .any(|(x, x0)| !((x - x0).norm() <= max_disp))
    }

    pub(super) fn max_free_residual(&self, ws: &Workspace) -> f64 {
        let mut worst = 0.0f64;
        for (r, mask) in ws.force.iter().zip(&self.free_mask) {
            let n = r.component_mul(mask).norm();
            if !(n <= worst) {
                worst = n;
            }
        }
        worst
    }

    /// Maps sliding for the current geometry, then fills `ws.force` with the
    /// out-of-balance force at every node (external plus member forces).
    /// Returns the largest member force and the friction residual left.
    pub(super) fn residual(&self, state: &mut DeploymentState, ws: &mut Workspace) -> (f64, f64) {
        let x = &state.positions_m;
        // Segment geometry first: the return mapping needs it.
        let n_members = self.structure.members.len();
        for e in &self.elements[n_members..] {
            if let ElementLaw::Segment { index, .. } = e.law {
                let d = x[e.b] - x[e.a];
                let l = d.norm();
                ws.seg_len[index] = l;
                ws.seg_dir[index] = d / l;
            }
        }
        let mut friction_left = 0.0f64;
        // Backward-Euler return mapping: sliding is always mapped from the
        // material distribution at the start of the solve to the current
        // geometry, so the result depends on where the increment starts and
        // ends, not on the pseudo-dynamic path DR takes in between (mapping
        // incrementally along that path lets transient overshoot slide
        // material, and the answer then fails to converge as increments
        // shrink).
        // The mapping only needs to be a little tighter than the force
        // tolerance: DR and Newton call it again at every iterate.
        let map_tol = 1e-2 * self.tolerance(ws.last_max_t);
        for (c, cable) in self.structure.continuous_cables.iter().enumerate() {
            let (o0, o1) = (state.segment_offsets[c], state.segment_offsets[c + 1]);
            if ws.slip_fixed {
                map_cable_with_slip(
                    cable.ea_n,
                    &ws.seg_len[o0..o1],
                    &ws.seg_dir[o0..o1],
                    &mut state.segment_rest_lengths_m[o0..o1],
                    &state.joint_slip[o0..o1],
                    IncrementStart {
                        rest_m: &ws.rest_start[o0..o1],
                        slip: &ws.slip_start[o0..o1],
                    },
                    &self.friction,
                );
                continue;
            }
            let left = map_cable(
                cable.ea_n,
                &ws.seg_len[o0..o1],
                &ws.seg_dir[o0..o1],
                &mut state.segment_rest_lengths_m[o0..o1],
                &mut state.joint_slip[o0..o1],
                IncrementStart {
                    rest_m: &ws.rest_start[o0..o1],
                    slip: &ws.slip_start[o0..o1],
                },
                &self.friction,
                map_tol,
            );
            friction_left = friction_left.max(left);
        }
        ws.force.copy_from_slice(&self.external_n);
        let mut max_t = 0.0f64;
        for e in &self.elements {
            let (t, dir) = match e.law {
                ElementLaw::Linear {
                    stiffness_n_per_m,
                    rest_m,
                    tension_only,
                } => {
                    let d = x[e.b] - x[e.a];
                    let l = d.norm();
                    let mut t = stiffness_n_per_m * (l - rest_m);
                    if tension_only && t < 0.0 {
                        t = 0.0;
                    }
                    (t, d / l)
                }
                ElementLaw::Segment { ea_n, index } => (
                    segment_tension(ea_n, ws.seg_len[index], state.segment_rest_lengths_m[index]),
                    ws.seg_dir[index],
                ),
            };
            let f = t * dir;
            ws.force[e.a] += f;
            ws.force[e.b] -= f;
            max_t = max_t.max(t.abs());
        }
        ws.last_max_t = max_t;
        (max_t, friction_left)
    }

    fn update_masses(&self, state: &DeploymentState, ws: &mut Workspace) {
        let x = &state.positions_m;
        ws.mass.fill(Vector3::zeros());
        for e in &self.elements {
            let d = x[e.b] - x[e.a];
            let l = d.norm();
            let (k, t) = match e.law {
                ElementLaw::Linear {
                    stiffness_n_per_m,
                    rest_m,
                    ..
                } => (stiffness_n_per_m, stiffness_n_per_m * (l - rest_m)),
                ElementLaw::Segment { ea_n, index } => {
                    let s = state.segment_rest_lengths_m[index];
                    (ea_n / s, segment_tension(ea_n, l, s))
                }
            };
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

    /// Member and segment forces and support reactions of a state.
    ///
    /// Does not relax or slide anything: it reads the state as it is.
    pub fn member_forces(&self, state: &DeploymentState) -> MemberForces {
        let x = &state.positions_m;
        let n_members = self.structure.members.len();
        let n_seg = state.segment_rest_lengths_m.len();
        let mut out = MemberForces {
            member_n: vec![0.0; n_members],
            segment_n: vec![0.0; n_seg],
            member_length_m: vec![0.0; n_members],
            segment_length_m: vec![0.0; n_seg],
            reaction_n: vec![Vector3::zeros(); x.len()],
        };
        let mut net = self.external_n.clone();
        for (k, e) in self.elements.iter().enumerate() {
            let d = x[e.b] - x[e.a];
            let l = d.norm();
            let t = match e.law {
                ElementLaw::Linear {
                    stiffness_n_per_m,
                    rest_m,
                    tension_only,
                } => {
                    let t = stiffness_n_per_m * (l - rest_m);
                    let t = if tension_only { t.max(0.0) } else { t };
                    out.member_n[k] = t;
                    out.member_length_m[k] = l;
                    t
                }
                ElementLaw::Segment { ea_n, index } => {
                    let t = segment_tension(ea_n, l, state.segment_rest_lengths_m[index]);
                    out.segment_n[index] = t;
                    out.segment_length_m[index] = l;
                    t
                }
            };
            let f = t * d / l;
            net[e.a] += f;
            net[e.b] -= f;
        }
        for (i, node) in self.structure.nodes.iter().enumerate() {
            for a in 0..3 {
                if node.fixed[a] {
                    out.reaction_n[i][a] = -net[i][a];
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::RelaxStatus;

    #[test]
    fn status_names_match_their_serialised_form() {
        for s in [
            RelaxStatus::Converged,
            RelaxStatus::IterationLimit,
            RelaxStatus::Diverged,
            RelaxStatus::UnstableMechanism,
        ] {
            assert_eq!(serde_json::to_value(s).unwrap(), s.as_str());
        }
    }
}
