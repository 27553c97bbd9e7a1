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

use nalgebra::{DMatrix, DVector, Vector3};

use crate::qp::{self, QpError, QpSettings, QpSolution, QuadraticProgram};

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
}

/// The QP that finds group forces in equilibrium with `loads_n` at the free
/// degrees of freedom. Pure: tests can inspect it.
pub fn prestress_problem(
    positions_m: &[Vector3<f64>],
    fixed: &[[bool; 3]],
    loads_n: &[Vector3<f64>],
    groups: &[ForceGroup],
) -> QuadraticProgram {
    let mut dof_row = vec![[usize::MAX; 3]; positions_m.len()];
    let mut rows = 0;
    for (i, f) in fixed.iter().enumerate() {
        for a in 0..3 {
            if !f[a] {
                dof_row[i][a] = rows;
                rows += 1;
            }
        }
    }
    let n = groups.len();
    let mut eq = DMatrix::zeros(rows, n);
    let mut rhs = DVector::zeros(rows);
    for (g, group) in groups.iter().enumerate() {
        for &[a, b] in &group.elements {
            let u = (positions_m[b] - positions_m[a]).normalize();
            // A tension pulls a towards b and b towards a.
            for ax in 0..3 {
                if dof_row[a][ax] != usize::MAX {
                    eq[(dof_row[a][ax], g)] += u[ax];
                }
                if dof_row[b][ax] != usize::MAX {
                    eq[(dof_row[b][ax], g)] -= u[ax];
                }
            }
        }
    }
    for (i, l) in loads_n.iter().enumerate() {
        for ax in 0..3 {
            if dof_row[i][ax] != usize::MAX {
                rhs[dof_row[i][ax]] = -l[ax];
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
