//! Least-squares machinery of the diagnosis, for any vector of parameters
//! whose residual `z` (in noise SDs) a closure gives: search boxes,
//! forward-difference Jacobians, the one-step Gauss–Newton screen and
//! Levenberg–Marquardt, with standard errors from `(JᵀJ)⁻¹` (σ = 1 in
//! `z` units). Parameters are scaled by their plausible range throughout.
//! Every choice that tunes them is a field of [`FitSettings`].

use nalgebra::{DMatrix, DVector};
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use super::settings::FitSettings;
use crate::model::effects::ParameterSpec;

// Guards against dividing by zero, not tunings: any tiny positive value
// gives the same fit wherever the problem is regular, so they are not
// settings.
/// Smallest diagonal entry of `JᵀJ` the damping is relative to, so that a
/// parameter the readings do not feel is still damped.
const DAMPING_DIAGONAL_FLOOR: f64 = 1e-12;
/// Ridge on the diagonal of the screen's normal equations, relative to
/// each entry: keeps the one-step solve regular where two parameters act
/// alike.
const SCREEN_RIDGE: f64 = 1e-12;
/// Smallest diagonal entry the screen's ridge is relative to.
const SCREEN_DIAGONAL_FLOOR: f64 = 1e-300;

/// The `z` residuals at parameters `x`; `None` if the model could not be
/// run there.
pub type Residuals<'a> = dyn Fn(&[f64]) -> Option<Vec<f64>> + Sync + 'a;

/// Where a fit may look for parameters: [`FitSettings::search_widening`]
/// plausible widths beyond the plausible range, within the admissible
/// one, always holding the neutral value; and the scale (the plausible
/// range's width) the search works in.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchBox {
    /// Scale per parameter.
    pub scale: Vec<f64>,
    /// Lower bounds.
    pub lower: Vec<f64>,
    /// Upper bounds.
    pub upper: Vec<f64>,
    /// Admissible lower bounds (the screen's step stops there).
    pub admissible_lower: Vec<f64>,
}

impl SearchBox {
    /// The box of parameters `specs`.
    pub fn of(specs: &[ParameterSpec], settings: &FitSettings) -> SearchBox {
        let widening = settings.search_widening;
        let scale: Vec<f64> = specs.iter().map(ParameterSpec::scale).collect();
        let (lower, upper) = specs.iter().map(|p| p.search_range(widening)).unzip();
        SearchBox {
            scale,
            lower,
            upper,
            admissible_lower: specs.iter().map(|p| p.admissible.0).collect(),
        }
    }

    /// The boxes of several parameter sets, one after the other.
    pub fn concat(boxes: &[SearchBox]) -> SearchBox {
        let cat =
            |f: fn(&SearchBox) -> &Vec<f64>| boxes.iter().flat_map(|b| f(b).clone()).collect();
        SearchBox {
            scale: cat(|b| &b.scale),
            lower: cat(|b| &b.lower),
            upper: cat(|b| &b.upper),
            admissible_lower: cat(|b| &b.admissible_lower),
        }
    }

    /// `x` moved into the box.
    pub fn clamp(&self, x: &mut [f64]) {
        for (i, v) in x.iter_mut().enumerate() {
            *v = v.clamp(self.lower[i], self.upper[i]);
        }
    }
}

/// Jacobian of `z` in scaled parameters at `x` by forward differences
/// (backwards where a step forwards would leave the box); `None` if a run
/// fails or changes which readings exist. The step is
/// [`FitSettings::difference_step`] plausible widths.
pub fn jacobian(
    eval: &Residuals,
    x: &[f64],
    r: &[f64],
    b: &SearchBox,
    settings: &FitSettings,
) -> Option<DMatrix<f64>> {
    assemble_jacobian(r, difference_columns(eval, x, b, settings), b)
}

/// The replays of a forward-difference Jacobian at `x`: per parameter,
/// its step (scaled units times the scale: the parameter's own units) and
/// the residuals there. The columns are independent replays, run side by
/// side (the screens of the last candidates of a round are otherwise one
/// thread's work).
fn difference_columns(
    eval: &Residuals,
    x: &[f64],
    b: &SearchBox,
    settings: &FitSettings,
) -> Vec<Option<(f64, Vec<f64>)>> {
    (0..x.len())
        .into_par_iter()
        .map(|i| {
            let h = settings.difference_step * b.scale[i];
            let mut xp = x.to_vec();
            xp[i] += if xp[i] + h <= b.upper[i] { h } else { -h };
            let step = xp[i] - x[i];
            eval(&xp).map(|rp| (step, rp))
        })
        .collect()
}

/// The Jacobian from [`difference_columns`] about residuals `r`; `None`
/// if a replay failed or changed which readings exist.
fn assemble_jacobian(
    r: &[f64],
    columns: Vec<Option<(f64, Vec<f64>)>>,
    b: &SearchBox,
) -> Option<DMatrix<f64>> {
    let mut jac = DMatrix::<f64>::zeros(r.len(), columns.len());
    for (i, column) in columns.into_iter().enumerate() {
        let (step, rp) = column?;
        if rp.len() != r.len() {
            return None;
        }
        for (row, (a, c)) in rp.iter().zip(r).enumerate() {
            jac[(row, i)] = (a - c) / step * b.scale[i];
        }
    }
    Some(jac)
}

/// The `χ²` that one Gauss–Newton step from `x0`, where the residuals are
/// `r0`, predicts the parameters remove, with the step kept admissible
/// (parameters it pushes below their admissible range held there, the
/// rest solved again). `None` if the model could not be run or changes
/// which readings exist.
///
/// `r0` is passed, not evaluated: the screen starts every candidate at
/// its neutral value, where the replay is the model's own (the same
/// residuals, bit for bit; a test in `measure::diagnose` checks it), so
/// it is known before the screen and one replay of a `k`-parameter
/// candidate's `k + 1` is saved.
pub fn predicted_gain(
    eval: &Residuals,
    x0: &[f64],
    r0: Vec<f64>,
    b: &SearchBox,
    settings: &FitSettings,
) -> Option<f64> {
    let k = x0.len();
    let jac = jacobian(eval, x0, &r0, b, settings)?;
    let r = DVector::from_vec(r0);
    let jtj = jac.transpose() * &jac;
    let grad = jac.transpose() * &r;
    let solve = |free: &[bool]| -> DVector<f64> {
        damped_step_on(&jtj, &grad, free, SCREEN_RIDGE, SCREEN_DIAGONAL_FLOOR)
            .unwrap_or_else(|| DVector::zeros(k))
    };
    let mut free = vec![true; k];
    let mut step = solve(&free);
    for i in 0..k {
        if x0[i] + step[i] * b.scale[i] < b.admissible_lower[i] {
            free[i] = false;
        }
    }
    if free.iter().any(|f| !f) {
        step = solve(&free);
    }
    let predicted = &r + &jac * &step;
    Some(r.norm_squared() - predicted.norm_squared())
}

/// The replay at `x`, and beside it, where a core is idle, the replays of
/// the forward-difference Jacobian there ([`difference_columns`]), which
/// the fit needs next if it keeps `x`: its chain of replays, one after
/// the other, is halved (a one-parameter fit with friction took half the
/// walkthrough's diagnosis). Only an idle core does them: the Jacobian's
/// half of the join is skipped if it starts after the replay at `x` ended
/// (no other thread stole it), so where every core is busy with other
/// fits nothing is replayed that may be thrown away. The values are the
/// ones the Jacobian would have at `x` anyway, so a fit is the same, bit
/// for bit, at any thread count.
#[allow(clippy::type_complexity)]
fn replay_with_jacobian_ahead(
    eval: &Residuals,
    x: &[f64],
    b: &SearchBox,
    settings: &FitSettings,
) -> (Option<Vec<f64>>, Option<Vec<Option<(f64, Vec<f64>)>>>) {
    let replayed = AtomicBool::new(false);
    rayon::join(
        || {
            let r = eval(x);
            replayed.store(true, Ordering::Release);
            r
        },
        || (!replayed.load(Ordering::Acquire)).then(|| difference_columns(eval, x, b, settings)),
    )
}

/// A least-squares fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Parameters at the optimum.
    pub values: Vec<f64>,
    /// Their standard errors, in their units (NaN where `JᵀJ` is singular).
    pub std_errors: Vec<f64>,
    /// Condition number of `JᵀJ` in scaled parameters.
    pub condition: f64,
    /// Whether it converged.
    pub converged: bool,
}

/// The step `(JᵀJ + λ·diag(JᵀJ))·d = −Jᵀr` on the parameters `free`
/// (the others held: 0), with `λ = damping` and the diagonal floored at
/// `floor`; `None` where that system is singular.
fn damped_step_on(
    jtj: &DMatrix<f64>,
    grad: &DVector<f64>,
    free: &[bool],
    damping: f64,
    floor: f64,
) -> Option<DVector<f64>> {
    let idx: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    let mut step = DVector::zeros(free.len());
    if idx.is_empty() {
        return Some(step);
    }
    let a = DMatrix::from_fn(idx.len(), idx.len(), |i, j| {
        jtj[(idx[i], idx[j])]
            + if i == j {
                damping * jtj[(idx[i], idx[i])].max(floor)
            } else {
                0.0
            }
    });
    let rhs = DVector::from_fn(idx.len(), |i, _| -grad[idx[i]]);
    let d = a.lu().solve(&rhs)?;
    for (&i, v) in idx.iter().zip(d.iter()) {
        step[i] = *v;
    }
    Some(step)
}

/// The damped Gauss–Newton step (scaled parameters) from `x` with damping
/// `lambda` on `JᵀJ = jtj` and gradient `Jᵀr = grad`, with every parameter
/// that sits on a bound of `b` and that the step would push through it
/// held there and the others solved again (an active set); `None` where
/// the damped system is singular.
///
/// Clamping the full step instead bends it: with a parameter pinned at its
/// bound (the strut scale of `stiffness_error` at 1.4 on a log whose
/// residual is friction's) the clamped step was rejected at every
/// iteration and the fit crawled along the valley for all 30 iterations
/// (151 replays, 5.2 s of the 9.9 s diagnose of the README's walkthrough
/// log).
fn bounded_step(
    jtj: &DMatrix<f64>,
    grad: &DVector<f64>,
    lambda: f64,
    x: &[f64],
    b: &SearchBox,
) -> Option<DVector<f64>> {
    let k = x.len();
    let mut free = vec![true; k];
    loop {
        let step = damped_step_on(jtj, grad, &free, lambda, DAMPING_DIAGONAL_FLOOR)?;
        let pushed: Vec<usize> = (0..k)
            .filter(|&i| free[i])
            .filter(|&i| {
                (x[i] >= b.upper[i] && step[i] > 0.0) || (x[i] <= b.lower[i] && step[i] < 0.0)
            })
            .collect();
        if pushed.is_empty() {
            return Some(step);
        }
        for i in pushed {
            free[i] = false;
        }
    }
}

/// Levenberg–Marquardt from `x0` within box `b`, its damping and
/// stopping rules from `settings`.
pub fn levenberg_marquardt(
    eval: &Residuals,
    x0: &[f64],
    b: &SearchBox,
    settings: &FitSettings,
) -> Option<Fit> {
    let k = x0.len();
    let mut x = x0.to_vec();
    b.clamp(&mut x);
    let (r, columns) = replay_with_jacobian_ahead(eval, &x, b, settings);
    let mut r = r?;
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    let mut lambda = settings.initial_damping;
    let mut converged = false;
    let mut jtj = DMatrix::<f64>::zeros(k, k);
    // The Jacobian at the point just accepted, replayed beside that
    // point's own replay where a core was idle.
    let mut ahead: Option<Option<DMatrix<f64>>> =
        columns.map(|columns| assemble_jacobian(&r, columns, b));
    for _ in 0..settings.max_iterations {
        let jac = match ahead.take() {
            Some(j) => j,
            None => jacobian(eval, &x, &r, b, settings),
        };
        let Some(jac) = jac else {
            break;
        };
        jtj = jac.transpose() * &jac;
        let grad = jac.transpose() * DVector::from_vec(r.clone());
        let mut improved = false;
        for _ in 0..settings.damping_tries {
            let Some(delta) = bounded_step(&jtj, &grad, lambda, &x, b) else {
                lambda *= settings.damping_raise_singular;
                continue;
            };
            let mut trial: Vec<f64> = (0..k).map(|i| x[i] + delta[i] * b.scale[i]).collect();
            b.clamp(&mut trial);
            // Every parameter held on its bound (or a zero gradient): no
            // damping moves it, and replaying `x` again gains nothing.
            if trial == x {
                break;
            }
            let (rt, columns) = replay_with_jacobian_ahead(eval, &trial, b, settings);
            if let Some(rt) = rt {
                let c: f64 = rt.iter().map(|v| v * v).sum();
                if rt.len() == r.len() && c < cost {
                    let gain = cost - c;
                    ahead = columns.map(|columns| assemble_jacobian(&rt, columns, b));
                    x = trial;
                    r = rt;
                    cost = c;
                    lambda = (lambda / settings.damping_lower).max(settings.min_damping);
                    improved = true;
                    if gain < settings.converged_gain_rel * cost.max(1.0) {
                        converged = true;
                    }
                    break;
                }
            }
            lambda *= settings.damping_raise;
        }
        if !improved {
            converged = true;
        }
        if converged {
            break;
        }
    }
    let (std_errors, condition) = match jtj.clone().try_inverse() {
        Some(inv) => {
            let eig = jtj.symmetric_eigen().eigenvalues;
            let (lo, hi) = (eig.min(), eig.max());
            (
                (0..k)
                    .map(|i| inv[(i, i)].max(0.0).sqrt() * b.scale[i])
                    .collect(),
                if lo > 0.0 { hi / lo } else { f64::INFINITY },
            )
        }
        None => (vec![f64::NAN; k], f64::INFINITY),
    };
    Some(Fit {
        values: x,
        std_errors,
        condition,
        converged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LINE: [ParameterSpec; 2] = [
        ParameterSpec {
            name: "a",
            unit: "1",
            neutral: 0.0,
            plausible: (-1.0, 1.0),
            admissible: (f64::NEG_INFINITY, f64::INFINITY),
        },
        ParameterSpec {
            name: "b",
            unit: "1",
            neutral: 0.0,
            plausible: (-1.0, 1.0),
            admissible: (f64::NEG_INFINITY, f64::INFINITY),
        },
    ];

    #[test]
    fn a_straight_line_fit_matches_the_normal_equations() {
        // z_i = y_i − (a + b·t_i) with unit noise: the least-squares line
        // and its standard errors in closed form, (XᵀX)⁻¹.
        let t: Vec<f64> = (0..20).map(|i| i as f64 / 19.0).collect();
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, t)| 0.3 - 0.4 * t + if i % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let eval = |x: &[f64]| -> Option<Vec<f64>> {
            Some(t.iter().zip(&y).map(|(t, y)| y - x[0] - x[1] * t).collect())
        };
        let settings = FitSettings::default();
        let b = SearchBox::of(&LINE, &settings);
        let fit = levenberg_marquardt(&eval, &[0.0, 0.0], &b, &settings).unwrap();
        let n = t.len() as f64;
        let (st, stt) = (t.iter().sum::<f64>(), t.iter().map(|t| t * t).sum::<f64>());
        let (sy, sty) = (
            y.iter().sum::<f64>(),
            t.iter().zip(&y).map(|(t, y)| t * y).sum::<f64>(),
        );
        let det = n * stt - st * st;
        let slope = (n * sty - st * sy) / det;
        let intercept = (sy - slope * st) / n;
        // Standard errors are exact for a linear model (the Jacobian is);
        // the values sit within a thousandth of a standard error of the
        // optimum: LM stops when a step gains under 1e-6 of χ² = 0.2, a
        // distance of about √(1e-6·0.2) ≈ 5e-4 standard errors.
        let se = [(stt / det).sqrt(), (n / det).sqrt()];
        assert!((fit.std_errors[0] - se[0]).abs() < 1e-9 * se[0]);
        assert!((fit.std_errors[1] - se[1]).abs() < 1e-9 * se[1]);
        assert!(
            (fit.values[0] - intercept).abs() < 1e-3 * se[0],
            "{:?}",
            fit.values
        );
        assert!((fit.values[1] - slope).abs() < 1e-3 * se[1]);
        // The screen's one Gauss–Newton step is exact for a linear model.
        let r0: f64 = y.iter().map(|v| v * v).sum();
        let left: f64 = eval(&fit.values).unwrap().iter().map(|v| v * v).sum();
        let gain = predicted_gain(&eval, &[0.0, 0.0], y.clone(), &b, &settings).unwrap();
        assert!((gain - (r0 - left)).abs() < 1e-5 * r0);
    }

    /// Issue 24 (diagnose speed): the replays of the Jacobian at a point
    /// run beside the point's own where a core idles. A nonlinear fit
    /// (an exponential decay: LM rejects some steps and accepts others)
    /// is the same bit for bit in a pool of one thread, where the
    /// speculative half is never stolen and never runs, and in pools of
    /// two and four, where it is (each replay takes two milliseconds, so an
    /// idle thread steals it): there the fit replays more points (the
    /// Jacobian at its last point, at least, is never used), which shows
    /// the speculative path ran.
    #[test]
    fn a_fit_with_its_jacobian_replayed_ahead_is_the_same_at_any_thread_count() {
        use std::sync::atomic::AtomicUsize;
        let t: Vec<f64> = (0..30).map(|i| i as f64 / 10.0).collect();
        let y: Vec<f64> = t.iter().map(|t| 0.7 * (-0.9 * t).exp()).collect();
        let replays = AtomicUsize::new(0);
        let eval = |x: &[f64]| -> Option<Vec<f64>> {
            replays.fetch_add(1, Ordering::Relaxed);
            std::thread::sleep(std::time::Duration::from_millis(2));
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(t, y)| 50.0 * (y - x[0] * (-x[1] * t).exp()))
                    .collect(),
            )
        };
        let settings = FitSettings::default();
        let b = SearchBox::of(&LINE, &settings);
        let fit_in = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let fit = pool.install(|| levenberg_marquardt(&eval, &[0.1, 0.1], &b, &settings));
            (fit.unwrap(), replays.swap(0, Ordering::Relaxed))
        };
        let (one, one_replays) = fit_in(1);
        assert!(one.converged);
        assert!((one.values[0] - 0.7).abs() < 1e-3 && (one.values[1] - 0.9).abs() < 1e-3);
        for threads in [2, 4] {
            let (many, many_replays) = fit_in(threads);
            assert_eq!(many.values, one.values);
            assert_eq!(many.std_errors, one.std_errors);
            assert_eq!(many.condition, one.condition);
            assert!(
                many_replays > one_replays,
                "{many_replays} vs {one_replays}"
            );
        }
    }

    /// Issue 24 (diagnose speed): where the optimum lies beyond the box,
    /// the parameter that reaches its bound must be held there and the
    /// others solved for. Clamping the full step bent it: the fit of
    /// `stiffness_error` on a friction log took all 30 iterations (151
    /// replays). On a line whose intercept's optimum (3) lies beyond the
    /// box's upper bound (2), the fit ends with the intercept on the bound
    /// and the slope at its optimum given that intercept.
    #[test]
    fn a_parameter_pinned_at_its_bound_does_not_stall_the_fit() {
        let t: Vec<f64> = (0..20).map(|i| 0.8 + 0.2 * i as f64 / 19.0).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 - 2.0 * t).collect();
        let eval = |x: &[f64]| -> Option<Vec<f64>> {
            Some(t.iter().zip(&y).map(|(t, y)| y - x[0] - x[1] * t).collect())
        };
        let settings = FitSettings::default();
        let b = SearchBox::of(&LINE, &settings);
        assert_eq!(b.upper[0], 2.0);
        let fit = levenberg_marquardt(&eval, &[0.0, 0.0], &b, &settings).unwrap();
        // With the intercept held at 2: the slope minimising
        // Σ(y − 2 − b·t)² is Σt(y − 2)/Σt².
        let a = b.upper[0];
        let slope = t.iter().zip(&y).map(|(t, y)| t * (y - a)).sum::<f64>()
            / t.iter().map(|t| t * t).sum::<f64>();
        assert!(fit.converged);
        assert_eq!(fit.values[0], a);
        // Clamped steps stalled 1.25e-3 from it (no clamped step lowered
        // χ², so the fit ended there as "converged").
        assert!(
            (fit.values[1] - slope).abs() < 1e-6,
            "{:?} vs {slope}",
            fit.values
        );
    }
}
