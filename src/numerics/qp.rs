//! Quadratic programs and the one adapter to the Clarabel interior-point
//! solver. This is the only file that imports `clarabel`.
//!
//! ```text
//!     minimise    ½·xᵀPx + qᵀx
//!     subject to  A_eq·x = b_eq,   G·x ≤ h
//! ```
//!
//! Problems are formulated as plain data by pure functions elsewhere (form
//! finding, the planner's step), so tests can inspect them; [`solve`] maps
//! Clarabel's status onto [`QpStatus`].

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use nalgebra::{DMatrix, DVector};
use thiserror::Error;

/// A convex QP in dense form. `hessian` must be symmetric positive
/// semidefinite; only its upper triangle is read.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticProgram {
    /// P, n×n.
    pub hessian: DMatrix<f64>,
    /// q, length n.
    pub linear: DVector<f64>,
    /// A_eq, m_eq×n (may have zero rows).
    pub eq_matrix: DMatrix<f64>,
    /// b_eq.
    pub eq_rhs: DVector<f64>,
    /// G, m_in×n (may have zero rows).
    pub ineq_matrix: DMatrix<f64>,
    /// h.
    pub ineq_rhs: DVector<f64>,
}

/// How a QP solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum QpStatus {
    /// Solved to full accuracy.
    Solved,
    /// Solved to reduced accuracy.
    AlmostSolved,
    /// No point satisfies the constraints.
    Infeasible,
    /// The objective is unbounded below.
    Unbounded,
    /// Iteration or time limit reached.
    IterationLimit,
    /// Numerical trouble or lack of progress.
    NumericalError,
}

impl QpStatus {
    /// `true` when `x` is a usable solution.
    pub fn is_solved(self) -> bool {
        matches!(self, QpStatus::Solved | QpStatus::AlmostSolved)
    }
}

/// The result of [`solve`].
#[derive(Debug, Clone, PartialEq)]
pub struct QpSolution {
    /// Status.
    pub status: QpStatus,
    /// Primal solution (meaningful only when solved).
    pub x: DVector<f64>,
    /// Objective value ½xᵀPx + qᵀx.
    pub objective: f64,
    /// Interior-point iterations.
    pub iterations: u32,
}

/// A malformed problem.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum QpError {
    /// Matrix and vector sizes disagree.
    #[error("QP dimensions disagree: {0}")]
    Dimensions(String),
    /// The solver refused the data.
    #[error("QP solver setup failed: {0}")]
    Setup(String),
}

/// Solver settings for [`solve`].
#[derive(Debug, Clone, PartialEq)]
pub struct QpSettings {
    /// Interior-point iteration limit. Default 200.
    pub max_iter: u32,
    /// Feasibility tolerance. Default 1e-9.
    pub tol_feas: f64,
    /// Duality-gap tolerance (absolute and relative). Default 1e-9.
    pub tol_gap: f64,
}

impl Default for QpSettings {
    fn default() -> Self {
        QpSettings {
            max_iter: 200,
            tol_feas: 1e-9,
            tol_gap: 1e-9,
        }
    }
}

fn to_csc(m: &DMatrix<f64>, upper_only: bool) -> CscMatrix<f64> {
    let (rows, cols) = m.shape();
    let mut colptr = Vec::with_capacity(cols + 1);
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    colptr.push(0);
    for j in 0..cols {
        let last = if upper_only { (j + 1).min(rows) } else { rows };
        for i in 0..last {
            let v = m[(i, j)];
            if v != 0.0 {
                rowval.push(i);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    CscMatrix::new(rows, cols, colptr, rowval, nzval)
}

/// Solves a QP with Clarabel. Errors only for malformed data; an infeasible
/// or unsolved problem is a status in the solution.
pub fn solve(qp: &QuadraticProgram, settings: &QpSettings) -> Result<QpSolution, QpError> {
    let n = qp.linear.len();
    let check = |what: &str, ok: bool| {
        if ok {
            Ok(())
        } else {
            Err(QpError::Dimensions(what.to_string()))
        }
    };
    check("hessian must be n×n", qp.hessian.shape() == (n, n))?;
    check("eq_matrix must have n columns", qp.eq_matrix.ncols() == n)?;
    check(
        "ineq_matrix must have n columns",
        qp.ineq_matrix.ncols() == n,
    )?;
    check("eq_rhs length", qp.eq_rhs.len() == qp.eq_matrix.nrows())?;
    check(
        "ineq_rhs length",
        qp.ineq_rhs.len() == qp.ineq_matrix.nrows(),
    )?;

    let (m_eq, m_in) = (qp.eq_matrix.nrows(), qp.ineq_matrix.nrows());
    let mut a = DMatrix::zeros(m_eq + m_in, n);
    a.rows_mut(0, m_eq).copy_from(&qp.eq_matrix);
    a.rows_mut(m_eq, m_in).copy_from(&qp.ineq_matrix);
    let mut b = Vec::with_capacity(m_eq + m_in);
    b.extend(qp.eq_rhs.iter());
    b.extend(qp.ineq_rhs.iter());
    let mut cones = Vec::new();
    if m_eq > 0 {
        cones.push(SupportedConeT::ZeroConeT(m_eq));
    }
    if m_in > 0 {
        cones.push(SupportedConeT::NonnegativeConeT(m_in));
    }
    let clarabel_settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .max_iter(settings.max_iter)
        .tol_feas(settings.tol_feas)
        .tol_gap_abs(settings.tol_gap)
        .tol_gap_rel(settings.tol_gap)
        .build()
        .map_err(|e| QpError::Setup(e.to_string()))?;
    let p = to_csc(&qp.hessian, true);
    let a = to_csc(&a, false);
    let mut solver =
        DefaultSolver::new(&p, qp.linear.as_slice(), &a, &b, &cones, clarabel_settings)
            .map_err(|e| QpError::Setup(e.to_string()))?;
    solver.solve();
    let status = match solver.solution.status {
        SolverStatus::Solved => QpStatus::Solved,
        SolverStatus::AlmostSolved => QpStatus::AlmostSolved,
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
            QpStatus::Infeasible
        }
        SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => QpStatus::Unbounded,
        SolverStatus::MaxIterations | SolverStatus::MaxTime => QpStatus::IterationLimit,
        SolverStatus::Unsolved
        | SolverStatus::NumericalError
        | SolverStatus::InsufficientProgress
        | SolverStatus::CallbackTerminated => QpStatus::NumericalError,
    };
    Ok(QpSolution {
        status,
        x: DVector::from_column_slice(&solver.solution.x),
        objective: solver.solution.obj_val,
        iterations: solver.solution.iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_box_constrained_projection() {
        // min ½‖x − (2, −1)‖² s.t. x1 + x2 = 0.5, x ≤ 1: analytic x = (1, −0.5).
        let qp = QuadraticProgram {
            hessian: DMatrix::identity(2, 2),
            linear: DVector::from_vec(vec![-2.0, 1.0]),
            eq_matrix: DMatrix::from_row_slice(1, 2, &[1.0, 1.0]),
            eq_rhs: DVector::from_vec(vec![0.5]),
            ineq_matrix: DMatrix::identity(2, 2),
            ineq_rhs: DVector::from_vec(vec![1.0, 1.0]),
        };
        let s = solve(&qp, &QpSettings::default()).unwrap();
        assert_eq!(s.status, QpStatus::Solved);
        assert!(
            (s.x[0] - 1.0).abs() < 1e-7 && (s.x[1] + 0.5).abs() < 1e-7,
            "{}",
            s.x
        );
    }

    #[test]
    fn reports_infeasibility() {
        let qp = QuadraticProgram {
            hessian: DMatrix::identity(1, 1),
            linear: DVector::zeros(1),
            eq_matrix: DMatrix::zeros(0, 1),
            eq_rhs: DVector::zeros(0),
            ineq_matrix: DMatrix::from_row_slice(2, 1, &[1.0, -1.0]),
            ineq_rhs: DVector::from_vec(vec![-1.0, -1.0]),
        };
        assert_eq!(
            solve(&qp, &QpSettings::default()).unwrap().status,
            QpStatus::Infeasible
        );
    }

    #[test]
    fn rejects_mismatched_dimensions() {
        let qp = QuadraticProgram {
            hessian: DMatrix::identity(2, 2),
            linear: DVector::zeros(3),
            eq_matrix: DMatrix::zeros(0, 3),
            eq_rhs: DVector::zeros(0),
            ineq_matrix: DMatrix::zeros(0, 3),
            ineq_rhs: DVector::zeros(0),
        };
        assert!(matches!(
            solve(&qp, &QpSettings::default()),
            Err(QpError::Dimensions(_))
        ));
    }
}
