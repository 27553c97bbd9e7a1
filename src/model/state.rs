//! What changes during a deployment: node positions, motor payouts and the
//! material in each continuous-cable segment.

use nalgebra::Vector3;

use super::structure::Structure;

/// Whether a joint is holding or sliding, and which way.
///
/// Sliding only matters when static and kinetic μ differ: a sliding joint
/// keeps its tension ratio on the kinetic bound. Every joint starts each
/// command increment stuck.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum JointSlip {
    /// Held by static friction.
    #[default]
    Stuck,
    /// Material moving from the downstream segment into the upstream one
    /// (towards the motor).
    TowardsMotor,
    /// Material moving towards the end node.
    TowardsEnd,
}

/// A complete, warm-startable state of the structure.
///
/// Cloning it is cheap (a few kilobytes for the reference bridge), which is
/// what lets the planner branch from a saved equilibrium thousands of times.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DeploymentState {
    /// Node positions, m.
    pub positions_m: Vec<Vector3<f64>>,
    /// Rest length of material in every continuous-cable segment, m,
    /// cable after cable (cable `c` starts at `segment_offsets[c]`).
    pub segment_rest_lengths_m: Vec<f64>,
    /// Start of each cable's segments in `segment_rest_lengths_m`; one extra
    /// entry at the end holds the total.
    pub segment_offsets: Vec<usize>,
    /// Motor payout of each continuous cable since the reference state, m
    /// (positive: paid out, cable longer; negative: reeled in).
    pub payout_m: Vec<f64>,
    /// Slip state of each interior joint, indexed like the segments (entry
    /// `offset + j` for the joint between segments `j−1` and `j`; entry
    /// `offset + 0` is unused: segment 0 starts at the motor).
    pub joint_slip: Vec<JointSlip>,
    /// Cable held on the joint seats at the ends of every continuous-cable
    /// segment, m, flat as the segments, as the seat arcs were last
    /// followed ([`crate::model::cable_seats`]); empty where the model
    /// has no seats (or has not followed them yet: the first follow takes
    /// the arcs as they are, moving nothing).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub seat_material_m: Vec<f64>,
}

impl DeploymentState {
    /// The as-built state: reference positions and rest lengths, no payout.
    pub fn reference(structure: &Structure) -> Self {
        let mut segment_offsets = Vec::with_capacity(structure.continuous_cables.len() + 1);
        let mut rest = Vec::with_capacity(structure.segment_count());
        for c in &structure.continuous_cables {
            segment_offsets.push(rest.len());
            rest.extend_from_slice(&c.segment_rest_lengths_m);
        }
        segment_offsets.push(rest.len());
        DeploymentState {
            positions_m: structure.reference_positions(),
            joint_slip: vec![JointSlip::Stuck; rest.len()],
            segment_rest_lengths_m: rest,
            segment_offsets,
            payout_m: vec![0.0; structure.continuous_cables.len()],
            seat_material_m: Vec::new(),
        }
    }

    /// Rest lengths of the segments of cable `c`, m.
    pub fn cable_rest_lengths(&self, c: usize) -> &[f64] {
        &self.segment_rest_lengths_m[self.segment_offsets[c]..self.segment_offsets[c + 1]]
    }

    /// Total material of cable `c` between motor and end node, m.
    pub fn cable_material_m(&self, c: usize) -> f64 {
        self.cable_rest_lengths(c).iter().sum()
    }

    /// Marks every joint stuck: done at the start of each command increment.
    pub fn stick_all_joints(&mut self) {
        self.joint_slip.fill(JointSlip::Stuck);
    }

    /// Largest node distance between two states of the same structure, m.
    pub fn max_position_difference_m(&self, other: &DeploymentState) -> f64 {
        self.positions_m
            .iter()
            .zip(&other.positions_m)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max)
    }
}

impl DeploymentState {
    /// Distance between the nodes of each midspan pair, m.
    pub fn midspan_gaps_m(&self, structure: &Structure) -> Vec<f64> {
        structure
            .midspan_pairs
            .iter()
            .map(|[a, b]| (self.positions_m[*a] - self.positions_m[*b]).norm())
            .collect()
    }

    /// Largest midspan gap, m; `None` for a structure without midspan pairs.
    pub fn max_midspan_gap_m(&self, structure: &Structure) -> Option<f64> {
        self.midspan_gaps_m(structure).into_iter().reduce(f64::max)
    }
}
