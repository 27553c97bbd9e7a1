//! Reusable buffers of a solve, one per thread.

use nalgebra::Vector3;

use super::counters::NewtonCounters;
use crate::model::state::{DeploymentState, JointSlip};
use crate::numerics::{BlockLayout, BlockLu, BlockMatrix};

/// Reusable buffers for [`super::ForwardModel::relax`]; one per thread.
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    pub(super) force: Vec<Vector3<f64>>,
    pub(super) velocity: Vec<Vector3<f64>>,
    pub(super) mass: Vec<Vector3<f64>>,
    pub(super) start: Vec<Vector3<f64>>,
    pub(super) seg_len: Vec<f64>,
    pub(super) seg_dir: Vec<Vector3<f64>>,
    pub(super) rest_start: Vec<f64>,
    pub(super) slip_start: Vec<JointSlip>,
    /// Largest member force at the last residual evaluation, N.
    pub(super) last_max_t: f64,
    /// Continuation step (fraction of an increment) that last succeeded.
    pub(super) continuation_step: f64,
    /// Zeroed storage of the last tangent factorised, to assemble the
    /// next one into without allocating.
    tangent_storage: Option<BlockMatrix>,
    /// The factorisation Newton converged with, kept for the next
    /// continuation step's predictor (see [`KeptTangent`]); cleared at the
    /// start of every command, like `continuation_step`.
    pub(super) kept_tangent: Option<KeptTangent>,
    /// How Newton fared so far.
    pub(super) counters: NewtonCounters,
}

/// A factorised tangent with the state it was assembled at.
#[derive(Debug, Clone)]
pub(super) struct KeptTangent {
    pub(super) factors: BlockLu,
    /// Slip states of the joints it was assembled with.
    pub(super) slip: Vec<JointSlip>,
    pub(super) positions_m: Vec<Vector3<f64>>,
    pub(super) rest_m: Vec<f64>,
}

impl Workspace {
    /// How the Newton solves run with this workspace fared: increments
    /// solved by Newton or handed to DR, and why Newton gave up.
    pub fn newton_counters(&self) -> NewtonCounters {
        self.counters
    }

    /// Sets the counters of [`Self::newton_counters`] to zero.
    pub fn reset_newton_counters(&mut self) {
        self.counters = NewtonCounters::default();
    }

    /// Records `state`'s material and slip as the start of an increment.
    pub(super) fn start_increment(&mut self, state: &DeploymentState) {
        self.fit(state.positions_m.len(), state.segment_rest_lengths_m.len());
        self.rest_start
            .copy_from_slice(&state.segment_rest_lengths_m);
        self.slip_start.copy_from_slice(&state.joint_slip);
    }

    /// Zeroed block storage for a tangent on `layout`: the last one's if
    /// it is on that layout, else new.
    pub(super) fn tangent_storage(&mut self, layout: &BlockLayout) -> BlockMatrix {
        match self.tangent_storage.take() {
            Some(m) if m.is_on(layout) => m,
            _ => BlockMatrix::zeros_on(layout),
        }
    }

    /// Keeps a factorisation's storage for the next tangent.
    pub(super) fn recycle(&mut self, factors: Option<BlockLu>) {
        if let Some(f) = factors {
            self.tangent_storage = Some(f.into_storage());
        }
    }

    /// Forgets the kept tangent (its storage is kept for the next one).
    pub(super) fn drop_kept_tangent(&mut self) {
        let kept = self.kept_tangent.take().map(|k| k.factors);
        self.recycle(kept);
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
