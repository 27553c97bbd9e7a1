//! Prestress for a given geometry: member forces in equilibrium with the
//! loads, found as a QP over the equilibrium matrix.
//!
//! With member forces `t` (tension positive) grouped so that all segments of
//! a continuous cable share one force (the frictionless state), equilibrium
//! of every free degree of freedom reads `A·t + f = 0`, where column `g` of
//! the equilibrium matrix `A` sums the unit vectors of group `g`'s elements
//! at each node and `f` holds the applied loads. Among the force sets that
//! satisfy it and the sign bounds (cables in tension, struts in compression)
//! the QP picks the one closest to the designer's target forces.
//!
//! # Stability
//! Equilibrium is not enough: a tensegrity whose continuous cables slide
//! freely can sit in an unstable equilibrium. For fixed geometry the tangent
//! stiffness is affine in the forces, `K(t) = K₀ + Σ_g t_g·G_g` (material
//! stiffness `K₀`, geometric stiffness `G_g = Σ (1/L)(I − e·eᵀ)` over group
//! `g`'s elements, with each multi-element group acting as a clustered cable,
//! see [`crate::model::stiffness`]). [`find_stable_prestress`] asks for
//! `λ_min(K(t)) ≥ κ` by Kelley's cutting planes: while the solution violates
//! it, each eigenvector `v` with `vᵀK v < κ` becomes the linear constraint
//! `Σ_g t_g·vᵀG_g v ≥ κ − vᵀK₀v`, and the QP is solved again.

use nalgebra::{DMatrix, DVector, Vector3};

use crate::numerics::qp::{self, QpError, QpSettings, QpSolution, QuadraticProgram};
use crate::numerics::FreeDofs;

/// Elements sharing one unknown force, with its bounds and target.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceGroup {
    /// Node pairs of the elements (one for a member, several for a
    /// continuous cable).
    pub elements: Vec<[usize; 2]>,
    /// Lower bound on the force, N.
    pub min_n: f64,
    /// Upper bound on the force, N.
    pub max_n: f64,
    /// Preferred force, N.
    pub target_n: f64,
    /// Weight of the squared deviation from the target, 1/N².
    pub weight: f64,
    /// Material stiffness of the group, N/m: `EA/L` of a member, `k` of a
    /// spring, `EA/ΣL` of a clustered cable (acting on its total length).
    pub axial_stiffness_n_per_m: f64,
}

/// The QP that finds group forces in equilibrium with `loads_n` at the free
/// degrees of freedom. Pure: tests can inspect it.
pub fn prestress_problem(
    positions_m: &[Vector3<f64>],
    fixed: &[[bool; 3]],
    loads_n: &[Vector3<f64>],
    groups: &[ForceGroup],
) -> QuadraticProgram {
    let dofs = FreeDofs::from_fixed(fixed);
    let (dof_row, rows) = (&dofs.index, dofs.count);
    let n = groups.len();
    let mut eq = DMatrix::zeros(rows, n);
    let mut rhs = DVector::zeros(rows);
    for (g, group) in groups.iter().enumerate() {
        for &[a, b] in &group.elements {
            let u = (positions_m[b] - positions_m[a]).normalize();
            // A tension pulls a towards b and b towards a.
            for ax in 0..3 {
                if let Some(r) = dof_row[a][ax] {
                    eq[(r, g)] += u[ax];
                }
                if let Some(r) = dof_row[b][ax] {
                    eq[(r, g)] -= u[ax];
                }
            }
        }
    }
    for (i, l) in loads_n.iter().enumerate() {
        for ax in 0..3 {
            if let Some(r) = dof_row[i][ax] {
                rhs[r] = -l[ax];
            }
        }
    }
    let mut hessian = DMatrix::zeros(n, n);
    let mut linear = DVector::zeros(n);
    let mut ineq = DMatrix::zeros(2 * n, n);
    let mut ineq_rhs = DVector::zeros(2 * n);
    for (g, group) in groups.iter().enumerate() {
        hessian[(g, g)] = group.weight;
        linear[g] = -group.weight * group.target_n;
        ineq[(2 * g, g)] = 1.0;
        ineq_rhs[2 * g] = group.max_n;
        ineq[(2 * g + 1, g)] = -1.0;
        ineq_rhs[2 * g + 1] = -group.min_n;
    }
    QuadraticProgram {
        hessian,
        linear,
        eq_matrix: eq,
        eq_rhs: rhs,
        ineq_matrix: ineq,
        ineq_rhs,
    }
}

/// Adds `scale·gᵀ-outer` style blocks: `k[(r_i, r_j)] += w·u_i·u_j` over
/// the free rows of the listed (node, vector) entries.
fn add_outer(
    k: &mut DMatrix<f64>,
    rows: &[[Option<usize>; 3]],
    entries: &[(usize, Vector3<f64>)],
    w: f64,
) {
    for (i, ui) in entries {
        for (j, uj) in entries {
            for a in 0..3 {
                let Some(r) = rows[*i][a] else {
                    continue;
                };
                for b in 0..3 {
                    if let Some(c) = rows[*j][b] {
                        k[(r, c)] += w * ui[a] * uj[b];
                    }
                }
            }
        }
    }
}

/// Material stiffness `K₀` and per-group geometric stiffness `G_g` (per
/// newton of group force) of `groups` in the given geometry, on the free DOFs.
pub fn stiffness_parts(
    positions_m: &[Vector3<f64>],
    fixed: &[[bool; 3]],
    groups: &[ForceGroup],
) -> (DMatrix<f64>, Vec<DMatrix<f64>>) {
    let dofs = FreeDofs::from_fixed(fixed);
    let (rows, n) = (&dofs.index, dofs.count);
    let mut material = DMatrix::zeros(n, n);
    let mut geometric = Vec::with_capacity(groups.len());
    for group in groups {
        let mut g = DMatrix::zeros(n, n);
        let mut grad: Vec<(usize, Vector3<f64>)> = Vec::new();
        for &[a, b] in &group.elements {
            let d = positions_m[b] - positions_m[a];
            let l = d.norm();
            let e = d / l;
            // (1/L)(I − eeᵀ) on x_b − x_a: identity part minus the e-outer part.
            for (i, j, sign) in [(a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)] {
                for ax in 0..3 {
                    if let (Some(r), Some(c)) = (rows[i][ax], rows[j][ax]) {
                        g[(r, c)] += sign / l;
                    }
                }
            }
            add_outer(&mut g, rows, &[(a, -e), (b, e)], -1.0 / l);
            grad.push((a, -e));
            grad.push((b, e));
        }
        add_outer(&mut material, rows, &grad, group.axial_stiffness_n_per_m);
        geometric.push(g);
    }
    (material, geometric)
}

/// Result of [`find_stable_prestress`].
#[derive(Debug, Clone, PartialEq)]
pub struct StablePrestress {
    /// The last QP solution; its status says whether forces were found.
    pub solution: QpSolution,
    /// Smallest eigenvalue of the tangent stiffness (sliding joints) at the
    /// found forces, N/m.
    pub min_eigenvalue_n_per_m: f64,
    /// QP solves used (1 + cutting-plane rounds).
    pub rounds: usize,
}

impl StablePrestress {
    /// `true` when forces were found and the stiffness bound holds (to 1 %
    /// of it, the cutting plane's stopping tolerance).
    pub fn is_stable(&self, min_eigenvalue_n_per_m: f64) -> bool {
        self.solution.status.is_solved()
            && self.min_eigenvalue_n_per_m >= 0.99 * min_eigenvalue_n_per_m
    }
}

/// Prestress in equilibrium with the loads whose tangent stiffness, with
/// every continuous cable sliding freely, has smallest eigenvalue at least
/// `min_eigenvalue_n_per_m` (see the module docs). Stops after `max_rounds`
/// cutting-plane rounds, or as soon as the QP has no solution.
pub fn find_stable_prestress(
    positions_m: &[Vector3<f64>],
    fixed: &[[bool; 3]],
    loads_n: &[Vector3<f64>],
    groups: &[ForceGroup],
    min_eigenvalue_n_per_m: f64,
    max_rounds: usize,
) -> Result<StablePrestress, QpError> {
    let mut problem = prestress_problem(positions_m, fixed, loads_n, groups);
    let (material, geometric) = stiffness_parts(positions_m, fixed, groups);
    let kappa = min_eigenvalue_n_per_m;
    let mut rounds = 0;
    loop {
        rounds += 1;
        let solution = qp::solve(&problem, &QpSettings::default())?;
        if !solution.status.is_solved() {
            return Ok(StablePrestress {
                solution,
                min_eigenvalue_n_per_m: f64::NAN,
                rounds,
            });
        }
        let mut k = material.clone();
        for (g, t) in geometric.iter().zip(solution.x.iter()) {
            k += g * *t;
        }
        let eigen = k.symmetric_eigen();
        let lambda_min = eigen.eigenvalues.min();
        if lambda_min >= 0.99 * kappa || rounds > max_rounds {
            return Ok(StablePrestress {
                solution,
                min_eigenvalue_n_per_m: lambda_min,
                rounds,
            });
        }
        // One cut per eigenvector below the bound.
        let cuts: Vec<_> = (0..eigen.eigenvalues.len())
            .filter(|&i| eigen.eigenvalues[i] < kappa)
            .map(|i| eigen.eigenvectors.column(i).into_owned())
            .collect();
        let old_rows = problem.ineq_matrix.nrows();
        let n = groups.len();
        problem.ineq_matrix = problem
            .ineq_matrix
            .clone()
            .resize_vertically(old_rows + cuts.len(), 0.0);
        problem.ineq_rhs = problem
            .ineq_rhs
            .clone()
            .resize_vertically(old_rows + cuts.len(), 0.0);
        for (c, v) in cuts.iter().enumerate() {
            // −Σ_g t_g·vᵀG_g v ≤ vᵀK₀v − κ
            for (g, gm) in geometric.iter().enumerate().take(n) {
                problem.ineq_matrix[(old_rows + c, g)] = -(v.transpose() * gm * v)[0];
            }
            problem.ineq_rhs[old_rows + c] = (v.transpose() * &material * v)[0] - kappa;
        }
    }
}

/// Solves [`prestress_problem`].
pub fn find_prestress(
    positions_m: &[Vector3<f64>],
    fixed: &[[bool; 3]],
    loads_n: &[Vector3<f64>],
    groups: &[ForceGroup],
) -> Result<QpSolution, QpError> {
    let problem = prestress_problem(positions_m, fixed, loads_n, groups);
    qp::solve(&problem, &QpSettings::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_bar_truss_matches_statics() {
        // Node 1 at (1, 0, -1) hangs from (0,0,0) and (2,0,0) with a 100 N
        // load downwards; y fixed. Each bar: T·(1/√2)·2 = 100 → T = 70.71 N.
        let x = [
            Vector3::zeros(),
            Vector3::new(1.0, 0.0, -1.0),
            Vector3::new(2.0, 0.0, 0.0),
        ];
        let fixed = [[true; 3], [false, true, false], [true; 3]];
        let loads = [
            Vector3::zeros(),
            Vector3::new(0.0, 0.0, -100.0),
            Vector3::zeros(),
        ];
        let g = |a, b| ForceGroup {
            elements: vec![[a, b]],
            min_n: 0.0,
            max_n: 1e4,
            target_n: 0.0,
            weight: 1.0,
            axial_stiffness_n_per_m: 1e6,
        };
        let s = find_prestress(&x, &fixed, &loads, &[g(0, 1), g(1, 2)]).unwrap();
        assert!(s.status.is_solved());
        let want = 100.0 / 2f64.sqrt();
        assert!(
            (s.x[0] - want).abs() < 1e-6 && (s.x[1] - want).abs() < 1e-6,
            "{}",
            s.x
        );
    }
}
