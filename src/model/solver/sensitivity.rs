//! Payout sensitivities: how a converged state responds, to first order, to
//! one motor paying out or reeling in.
//!
//! The state is taken as the start of a new command increment (every joint
//! stuck, as [`ForwardModel::apply_payout`] starts each increment), and a
//! payout change `dp` adds to the rest length of the motor's first segment.
//! The response is the one-sided derivative of the increment's solution
//! (the return-mapped equilibrium) with respect to `dp`. With friction it
//! differs between paying out and reeling in: a joint on the edge of its
//! capstan cone slides when the motion loads it further and holds when the
//! motion unloads it, and a sliding joint makes its cable softer.
//!
//! # Method
//! Joints strictly inside their cone hold for any small enough motion, and
//! joints without friction at their angle always slide; only the joints on
//! a cone's edge (the *edge joints*, which the return mapping at the state
//! itself reports sliding) can go either way. So:
//! 1. the consistent tangent [`JointMode::AsMapped`] is factorised once,
//!    with the edge joints held and frictionless joints sliding (`K₀`, per
//!    DOF block: the bridge halves are independent);
//! 2. sliding is expressed as material `q_j ≥ 0` moved over edge joint `j`
//!    into its high-tension segment: with the increment's start material
//!    moved by `q` and the joints held, the equilibrium moves by
//!    `K₀⁻¹·B·q` (`B`: force per unit slide at fixed geometry), and each edge
//!    joint's capstan violation `v = T_high − b(θ)·T_low` changes by
//!    `W·q`, one column per edge joint, computed once for all motors;
//! 3. per motor and direction, the motion `dp = ±1` with all edge joints
//!    held gives `dx₀ = K₀⁻¹·g` (`g = ∂R/∂p`) and violation rates `v₀`; the
//!    joints that slide are those of the complementarity problem
//!    `q ≥ 0, v₀ + W·q ≤ 0, q·(v₀ + W·q) = 0` (a handful of unknowns per
//!    half, solved by active sets). Then `dx = dx₀ + K₀⁻¹·B·q`: the solution
//!    of the tangent in which exactly those joints slide.
//!
//! All loads and violation rates are central differences over
//! `STEP_M` (1 µm) of the exact functions (segment tension law, capstan bound,
//! the material distribution of sliding clusters by
//! [`crate::model::sliding::map_cable_with_slip`]), so they are accurate to
//! second order in the step (relative error about 1e-12). Forces and
//! tensions are differentiated the same way along the linear solution
//! (positions `x ± ε·dx`, start material `± ε·ds`, clusters redistributed):
//! a segment's tension rate holds both the geometric change and the
//! material the sliding joints move, and the central difference cancels
//! the second-order stretch `ε·|dx⊥|²/(2L)` of rotating stiff struts that
//! a one-sided difference would leave (tens of N/m).
//!
//! With static μ above kinetic μ a joint that starts sliding drops to the
//! kinetic bound, a jump no derivative holds: edge joints are those at the
//! static bound, and their sliding follows the kinetic law.

use nalgebra::{DMatrix, DVector, Vector3};

use super::residual::SlipMapping;
use super::{ForwardModel, Workspace};
use crate::model::sliding::{interior_angle, map_cable_with_slip, segment_tension, IncrementStart};
use crate::model::state::{DeploymentState, JointSlip};
use crate::model::stiffness::{tangent_stiffness, JointMode};
use crate::model::structure::Structure;
use crate::numerics::BlockLu;

/// Step of the central differences, m of payout or of slid material
/// (positions move by about as much). Small against the segments' rest
/// lengths (decimetres) so the third-order terms vanish, large against
/// rounding (tensions of ~1e3 N to 1e-16 relative, over 2 µm: ~1e-7 N/m).
const STEP_M: f64 = 1e-6;
/// Relative tolerance of the complementarity problem (violation rates and
/// slides against the largest of their kind).
const COMPLEMENTARITY_TOL: f64 = 1e-9;

/// Direction of a motor's motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotorDirection {
    /// Payout increasing: the cable gets longer.
    PayOut,
    /// Payout decreasing: the motor reels the cable in.
    ReelIn,
}

impl MotorDirection {
    /// Both directions, pay-out first.
    pub const BOTH: [MotorDirection; 2] = [MotorDirection::PayOut, MotorDirection::ReelIn];

    /// Sign of the payout change: +1 paying out, −1 reeling in.
    pub fn sign(self) -> f64 {
        match self {
            MotorDirection::PayOut => 1.0,
            MotorDirection::ReelIn => -1.0,
        }
    }
}

/// Which joints a payout response lets slide.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SlipOnset {
    /// As the state's cones say: joints strictly inside their cone hold,
    /// joints on an edge slide where the motion loads them further. The
    /// exact one-sided derivative: what the first millimetre of a move does
    /// (at a state where every joint sticks, nothing slides at all).
    #[default]
    AtState,
    /// Every joint with friction as if it were on the edge of its cone
    /// that the motion loads it towards: a joint whose tension ratio the
    /// motion moves faster than its cone widens may slide, keeping its
    /// ratio (`d ln(T_high/T_low) = d ln b(θ)`), and the complementarity
    /// problem decides which do. The response to a move large enough for
    /// the joints it loads to reach their cone (the *slip-onset* tangent):
    /// for a joint already on its edge it is the exact law; one strictly
    /// inside is assumed to get there at once, so the response is that of
    /// a move long against the millimetres a joint sticks for. A joint
    /// with a slack segment holds.
    Loaded,
}

/// Linear response of a converged state to one motor moving in one direction:
/// derivatives with respect to that motor's payout p (m; positive pays out),
/// taken one-sided: for PayOut as p increases, for ReelIn as p decreases
/// (still d/dp, so a reel-in of r ≥ 0 metres changes x by about −r·positions_m).
#[derive(Debug, Clone, PartialEq)]
pub struct MotorResponse {
    /// d(position)/dp of each node, m/m (zero on fixed DOFs).
    pub positions_m_per_m: Vec<Vector3<f64>>,
    /// d(axial force)/dp of each member, N/m, as [`Structure::members`]
    /// (tension positive).
    pub member_force_n_per_m: Vec<f64>,
    /// d(tension)/dp of each continuous-cable segment, N/m, flat as
    /// [`DeploymentState::segment_rest_lengths_m`].
    pub segment_tension_n_per_m: Vec<f64>,
    /// Joints that slide in this direction (over the cables whose nodes the
    /// motion moves).
    pub sliding_joints: usize,
}

/// Payout sensitivities of a converged state, both directions, every motor.
#[derive(Debug, Clone, PartialEq)]
pub struct PayoutSensitivities {
    /// Paying out: one response per continuous cable (motor), in cable order.
    pub pay_out: Vec<MotorResponse>,
    /// Reeling in: one response per continuous cable (motor), in cable order.
    pub reel_in: Vec<MotorResponse>,
}

/// Why sensitivities could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SensitivityError {
    /// The tangent is singular (mechanism) or not positive along the load
    /// (unstable), or no consistent pattern of sliding joints was found in
    /// 4n + 4 active-set revisions (n candidate sliding joints).
    #[error("motor {motor}, {direction:?}: the tangent stiffness is singular or unstable")]
    UnstableTangent {
        /// The motor (continuous cable) index.
        motor: usize,
        /// The direction of its motion.
        direction: MotorDirection,
    },
    /// The state's force residual exceeds the solver tolerance: not an equilibrium.
    #[error("state is not an equilibrium: residual {residual_n:.3e} N exceeds the tolerance {tolerance_n:.3e} N")]
    NotConverged {
        /// Largest out-of-balance force on a free node, N.
        residual_n: f64,
        /// The solver's force tolerance at this state, N.
        tolerance_n: f64,
    },
}

impl PayoutSensitivities {
    /// The response of motor `motor` in `direction`; `None` for a motor
    /// index out of range.
    pub fn response(&self, motor: usize, direction: MotorDirection) -> Option<&MotorResponse> {
        match direction {
            MotorDirection::PayOut => self.pay_out.get(motor),
            MotorDirection::ReelIn => self.reel_in.get(motor),
        }
    }

    /// The midspan gap vectors' derivative: for each midspan pair [a, b] of
    /// the structure, d(x_a − x_b)/dp (a Vector3 per pair, m/m) for motor
    /// `motor` in `direction`. Empty when the motor index is out of range
    /// or `structure` is not the one these sensitivities belong to (a pair
    /// names a node they do not have).
    pub fn midspan_gap_response(
        &self,
        structure: &Structure,
        motor: usize,
        direction: MotorDirection,
    ) -> Vec<Vector3<f64>> {
        let Some(r) = self.response(motor, direction) else {
            return Vec::new();
        };
        let dx = &r.positions_m_per_m;
        structure
            .midspan_pairs
            .iter()
            .map(|[a, b]| Some(dx.get(*a)? - dx.get(*b)?))
            .collect::<Option<Vec<_>>>()
            .unwrap_or_default()
    }
}

/// An edge joint: on its cone's edge at the state, so free to slide
/// towards its high-tension segment or to hold.
#[derive(Debug, Clone, Copy)]
struct EdgeJoint {
    /// Flat segment index of the high-tension side (material slides in).
    high: usize,
    /// Flat segment index of the low-tension side.
    low: usize,
    /// The joint's node.
    node: usize,
    /// The nodes before and after it on the cable.
    before: usize,
    after: usize,
    ea_n: f64,
}

/// The state linearised with its edge joints held: everything the motors
/// share.
struct HeldTangent {
    /// Per DOF block, the factors of `K₀` (`None`: singular).
    factors: Vec<Option<BlockLu>>,
    /// Slip states to distribute material with: frictionless joints
    /// sliding, every other joint held.
    labels: Vec<JointSlip>,
    /// Cables with a sliding (frictionless) joint, whose material moves
    /// with the geometry.
    clustered: Vec<bool>,
    edge: Vec<EdgeJoint>,
    /// Which joints are edge joints.
    onset: SlipOnset,
    /// Per edge joint, whether both its segments are taut at the state
    /// (a slip-onset joint with a slack segment holds).
    eligible: Vec<bool>,
    /// Per edge joint, `K₀⁻¹·B_j`: the motion per metre slid over it.
    slide_dx: Vec<DVector<f64>>,
    /// `W[(i, j)]`: rate per metre slid over edge joint `j` of edge joint
    /// `i`'s violation `T_high − b·T_low`, N/m ([`SlipOnset::AtState`]),
    /// or of its log ratio `ln(T_high/T_low)`, 1/m ([`SlipOnset::Loaded`]).
    w: DMatrix<f64>,
    /// [`SlipOnset::Loaded`]: the rate of each edge joint's log bound
    /// `ln b(θ)` per metre slid over edge joint `j`, 1/m (empty otherwise).
    w_bound: DMatrix<f64>,
    /// Per DOF row, its block.
    block_of_row: Vec<usize>,
}

/// A first-order motion: positions (free DOFs) and start material (flat
/// per segment), per metre of the driving variable.
struct Motion {
    dx: DVector<f64>,
    ds: Vec<f64>,
}

impl ForwardModel {
    /// Payout sensitivities of the converged `state`: for every motor and
    /// both directions, the one-sided derivative of node positions, member
    /// forces and segment tensions with respect to its payout, from the
    /// consistent tangent (see the [module docs](self)).
    ///
    /// The state is treated as the start of a new command increment (every
    /// joint stuck); `ws` is scratch space and is left ready for any solve.
    /// Errors: [`SensitivityError::NotConverged`] when the state fails the
    /// solver's own convergence test, and
    /// [`SensitivityError::UnstableTangent`] when a response does not exist
    /// (a mechanism, an unstable equilibrium, or no consistent set of
    /// sliding joints).
    pub fn payout_sensitivities(
        &self,
        state: &DeploymentState,
        ws: &mut Workspace,
    ) -> Result<PayoutSensitivities, SensitivityError> {
        self.payout_sensitivities_with(state, ws, SlipOnset::AtState)
    }

    /// [`Self::payout_sensitivities`] with the joints that may slide chosen
    /// by `onset`: [`SlipOnset::AtState`] is the exact derivative,
    /// [`SlipOnset::Loaded`] the slip-onset tangent (every joint with
    /// friction may slide in the direction the motion loads it).
    pub fn payout_sensitivities_with(
        &self,
        state: &DeploymentState,
        ws: &mut Workspace,
        onset: SlipOnset,
    ) -> Result<PayoutSensitivities, SensitivityError> {
        let mut from = state.clone();
        from.stick_all_joints();
        ws.fit(from.positions_m.len(), from.segment_rest_lengths_m.len());
        // The state's own residual, its material as it is (joints held):
        // the test its solve passed. (Mapping from it as a new start would
        // also balance the friction the solve left within tolerance, and
        // move that into the forces.)
        ws.start_increment(&from);
        let mut held = from.clone();
        let (max_t, _) = self.residual_as(&mut held, ws, SlipMapping::Fixed);
        let tolerance_n = self.tolerance(max_t);
        let residual_n = self.max_free_residual(ws);
        if !(residual_n <= tolerance_n) {
            return Err(SensitivityError::NotConverged {
                residual_n,
                tolerance_n,
            });
        }
        // The return mapping at the state, from itself: joints it slides
        // are on their cone's edge (or frictionless).
        let mut mapped = from.clone();
        self.residual(&mut mapped, ws);
        let held = self.held_tangent(&from, &mapped.joint_slip, onset);
        let n_cables = self.structure.continuous_cables.len();
        let mut out = PayoutSensitivities {
            pay_out: Vec::with_capacity(n_cables),
            reel_in: Vec::with_capacity(n_cables),
        };
        for motor in 0..n_cables {
            for direction in MotorDirection::BOTH {
                let r = self
                    .motor_response(&from, &held, motor, direction)
                    .ok_or(SensitivityError::UnstableTangent { motor, direction })?;
                match direction {
                    MotorDirection::PayOut => out.pay_out.push(r),
                    MotorDirection::ReelIn => out.reel_in.push(r),
                }
            }
        }
        Ok(out)
    }

    /// Factorises the tangent with the edge joints held and computes what
    /// sliding each of them does.
    fn held_tangent(
        &self,
        from: &DeploymentState,
        mapped_slip: &[JointSlip],
        onset: SlipOnset,
    ) -> HeldTangent {
        let x = &from.positions_m;
        let dofs = self.free_dofs();
        let blocks = self.dof_blocks();
        let mut block_of_row = vec![0; dofs.count];
        for (b, rows) in blocks.iter().enumerate() {
            for &r in rows {
                block_of_row[r] = b;
            }
        }
        let mut labels = vec![JointSlip::Stuck; from.joint_slip.len()];
        let mut clustered = vec![false; self.structure.continuous_cables.len()];
        let mut edge = Vec::new();
        for (c, cable) in self.structure.continuous_cables.iter().enumerate() {
            let o = from.segment_offsets[c];
            for (j, w) in cable.path.windows(3).enumerate() {
                let joint = o + j + 1;
                let slide = mapped_slip[joint];
                let theta = interior_angle(
                    &(x[w[1]] - x[w[0]]).normalize(),
                    &(x[w[2]] - x[w[1]]).normalize(),
                );
                let frictionless = self.friction.ratio_bound(theta, true) == 1.0
                    && self.friction.ratio_bound(theta, false) == 1.0;
                if slide == JointSlip::Stuck && (onset == SlipOnset::AtState || frictionless) {
                    continue;
                }
                if frictionless {
                    labels[joint] = slide;
                    clustered[c] = true;
                    continue;
                }
                // Slip-onset joints are oriented towards the motor (a
                // negative slide moves material the other way); edge
                // joints towards the side the mapping slid them.
                let (high, low) = if onset == SlipOnset::Loaded || slide == JointSlip::TowardsMotor
                {
                    (joint - 1, joint)
                } else {
                    (joint, joint - 1)
                };
                edge.push(EdgeJoint {
                    high,
                    low,
                    node: w[1],
                    before: w[0],
                    after: w[2],
                    ea_n: cable.ea_n,
                });
            }
        }
        let mut linearised = from.clone();
        linearised.joint_slip.copy_from_slice(&labels);
        let (k, _) = tangent_stiffness(self, &linearised, JointMode::AsMapped);
        let factors = (0..blocks.len())
            .map(|b| BlockLu::new(&k, &blocks[b..=b]))
            .collect();
        // A slip-onset joint with a slack segment has no ratio to keep.
        let eligible = edge
            .iter()
            .map(|j| {
                let (_, high, low) = self.joint_tensions(from, j);
                high > 0.0 && low > 0.0
            })
            .collect();
        let mut held = HeldTangent {
            factors,
            labels,
            clustered,
            edge,
            onset,
            eligible,
            slide_dx: Vec::new(),
            w: DMatrix::zeros(0, 0),
            w_bound: DMatrix::zeros(0, 0),
            block_of_row,
        };
        let n_edge = held.edge.len();
        let mut w = DMatrix::zeros(n_edge, n_edge);
        let mut w_bound = DMatrix::zeros(n_edge, n_edge);
        let mut slide_dx = Vec::with_capacity(n_edge);
        for (j, joint) in held.edge.iter().enumerate() {
            let mut ds = vec![0.0; from.segment_rest_lengths_m.len()];
            ds[joint.high] = 1.0;
            ds[joint.low] = -1.0;
            let load = self.start_change_load(from, &held, &ds);
            // A slide moves the blocks its segments' nodes are in.
            let dx = held
                .solve_all(&load)
                .unwrap_or_else(|| DVector::zeros(load.len()));
            let motion = Motion { dx, ds };
            match onset {
                SlipOnset::AtState => w.set_column(
                    j,
                    &DVector::from_vec(self.violation_rates(from, &held, &motion)),
                ),
                SlipOnset::Loaded => {
                    let (ratio, bound) = self.log_ratio_rates(from, &held, &motion);
                    w.set_column(j, &DVector::from_vec(ratio));
                    w_bound.set_column(j, &DVector::from_vec(bound));
                }
            }
            slide_dx.push(motion.dx);
        }
        held.w = w;
        held.w_bound = w_bound;
        held.slide_dx = slide_dx;
        held
    }

    /// The slide over each edge joint (m per metre of `motion`, positive
    /// into its `high` segment) that the complementarity problem of
    /// `held`'s onset gives; `None` where it has no solution.
    fn edge_slides(
        &self,
        from: &DeploymentState,
        held: &HeldTangent,
        motion: &Motion,
    ) -> Option<Vec<f64>> {
        match held.onset {
            SlipOnset::AtState => {
                let v0 = self.violation_rates(from, held, motion);
                solve_complementarity(&v0, &held.w)
            }
            SlipOnset::Loaded => {
                // Each taut joint on the edge its ratio moves towards:
                // direction d = sign(d ln(T_high/T_low)), violation rate
                // d·ℓ' − β' (ℓ the log ratio, β the log bound).
                let (ratio, bound) = self.log_ratio_rates(from, held, motion);
                let candidates: Vec<usize> = (0..held.edge.len())
                    .filter(|&i| held.eligible[i] && ratio[i] != 0.0)
                    .collect();
                let d = |i: usize| ratio[i].signum();
                let v0: Vec<f64> = candidates
                    .iter()
                    .map(|&i| d(i) * ratio[i] - bound[i])
                    .collect();
                let w = DMatrix::from_fn(candidates.len(), candidates.len(), |a, b| {
                    let (i, j) = (candidates[a], candidates[b]);
                    d(j) * (d(i) * held.w[(i, j)] - held.w_bound[(i, j)])
                });
                let q = solve_complementarity(&v0, &w)?;
                let mut slides = vec![0.0; held.edge.len()];
                for (a, &i) in candidates.iter().enumerate() {
                    slides[i] = d(i) * q[a];
                }
                Some(slides)
            }
        }
    }

    /// The response of `from` to `motor` moving in `direction`; `None`
    /// where the tangent is singular or unstable or the sliding joints find
    /// no consistent set.
    fn motor_response(
        &self,
        from: &DeploymentState,
        held: &HeldTangent,
        motor: usize,
        direction: MotorDirection,
    ) -> Option<MotorResponse> {
        let sign = direction.sign();
        let n_seg = from.segment_rest_lengths_m.len();
        // Per metre of motion in this direction (dp = sign).
        let mut ds = vec![0.0; n_seg];
        ds[from.segment_offsets[motor]] = sign;
        let load = self.start_change_load(from, held, &ds);
        let dx = held.solve_all(&load)?;
        let mut motion = Motion { dx, ds };
        let q = self.edge_slides(from, held, &motion)?;
        let Motion { dx, ds } = &mut motion;
        let mut sliding_joints = 0;
        for (j, (qj, joint)) in q.iter().zip(&held.edge).enumerate() {
            if *qj != 0.0 {
                dx.axpy(*qj, &held.slide_dx[j], 1.0);
                ds[joint.high] += qj;
                ds[joint.low] -= qj;
                sliding_joints += 1;
            }
        }
        // Stability along the load: with the sliding joints eliminated the
        // tangent K satisfies K·dx = load.
        if load.amax() > 0.0 && !(dx.dot(&load) > 0.0) {
            return None;
        }
        // Frictionless joints slide wherever the motion reaches.
        let moved_blocks: Vec<bool> = (0..held.factors.len())
            .map(|b| {
                held.block_of_row
                    .iter()
                    .zip(dx.iter())
                    .any(|(rb, v)| *rb == b && *v != 0.0)
            })
            .collect();
        for (c, cable) in self.structure.continuous_cables.iter().enumerate() {
            if !held.clustered[c] {
                continue;
            }
            let reached = cable.path.iter().any(|&n| {
                self.free_dofs().index[n]
                    .iter()
                    .flatten()
                    .any(|&r| moved_blocks[held.block_of_row[r]])
            });
            if reached {
                let o = (from.segment_offsets[c], from.segment_offsets[c + 1]);
                sliding_joints += held.labels[o.0..o.1]
                    .iter()
                    .filter(|s| **s != JointSlip::Stuck)
                    .count();
            }
        }
        let (lo, hi) = (
            self.moved(from, held, &motion, -STEP_M),
            self.moved(from, held, &motion, STEP_M),
        );
        let (f0, f1) = (self.member_forces(&lo), self.member_forces(&hi));
        // Rates per metre of motion; d/dp is `sign` times that.
        let rate = |a: &[f64], b: &[f64]| -> Vec<f64> {
            a.iter()
                .zip(b)
                .map(|(a, b)| sign * (b - a) / (2.0 * STEP_M))
                .collect()
        };
        let mut positions_m_per_m = vec![Vector3::zeros(); from.positions_m.len()];
        self.free_dofs()
            .scatter_add(&mut positions_m_per_m, &motion.dx, sign);
        Some(MotorResponse {
            positions_m_per_m,
            member_force_n_per_m: rate(&f0.member_n, &f1.member_n),
            segment_tension_n_per_m: rate(&f0.segment_n, &f1.segment_n),
            sliding_joints,
        })
    }

    /// `from` moved by `scale` along `motion`: positions `x + scale·dx`,
    /// start material `s + scale·ds`, held joints keeping it and sliding
    /// clusters sharing it for the new geometry.
    fn moved(
        &self,
        from: &DeploymentState,
        held: &HeldTangent,
        motion: &Motion,
        scale: f64,
    ) -> DeploymentState {
        let mut s = from.clone();
        self.free_dofs()
            .scatter_add(&mut s.positions_m, &motion.dx, scale);
        let start: Vec<f64> = from
            .segment_rest_lengths_m
            .iter()
            .zip(&motion.ds)
            .map(|(r, d)| r + scale * d)
            .collect();
        for (c, cable) in self.structure.continuous_cables.iter().enumerate() {
            let (o0, o1) = (from.segment_offsets[c], from.segment_offsets[c + 1]);
            let rest = &mut s.segment_rest_lengths_m[o0..o1];
            rest.copy_from_slice(&start[o0..o1]);
            if !held.clustered[c] {
                continue;
            }
            let (lengths, dirs): (Vec<f64>, Vec<Vector3<f64>>) = cable
                .path
                .windows(2)
                .map(|w| {
                    let d = s.positions_m[w[1]] - s.positions_m[w[0]];
                    (d.norm(), d.normalize())
                })
                .unzip();
            map_cable_with_slip(
                cable.ea_n,
                &lengths,
                &dirs,
                rest,
                &held.labels[o0..o1],
                IncrementStart {
                    rest_m: &start[o0..o1],
                    slip: &from.joint_slip[o0..o1],
                },
                &self.friction,
            );
        }
        s
    }

    /// The out-of-balance force per metre of the start-material change `ds`
    /// at the state's geometry (joints held, clusters redistributed), on
    /// the free DOFs: a central difference of the segment forces.
    fn start_change_load(
        &self,
        from: &DeploymentState,
        held: &HeldTangent,
        ds: &[f64],
    ) -> DVector<f64> {
        let still = DVector::zeros(self.free_dofs().count);
        let motion = Motion {
            dx: still,
            ds: ds.to_vec(),
        };
        let (lo, hi) = (
            self.moved(from, held, &motion, -STEP_M),
            self.moved(from, held, &motion, STEP_M),
        );
        let x = &from.positions_m;
        let mut force = vec![Vector3::zeros(); x.len()];
        for (c, cable) in self.structure.continuous_cables.iter().enumerate() {
            let o = from.segment_offsets[c];
            for (i, w) in cable.path.windows(2).enumerate() {
                let (a, b) = (
                    lo.segment_rest_lengths_m[o + i],
                    hi.segment_rest_lengths_m[o + i],
                );
                if a == b {
                    continue;
                }
                let d = x[w[1]] - x[w[0]];
                let l = d.norm();
                let dt = (segment_tension(cable.ea_n, l, b) - segment_tension(cable.ea_n, l, a))
                    / (2.0 * STEP_M);
                // As the residual: +T·e on the first node, −T·e on the second.
                force[w[0]] += dt * d / l;
                force[w[1]] -= dt * d / l;
            }
        }
        self.free_dofs().gather(&force)
    }

    /// Capstan violation rate of every edge joint along `motion` (N per
    /// metre of it), by a central difference.
    fn violation_rates(
        &self,
        from: &DeploymentState,
        held: &HeldTangent,
        motion: &Motion,
    ) -> Vec<f64> {
        let (lo, hi) = (
            self.moved(from, held, motion, -STEP_M),
            self.moved(from, held, motion, STEP_M),
        );
        held.edge
            .iter()
            .map(|j| (self.violation(&hi, j) - self.violation(&lo, j)) / (2.0 * STEP_M))
            .collect()
    }

    /// Rates along `motion` (per metre of it, central differences) of
    /// each edge joint's log tension ratio `ln(T_high/T_low)` and log
    /// kinetic bound `ln b(θ)`; zero for a joint with a slack segment.
    fn log_ratio_rates(
        &self,
        from: &DeploymentState,
        held: &HeldTangent,
        motion: &Motion,
    ) -> (Vec<f64>, Vec<f64>) {
        let (lo, hi) = (
            self.moved(from, held, motion, -STEP_M),
            self.moved(from, held, motion, STEP_M),
        );
        held.edge
            .iter()
            .map(|j| match (self.log_ratio(&lo, j), self.log_ratio(&hi, j)) {
                (Some((r0, b0)), Some((r1, b1))) => {
                    ((r1 - r0) / (2.0 * STEP_M), (b1 - b0) / (2.0 * STEP_M))
                }
                _ => (0.0, 0.0),
            })
            .unzip()
    }

    /// `(ln(T_high/T_low), ln b(θ))` of an edge joint in `state` (kinetic
    /// bound); `None` with a slack segment.
    fn log_ratio(&self, state: &DeploymentState, joint: &EdgeJoint) -> Option<(f64, f64)> {
        let (theta, t_high, t_low) = self.joint_tensions(state, joint);
        (t_high > 0.0 && t_low > 0.0).then(|| {
            (
                t_high.ln() - t_low.ln(),
                self.friction.ratio_bound(theta, true).ln(),
            )
        })
    }

    /// Interior angle, rad, and high- and low-side tensions, N, of an edge
    /// joint in `state`.
    fn joint_tensions(&self, state: &DeploymentState, joint: &EdgeJoint) -> (f64, f64, f64) {
        let x = &state.positions_m;
        let (d_in, d_out) = (
            x[joint.node] - x[joint.before],
            x[joint.after] - x[joint.node],
        );
        let theta = interior_angle(&d_in.normalize(), &d_out.normalize());
        let rest = &state.segment_rest_lengths_m;
        // The segment before the joint is the lower flat index.
        let (l_high, l_low) = if joint.high < joint.low {
            (d_in.norm(), d_out.norm())
        } else {
            (d_out.norm(), d_in.norm())
        };
        (
            theta,
            segment_tension(joint.ea_n, l_high, rest[joint.high]),
            segment_tension(joint.ea_n, l_low, rest[joint.low]),
        )
    }

    /// `T_high − b(θ)·T_low` of an edge joint in `state`, N (kinetic bound:
    /// the law it slides by).
    fn violation(&self, state: &DeploymentState, joint: &EdgeJoint) -> f64 {
        let (theta, t_high, t_low) = self.joint_tensions(state, joint);
        t_high - self.friction.ratio_bound(theta, true) * t_low
    }
}

impl HeldTangent {
    /// `K₀⁻¹·load` over every block the load touches; `None` if one of them
    /// is singular.
    fn solve_all(&self, load: &DVector<f64>) -> Option<DVector<f64>> {
        let mut dx = DVector::zeros(load.len());
        for (b, factor) in self.factors.iter().enumerate() {
            let touched = self
                .block_of_row
                .iter()
                .zip(load.iter())
                .any(|(rb, v)| *rb == b && *v != 0.0);
            if touched {
                dx += factor.as_ref()?.solve(load);
            }
        }
        Some(dx)
    }
}

/// The slides `q ≥ 0` (m per metre of motion) with violation rates
/// `v = v0 + W·q ≤ 0` and `q·v = 0`, by active sets: joints whose violation
/// would grow start sliding, joints whose slide would turn negative stop.
/// `None` if a subproblem is singular or the sets cycle.
fn solve_complementarity(v0: &[f64], w: &DMatrix<f64>) -> Option<Vec<f64>> {
    let n = v0.len();
    let mut q = vec![0.0; n];
    let scale = v0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 {
        return Some(q);
    }
    let tol_v = COMPLEMENTARITY_TOL * scale;
    let mut active: Vec<bool> = v0.iter().map(|v| *v > tol_v).collect();
    for _ in 0..4 * n + 4 {
        let set: Vec<usize> = (0..n).filter(|&j| active[j]).collect();
        q.fill(0.0);
        if !set.is_empty() {
            let sub = DMatrix::from_fn(set.len(), set.len(), |a, b| w[(set[a], set[b])]);
            let rhs = DVector::from_iterator(set.len(), set.iter().map(|&j| -v0[j]));
            let sol = sub.lu().solve(&rhs)?;
            for (k, &j) in set.iter().enumerate() {
                q[j] = sol[k];
            }
        }
        let q_scale = q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        // The most negative slide stops first.
        let worst = set
            .iter()
            .copied()
            .filter(|&j| q[j] < -COMPLEMENTARITY_TOL * q_scale)
            .min_by(|&a, &b| q[a].total_cmp(&q[b]));
        if let Some(j) = worst {
            active[j] = false;
            continue;
        }
        // The most violated held joint starts sliding.
        let v = |i: usize| v0[i] + (0..n).map(|j| w[(i, j)] * q[j]).sum::<f64>();
        let worst = (0..n)
            .filter(|&i| !active[i])
            .map(|i| (i, v(i)))
            .filter(|(_, vi)| *vi > tol_v)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            Some((i, _)) => active[i] = true,
            None => {
                for s in q.iter_mut() {
                    *s = s.max(0.0);
                }
                return Some(q);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::friction::JointFriction;
    use crate::model::structure::{ContinuousCable, Node};
    use crate::model::RelaxSettings;

    /// `q ≥ 0`, `v = v0 + W·q ≤ 0`, `q·v = 0`, checked from the definition.
    fn assert_complementary(v0: &[f64], w: &DMatrix<f64>, q: &[f64]) {
        for i in 0..v0.len() {
            let v = v0[i] + (0..q.len()).map(|j| w[(i, j)] * q[j]).sum::<f64>();
            assert!(q[i] >= 0.0 && v <= 1e-12, "joint {i}: q {} v {v}", q[i]);
            assert!((q[i] * v).abs() <= 1e-12, "joint {i}: q·v = {}", q[i] * v);
        }
    }

    #[test]
    fn complementarity_solutions_satisfy_the_conditions() {
        // One joint loaded, its neighbour unloaded by its slide.
        let w = DMatrix::from_row_slice(2, 2, &[-2.0, 1.0, 1.0, -2.0]);
        let q = solve_complementarity(&[1.0, -1.0], &w).unwrap();
        assert_complementary(&[1.0, -1.0], &w, &q);
        assert!(q[0] > 0.0 && q[1] == 0.0);
        // Both loaded, both slide.
        let w = DMatrix::from_row_slice(2, 2, &[-1.0, 0.5, 0.5, -1.0]);
        let q = solve_complementarity(&[1.0, 0.2], &w).unwrap();
        assert_complementary(&[1.0, 0.2], &w, &q);
        assert!(q.iter().all(|q| *q > 0.0));
        // Both loaded at first, but the first one's slide unloads the
        // second, which must stop sliding again.
        let w = DMatrix::from_row_slice(2, 2, &[-1.0, 0.0, -3.0, -1.0]);
        let q = solve_complementarity(&[1.0, 0.5], &w).unwrap();
        assert_complementary(&[1.0, 0.5], &w, &q);
        assert_eq!(q, vec![1.0, 0.0]);
        // Nothing loaded.
        assert_eq!(solve_complementarity(&[0.0, 0.0], &w), Some(vec![0.0; 2]));
    }

    #[test]
    fn a_cable_without_tension_is_an_unstable_tangent() {
        // A straight continuous cable between two supports over one free
        // joint, exactly at its rest length: in equilibrium, but nothing
        // holds the joint sideways, and reeling in loads it.
        let node = |id: &str, x: f64, fixed: bool| Node {
            id: id.into(),
            position_m: Vector3::new(x, 0.0, 0.0),
            mass_kg: 0.0,
            fixed: [fixed; 3],
            load_n: Vector3::zeros(),
        };
        let cable = ContinuousCable {
            id: "c".into(),
            path: vec![0, 1, 2],
            ea_n: 1e5,
            segment_rest_lengths_m: vec![1.0, 1.0],
        };
        let structure = Structure::new(
            "straight",
            vec![
                node("a", 0.0, true),
                node("j", 1.0, false),
                node("b", 2.0, true),
            ],
            vec![],
            vec![cable],
            Vector3::zeros(),
            vec![],
        )
        .unwrap();
        let model = ForwardModel::new(
            structure,
            JointFriction::constant(0.2).unwrap(),
            RelaxSettings::default(),
        )
        .unwrap();
        let state = model.reference_state();
        let err = model
            .payout_sensitivities(&state, &mut Workspace::default())
            .unwrap_err();
        assert!(
            matches!(err, SensitivityError::UnstableTangent { motor: 0, .. }),
            "{err:?}"
        );
    }
}
