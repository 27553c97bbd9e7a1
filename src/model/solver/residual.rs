//! The out-of-balance force of a state, with the friction return mapping
//! run from the start of the increment, and the convergence measures the
//! DR and Newton loops share.

use super::element::ElementLaw;
use super::forward_model::ForwardModel;
use super::status::PLAUSIBLE_STRAIN;
use super::workspace::Workspace;
use crate::model::sliding::{map_cable, map_cable_with_slip, IncrementStart};
use crate::model::state::DeploymentState;
use crate::model::MemberKind;

/// How a residual evaluation treats the joints' slip.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum SlipMapping {
    /// The friction return mapping decides which joints slide (the
    /// physical residual; DR and every convergence test use it).
    ReturnMapping,
    /// The state's joint slip states are kept and the material is
    /// distributed for them: Newton's smooth active-set problem.
    Fixed,
}

impl ForwardModel {
    /// Makes `state` the start of an increment in `ws` and maps sliding for
    /// its geometry, leaving its residual in `ws.force` (for tests).
    #[cfg(test)]
    pub(super) fn prime(&self, state: &mut DeploymentState, ws: &mut Workspace) {
        ws.start_increment(state);
        self.residual(state, ws);
    }

    /// The force tolerance for the largest member force `max_t`, N.
    pub(super) fn tolerance(&self, max_t: f64) -> f64 {
        self.tolerance_rel(max_t, self.settings.tol_force_rel)
    }

    /// The force tolerance `tol_rel · max_t` with the floor
    /// `tol_force_abs`, N.
    pub(super) fn tolerance_rel(&self, max_t: f64, tol_rel: f64) -> f64 {
        self.settings.tol_force_abs.max(tol_rel * max_t)
    }

    pub(super) fn ran_away(&self, state: &DeploymentState, ws: &Workspace, max_disp: f64) -> bool {
        state
            .positions_m
            .iter()
            .zip(&ws.start)
            .any(|(x, x0)| !((x - x0).norm() <= max_disp))
    }

    /// Whether every strut, cable and segment of `state` is strained by at
    /// most [`PLAUSIBLE_STRAIN`] (struts both ways, cables and segments in
    /// tension; springs exempt). Elements `0..members` are the members in
    /// structure order, the rest the segments.
    pub(super) fn strain_is_plausible(&self, state: &DeploymentState) -> bool {
        let x = &state.positions_m;
        self.elements.iter().enumerate().all(|(k, e)| {
            let length = (x[e.b] - x[e.a]).norm();
            let (rest, both_ways) = match e.law {
                ElementLaw::Segment { index, .. } => (state.segment_rest_lengths_m[index], false),
                ElementLaw::Linear { rest_m, .. } => match self.structure.members[k].kind {
                    MemberKind::Spring { .. } => return true,
                    MemberKind::Strut { .. } => (rest_m, true),
                    MemberKind::Cable { .. } => (rest_m, false),
                },
            };
            let strain = length / rest - 1.0;
            let limit = if both_ways { strain.abs() } else { strain };
            // A NaN strain fails the test, so it is not plausible.
            limit <= PLAUSIBLE_STRAIN
        })
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

    /// Maps sliding for the current geometry by the return mapping, then
    /// fills `ws.force` with the out-of-balance force at every node
    /// (external plus member forces). Returns the largest member force and
    /// the friction residual left.
    pub(super) fn residual(&self, state: &mut DeploymentState, ws: &mut Workspace) -> (f64, f64) {
        self.residual_as(state, ws, SlipMapping::ReturnMapping)
    }

    /// [`Self::residual`], with the joints' slip treated as `mapping` says.
    pub(super) fn residual_as(
        &self,
        state: &mut DeploymentState,
        ws: &mut Workspace,
        mapping: SlipMapping,
    ) -> (f64, f64) {
        ws.counters.residual_evaluations += 1;
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
        let map_tol = self.settings.tol_mapping_rel * self.tolerance(ws.last_max_t);
        for (c, cable) in self.structure.continuous_cables.iter().enumerate() {
            let (o0, o1) = (state.segment_offsets[c], state.segment_offsets[c + 1]);
            if mapping == SlipMapping::Fixed {
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
            // Segment geometry is already in the workspace.
            let (l, dir) = match e.law {
                ElementLaw::Segment { index, .. } => (ws.seg_len[index], ws.seg_dir[index]),
                ElementLaw::Linear { .. } => {
                    let d = x[e.b] - x[e.a];
                    let l = d.norm();
                    (l, d / l)
                }
            };
            let t = e.law.at(l, &state.segment_rest_lengths_m).tension_n;
            let f = t * dir;
            ws.force[e.a] += f;
            ws.force[e.b] -= f;
            max_t = max_t.max(t.abs());
        }
        ws.last_max_t = max_t;
        (max_t, friction_left)
    }
}
