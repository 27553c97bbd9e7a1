//! Norm-optimal iterative learning control of a deployment's commands.
//!
//! A cycle sends the drum commands `u_1 … u_J` (one vector of motor
//! payout changes per command) and ends with the measured midspan gap
//! vectors `e` (target: zero). The next cycle's commands are
//! `u_j + Δu_j`, with the update
//!
//! ```text
//!   Δu = argmin ½ Σ_p w_p ‖e_p + G_p·Σ_j Δu_j‖² + ½ Σ_j ρ_j ‖Δu_j‖²
//!   ρ_j = ρ·(J/j)²
//!   subject to   |u_jm + Δu_jm| ≤ step_m                      (drum step)
//!                min_m ≤ p0_m + Σ_{i≤j} (u_im + Δu_im) ≤ max_m   (stroke)
//!                lower_l ≤ f_l + L_l·Σ_j Δu_j ≤ upper_l          (members)
//!                |Σ_j Δu_jm| ≤ r                              (trust region)
//!                |Σ_j (u_jm + Δu_jm) − Σ_j (u_jn + Δu_jn)| ≤ d   (m, n in one group)
//! ```
//!
//! where `G` is the sensitivity of the end gaps to each motor's drum
//! payout and `L` that of the end's force and clearance rows, both
//! linearised at the end of the cycle on the controller's model. This is
//! norm-optimal ILC (Amann, Owens & Rogers 1996) on the lifted system of
//! one trial, with the terminal error only: the path between start and
//! connection is the planner's business, the learnt part is where the
//! commands end. ρ trades how much of the last error one update removes
//! (the learning gain `GᵀG/(GᵀG + ρ_eff)`, `1/ρ_eff = Σ_j 1/ρ_j`) against
//! how far a noisy error moves the commands. The weights grow towards the
//! first command, so the correction goes mostly into the last commands:
//! the path to the case's end is its pace along the straight line there
//! (`learn::adaptation::paced_path`; or the case's own commands, with
//! `learnt_path = "replayed"`), each of its commands still checked on the
//! model when it is sent, and changing an early command moves every state
//! after it, while changing the last moves only the end.
//! (Spread evenly, a correction of a few millimetres shifted the whole
//! path of a high-friction bridge enough for the model to refuse a
//! command the case had sent.) A drum's step limit moves the rest to
//! earlier commands.
//!
//! The trust region r bounds how far one update moves a motor's total
//! payout. `G` and `L` come from a frictionless model at the case's end;
//! on a truth whose cables are softer than the model's or stick at the
//! joints, the real gain can be twice the model's in some directions, and
//! the unbounded update then swings by centimetres from cycle to cycle
//! (10–28 mm per motor on some drawn truths, against at most 4 mm on the
//! default one), taking segments slack that the model still sees in
//! tension. The bound alone did not make the update safe on every truth:
//! with r = 4 mm, 3 of 40 drawn truths on each of two seeds still
//! slackened an axial cable. There the update had spread the motors of
//! one half apart (up to 7 mm), to fit the lateral components of the
//! gaps, and the truth's axial cable, which no sensor sees and whose
//! response to that spread the frictionless model gets wrong, went slack.
//! So the updated totals of one group's motors are also kept within d of
//! each other (`max_group_spread_m`), or, where the case's own totals are
//! already further apart, not moved further apart.
//!
//! The member rows are the planner's ([`crate::plan::search::step_data`])
//! with its margins; the end of a case carries no load-cell reading, so
//! every tension's predicted fall counts (1 + β) times there
//! (`Margins::unmeasured_force_fall`).
//!
//! [`formulate`] builds the QP (pure, inspected by tests); [`learn_commands`]
//! solves it through the one Clarabel adapter.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::numerics::qp::{solve, QpStatus, QuadraticProgram};
use crate::plan::qp_step::{step_solver_settings, LinearLimit};

/// Everything one ILC update is formulated from, as plain numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct IlcData {
    /// The commands to update, per command and motor, m: the last cycle's
    /// drum commands as the learnt path takes them (paced along the
    /// straight line to their end, or replayed; `learn::adaptation`).
    pub commands_m: Vec<Vec<f64>>,
    /// Measured gap vector of each midspan pair at the last cycle's end,
    /// m (`None`: not measured; that pair is left out of the objective).
    pub end_gaps_m: Vec<Option<[f64; 3]>>,
    /// Weight of each pair's squared gap.
    pub gap_weights: Vec<f64>,
    /// d(end gap)/d(drum payout): 3 rows per pair, one column per motor.
    pub gap_sensitivity: DMatrix<f64>,
    /// The end's limits, linearised in the drum payout (each row's
    /// `pay_out` is used as its gradient; see [`IlcData::limit_gradient`]).
    pub limits: Vec<LinearLimit>,
    /// Payout of each motor at the start of the cycle, m.
    pub start_payout_m: Vec<f64>,
    /// Smallest payout per motor, m.
    pub min_payout_m: Vec<f64>,
    /// Largest payout per motor, m.
    pub max_payout_m: Vec<f64>,
    /// Largest change per command per motor, m.
    pub max_step_m: Vec<f64>,
    /// Largest total change of a motor's payout over the update,
    /// `|Σ_j Δu_jm|`, m (infinite: none): the trust region r of the
    /// linearisation at the case's end.
    pub max_total_change_m: f64,
    /// The motor group of each motor (`None`: in none): motors of one
    /// group (one bridge half) move together under the spread bound.
    pub motor_group: Vec<Option<usize>>,
    /// Largest difference between the updated total payout changes of two
    /// motors of one group, `|Σ_j (u_jm + Δu_jm) − Σ_j (u_jn + Δu_jn)|`, m
    /// (infinite: none). Where the last commands already differ by more,
    /// the update may not widen the difference.
    pub max_group_spread_m: f64,
}

impl IlcData {
    /// Number of motors.
    pub fn motors(&self) -> usize {
        self.start_payout_m.len()
    }

    /// Number of variables: one per command and motor.
    pub fn variables(&self) -> usize {
        self.commands_m.len() * self.motors()
    }

    /// The gradient of limit `l` in the drum payout: the mean of its
    /// pay-out and reel-in slopes (equal on a frictionless model; the ILC
    /// update is small, so one slope serves both directions).
    pub fn limit_gradient(&self, l: usize) -> Vec<f64> {
        let r = &self.limits[l];
        r.pay_out
            .iter()
            .zip(&r.reel_in)
            .map(|(a, b)| 0.5 * (a + b))
            .collect()
    }
}

/// What an inequality row of the ILC QP is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "row")]
pub enum IlcRow {
    /// `u_jm + Δu_jm ≤ step_m`.
    StepOut {
        /// Command.
        command: usize,
        /// Motor.
        motor: usize,
    },
    /// `−(u_jm + Δu_jm) ≤ step_m`.
    StepIn {
        /// Command.
        command: usize,
        /// Motor.
        motor: usize,
    },
    /// Payout after command `command` at most the motor's largest.
    StrokeMax {
        /// Command.
        command: usize,
        /// Motor.
        motor: usize,
    },
    /// Payout after command `command` at least the motor's smallest.
    StrokeMin {
        /// Command.
        command: usize,
        /// Motor.
        motor: usize,
    },
    /// `Σ_j Δu_jm ≤ max_total_change_m`.
    TotalOut {
        /// Motor.
        motor: usize,
    },
    /// `−Σ_j Δu_jm ≤ max_total_change_m`.
    TotalIn {
        /// Motor.
        motor: usize,
    },
    /// The updated total payout change of `motor` exceeds that of
    /// `other` (same group) by at most `max_group_spread_m`:
    /// `Σ_j (u_jm + Δu_jm) − Σ_j (u_jn + Δu_jn) ≤ d`.
    SpreadOut {
        /// Motor.
        motor: usize,
        /// The other motor of its group.
        other: usize,
    },
    /// The same, `other` exceeding `motor`.
    SpreadIn {
        /// Motor.
        motor: usize,
        /// The other motor of its group.
        other: usize,
    },
    /// Limit `limit` from below.
    LimitLower {
        /// Index into [`IlcData::limits`].
        limit: usize,
    },
    /// Limit `limit` from above.
    LimitUpper {
        /// Index into [`IlcData::limits`].
        limit: usize,
    },
}

/// The formulated update: the QP and the meaning of each inequality row.
/// Variable `j·M + m` is `Δu_jm`; the last `M` variables are the totals
/// `S_m = Σ_j Δu_jm`, tied to them by `M` equality rows. With the totals
/// as variables the gap objective and every limit row touch `M` variables
/// instead of `J·M`, which keeps the KKT system sparse: a fifth of the
/// solve time of the dense form on the bridge (116 limits, 8 commands).
#[derive(Debug, Clone, PartialEq)]
pub struct IlcFormulation {
    /// The QP.
    pub qp: QuadraticProgram,
    /// Meaning of each inequality row.
    pub rows: Vec<IlcRow>,
}

/// Builds the ILC update's QP (see the module documentation). A limit the
/// last cycle's end already breaks is widened to its value there, so that
/// `Δu = 0` is always feasible (the commands meet the step and stroke
/// limits: the last cycle sent them, and its pace along the straight line
/// keeps every motor within the share of its step it used and between
/// the payouts it started and ended at).
pub fn formulate(data: &IlcData, regularisation: f64) -> IlcFormulation {
    let m = data.motors();
    let j_count = data.commands_m.len();
    let commands = data.variables();
    let n = commands + m;
    let total = |c: usize| commands + c;
    // S − Σ_j Δu_j = 0.
    let mut eq_matrix = DMatrix::zeros(m, n);
    for c in 0..m {
        eq_matrix[(c, total(c))] = 1.0;
        for j in 0..j_count {
            eq_matrix[(c, j * m + c)] = -1.0;
        }
    }
    let mut weighted_g = data.gap_sensitivity.clone();
    let mut e = DVector::zeros(data.gap_sensitivity.nrows());
    for (p, (gap, w)) in data.end_gaps_m.iter().zip(&data.gap_weights).enumerate() {
        let w = gap.map_or(0.0, |_| *w);
        for axis in 0..3 {
            let row = 3 * p + axis;
            weighted_g.row_mut(row).scale_mut(w);
            e[row] = gap.map_or(0.0, |g| g[axis]);
        }
    }
    // P = diag(ρ_j) on the commands, GᵀWG on the totals; q = GᵀWe.
    let gtwg = data.gap_sensitivity.transpose() * &weighted_g;
    let mut hessian = DMatrix::zeros(n, n);
    for v in 0..commands {
        hessian[(v, v)] = command_weight(v / m, j_count, regularisation);
    }
    hessian
        .view_mut((commands, commands), (m, m))
        .copy_from(&gtwg);
    let gtwe = weighted_g.transpose() * e;
    let mut linear = DVector::zeros(n);
    linear.rows_mut(commands, m).copy_from(&gtwe);

    let mut rows = Vec::new();
    let mut g_rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::new();
    for (j, u) in data.commands_m.iter().enumerate() {
        for c in 0..m {
            let v = j * m + c;
            g_rows.push((vec![(v, 1.0)], data.max_step_m[c] - u[c]));
            rows.push(IlcRow::StepOut {
                command: j,
                motor: c,
            });
            g_rows.push((vec![(v, -1.0)], data.max_step_m[c] + u[c]));
            rows.push(IlcRow::StepIn {
                command: j,
                motor: c,
            });
        }
    }
    let mut payout = data.start_payout_m.clone();
    for (j, u) in data.commands_m.iter().enumerate() {
        for c in 0..m {
            payout[c] += u[c];
            let vars: Vec<(usize, f64)> = (0..=j).map(|i| (i * m + c, 1.0)).collect();
            g_rows.push((vars.clone(), data.max_payout_m[c] - payout[c]));
            rows.push(IlcRow::StrokeMax {
                command: j,
                motor: c,
            });
            let neg = vars.iter().map(|(v, a)| (*v, -a)).collect();
            g_rows.push((neg, payout[c] - data.min_payout_m[c]));
            rows.push(IlcRow::StrokeMin {
                command: j,
                motor: c,
            });
        }
    }
    if data.max_total_change_m.is_finite() {
        let r = data.max_total_change_m.max(0.0);
        for c in 0..m {
            g_rows.push((vec![(total(c), 1.0)], r));
            rows.push(IlcRow::TotalOut { motor: c });
            g_rows.push((vec![(total(c), -1.0)], r));
            rows.push(IlcRow::TotalIn { motor: c });
        }
    }
    if data.max_group_spread_m.is_finite() {
        // On the updated totals, not on the update: a bound per update
        // would let the spread grow by d every cycle.
        let d = data.max_group_spread_m.max(0.0);
        let last_total: Vec<f64> = (0..m)
            .map(|c| data.commands_m.iter().map(|u| u[c]).sum())
            .collect();
        let group = |c: usize| data.motor_group.get(c).copied().flatten();
        for a in 0..m {
            for b in a + 1..m {
                if group(a).is_none() || group(a) != group(b) {
                    continue;
                }
                let spread = last_total[a] - last_total[b];
                g_rows.push((vec![(total(a), 1.0), (total(b), -1.0)], d - spread));
                rows.push(IlcRow::SpreadOut { motor: a, other: b });
                g_rows.push((vec![(total(a), -1.0), (total(b), 1.0)], d + spread));
                rows.push(IlcRow::SpreadIn { motor: a, other: b });
            }
        }
    }
    for (l, limit) in data.limits.iter().enumerate() {
        let gradient = data.limit_gradient(l);
        let vars = |sign: f64| -> Vec<(usize, f64)> {
            (0..m).map(|c| (total(c), sign * gradient[c])).collect()
        };
        if limit.lower.is_finite() {
            g_rows.push((vars(-1.0), (limit.value - limit.lower).max(0.0)));
            rows.push(IlcRow::LimitLower { limit: l });
        }
        if limit.upper.is_finite() {
            g_rows.push((vars(1.0), (limit.upper - limit.value).max(0.0)));
            rows.push(IlcRow::LimitUpper { limit: l });
        }
    }
    let mut ineq_matrix = DMatrix::zeros(g_rows.len(), n);
    let mut ineq_rhs = DVector::zeros(g_rows.len());
    for (r, (entries, rhs)) in g_rows.into_iter().enumerate() {
        for (v, a) in entries {
            ineq_matrix[(r, v)] = a;
        }
        // A start already beyond a step or stroke bound (it cannot be,
        // for commands that were sent) is held where it is.
        ineq_rhs[r] = rhs.max(0.0);
    }
    IlcFormulation {
        qp: QuadraticProgram {
            hessian,
            linear,
            eq_matrix,
            eq_rhs: DVector::zeros(m),
            ineq_matrix,
            ineq_rhs,
        },
        rows,
    }
}

/// ρ_j of command `j` (0-based) of `count`: `ρ·(count/(j+1))²`.
pub fn command_weight(j: usize, count: usize, regularisation: f64) -> f64 {
    regularisation * (count as f64 / (j + 1) as f64).powi(2)
}

/// How an ILC update ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IlcUpdate {
    /// The QP's status.
    pub status: QpStatus,
    /// The next cycle's drum commands, per command and motor, m (the
    /// commands given, [`IlcData::commands_m`], unchanged unless the QP
    /// solved).
    pub commands_m: Vec<Vec<f64>>,
    /// Largest end gap the linearisation predicts for them, m.
    pub predicted_end_gap_m: f64,
    /// The end gap of each midspan pair it predicts, m (`None`: the pair
    /// was not read at the last cycle's end).
    pub predicted_end_gaps_m: Vec<Option<f64>>,
    /// Largest end gap measured in the last cycle, m.
    pub last_end_gap_m: f64,
}

/// Solves the update (see [`formulate`]).
pub fn learn_commands(data: &IlcData, regularisation: f64) -> IlcUpdate {
    let f = formulate(data, regularisation);
    let m = data.motors();
    let end_gaps = |delta: &DVector<f64>| -> Vec<Option<f64>> {
        // Summed from the commands (not read from the totals), so the
        // prediction holds for the commands that are sent.
        let mut total = DVector::zeros(m);
        for (v, d) in delta.iter().take(data.variables()).enumerate() {
            total[v % m] += d;
        }
        let change = &data.gap_sensitivity * total;
        data.end_gaps_m
            .iter()
            .enumerate()
            .map(|(p, g)| {
                let g = (*g)?;
                let moved: f64 = (0..3)
                    .map(|a| (g[a] + change[3 * p + a]).powi(2))
                    .sum::<f64>();
                Some(moved.sqrt())
            })
            .collect()
    };
    let largest = |gaps: &[Option<f64>]| gaps.iter().flatten().copied().fold(0.0, f64::max);
    let zero = DVector::zeros(data.variables());
    let last_end_gap_m = largest(&end_gaps(&zero));
    // The objective is in m² and tiny (a 1 cm gap is 1e-4): the default
    // gap tolerance would leave the solution tens of micrometres off, as in
    // the planner's step, whose tight settings serve here too.
    let solved = solve(&f.qp, &step_solver_settings());
    let (status, delta) = match solved {
        Ok(s) if s.status.is_solved() => (s.status, s.x),
        Ok(s) => (s.status, zero),
        Err(_) => (QpStatus::NumericalError, zero),
    };
    let commands_m = data
        .commands_m
        .iter()
        .enumerate()
        .map(|(j, u)| {
            u.iter()
                .enumerate()
                .map(|(c, x)| x + delta[j * m + c])
                .collect()
        })
        .collect();
    let predicted_end_gaps_m = end_gaps(&delta);
    IlcUpdate {
        status,
        commands_m,
        predicted_end_gap_m: largest(&predicted_end_gaps_m),
        predicted_end_gaps_m,
        last_end_gap_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two motors, one pair; the gap's x moves 0.3 m per m of motor 0,
    /// its y 0.2 m per m of motor 1.
    fn data(commands: usize, end_gap: [f64; 3]) -> IlcData {
        let mut g = DMatrix::zeros(3, 2);
        g[(0, 0)] = 0.3;
        g[(1, 1)] = 0.2;
        IlcData {
            commands_m: vec![vec![-0.04, -0.04]; commands],
            end_gaps_m: vec![Some(end_gap)],
            gap_weights: vec![1.0],
            gap_sensitivity: g,
            limits: Vec::new(),
            start_payout_m: vec![0.4, 0.4],
            min_payout_m: vec![-0.1, -0.1],
            max_payout_m: vec![0.5, 0.5],
            max_step_m: vec![0.05, 0.05],
            max_total_change_m: f64::INFINITY,
            motor_group: vec![Some(0), Some(0)],
            max_group_spread_m: f64::INFINITY,
        }
    }

    /// Without binding limits the update is the regularised least-squares
    /// solution by hand: a total change `s` of a motor is shared as
    /// `Δu_j = s·(1/ρ_j)/Σ_i(1/ρ_i)` (the cheapest split), which costs
    /// ½ρ_eff s² with `1/ρ_eff = Σ_i 1/ρ_i`; for motor 0, s minimises
    /// ½(e + 0.3 s)² + ½ρ_eff s², so s = −0.3 e / (0.09 + ρ_eff).
    #[test]
    fn an_unconstrained_update_is_the_regularised_least_squares_solution() {
        let (j, rho, e) = (4, 1e-4, 0.003);
        let d = data(j, [e, -0.006, 0.0]);
        let u = learn_commands(&d, rho);
        assert!(u.status.is_solved(), "{:?}", u.status);
        let inverse: Vec<f64> = (0..j).map(|k| 1.0 / command_weight(k, j, rho)).collect();
        let rho_eff = 1.0 / inverse.iter().sum::<f64>();
        let s0 = -0.3 * e / (0.09 + rho_eff);
        let s1 = -0.2 * -0.006 / (0.04 + rho_eff);
        for (k, cmd) in u.commands_m.iter().enumerate() {
            let share = inverse[k] * rho_eff;
            // The planner's tight solver settings leave ~1e-10 m; 1e-8 m
            // is far below any drum's resolution.
            assert!((cmd[0] - (-0.04 + s0 * share)).abs() < 1e-8, "{cmd:?}");
            assert!((cmd[1] - (-0.04 + s1 * share)).abs() < 1e-8, "{cmd:?}");
        }
        // The last command takes the largest share: J² times the first's.
        assert!((inverse[j - 1] / inverse[0] - (j * j) as f64).abs() < 1e-9);
        // The predicted end gap is what is left of e by the learning gain.
        let left0 = e + 0.3 * s0;
        let left1 = -0.006 + 0.2 * s1;
        assert!((u.predicted_end_gap_m - left0.hypot(left1)).abs() < 1e-8);
        assert!((u.last_end_gap_m - e.hypot(0.006)).abs() < 1e-15);
    }

    /// A correction larger than the step limits allow ends at the limit:
    /// every command of motor 0 at the full step, and the QP says which
    /// rows bind.
    #[test]
    fn the_drum_step_limit_bounds_the_update() {
        let mut d = data(2, [0.05, 0.0, 0.0]);
        d.commands_m = vec![vec![-0.049, -0.04]; 2];
        let f = formulate(&d, 1e-4);
        assert_eq!(f.rows.len(), 2 * 2 * 2 + 2 * 2 * 2);
        let u = learn_commands(&d, 1e-4);
        assert!(u.status.is_solved());
        for cmd in &u.commands_m {
            assert!(cmd[0] >= -0.05 - 1e-7 && cmd[0] < -0.0499, "{cmd:?}");
        }
        assert!(u.predicted_end_gap_m > 0.05 - 0.3 * 0.002 - 1e-6);
    }

    /// A member limit on the total reel-in of motor 0 caps the update
    /// where the limit's linearisation says.
    #[test]
    fn a_member_limit_caps_the_update() {
        let mut d = data(4, [0.02, 0.0, 0.0]);
        // A tension of 100 N rising 1000 N per m reeled in by motor 0
        // (payout falls), at most 105 N.
        d.limits.push(LinearLimit {
            name: "segment A[0] max".into(),
            value: 100.0,
            pay_out: vec![-1000.0, 0.0],
            reel_in: vec![-1000.0, 0.0],
            lower: f64::NEG_INFINITY,
            upper: 105.0,
            scale: 100.0,
        });
        let u = learn_commands(&d, 1e-4);
        assert!(u.status.is_solved());
        let total: f64 = u.commands_m.iter().map(|c| c[0] + 0.04).sum();
        // Unconstrained it would reel in 0.3·0.02/0.09 ≈ 6.7 cm; the limit
        // allows 5 mm.
        assert!((total - -0.005).abs() < 1e-6, "{total}");
    }

    /// The trust region caps a motor's total change at r where its
    /// unconstrained update exceeds it, and leaves the others: motor 0
    /// would move s0 = −0.3 e/(0.09 + ρ_eff) ≈ −6.7 cm (see the
    /// unconstrained test) and ends at −r; motor 1 keeps its unconstrained
    /// 1 mm (the motors are decoupled in this G).
    #[test]
    fn the_trust_region_bounds_each_motors_total_change() {
        let (j, rho, r) = (4, 1e-4, 0.005);
        let mut d = data(j, [0.02, -0.0002, 0.0]);
        d.max_total_change_m = r;
        let f = formulate(&d, rho);
        let totals = f
            .rows
            .iter()
            .filter(|w| matches!(w, IlcRow::TotalOut { .. } | IlcRow::TotalIn { .. }))
            .count();
        assert_eq!(totals, 2 * 2);
        let u = learn_commands(&d, rho);
        assert!(u.status.is_solved(), "{:?}", u.status);
        let total = |c: usize| u.commands_m.iter().map(|x| x[c] + 0.04).sum::<f64>();
        // Motor 0 at the bound (solver tolerance ~1e-10 m).
        assert!((total(0) + r).abs() < 1e-7, "{}", total(0));
        // Motor 1 is free: its unconstrained change, 0.2·0.0002/(0.04 +
        // ρ_eff), is 1 mm, inside r.
        let inverse: f64 = (0..j).map(|k| 1.0 / command_weight(k, j, rho)).sum();
        let s1 = 0.2 * 0.0002 / (0.04 + 1.0 / inverse);
        assert!(s1 < r);
        assert!((total(1) - s1).abs() < 1e-7, "{} vs {s1}", total(1));
        // The predicted gap is what the capped update leaves of e.
        let left0 = 0.02 + 0.3 * -r;
        let left1 = -0.0002 + 0.2 * s1;
        assert!((u.predicted_end_gap_m - left0.hypot(left1)).abs() < 1e-7);
    }

    /// The group spread bound against the regularised least-squares
    /// solution on the bound, by hand. Free, motor 1's total would rise
    /// by ~30 mm and motor 0's fall by ~10 mm; bounded by d, the totals
    /// lie on `s1 − s0 = d + (T0 − T1)` (T: the last commands' totals),
    /// and minimising along that line, `s0 = s1 − c`, gives
    /// `s1·(0.13 + 2ρ_eff) = −0.3 e_x − 0.2 e_y + (0.09 + ρ_eff)·c`.
    #[test]
    fn the_spread_bound_keeps_a_groups_totals_together() {
        let (j, rho, d_max) = (4, 1e-4, 0.005);
        let (ex, ey) = (0.003, -0.006);
        let inverse: f64 = (0..j).map(|k| 1.0 / command_weight(k, j, rho)).sum();
        let rho_eff = 1.0 / inverse;
        let check = |motor1_command: f64, c: f64| {
            let mut d = data(j, [ex, ey, 0.0]);
            for u in &mut d.commands_m {
                u[1] = motor1_command;
            }
            d.max_group_spread_m = d_max;
            let spread_rows = formulate(&d, rho)
                .rows
                .iter()
                .filter(|w| matches!(w, IlcRow::SpreadOut { .. } | IlcRow::SpreadIn { .. }))
                .count();
            assert_eq!(spread_rows, 2);
            let u = learn_commands(&d, rho);
            assert!(u.status.is_solved(), "{:?}", u.status);
            let change =
                |m: usize, base: f64| u.commands_m.iter().map(|x| x[m] - base).sum::<f64>();
            let (s0, s1) = (change(0, -0.04), change(1, motor1_command));
            let s1_hand = (-0.3 * ex - 0.2 * ey + (0.09 + rho_eff) * c) / (0.13 + 2.0 * rho_eff);
            // Solver tolerance ~1e-10 m, as in the unbounded test.
            assert!((s1 - s1_hand).abs() < 1e-7, "{s1} vs {s1_hand}");
            assert!((s1 - s0 - c).abs() < 1e-7, "{s0} {s1} {c}");
        };
        // Equal last commands: the totals end d apart.
        check(-0.04, d_max);
        // Last commands already 40 mm apart (motor 1 reeled in less): the
        // update may not widen that, so both totals change alike.
        check(-0.03, 0.0);
    }
}
