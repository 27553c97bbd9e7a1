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
//!   segment.
//!
//! The matrix is dense over the free degrees of freedom, which is what a
//! structure of a few hundred of them needs. It is symmetric, and positive
//! definite exactly when the equilibrium is stable.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::relax::ForwardModel;
use super::sliding::segment_tension;
use super::state::DeploymentState;

/// How continuous cables behave at their joints in a linearisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointMode {
    /// All joints hold: segments act as separate cables.
    Stuck,
    /// All joints slide without friction: one tension per cable (μ = 0).
    Sliding,
}

/// Numbering of the free degrees of freedom: `index[node][axis]` is the
/// row of that DOF, `None` where the axis is fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeDofs {
    /// Row of each node's axis, or `None` for a supported axis.
    pub index: Vec<[Option<usize>; 3]>,
    /// Number of free DOFs.
    pub count: usize,
}

impl FreeDofs {
    /// Numbers the free DOFs of a structure node by node, x, y, z.
    pub fn of(model: &ForwardModel) -> Self {
        let mut count = 0;
        let index = model
            .structure
            .nodes
            .iter()
            .map(|n| {
                let mut row = [None; 3];
                for (a, slot) in row.iter_mut().enumerate() {
                    if !n.fixed[a] {
                        *slot = Some(count);
                        count += 1;
                    }
                }
                row
            })
            .collect();
        FreeDofs { index, count }
    }
}

/// Adds `sign·block` to the (`i`, `j`) node block of `k`, free rows only.
fn add_block(k: &mut DMatrix<f64>, dofs: &FreeDofs, i: usize, j: usize, block: &Matrix3<f64>) {
    for a in 0..3 {
        let Some(r) = dofs.index[i][a] else { continue };
        for b in 0..3 {
            if let Some(c) = dofs.index[j][b] {
                k[(r, c)] += block[(a, b)];
            }
        }
    }
}

/// Adds a two-node element's stiffness `block` (on `x_b − x_a`).
fn add_element(k: &mut DMatrix<f64>, dofs: &FreeDofs, a: usize, b: usize, block: &Matrix3<f64>) {
    add_block(k, dofs, a, a, block);
    add_block(k, dofs, b, b, block);
    add_block(k, dofs, a, b, &-block);
    add_block(k, dofs, b, a, &-block);
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
    let dofs = FreeDofs::of(model);
    let mut k = DMatrix::zeros(dofs.count, dofs.count);
    let x = &state.positions_m;
    for m in &model.structure.members {
        let [a, b] = m.nodes;
        let d = x[b] - x[a];
        let l = d.norm();
        let k_axial = m.kind.axial_stiffness(m.rest_length_m);
        let t = k_axial * (l - m.rest_length_m);
        if m.kind.is_tension_only() && t <= 0.0 {
            continue;
        }
        add_element(&mut k, &dofs, a, b, &element_block(k_axial, t, &d));
    }
    for (c, cable) in model.structure.continuous_cables.iter().enumerate() {
        let rest = state.cable_rest_lengths(c);
        match joints {
            JointMode::Stuck => {
                for (w, s) in cable.path.windows(2).zip(rest) {
                    let d = x[w[1]] - x[w[0]];
                    let t = segment_tension(cable.ea_n, d.norm(), *s);
                    if t > 0.0 {
                        let block = element_block(cable.ea_n / s, t, &d);
                        add_element(&mut k, &dofs, w[0], w[1], &block);
                    }
                }
            }
            JointMode::Sliding => {
                let total_rest: f64 = rest.iter().sum();
                let total_len: f64 = cable
                    .path
                    .windows(2)
                    .map(|w| (x[w[1]] - x[w[0]]).norm())
                    .sum();
                let t = segment_tension(cable.ea_n, total_len, total_rest);
                if t <= 0.0 {
                    continue;
                }
                // Geometric part per segment; material part on the total length.
                let mut grad = vec![Vector3::zeros(); cable.path.len()];
                for (i, w) in cable.path.windows(2).enumerate() {
                    let d = x[w[1]] - x[w[0]];
                    add_element(&mut k, &dofs, w[0], w[1], &element_block(0.0, t, &d));
                    let e = d / d.norm();
                    grad[i] -= e;
                    grad[i + 1] += e;
                }
                let k_axial = cable.ea_n / total_rest;
                for (i, gi) in grad.iter().enumerate() {
                    for (j, gj) in grad.iter().enumerate() {
                        let block = k_axial * gi * gj.transpose();
                        add_block(&mut k, &dofs, cable.path[i], cable.path[j], &block);
                    }
                }
            }
        }
    }
    (k, dofs)
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
    use crate::model::relax::RelaxSettings;
    use crate::model::structure::{ContinuousCable, Node, Structure};

    /// A V-shaped continuous cable from two supports over one free joint.
    fn v_cable(rest_scale: f64) -> ForwardModel {
        let node = |id: &str, p: [f64; 3], fixed: bool| Node {
            id: id.into(),
            position_m: Vector3::from(p),
            mass_kg: 0.0,
            fixed: [fixed; 3],
            load_n: Vector3::zeros(),
        };
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
        ForwardModel::new(s, JointFriction::frictionless(), RelaxSettings::default())
    }

    /// Central differences of the out-of-balance force, for comparison.
    fn finite_difference(model: &ForwardModel, state: &DeploymentState, h: f64) -> DMatrix<f64> {
        let dofs = FreeDofs::of(model);
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
}
