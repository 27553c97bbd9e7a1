//! One planning step as a convex QP on linearised one-sided responses.
//!
//! Variables, per motor `c`: `u⁺_c ≥ 0` (pay out) and `u⁻_c ≥ 0` (reel
//! in), each with its own sensitivities, since friction makes the two
//! directions respond differently. With `G⁺`, `G⁻` the gap responses
//! (3 rows per midspan pair) and `g` the current gap vectors:
//!
//! ```text
//! minimise   Σ_pairs w_p ‖g_p + G⁺_p u⁺ − G⁻_p u⁻‖²
//!            + η Σ_pairs ‖d_p + D⁺_p u⁺ − D⁻_p u⁻‖²  +  ρ‖u‖²  +  κ·Σ(u⁺ + u⁻)
//! subject to lower_i ≤ f_i + a⁺_i u⁺ − a⁻_i u⁻ ≤ upper_i     (member limits, clearances)
//!            min_c ≤ p_c + u⁺_c − u⁻_c ≤ max_c              (motor stroke)
//!            0 ≤ u±_c ≤ min(Δ, max_step_c)                  (per-command limit, trust region)
//! ```
//! The gaps are relative: the two halves' midspan nodes can meet anywhere,
//! and far from the design the steepest way to close a gap is often to
//! pay one half *out* towards the other (an uneven fold: the less folded
//! half sags back to meet the more folded one), which slackens that
//! half's cables and leads away from the only place the halves connect
//! with every member in its designed prestress. The η term, on each
//! midspan pair's midpoint offset `d_p = ½(x_a + x_b) − M_p` from its
//! designed position (responses `D±`), makes the step close the gaps by
//! moving both halves towards the design. The midpoint is orthogonal to
//! the gap, so the term never competes with closing it, also when the
//! measured gap offsets shift the gaps the planner closes (see
//! [`StepWeights::design_position`]).
//!
//! The small κ keeps the QP from using both directions of one motor at
//! once; should it still do so (the two one-sided slopes differ, so a
//! net-zero pair could look useful), the step is solved again with each
//! motor held to the direction of its net move, so the command and its
//! prediction always use the slope of the way the motor really turns. If
//! only the split met the limits (the slopes' difference did, not a
//! motion), the held step is softened like an infeasible one.
//!
//! If the member limits cannot be met (an infeasible QP), the step is
//! solved again with every limit softened by a slack variable that costs
//! `soft_limit_penalty` per unit of the limit's scale, and reported as
//! such: the command is then still checked against the true limits at
//! every increment before anything accepts it.
//!
//! [`formulate`] is a pure function of plain numbers so tests can inspect
//! the matrices; [`solve_step`] solves through `numerics::qp::solve`.

use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

use crate::numerics::qp::{solve, QpSettings, QpStatus, QuadraticProgram};

/// One linearised limit: `lower ≤ value + Σ pay_out·u⁺ − Σ reel_in·u⁻ ≤ upper`.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearLimit {
    /// Name for reports, e.g. `segment A_cc0[3] min`.
    pub name: String,
    /// Current value (N for forces, m for clearances).
    pub value: f64,
    /// d(value)/dp for paying out, per motor.
    pub pay_out: Vec<f64>,
    /// d(value)/dp for reeling in, per motor.
    pub reel_in: Vec<f64>,
    /// Smallest admissible value (`-inf` for none).
    pub lower: f64,
    /// Largest admissible value (`inf` for none).
    pub upper: f64,
    /// Unit the row is scaled by (e.g. 100 N, 0.01 m), so rows of
    /// different kinds weigh alike in the solver and in the slack penalty.
    pub scale: f64,
}

/// Everything one step is formulated from, as plain numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct StepData {
    /// Current gap vector `x_a − x_b` of each midspan pair, m.
    pub gaps_m: Vec<Vector3<f64>>,
    /// Weight of each pair in the objective.
    pub gap_weights: Vec<f64>,
    /// d(gap)/dp for paying out: 3 rows per pair, one column per motor.
    pub gap_pay_out: DMatrix<f64>,
    /// d(gap)/dp for reeling in, same shape.
    pub gap_reel_in: DMatrix<f64>,
    /// Offset of each midspan pair's midpoint `½(x_a + x_b)` from its
    /// designed position, m.
    pub design_offsets_m: Vec<Vector3<f64>>,
    /// d(offset)/dp for paying out: 3 rows per pair, one column per motor.
    pub design_pay_out: DMatrix<f64>,
    /// d(offset)/dp for reeling in, same shape.
    pub design_reel_in: DMatrix<f64>,
    /// Linearised limits.
    pub limits: Vec<LinearLimit>,
    /// Current payout of each motor, m.
    pub payout_m: Vec<f64>,
    /// Smallest payout per motor, m.
    pub min_payout_m: Vec<f64>,
    /// Largest payout per motor, m.
    pub max_payout_m: Vec<f64>,
    /// Largest change per command per motor, m.
    pub max_step_m: Vec<f64>,
    /// Trust-region radius Δ, m: no `u±` above it.
    pub trust_region_m: f64,
    /// Motor names for reports.
    pub motor_names: Vec<String>,
}

/// Weights of the step's objective.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepWeights {
    /// η on the midspan pairs' squared midpoint offsets from their designed
    /// positions, dimensionless, relative to a gap weight of 1 (see the
    /// module notes).
    pub design_position: f64,
    /// ρ on ‖u‖², dimensionless (gaps and commands both in m).
    pub regularisation: f64,
    /// κ on Σ(u⁺ + u⁻), m.
    pub split_penalty: f64,
    /// Cost of softening a limit by one unit of its scale, in objective
    /// units (m²); `None` disables the softened fallback.
    pub soft_limit_penalty: Option<f64>,
}

/// Which way a motor may turn in a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Either way.
    Free,
    /// Paying out only (`u⁻ = 0`).
    PayOut,
    /// Reeling in only (`u⁺ = 0`).
    ReelIn,
}

/// What an inequality row of the formulation is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowKind {
    /// `−u± ≤ 0`.
    NonNegative {
        /// Motor.
        motor: usize,
        /// `true` for `u⁺`.
        pay_out: bool,
    },
    /// `u± ≤ min(Δ, max_step)`; `trust_region` when Δ is the smaller.
    StepBound {
        /// Motor.
        motor: usize,
        /// `true` for `u⁺`.
        pay_out: bool,
        /// Whether the trust region is the binding bound.
        trust_region: bool,
    },
    /// `p + u⁺ − u⁻ ≤ max`.
    StrokeMax {
        /// Motor.
        motor: usize,
    },
    /// `p + u⁺ − u⁻ ≥ min`.
    StrokeMin {
        /// Motor.
        motor: usize,
    },
    /// Limit `i` from below.
    LimitLower {
        /// Index into [`StepData::limits`].
        limit: usize,
    },
    /// Limit `i` from above.
    LimitUpper {
        /// Index into [`StepData::limits`].
        limit: usize,
    },
    /// `−s_i ≤ 0` for the slack of limit `i` (softened formulation).
    SlackNonNegative {
        /// Index into [`StepData::limits`].
        limit: usize,
    },
}

/// A formulated step: the QP and what each of its inequality rows is.
/// Variables: `u⁺` (motors), then `u⁻` (motors), then, when softened, one
/// slack per limit.
#[derive(Debug, Clone, PartialEq)]
pub struct Formulation {
    /// The QP.
    pub qp: QuadraticProgram,
    /// Meaning of each inequality row.
    pub rows: Vec<RowKind>,
    /// Number of motors.
    pub motors: usize,
    /// Whether limits carry slack variables.
    pub softened: bool,
}

/// Builds the step's QP (see the module documentation).
pub fn formulate(
    data: &StepData,
    weights: &StepWeights,
    directions: &[Direction],
    softened: bool,
) -> Formulation {
    let n = data.payout_m.len();
    let n_lim = data.limits.len();
    let nv = 2 * n + if softened { n_lim } else { 0 };
    // J = [G⁺, −G⁻; D⁺, −D⁻], W per row.
    let (gap_rows, design_rows) = (data.gap_pay_out.nrows(), data.design_pay_out.nrows());
    let mut j = DMatrix::zeros(gap_rows + design_rows, 2 * n);
    j.view_mut((0, 0), (gap_rows, n))
        .copy_from(&data.gap_pay_out);
    j.view_mut((0, n), (gap_rows, n))
        .copy_from(&(-&data.gap_reel_in));
    j.view_mut((gap_rows, 0), (design_rows, n))
        .copy_from(&data.design_pay_out);
    j.view_mut((gap_rows, n), (design_rows, n))
        .copy_from(&(-&data.design_reel_in));
    let g = DVector::from_iterator(
        gap_rows + design_rows,
        data.gaps_m
            .iter()
            .chain(&data.design_offsets_m)
            .flat_map(|v| v.iter().copied()),
    );
    let w = DVector::from_iterator(
        g.len(),
        data.gap_weights
            .iter()
            .flat_map(|w| [*w; 3])
            .chain(std::iter::repeat_n(weights.design_position, design_rows)),
    );
    let wj = DMatrix::from_fn(j.nrows(), j.ncols(), |r, c| w[r] * j[(r, c)]);
    let mut hessian = DMatrix::zeros(nv, nv);
    let jwj = j.transpose() * &wj;
    hessian
        .view_mut((0, 0), (2 * n, 2 * n))
        .copy_from(&(2.0 * (jwj + weights.regularisation * DMatrix::identity(2 * n, 2 * n))));
    let mut linear = DVector::zeros(nv);
    let jwg = wj.transpose() * &g;
    for k in 0..2 * n {
        linear[k] = 2.0 * jwg[k] + weights.split_penalty;
    }
    if softened {
        let penalty = weights.soft_limit_penalty.unwrap_or(0.0);
        for k in 0..n_lim {
            linear[2 * n + k] = penalty;
        }
    }

    let mut rows_g: Vec<Vec<(usize, f64)>> = Vec::new();
    let mut rhs = Vec::new();
    let mut kinds = Vec::new();
    let mut push = |coeffs: Vec<(usize, f64)>, h: f64, kind: RowKind| {
        rows_g.push(coeffs);
        rhs.push(h);
        kinds.push(kind);
    };
    for c in 0..n {
        for (pay_out, col) in [(true, c), (false, n + c)] {
            push(
                vec![(col, -1.0)],
                0.0,
                RowKind::NonNegative { motor: c, pay_out },
            );
            let allowed = match directions.get(c).copied().unwrap_or(Direction::Free) {
                Direction::Free => true,
                Direction::PayOut => pay_out,
                Direction::ReelIn => !pay_out,
            };
            let bound = if allowed {
                data.trust_region_m.min(data.max_step_m[c])
            } else {
                0.0
            };
            push(
                vec![(col, 1.0)],
                bound,
                RowKind::StepBound {
                    motor: c,
                    pay_out,
                    trust_region: data.trust_region_m < data.max_step_m[c],
                },
            );
        }
        push(
            vec![(c, 1.0), (n + c, -1.0)],
            data.max_payout_m[c] - data.payout_m[c],
            RowKind::StrokeMax { motor: c },
        );
        push(
            vec![(c, -1.0), (n + c, 1.0)],
            data.payout_m[c] - data.min_payout_m[c],
            RowKind::StrokeMin { motor: c },
        );
    }
    for (i, l) in data.limits.iter().enumerate() {
        let slack = softened.then_some(2 * n + i);
        // Scaled: value/scale + (a⁺u⁺ − a⁻u⁻)/scale ≥ lower/scale − s.
        let row = |sign: f64| {
            let mut coeffs: Vec<(usize, f64)> = (0..n)
                .flat_map(|c| {
                    [
                        (c, sign * l.pay_out[c] / l.scale),
                        (n + c, -sign * l.reel_in[c] / l.scale),
                    ]
                })
                .collect();
            if let Some(s) = slack {
                coeffs.push((s, -1.0));
            }
            coeffs
        };
        if l.lower.is_finite() {
            push(
                row(-1.0),
                (l.value - l.lower) / l.scale,
                RowKind::LimitLower { limit: i },
            );
        }
        if l.upper.is_finite() {
            push(
                row(1.0),
                (l.upper - l.value) / l.scale,
                RowKind::LimitUpper { limit: i },
            );
        }
        if let Some(s) = slack {
            push(vec![(s, -1.0)], 0.0, RowKind::SlackNonNegative { limit: i });
        }
    }
    let mut ineq_matrix = DMatrix::zeros(rows_g.len(), nv);
    for (r, coeffs) in rows_g.iter().enumerate() {
        for &(col, v) in coeffs {
            ineq_matrix[(r, col)] += v;
        }
    }
    Formulation {
        qp: QuadraticProgram {
            hessian,
            linear,
            eq_matrix: DMatrix::zeros(0, nv),
            eq_rhs: DVector::zeros(0),
            ineq_matrix,
            ineq_rhs: DVector::from_vec(rhs),
        },
        rows: kinds,
        motors: n,
        softened,
    }
}

/// How a step's QP ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "status")]
pub enum QpStepStatus {
    /// Solved with every linearised limit.
    Solved,
    /// The limits could not all be met; solved with them softened, the
    /// largest softening in units of the limit's scale given.
    SoftenedLimits {
        /// Largest slack, in units of its limit's scale.
        max_softening: f64,
    },
    /// No command meets the limits (and no softened fallback was allowed,
    /// or it failed too): hold.
    Infeasible,
    /// The solver failed numerically: hold.
    NumericalTrouble,
}

impl QpStepStatus {
    /// Short name for tables.
    pub fn as_str(self) -> &'static str {
        match self {
            QpStepStatus::Solved => "solved",
            QpStepStatus::SoftenedLimits { .. } => "softened_limits",
            QpStepStatus::Infeasible => "infeasible",
            QpStepStatus::NumericalTrouble => "numerical_trouble",
        }
    }

    /// `true` when the step has a command.
    pub fn has_command(self) -> bool {
        matches!(
            self,
            QpStepStatus::Solved | QpStepStatus::SoftenedLimits { .. }
        )
    }
}

/// A solved step.
#[derive(Debug, Clone, PartialEq)]
pub struct QpStep {
    /// How it ended.
    pub status: QpStepStatus,
    /// Net payout change per motor, m (zero when holding).
    pub command_m: Vec<f64>,
    /// Gap vectors the linear model predicts after the command, m.
    pub predicted_gaps_m: Vec<Vector3<f64>>,
    /// Midpoint offsets from the design the linear model predicts after
    /// the command, m.
    pub predicted_design_offsets_m: Vec<Vector3<f64>>,
    /// Names of the constraints active at the solution (non-negativity
    /// rows left out).
    pub active_constraints: Vec<String>,
    /// QPs solved for this step (1 to 4).
    pub qp_solves: usize,
}

/// Solver settings for a step. The step's multipliers on weakly active
/// bounds are as small as the split penalty κ (1e-6), and an interior
/// point leaves a variable about `tol_gap / multiplier` from its bound, so
/// the gap tolerance is 1e-13 rather than the default 1e-9 (which left
/// idle motors moving by tens of micrometres). The QPs are small, so the
/// extra iterations cost little.
pub fn step_solver_settings() -> QpSettings {
    QpSettings {
        max_iter: 200,
        tol_feas: 1e-10,
        tol_gap: 1e-13,
    }
}

/// Predicted gap vectors after net commands `command_m`, each motor with
/// the slope of its own direction, m.
pub fn predicted_gaps(data: &StepData, command_m: &[f64]) -> Vec<Vector3<f64>> {
    predicted_vectors(
        &data.gaps_m,
        &data.gap_pay_out,
        &data.gap_reel_in,
        command_m,
    )
}

/// Predicted midpoint offsets from the design after net commands
/// `command_m`, each motor with the slope of its own direction, m.
pub fn predicted_design_offsets(data: &StepData, command_m: &[f64]) -> Vec<Vector3<f64>> {
    predicted_vectors(
        &data.design_offsets_m,
        &data.design_pay_out,
        &data.design_reel_in,
        command_m,
    )
}

/// `now` (3-vectors) moved linearly by `command_m`, with the `pay_out`
/// or `reel_in` column of each motor's direction (3 rows per vector).
fn predicted_vectors(
    now: &[Vector3<f64>],
    pay_out: &DMatrix<f64>,
    reel_in: &DMatrix<f64>,
    command_m: &[f64],
) -> Vec<Vector3<f64>> {
    now.iter()
        .enumerate()
        .map(|(p, g)| {
            let mut out = *g;
            for (c, &d) in command_m.iter().enumerate() {
                let m = if d >= 0.0 { pay_out } else { reel_in };
                for k in 0..3 {
                    out[k] += d * m[(3 * p + k, c)];
                }
            }
            out
        })
        .collect()
}

/// Below this, m, a variable counts as zero (the solver's tolerance
/// leaves ~1e-9 on inactive variables).
const ZERO_M: f64 = 1e-7;

fn active_names(f: &Formulation, data: &StepData, x: &DVector<f64>) -> Vec<String> {
    let slack = &f.qp.ineq_rhs - &f.qp.ineq_matrix * x;
    let mut out = Vec::new();
    for (r, kind) in f.rows.iter().enumerate() {
        if slack[r] > 1e-6 {
            continue;
        }
        let name = |c: usize| {
            data.motor_names
                .get(c)
                .cloned()
                .unwrap_or(format!("motor {c}"))
        };
        out.push(match *kind {
            RowKind::NonNegative { .. } | RowKind::SlackNonNegative { .. } => continue,
            RowKind::StepBound {
                motor,
                pay_out,
                trust_region,
            } => {
                // A bound of zero is a held direction, not a limit.
                if f.qp.ineq_rhs[r] <= 0.0 {
                    continue;
                }
                format!(
                    "{} {} {}",
                    name(motor),
                    if pay_out { "pay-out" } else { "reel-in" },
                    if trust_region {
                        "trust region"
                    } else {
                        "max step"
                    }
                )
            }
            RowKind::StrokeMax { motor } => format!("{} stroke max", name(motor)),
            RowKind::StrokeMin { motor } => format!("{} stroke min", name(motor)),
            RowKind::LimitLower { limit } => format!("{} min", data.limits[limit].name),
            RowKind::LimitUpper { limit } => format!("{} max", data.limits[limit].name),
        });
    }
    out
}

fn net_command(n: usize, x: &DVector<f64>) -> Vec<f64> {
    (0..n).map(|c| x[c] - x[n + c]).collect()
}

/// Solves a step: the hard QP; if it is infeasible, the softened QP (when
/// allowed); if the solution splits a motor both ways, again with each
/// motor held to its net direction, softened (when allowed) if only the
/// split met the limits. A failure holds (zero command): infeasible
/// limits as [`QpStepStatus::Infeasible`], anything else as numerical
/// trouble.
pub fn solve_step(data: &StepData, weights: &StepWeights, settings: &QpSettings) -> QpStep {
    let n = data.payout_m.len();
    let hold = |status, qp_solves| QpStep {
        status,
        command_m: vec![0.0; n],
        predicted_gaps_m: data.gaps_m.clone(),
        predicted_design_offsets_m: data.design_offsets_m.clone(),
        active_constraints: vec![],
        qp_solves,
    };
    let run = |directions: &[Direction], softened: bool| {
        let f = formulate(data, weights, directions, softened);
        let s = solve(&f.qp, settings);
        (f, s)
    };
    let free = vec![Direction::Free; n];
    let (mut f, s) = run(&free, false);
    let mut solves = 1;
    let mut status = QpStepStatus::Solved;
    let mut x = match s {
        Ok(s) if s.status.is_solved() => s.x,
        Ok(s) if s.status == QpStatus::Infeasible => {
            if weights.soft_limit_penalty.is_none() {
                return hold(QpStepStatus::Infeasible, solves);
            }
            let (fs, ss) = run(&free, true);
            solves += 1;
            match ss {
                Ok(ss) if ss.status.is_solved() => {
                    let max_softening = (2 * n..ss.x.len()).map(|k| ss.x[k]).fold(0.0, f64::max);
                    status = QpStepStatus::SoftenedLimits { max_softening };
                    f = fs;
                    ss.x
                }
                Ok(ss) if ss.status == QpStatus::Infeasible => {
                    return hold(QpStepStatus::Infeasible, solves)
                }
                _ => return hold(QpStepStatus::NumericalTrouble, solves),
            }
        }
        _ => return hold(QpStepStatus::NumericalTrouble, solves),
    };
    let split = (0..n).any(|c| x[c] > ZERO_M && x[n + c] > ZERO_M);
    if split {
        let directions: Vec<Direction> = (0..n)
            .map(|c| {
                if x[c] >= x[n + c] {
                    Direction::PayOut
                } else {
                    Direction::ReelIn
                }
            })
            .collect();
        let (f2, s2) = run(&directions, f.softened);
        solves += 1;
        let softening = |x: &DVector<f64>| (2 * n..x.len()).map(|k| x[k]).fold(0.0, f64::max);
        match s2 {
            Ok(s2) if s2.status.is_solved() => {
                f = f2;
                x = s2.x;
            }
            // Only the split met the limits: the difference between the
            // one-sided slopes did, not a motion any motor can make. The
            // limits are softened as for an infeasible step.
            Ok(s2)
                if s2.status == QpStatus::Infeasible
                    && !f.softened
                    && weights.soft_limit_penalty.is_some() =>
            {
                let (f3, s3) = run(&directions, true);
                solves += 1;
                match s3 {
                    Ok(s3) if s3.status.is_solved() => {
                        status = QpStepStatus::SoftenedLimits {
                            max_softening: softening(&s3.x),
                        };
                        f = f3;
                        x = s3.x;
                    }
                    Ok(s3) if s3.status == QpStatus::Infeasible => {
                        return hold(QpStepStatus::Infeasible, solves)
                    }
                    _ => return hold(QpStepStatus::NumericalTrouble, solves),
                }
            }
            Ok(s2) if s2.status == QpStatus::Infeasible => {
                return hold(QpStepStatus::Infeasible, solves)
            }
            _ => return hold(QpStepStatus::NumericalTrouble, solves),
        }
    }
    let mut command_m = net_command(n, &x);
    for (c, d) in command_m.iter_mut().enumerate() {
        // The interior-point solution may sit a solver tolerance outside
        // its bounds; project it onto them so the motor limits hold exactly.
        let bound = data.trust_region_m.min(data.max_step_m[c]);
        let lo = (-bound).max(data.min_payout_m[c] - data.payout_m[c]);
        let hi = bound.min(data.max_payout_m[c] - data.payout_m[c]);
        *d = d.min(hi).max(lo);
        if d.abs() < ZERO_M {
            *d = 0.0;
        }
    }
    QpStep {
        status,
        predicted_gaps_m: predicted_gaps(data, &command_m),
        predicted_design_offsets_m: predicted_design_offsets(data, &command_m),
        active_constraints: active_names(&f, data, &x),
        command_m,
        qp_solves: solves,
    }
}
