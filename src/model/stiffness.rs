//! Tangent stiffness of a state: the linearisation of the out-of-balance
//! force about an equilibrium.
//!
//! A two-node element with axial stiffness `k`, tension `T`, length `L` and
//! unit direction `e` contributes, on the displacement of its end `b`
//! relative to end `a`,
//!
//! ```text
//!     K_e = k·e·eᵀ + (T/L)·(I − e·eᵀ)        (material + geometric)
//! ```
//!
//! A slack tension-only element contributes nothing. A continuous cable
//! contributes in one of two ways, the two limits of joint friction:
//! - [`JointMode::Stuck`]: every joint holds, so each segment is an
//!   independent element with `k = EA/s` (`s` its rest length);
//! - [`JointMode::Sliding`]: every joint slides freely (μ = 0, the clustered
//!   cable), so all segments share one tension `T = EA·(ΣL − S)/S`, and the
//!   material term couples them: `(EA/S)·g·gᵀ` with `g = Σ ∂L_i/∂x`, the
//!   gradient of the cable's total length; the geometric terms stay per
//!   segment;
//! - [`JointMode::AsMapped`]: joints as the friction mapping left them,
//!   between the two.
//!
//! [`tangent_stiffness`] gives a dense matrix over the free degrees of
//! freedom; [`assemble_tangent_stiffness`] adds into any
//! [`MatrixAssembly`], such as the per-block storage of
//! [`tangent_layout`], sparse for large blocks. Stuck and sliding matrices
//! are symmetric, and positive definite exactly when the equilibrium is
//! stable.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::friction::JointFriction;
use super::sliding::{interior_angle, segment_tension};
use super::solver::element::ElementLaw;
use super::solver::ForwardModel;
use super::state::{DeploymentState, JointSlip};
use crate::numerics::block_matrix::MIN_SPARSE_ROWS;
use crate::numerics::{BlockLayout, FreeDofs, MatrixAssembly};

/// How continuous cables behave at their joints in a linearisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointMode {
    /// All joints hold: segments act as separate cables.
    Stuck,
    /// All joints slide without friction: one tension per cable (μ = 0).
    Sliding,
    /// Each joint as the state's [`JointSlip`] says: stuck joints hold,
    /// sliding ones exchange material at their current tension ratio (the
    /// consistent tangent of the friction return mapping; non-symmetric).
    AsMapped,
}

/// Adds `sign·block` to the (`i`, `j`) node block of `k`, free rows only.
fn add_block(
    k: &mut impl MatrixAssembly,
    dofs: &FreeDofs,
    i: usize,
    j: usize,
    block: &Matrix3<f64>,
) {
    k.add_3x3(&dofs.index[i], &dofs.index[j], block);
}

/// Adds a two-node element's stiffness `block` (on `x_b − x_a`).
fn add_element(
    k: &mut impl MatrixAssembly,
    dofs: &FreeDofs,
    a: usize,
    b: usize,
    block: &Matrix3<f64>,
) {
    k.add_pair(&dofs.index[a], &dofs.index[b], block);
}

/// Geometric plus material stiffness of one element.
fn element_block(k_axial: f64, tension_n: f64, d: &Vector3<f64>) -> Matrix3<f64> {
    let l = d.norm();
    let e = d / l;
    let eet = e * e.transpose();
    k_axial * eet + (tension_n / l) * (Matrix3::identity() - eet)
}

/// Tangent stiffness of `state` on the free DOFs, N/m.
///
/// The state should be in equilibrium for the matrix to mean stability; it
/// is evaluated as given, with tensions from the current geometry.
pub fn tangent_stiffness(
    model: &ForwardModel,
    state: &DeploymentState,
    joints: JointMode,
) -> (DMatrix<f64>, FreeDofs) {
    let dofs = model.free_dofs().clone();
    let mut k = DMatrix::zeros(dofs.count, dofs.count);
    assemble_tangent_stiffness(model, state, joints, &mut k);
    (k, dofs)
}

/// Every entry (row, column of free DOFs) that a tangent of `model` can
/// have nonzero, each pair of coupled nodes once (the layout stores the
/// transpose too): the ends of each member, and every two nodes of a
/// continuous cable's path (a cluster of sliding joints can span the whole
/// cable and couples all its nodes). Slack members and stuck joints only
/// zero some of these, so one pattern serves every state.
pub fn tangent_coupling(model: &ForwardModel) -> Vec<(usize, usize)> {
    let dofs = model.free_dofs();
    let mut node_pairs: Vec<[usize; 2]> = model.structure.members.iter().map(|m| m.nodes).collect();
    for cable in &model.structure.continuous_cables {
        for (k, &a) in cable.path.iter().enumerate() {
            for &b in &cable.path[k + 1..] {
                node_pairs.push([a, b]);
            }
        }
    }
    for p in &mut node_pairs {
        p.sort_unstable();
    }
    node_pairs.sort_unstable();
    node_pairs.dedup();
    let mut pairs = Vec::new();
    for [a, b] in node_pairs {
        for (p, q) in [(a, a), (a, b), (b, b)] {
            for r in dofs.index[p].iter().flatten() {
                for c in dofs.index[q].iter().flatten() {
                    pairs.push((*r, *c));
                }
            }
        }
    }
    pairs
}

/// The block layout to assemble `model`'s tangents into: its DOF blocks,
/// each dense or sparse on the pattern of [`tangent_coupling`], whichever
/// is estimated to factorise faster ([`BlockLayout::new`]).
pub fn tangent_layout(model: &ForwardModel) -> BlockLayout {
    let (size, blocks) = (model.free_dofs().count, model.dof_blocks());
    if blocks.iter().all(|b| b.len() < MIN_SPARSE_ROWS) {
        return BlockLayout::dense(size, blocks);
    }
    BlockLayout::new(size, blocks, &tangent_coupling(model))
}

/// Adds the tangent stiffness of `state` (N/m, as [`tangent_stiffness`],
/// rows and columns numbered by the model's free DOFs) to `k`: a dense
/// matrix, or the per-block storage that [`crate::numerics::BlockLu`]
/// factorises in place.
pub fn assemble_tangent_stiffness(
    model: &ForwardModel,
    state: &DeploymentState,
    joints: JointMode,
    k: &mut impl MatrixAssembly,
) {
    let dofs = model.free_dofs();
    let x = &state.positions_m;
    // Members: the solver's element law (segments are handled per cable
    // below, where joints couple them).
    for e in &model.elements[..model.structure.members.len()] {
        let ElementLaw::Linear { tension_only, .. } = e.law else {
            continue;
        };
        let d = x[e.b] - x[e.a];
        let axial = e.law.at(d.norm(), &state.segment_rest_lengths_m);
        if tension_only && axial.tension_n <= 0.0 {
            continue;
        }
        add_element(
            k,
            dofs,
            e.a,
            e.b,
            &element_block(axial.stiffness_n_per_m, axial.tension_n, &d),
        );
    }
    for (c, cable) in model.structure.continuous_cables.iter().enumerate() {
        let o = state.segment_offsets[c];
        let rest = state.cable_rest_lengths(c);
        let n_seg = rest.len();
        let d: Vec<Vector3<f64>> = cable.path.windows(2).map(|w| x[w[1]] - x[w[0]]).collect();
        let t: Vec<f64> = d
            .iter()
            .zip(rest)
            .map(|(d, s)| segment_tension(cable.ea_n, d.norm(), *s))
            .collect();
        // σ_j·∂ln b/∂θ per joint (index 0 unused), for sliding joints.
        let slope: Vec<f64> = (0..n_seg)
            .map(|j| {
                if j == 0 {
                    return 0.0;
                }
                let sigma = match (joints, state.joint_slip[o + j]) {
                    (JointMode::AsMapped, JointSlip::TowardsMotor) => -1.0,
                    (JointMode::AsMapped, JointSlip::TowardsEnd) => 1.0,
                    _ => return 0.0,
                };
                let theta = interior_angle(&d[j - 1].normalize(), &d[j].normalize());
                sigma * log_bound_slope(&model.friction, theta)
            })
            .collect();
        // Clusters: runs of taut segments joined by sliding joints.
        let mut first = 0;
        while first < n_seg {
            let mut last = first;
            while last + 1 < n_seg
                && t[last] > 0.0
                && t[last + 1] > 0.0
                && match joints {
                    JointMode::Stuck => false,
                    JointMode::Sliding => true,
                    JointMode::AsMapped => state.joint_slip[o + last + 1] != JointSlip::Stuck,
                }
            {
                last += 1;
            }
            add_cluster(
                k,
                dofs,
                &Cluster {
                    ea_n: cable.ea_n,
                    path: &cable.path[first..=last + 1],
                    d: &d[first..=last],
                    rest_m: &rest[first..=last],
                    tension_n: &t[first..=last],
                    log_bound_slope: &slope[first..=last],
                },
            );
            first = last + 1;
        }
    }
}

/// A run of consecutive taut segments of one cable that exchange material
/// over sliding joints (a single segment is a cluster of one).
struct Cluster<'a> {
    ea_n: f64,
    /// Path nodes, one more than segments.
    path: &'a [usize],
    /// Segment vectors `x[path[i+1]] − x[path[i]]`, m.
    d: &'a [Vector3<f64>],
    rest_m: &'a [f64],
    tension_n: &'a [f64],
    /// Per interior joint `j = 1..` (index 0 unused): `σ_j·∂ln b/∂θ`, with
    /// `σ = −1` sliding towards the motor (`T_{j−1} = b·T_j`) and `+1`
    /// towards the end (`T_j = b·T_{j−1}`).
    log_bound_slope: &'a [f64],
}

/// How the capstan bound of one sliding joint moves a cluster's forces.
struct JointTerm {
    joint: usize,
    angle_gradient: [Vector3<f64>; 3],
    force_per_rad: Vec<Vector3<f64>>,
}

/// Adds a cluster's consistent tangent.
///
/// Tensions keep the ratios the sliding joints impose, `T_i = w_i·T`, where
/// `ln w_i = Σ_{j≤i} σ_j·ln b(θ_j)` changes with the joint angles, and the
/// total material `S = Σ s_i` is fixed. With `s_i = EA·L_i/(EA + T_i)`,
/// `dS = 0` gives
///
/// ```text
///     dT = [Σ_i (s_i/L_i)·dL_i − T·Σ_j σ_j β_j C_j·dθ_j] / D,
///     D  = Σ_i s_i w_i/(EA + T_i),   C_j = Σ_{i≥j} s_i w_i/(EA + T_i),
/// ```
/// (`β_j = ∂ln b/∂θ` at joint `j`), and the nodal force `Σ_i T_i·b_i`
/// (`b_i = ∂L_i/∂x`) changes by `Σ_i b_i·(w_i·dT + T·dw_i)`. For one segment
/// this is `EA/s·b·bᵀ`; without friction `EA/S·g·gᵀ`. With friction it is
/// not symmetric. Geometric terms `(T_i/L_i)(I − e·eᵀ)` stay per segment.
fn add_cluster(k: &mut impl MatrixAssembly, dofs: &FreeDofs, c: &Cluster<'_>) {
    let t_ref = c.tension_n[0];
    if t_ref <= 0.0 {
        return;
    }
    let m = c.d.len();
    let n_nodes = m + 1;
    let len: Vec<f64> = c.d.iter().map(|d| d.norm()).collect();
    let e: Vec<Vector3<f64>> = c.d.iter().zip(&len).map(|(d, l)| d / *l).collect();
    let w: Vec<f64> = c.tension_n.iter().map(|t| t / t_ref).collect();
    let compliance: Vec<f64> = (0..m)
        .map(|i| c.rest_m[i] * w[i] / (c.ea_n + c.tension_n[i]))
        .collect();
    let denominator: f64 = compliance.iter().sum();
    // The cluster's 3×3 blocks over its node pairs (row node p, column
    // node q at `p * n_nodes + q`), summed here and added to `k` once per
    // pair: the friction terms couple every pair, and adding each term
    // straight into `k` cost four times the calls (assembly was 20 % of
    // `evaluate`).
    let mut local = vec![Matrix3::zeros(); n_nodes * n_nodes];
    for i in 0..m {
        let g = element_block(0.0, c.tension_n[i], &c.d[i]);
        local[i * n_nodes + i] += g;
        local[(i + 1) * n_nodes + i + 1] += g;
        local[i * n_nodes + i + 1] -= g;
        local[(i + 1) * n_nodes + i] -= g;
    }
    // Row vectors over the cluster's nodes (3 entries per node).
    // force_side: Σ_i w_i b_i;  dt_row: ∂T/∂x;  and per joint the
    // gradient of θ_j with its coefficient on the force.
    let mut force_side = vec![Vector3::zeros(); n_nodes];
    let mut dt_row = vec![Vector3::zeros(); n_nodes];
    for i in 0..m {
        force_side[i] -= w[i] * e[i];
        force_side[i + 1] += w[i] * e[i];
        let f = c.rest_m[i] / len[i] / denominator;
        dt_row[i] -= f * e[i];
        dt_row[i + 1] += f * e[i];
    }
    // Joint terms: dθ_j = a_j·dx over nodes j−1, j, j+1 (local indices).
    // Per joint: its index, the gradient of θ_j over nodes j−1..=j+1, and
    // the force it moves per radian over the cluster's nodes.
    let mut joint_terms: Vec<JointTerm> = Vec::new();
    for j in 1..m {
        let slope = c.log_bound_slope[j];
        if slope == 0.0 {
            continue;
        }
        let (ea, eb) = (e[j - 1], e[j]);
        let cos = -ea.dot(&eb);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        if sin < 1e-9 {
            // Straight cable: the angle is not differentiable; no term.
            continue;
        }
        let u_a = (eb - ea * ea.dot(&eb)) / len[j - 1];
        let u_b = (ea - eb * eb.dot(&ea)) / len[j];
        // θ = acos(−e_a·e_b): dθ = (u_a·(dx_j − dx_{j−1}) + u_b·(dx_{j+1} − dx_j)) / sin θ.
        let grad = [-u_a / sin, (u_a - u_b) / sin, u_b / sin];
        // Σ_{i≥j} w_i b_i over nodes, and C_j.
        let mut tail_force = vec![Vector3::zeros(); n_nodes];
        let mut tail_compliance = 0.0;
        for i in j..m {
            tail_force[i] -= w[i] * e[i];
            tail_force[i + 1] += w[i] * e[i];
            tail_compliance += compliance[i];
        }
        // dT gains −T·σβ·C_j/D · dθ_j.
        let dt_coef = -t_ref * slope * tail_compliance / denominator;
        for (q, g) in grad.iter().enumerate() {
            dt_row[j - 1 + q] += dt_coef * g;
        }
        // Force gains T·σβ·(Σ_{i≥j} w_i b_i)·dθ_j.
        let scaled: Vec<Vector3<f64>> = tail_force.iter().map(|v| t_ref * slope * v).collect();
        joint_terms.push(JointTerm {
            joint: j,
            angle_gradient: grad,
            force_per_rad: scaled,
        });
    }
    for (p, fp) in force_side.iter().enumerate() {
        for (q, tq) in dt_row.iter().enumerate() {
            local[p * n_nodes + q] += fp * tq.transpose();
        }
    }
    for term in &joint_terms {
        for (p, fp) in term.force_per_rad.iter().enumerate() {
            for (q, g) in term.angle_gradient.iter().enumerate() {
                local[p * n_nodes + term.joint - 1 + q] += fp * g.transpose();
            }
        }
    }
    for (p, &row_node) in c.path.iter().enumerate() {
        for (q, &col_node) in c.path.iter().enumerate() {
            add_block(k, dofs, row_node, col_node, &local[p * n_nodes + q]);
        }
    }
}

/// `∂ln b/∂θ` of the kinetic capstan bound at interior angle `theta`, by a
/// central difference (exact for constant μ; the mean slope across a kink
/// of a μ table).
fn log_bound_slope(friction: &JointFriction, theta: f64) -> f64 {
    const H: f64 = 1e-6;
    let (lo, hi) = ((theta - H).max(0.0), (theta + H).min(std::f64::consts::PI));
    (friction.ratio_bound(hi, true).ln() - friction.ratio_bound(lo, true).ln()) / (hi - lo)
}

/// Smallest eigenvalue of the tangent stiffness, N/m: positive for a stable
/// equilibrium, zero for a mechanism, negative for an unstable one.
pub fn min_stiffness_eigenvalue(k: &DMatrix<f64>) -> f64 {
    k.clone()
        .symmetric_eigen()
        .eigenvalues
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::friction::JointFriction;
    use crate::model::state::JointSlip;
    use crate::model::structure::{ContinuousCable, Node, Structure};
    use crate::model::RelaxSettings;
    use crate::numerics::BlockMatrix;

    /// A massless, unloaded node at `p`, fixed in all three axes or free.
    fn node(id: &str, p: [f64; 3], fixed: bool) -> Node {
        Node {
            id: id.into(),
            position_m: Vector3::from(p),
            mass_kg: 0.0,
            fixed: [fixed; 3],
            load_n: Vector3::zeros(),
        }
    }

    /// A V-shaped continuous cable from two supports over one free joint.
    fn v_cable(rest_scale: f64) -> ForwardModel {
        let nodes = vec![
            node("a", [0.0, 0.0, 0.0], true),
            node("j", [1.0, 0.0, -0.5], false),
            node("b", [2.0, 0.0, 0.0], true),
        ];
        let l = (1.25f64).sqrt();
        let cable = ContinuousCable {
            id: "c".into(),
            path: vec![0, 1, 2],
            ea_n: 1e5,
            segment_rest_lengths_m: vec![l * rest_scale, l * rest_scale],
        };
        let s = Structure::new("v", nodes, vec![], vec![cable], Vector3::zeros(), vec![]).unwrap();
        ForwardModel::new(s, JointFriction::frictionless(), RelaxSettings::default()).unwrap()
    }

    /// Regression: a continuous cable over a support (a fixed joint
    /// between free ones) was split into two DOF blocks at the support, and
    /// the block storage dropped the coupling that a cluster sliding over
    /// all its joints puts between the free nodes on either side.
    #[test]
    fn a_cable_sliding_over_a_support_keeps_both_sides_in_one_block() {
        // W shape: motor, joint, support seat, joint, end.
        let nodes = vec![
            node("motor", [0.0, 0.0, 0.0], true),
            node("j1", [1.0, 0.1, -0.5], false),
            node("seat", [2.0, 0.0, 0.0], true),
            node("j2", [3.0, -0.1, -0.4], false),
            node("end", [4.0, 0.0, 0.0], true),
        ];
        let len = |a: usize, b: usize| (nodes[b].position_m - nodes[a].position_m).norm();
        let cable = ContinuousCable {
            id: "c".into(),
            path: vec![0, 1, 2, 3, 4],
            ea_n: 1e5,
            segment_rest_lengths_m: (0..4).map(|i| 0.99 * len(i, i + 1)).collect(),
        };
        let s = Structure::new("w", nodes, vec![], vec![cable], Vector3::zeros(), vec![]).unwrap();
        let model = ForwardModel::new(
            s,
            JointFriction::constant(0.1).unwrap(),
            RelaxSettings::default(),
        )
        .unwrap();
        assert_eq!(model.dof_blocks().len(), 1, "{:?}", model.dof_blocks());
        // Every joint sliding towards the motor: one cluster over j1, the
        // seat and j2.
        let mut state = model.reference_state();
        for slip in state.joint_slip.iter_mut().skip(1) {
            *slip = JointSlip::TowardsMotor;
        }
        let (dense, dofs) = tangent_stiffness(&model, &state, JointMode::AsMapped);
        let (j1, j2) = (dofs.index[1][0].unwrap(), dofs.index[3][0].unwrap());
        let coupling = (0..3)
            .flat_map(|a| (0..3).map(move |b| (a, b)))
            .map(|(a, b)| dense[(j1 + a, j2 + b)].abs())
            .fold(0.0, f64::max);
        assert!(
            coupling > 1e-3 * dense.amax(),
            "{coupling} of {}",
            dense.amax()
        );
        let mut blocks = BlockMatrix::zeros_on(&tangent_layout(&model));
        assemble_tangent_stiffness(&model, &state, JointMode::AsMapped, &mut blocks);
        for r in 0..dense.nrows() {
            for c in 0..dense.ncols() {
                assert_eq!(blocks.get(r, c), dense[(r, c)], "entry ({r}, {c})");
            }
        }
    }

    /// Central differences of the out-of-balance force, for comparison.
    fn finite_difference(model: &ForwardModel, state: &DeploymentState, h: f64) -> DMatrix<f64> {
        let dofs = model.free_dofs().clone();
        let mut k = DMatrix::zeros(dofs.count, dofs.count);
        let force = |s: &DeploymentState| -> Vec<Vector3<f64>> {
            let f = model.member_forces(s);
            let mut net = vec![Vector3::zeros(); s.positions_m.len()];
            for (m, t) in model.structure.members.iter().zip(&f.member_n) {
                let d = s.positions_m[m.nodes[1]] - s.positions_m[m.nodes[0]];
                net[m.nodes[0]] += *t * d / d.norm();
                net[m.nodes[1]] -= *t * d / d.norm();
            }
            let mut seg = 0;
            for c in &model.structure.continuous_cables {
                for w in c.path.windows(2) {
                    let d = s.positions_m[w[1]] - s.positions_m[w[0]];
                    net[w[0]] += f.segment_n[seg] * d / d.norm();
                    net[w[1]] -= f.segment_n[seg] * d / d.norm();
                    seg += 1;
                }
            }
            net
        };
        for (node, rows) in dofs.index.iter().enumerate() {
            for a in 0..3 {
                let Some(col) = rows[a] else { continue };
                let mut plus = state.clone();
                plus.positions_m[node][a] += h;
                let mut minus = state.clone();
                minus.positions_m[node][a] -= h;
                let (fp, fm) = (force(&plus), force(&minus));
                for (i, r) in dofs.index.iter().enumerate() {
                    for b in 0..3 {
                        if let Some(row) = r[b] {
                            // K = −∂R/∂x.
                            k[(row, col)] = -(fp[i][b] - fm[i][b]) / (2.0 * h);
                        }
                    }
                }
            }
        }
        k
    }

    #[test]
    fn stuck_stiffness_matches_finite_differences() {
        let model = v_cable(0.99);
        let state = model.reference_state();
        let (k, _) = tangent_stiffness(&model, &state, JointMode::Stuck);
        let fd = finite_difference(&model, &state, 1e-7);
        let scale = k.amax();
        assert!((&k - &fd).amax() < 1e-6 * scale, "{k} vs {fd}");
    }

    #[test]
    fn sliding_joint_has_no_stiffness_along_the_ellipse() {
        // With equal rest lengths and a sliding joint, moving the joint along
        // the ellipse of constant total length costs only geometric stiffness:
        // the direction tangent to the ellipse sees T·(1/L1 + 1/L2)·sin²
        // terms but no EA term, while the stuck cable sees EA there.
        let model = v_cable(0.99);
        let state = model.reference_state();
        let (k_slide, _) = tangent_stiffness(&model, &state, JointMode::Sliding);
        let (k_stuck, _) = tangent_stiffness(&model, &state, JointMode::Stuck);
        // Ellipse tangent at the joint: along x (the foci are symmetric).
        let along = nalgebra::DVector::from_vec(vec![1.0, 0.0, 0.0]);
        let slide = (along.transpose() * &k_slide * &along)[0];
        let stuck = (along.transpose() * &k_stuck * &along)[0];
        let l = 1.25f64.sqrt();
        let t = 1e5 * (l - 0.99 * l) / (0.99 * l);
        // Geometric only: Σ T/L·(1 − e_x²) with e_x² = 1/1.25 for both.
        let expected = 2.0 * t / l * (1.0 - 1.0 / 1.25);
        assert!(
            (slide - expected).abs() < 1e-9 * expected,
            "{slide} vs {expected}"
        );
        assert!(stuck > 100.0 * slide);
        assert!(min_stiffness_eigenvalue(&k_slide) > 0.0);
    }

    /// An N×N net as the peer benchmark's (perimeter pinned, 1 m grid,
    /// prestressed by rest lengths 0.998 m, so its flat tangent is SPD),
    /// unloaded.
    fn square_net(n: usize) -> ForwardModel {
        let net = crate::design::square_net(&crate::design::SquareNetParameters {
            nodes_per_side: n,
            free_node_load_n: 0.0,
            ..Default::default()
        })
        .unwrap();
        ForwardModel::new(net, JointFriction::frictionless(), RelaxSettings::default()).unwrap()
    }

    /// Solves `k·x = rhs` on every block stored sparse and on every block
    /// dense (faer's dense kernels, tested against nalgebra in
    /// `block_lu`), and returns (the sparse solution, its relative
    /// difference from the dense one, whether the sparse used Cholesky).
    fn sparse_against_dense(
        model: &ForwardModel,
        k: &DMatrix<f64>,
        layout: &BlockLayout,
    ) -> (nalgebra::DVector<f64>, f64, bool) {
        use crate::numerics::{BlockLu, BlockMatrix};
        let n = k.nrows();
        let rhs = nalgebra::DVector::from_fn(n, |i, _| (0.7 * i as f64).sin() + 0.1);
        let sparse = BlockLu::factorise(BlockMatrix::from_dense_on(k, layout)).unwrap();
        let dense = BlockLu::new(k, model.dof_blocks()).unwrap();
        let (xs, xd) = (sparse.solve(&rhs), dense.solve(&rhs));
        (
            xs.clone(),
            (&xs - &xd).amax() / xd.amax(),
            sparse.is_cholesky(),
        )
    }

    /// The sparse kernels solve the tangents of the bridge and of a net as
    /// the dense ones do, to 1e-10 relative: the tangents' condition
    /// numbers are ~1e6–1e8 (steel struts against soft springs, the net's
    /// prestress against EA), so the two factorisations, whose rounding
    /// differs by their orderings, agree to ~1e-16·κ ≤ 1e-8 in the worst
    /// case and in practice to ~1e-12; 1e-10 leaves margin and still fails
    /// on any wrong entry (a missed coupling changes the answer at 1e-3).
    /// Symmetric tangents take Cholesky; the friction tangent (sliding
    /// joints) and an unsymmetric net take LU. A second matrix on the same
    /// layout (the symbolic analysis reused) is solved exactly as on a
    /// fresh layout.
    #[test]
    fn sparse_blocks_solve_tangents_like_dense_ones() {
        let bridge = ForwardModel::new(
            crate::design::reference_bridge(&crate::design::BridgeParameters::default()).unwrap(),
            JointFriction::constant(0.2).unwrap(),
            RelaxSettings::default(),
        )
        .unwrap();
        let net = square_net(11);
        let sparse_layout = |m: &ForwardModel| {
            BlockLayout::with_sparse_from(
                m.free_dofs().count,
                m.dof_blocks(),
                &tangent_coupling(m),
                0,
            )
        };
        // The bridge, joints stuck (symmetric) and some sliding (not).
        let layout = sparse_layout(&bridge);
        let stuck = bridge.reference_state();
        let mut sliding = stuck.clone();
        for c in 0..bridge.structure.continuous_cables.len() {
            let o = sliding.segment_offsets[c];
            sliding.joint_slip[o + 1] = JointSlip::TowardsMotor;
            sliding.joint_slip[o + 2] = JointSlip::TowardsEnd;
        }
        let (k_stuck, _) = tangent_stiffness(&bridge, &stuck, JointMode::AsMapped);
        let (k_sliding, _) = tangent_stiffness(&bridge, &sliding, JointMode::AsMapped);
        assert!((&k_sliding - k_sliding.transpose()).amax() > 1e-8 * k_sliding.amax());
        let (_, err, cholesky) = sparse_against_dense(&bridge, &k_stuck, &layout);
        assert!(err < 1e-10 && cholesky, "bridge stuck: {err}");
        let (x_reused, err, cholesky) = sparse_against_dense(&bridge, &k_sliding, &layout);
        assert!(err < 1e-10 && !cholesky, "bridge sliding: {err}");
        let (x_fresh, _, _) = sparse_against_dense(&bridge, &k_sliding, &sparse_layout(&bridge));
        assert_eq!(x_reused, x_fresh, "symbolic reuse");
        // The net, flat (symmetric) and with an unsymmetric term on its
        // pattern (the upper triangle scaled by 1.3).
        let layout = sparse_layout(&net);
        let (k_net, _) = tangent_stiffness(&net, &net.reference_state(), JointMode::AsMapped);
        let (_, err, cholesky) = sparse_against_dense(&net, &k_net, &layout);
        assert!(err < 1e-10 && cholesky, "net: {err}");
        let k_unsym = DMatrix::from_fn(k_net.nrows(), k_net.ncols(), |i, j| {
            k_net[(i, j)] * if i < j { 1.3 } else { 1.0 }
        });
        let (_, err, cholesky) = sparse_against_dense(&net, &k_unsym, &layout);
        assert!(err < 1e-10 && !cholesky, "unsymmetric net: {err}");
    }

    /// Assembling straight into the sparse blocks gives the dense
    /// assembly's entries (the pattern holds every coupling: no entry
    /// dropped, none misplaced), on the bridge with sliding joints (whose
    /// clusters couple a cable's nodes beyond neighbours).
    #[test]
    fn assembly_into_sparse_blocks_matches_the_dense_tangent() {
        use crate::numerics::BlockMatrix;
        let bridge = ForwardModel::new(
            crate::design::reference_bridge(&crate::design::BridgeParameters::default()).unwrap(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap();
        let mut state = bridge.reference_state();
        state.joint_slip.fill(JointSlip::TowardsEnd);
        let layout = BlockLayout::with_sparse_from(
            bridge.free_dofs().count,
            bridge.dof_blocks(),
            &tangent_coupling(&bridge),
            0,
        );
        let mut m = BlockMatrix::zeros_on(&layout);
        assert!(m.has_sparse_blocks());
        assemble_tangent_stiffness(&bridge, &state, JointMode::Sliding, &mut m);
        let (k, dofs) = tangent_stiffness(&bridge, &state, JointMode::Sliding);
        for r in 0..dofs.count {
            for c in 0..dofs.count {
                assert_eq!(m.get(r, c), k[(r, c)], "({r}, {c})");
            }
        }
        // The default layout keeps the bridge's 60-row halves dense (dense
        // is faster there) and makes the 11×11 net's block sparse.
        assert!(!BlockMatrix::zeros_on(&tangent_layout(&bridge)).has_sparse_blocks());
        assert!(BlockMatrix::zeros_on(&tangent_layout(&square_net(11))).has_sparse_blocks());
    }
}
