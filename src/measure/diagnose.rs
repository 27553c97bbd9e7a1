//! Which physical effect is missing: every effect the model lacks is fitted
//! to the log through the model, scored on cycles it was not fitted on,
//! and ranked; the best is added and the search repeats.
//!
//! # Fitting
//! Levenberg–Marquardt on the parameters of one effect (the model's own
//! effects held fixed), minimising `χ² = Σ z²` over the *fit* cycles, with
//! `z` the residual in noise SDs. The Jacobian is by forward differences
//! of whole replays (each a warm run of the forward model), in parameters
//! scaled by their plausible range. Parameters stay within twice their
//! plausible range. At the optimum, `(JᵀJ)⁻¹` (σ = 1 in `z` units) gives
//! each parameter's standard error, and the condition number of `JᵀJ`
//! says how well the log identifies them.
//!
//! # Screening
//! Before fitting, each candidate is screened where it is switched on at
//! its neutral value (the model as it is): one Gauss–Newton step from there
//! predicts how much `χ²` on the fit cycles it could remove. Only
//! candidates whose predicted gain beats the BIC penalty `k·ln n` are
//! fitted. Under pure noise the gain of `k` useless parameters is
//! χ²-distributed with `k` degrees of freedom, so the screen passes such a
//! candidate about once in a hundred logs (`k` = 1, n ≈ 600), and the
//! held-out test below stops it.
//!
//! # Scoring
//! Cycles alternate between fitting and held out (the first, third, … are
//! fitted; the second, fourth, … held out). The whole log is replayed every
//! time, because friction carries each cycle's history into the next; the
//! split decides which readings each score counts. A candidate is ranked by
//! the held-out RMS of `z` it leaves; it is accepted only if it improves
//! the Bayesian information criterion `χ² + k·ln n` on the fit cycles *and*
//! lowers the held-out `χ²` by more than `k·ln n_held` (the same penalty,
//! on readings it never saw).
//!
//! # Verdict
//! "Clean" below means: the held-out RMS `z` is within [`noise_rms_limit`]
//! *and* no per-sensor or per-group test of the final comparison rejects
//! noise ([`super::evidence`], Holm-controlled): a local failure that the
//! overall RMS dilutes still counts.
//! - **nothing missing**: no candidate is accepted and the model is clean;
//! - **effect X is missing**: the effects accepted leave the model clean
//!   *and* remove at least [`EXPLAINED_SHARE`] of the held-out mean square
//!   `z` above noise (a weak fit that only nudges a near-noise residual is
//!   not a finding). It is *confident* only if every fitted parameter is
//!   off its search bounds (by [`NEAR_BOUND`] of the range), inside its
//!   plausible range and identified ([`ParameterFlag`]); the flags are
//!   reported in words;
//! - **structured residual**: otherwise, with where it is.
//!
//! Search ranges are the plausible range widened by half its width on
//! each side, within the admissible range, and always include the neutral
//! value (the effect absent).
//!
//! # Reports
//! The results serialise (serde) for JSON reports. They do not
//! deserialise: a standard error or a screening gain that could not be
//! estimated is NaN, which JSON writes as `null`.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::measure::log::{LogProblem, MeasurementLog};
use crate::model::{EffectKind, Effects};

use super::compare::{compare, noise_rms_limit, Comparison};
use super::evidence::{evidence, Evidence};
use crate::sim::{EffectModel, ReplayError};

/// Why a diagnosis could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnoseError {
    /// The log cannot be compared with a model.
    #[error("{0}")]
    Log(#[from] LogProblem),
    /// A replay of the log through the model stopped.
    #[error("{0}")]
    Replay(#[from] ReplayError),
}

/// Levenberg–Marquardt iterations per fit.
const MAX_LM_ITERATIONS: usize = 30;
/// Held-out RMS `z` a found effect must reach, in noise SDs.
pub const EXPLAINED_RMS: f64 = 1.5;
/// Share of the held-out mean square `z` above noise that the effects found
/// must remove to be called missing: most of it.
pub const EXPLAINED_SHARE: f64 = 0.5;
/// How near a search bound, as a share of the search range's width, a
/// fitted parameter counts as sitting on it.
pub const NEAR_BOUND: f64 = 0.02;
/// Forward-difference step for sensitivities, as a fraction of each
/// parameter's plausible range: large against solver noise (residuals move
/// by ~1e-2 noise SDs, the solver's error by ~1e-6), small against the
/// curvature of every effect's response.
const DIFFERENCE_STEP: f64 = 1e-3;

/// One candidate effect fitted to the log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// The effect.
    pub kind: EffectKind,
    /// Fitted parameters ([`EffectKind::parameters`] order).
    pub values: Vec<f64>,
    /// Their standard errors (NaN where not identifiable).
    pub std_errors: Vec<f64>,
    /// Condition number of `JᵀJ` in scaled parameters.
    pub condition: f64,
    /// RMS `z` on the held-out cycles with the effect.
    pub held_out_rms: f64,
    /// How much the effect lowers `χ²` on the held-out cycles.
    pub held_out_gain: f64,
    /// BIC on the fit cycles with the effect.
    pub bic: f64,
    /// Share of the held-out mean square `z` above noise that the effect
    /// removes, 0–1.
    pub explained: f64,
    /// Whether the fit converged (else the values are the last iterate).
    pub converged: bool,
    /// What keeps the fit from being trusted: parameters at a search bound,
    /// outside their plausible range, or not identified.
    pub flags: Vec<ParameterFlag>,
}

/// A warning on one fitted parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "flag")]
pub enum ParameterFlag {
    /// Within [`NEAR_BOUND`] of the search range's width from one of its
    /// ends: the fit was stopped by the range, not by the data.
    AtSearchBound {
        /// Parameter name.
        parameter: String,
        /// Fitted value.
        value: f64,
        /// The bound it sits at.
        bound: f64,
    },
    /// Outside the effect's plausible range: physically unlikely, so the
    /// effect probably stands in for something else.
    OutsidePlausible {
        /// Parameter name.
        parameter: String,
        /// Fitted value.
        value: f64,
        /// The plausible range.
        plausible: (f64, f64),
    },
    /// Its standard error is not finite or exceeds its plausible range's
    /// width: the log does not identify it, so its value (at a bound or
    /// not) means nothing. Does not by itself make the fit untrusted
    /// unless no parameter of the effect is identified.
    NotIdentified {
        /// Parameter name.
        parameter: String,
    },
}

impl std::fmt::Display for ParameterFlag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParameterFlag::AtSearchBound {
                parameter,
                value,
                bound,
            } => write!(
                f,
                "{parameter} = {value:.4e} sits at its search bound {bound:.4e}"
            ),
            ParameterFlag::OutsidePlausible {
                parameter,
                value,
                plausible,
            } => write!(
                f,
                "{parameter} = {value:.4e} is outside its plausible range {:.4e} to {:.4e}",
                plausible.0, plausible.1
            ),
            ParameterFlag::NotIdentified { parameter } => {
                write!(
                    f,
                    "{parameter} is not identified by the log (standard error wider than its plausible range)"
                )
            }
        }
    }
}

impl Candidate {
    /// Whether the fit can be trusted: converged, no parameter at a search
    /// bound or outside its plausible range, and at least one identified.
    pub fn trusted(&self) -> bool {
        let unidentified = self
            .flags
            .iter()
            .filter(|f| matches!(f, ParameterFlag::NotIdentified { .. }))
            .count();
        self.converged && unidentified == self.flags.len() && unidentified < self.values.len()
    }
}

/// One round of the search.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Round {
    /// The model's effects at the start of the round.
    pub base: Effects,
    /// Held-out RMS `z` of the model as it is.
    pub base_held_out_rms: f64,
    /// BIC of the model as it is on the fit cycles.
    pub base_bic: f64,
    /// The screen of every effect the model lacked.
    pub screened: Vec<Screened>,
    /// Candidates that passed the screen, fitted, best first.
    pub ranking: Vec<Candidate>,
}

/// An effect screened at its neutral value (see the module notes).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Screened {
    /// The effect.
    pub kind: EffectKind,
    /// `χ²` on the fit cycles that one Gauss–Newton step predicts the
    /// effect removes (NaN where the model could not be run).
    pub predicted_gain: f64,
    /// The gain it needs to be fitted: `k·ln n`.
    pub threshold: f64,
}

impl Screened {
    /// Whether the effect is worth fitting.
    pub fn passed(&self) -> bool {
        self.predicted_gain > self.threshold
    }
}

/// What the search concluded.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The model explains the log to the noise.
    NothingMissing,
    /// These effects were found, in order (with their fits).
    Missing {
        /// The effects, in the order found.
        found: Vec<Candidate>,
        /// Whether every fit is trusted ([`Candidate::trusted`]); if not,
        /// the flags say why.
        confident: bool,
    },
    /// Residual structure that no candidate explains, after adding the
    /// effects found (possibly none).
    Unexplained {
        /// Effects found before getting stuck.
        found: Vec<Candidate>,
        /// Held-out RMS `z` left.
        held_out_rms: f64,
    },
}

/// The whole diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// Rounds of the greedy search.
    pub rounds: Vec<Round>,
    /// The conclusion.
    pub verdict: Verdict,
    /// The final comparison (model with the effects found) on all cycles.
    pub final_comparison: Comparison,
    /// Per-sensor and per-group tests of the final comparison.
    pub evidence: Evidence,
}

/// Settings of the search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiagnoseSettings {
    /// Greedy rounds (effects to find at most). Default 2.
    pub max_rounds: usize,
}

impl Default for DiagnoseSettings {
    fn default() -> Self {
        DiagnoseSettings { max_rounds: 2 }
    }
}

/// Which cycles are held out: the second, fourth, …; a one-cycle log is
/// fitted and scored on the same cycle. The whole log is always replayed
/// (friction makes every cycle depend on the ones before); the split only
/// decides which readings each score counts.
pub fn is_held_out(cycle: usize, cycles: usize) -> bool {
    cycles > 1 && cycle % 2 == 1
}

/// The readings of one part of the log: fitted (`held = false`) or held
/// out, as a comparison of its own.
pub fn part(c: &Comparison, cycles: usize, held: bool) -> Comparison {
    let keep = |cycle: usize| {
        if cycles <= 1 {
            true
        } else {
            is_held_out(cycle, cycles) == held
        }
    };
    let residuals: Vec<_> = c
        .residuals
        .iter()
        .filter(|r| keep(r.cycle))
        .copied()
        .collect();
    let overall = super::compare::Stats::of(residuals.iter().map(|r| r.z));
    Comparison {
        residuals,
        per_sensor: vec![],
        per_direction: vec![],
        overall,
    }
}

/// χ² and count of the comparison's `z`.
fn chi2(c: &Comparison) -> (f64, usize) {
    (
        c.residuals.iter().map(|r| r.z * r.z).sum(),
        c.residuals.len(),
    )
}

fn bic(c: &Comparison, parameters: usize) -> f64 {
    let (x2, n) = chi2(c);
    x2 + parameters as f64 * (n.max(1) as f64).ln()
}

fn with_effects(model: &EffectModel, effects: Effects) -> EffectModel {
    EffectModel {
        effects,
        ..model.clone()
    }
}

/// The `z` residual vector of `effects` on the fitted readings of `log`.
fn z_vector(model: &EffectModel, effects: Effects, log: &MeasurementLog) -> Option<Vec<f64>> {
    let c = compare(&with_effects(model, effects), log).ok()?;
    let fit = part(&c, log.cycles.len(), false);
    Some(fit.residuals.iter().map(|r| r.z).collect())
}

/// Where a fit may look for an effect's parameters: half a plausible range
/// beyond the plausible range, within the admissible one; and the scale
/// (the plausible range) the search works in.
struct SearchBox {
    scale: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl SearchBox {
    fn of(kind: EffectKind) -> SearchBox {
        let specs = kind.parameters();
        let scale: Vec<f64> = specs
            .iter()
            .map(|p| (p.plausible.1 - p.plausible.0).abs().max(1e-12))
            .collect();
        // The neutral value (the effect absent) is always inside: a range
        // that excludes it forces every fit onto a bound (thermal expansion's
        // plausible range does not reach zero).
        let lower = specs
            .iter()
            .zip(&scale)
            .map(|(p, s)| (p.plausible.0 - 0.5 * s).min(p.neutral).max(p.admissible.0))
            .collect();
        let upper = specs
            .iter()
            .zip(&scale)
            .map(|(p, s)| (p.plausible.1 + 0.5 * s).max(p.neutral).min(p.admissible.1))
            .collect();
        SearchBox {
            scale,
            lower,
            upper,
        }
    }

    fn clamp(&self, x: &mut [f64]) {
        for (i, v) in x.iter_mut().enumerate() {
            *v = v.clamp(self.lower[i], self.upper[i]);
        }
    }
}

/// Jacobian of `z` in scaled parameters at `x` by forward differences
/// (backwards where a step forwards would leave `[lower, upper]`); `None`
/// if a replay fails or changes which readings exist.
fn jacobian(
    eval: &dyn Fn(&[f64]) -> Option<Vec<f64>>,
    x: &[f64],
    r: &[f64],
    scale: &[f64],
    upper: &[f64],
) -> Option<nalgebra::DMatrix<f64>> {
    let mut jac = nalgebra::DMatrix::<f64>::zeros(r.len(), x.len());
    for i in 0..x.len() {
        let h = DIFFERENCE_STEP * scale[i];
        let mut xp = x.to_vec();
        xp[i] += if xp[i] + h <= upper[i] { h } else { -h };
        let step = xp[i] - x[i];
        let rp = eval(&xp)?;
        if rp.len() != r.len() {
            return None;
        }
        for (row, (a, b)) in rp.iter().zip(r).enumerate() {
            jac[(row, i)] = (a - b) / step * scale[i];
        }
    }
    Some(jac)
}

/// Screens effect `kind` on top of `base`: the `χ²` on the fit cycles that
/// one Gauss–Newton step from the neutral parameters predicts it removes,
/// with the step kept admissible. `base_z` is the model's own `z` on the
/// fit cycles.
pub fn screen_candidate(
    model: &EffectModel,
    base: Effects,
    kind: EffectKind,
    log: &MeasurementLog,
    base_z: &[f64],
) -> Screened {
    let specs = kind.parameters();
    let k = specs.len();
    let threshold = k as f64 * (base_z.len().max(1) as f64).ln();
    let neutral: Vec<f64> = specs.iter().map(|p| p.neutral).collect();
    let scale: Vec<f64> = SearchBox::of(kind).scale;
    let upper: Vec<f64> = specs.iter().map(|p| p.admissible.1).collect();
    let eval = |x: &[f64]| z_vector(model, base.with_parameters(kind, x), log);
    let gain = (|| {
        // The neutral effect switched on is the model as it is, except that
        // an effect may carry settings of its own (a thermal reference
        // temperature): run it rather than assume.
        let r0 = eval(&neutral)?;
        if r0.len() != base_z.len() {
            return None;
        }
        let jac = jacobian(&eval, &neutral, &r0, &scale, &upper)?;
        let r = nalgebra::DVector::from_vec(r0);
        let jtj = jac.transpose() * &jac;
        let grad = jac.transpose() * &r;
        // Unconstrained step, then the parameters it pushes out of their
        // admissible range held at the bound and the rest solved again.
        let solve = |free: &[bool]| -> nalgebra::DVector<f64> {
            let idx: Vec<usize> = (0..k).filter(|i| free[*i]).collect();
            let mut step = nalgebra::DVector::zeros(k);
            if idx.is_empty() {
                return step;
            }
            let a = nalgebra::DMatrix::from_fn(idx.len(), idx.len(), |i, j| {
                jtj[(idx[i], idx[j])]
                    + if i == j {
                        1e-12 * jtj[(idx[i], idx[i])].max(1e-300)
                    } else {
                        0.0
                    }
            });
            let b = nalgebra::DVector::from_fn(idx.len(), |i, _| -grad[idx[i]]);
            if let Some(d) = a.lu().solve(&b) {
                for (i, &v) in idx.iter().zip(d.iter()) {
                    step[*i] = v;
                }
            }
            step
        };
        let mut free = vec![true; k];
        let mut step = solve(&free);
        for i in 0..k {
            let lo = specs[i].admissible.0;
            if neutral[i] + step[i] * scale[i] < lo {
                free[i] = false;
            }
        }
        if free.iter().any(|f| !f) {
            step = solve(&free);
        }
        let predicted = &r + &jac * &step;
        Some(r.norm_squared() - predicted.norm_squared())
    })();
    Screened {
        kind,
        predicted_gain: gain.unwrap_or(f64::NAN),
        threshold,
    }
}

/// Fits effect `kind` on top of `base` to the fitted cycles of `log`, then
/// scores it on the held-out ones. `base_held` is the model's own
/// held-out part.
pub fn fit_candidate(
    model: &EffectModel,
    base: Effects,
    kind: EffectKind,
    log: &MeasurementLog,
    base_held: &Comparison,
) -> Result<Candidate, ReplayError> {
    let specs = kind.parameters();
    let k = specs.len();
    let bounds = SearchBox::of(kind);
    // Start in the middle of the plausible range, but near the neutral
    // value where it lies inside (a small effect is the likelier one).
    let mut x: Vec<f64> = specs
        .iter()
        .map(|p| {
            if p.neutral >= p.plausible.0 && p.neutral <= p.plausible.1 {
                p.neutral + 0.1 * (p.plausible.1 - p.plausible.0)
            } else {
                0.5 * (p.plausible.0 + p.plausible.1)
            }
        })
        .collect();
    bounds.clamp(&mut x);
    let eval = |x: &[f64]| z_vector(model, base.with_parameters(kind, x), log);
    let start = compare(&with_effects(model, base.with_parameters(kind, &x)), log)?;
    let mut r: Vec<f64> = part(&start, log.cycles.len(), false)
        .residuals
        .iter()
        .map(|r| r.z)
        .collect();
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    let mut lambda = 1e-2;
    let mut converged = false;
    let mut jtj = nalgebra::DMatrix::<f64>::zeros(k, k);
    for _ in 0..MAX_LM_ITERATIONS {
        let Some(jac) = jacobian(&eval, &x, &r, &bounds.scale, &bounds.upper) else {
            break;
        };
        jtj = jac.transpose() * &jac;
        let grad = jac.transpose() * nalgebra::DVector::from_vec(r.clone());
        let mut improved = false;
        for _ in 0..8 {
            let mut a = jtj.clone();
            for i in 0..k {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(delta) = a.lu().solve(&(-&grad)) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial: Vec<f64> = (0..k).map(|i| x[i] + delta[i] * bounds.scale[i]).collect();
            bounds.clamp(&mut trial);
            if let Some(rt) = eval(&trial) {
                let c: f64 = rt.iter().map(|v| v * v).sum();
                if rt.len() == r.len() && c < cost {
                    let gain = cost - c;
                    x = trial;
                    r = rt;
                    cost = c;
                    lambda = (lambda / 3.0).max(1e-9);
                    improved = true;
                    if gain < 1e-6 * cost.max(1.0) {
                        converged = true;
                    }
                    break;
                }
            }
            lambda *= 4.0;
        }
        if !improved {
            converged = true;
        }
        if converged {
            break;
        }
    }
    let effects = base.with_parameters(kind, &x);
    let all = compare(&with_effects(model, effects), log)?;
    let fitted = part(&all, log.cycles.len(), false);
    let held = part(&all, log.cycles.len(), true);
    let (std_errors, condition) = match jtj.clone().try_inverse() {
        Some(inv) => {
            let eig = jtj.symmetric_eigen().eigenvalues;
            let (lo, hi) = (eig.min(), eig.max());
            (
                (0..k)
                    .map(|i| inv[(i, i)].max(0.0).sqrt() * bounds.scale[i])
                    .collect(),
                if lo > 0.0 { hi / lo } else { f64::INFINITY },
            )
        }
        None => (vec![f64::NAN; k], f64::INFINITY),
    };
    let flags = parameter_flags(kind, &bounds, &x, &std_errors);
    Ok(Candidate {
        kind,
        flags,
        values: x,
        std_errors,
        condition,
        held_out_rms: held.overall.rms,
        held_out_gain: chi2(base_held).0 - chi2(&held).0,
        bic: bic(
            &fitted,
            base.enabled()
                .iter()
                .map(|e| e.parameters().len())
                .sum::<usize>()
                + k,
        ),
        explained: explained_share(base_held.overall.rms, held.overall.rms),
        converged,
    })
}

/// The warnings on the fitted parameters `x` of `kind`.
fn parameter_flags(
    kind: EffectKind,
    bounds: &SearchBox,
    x: &[f64],
    std_errors: &[f64],
) -> Vec<ParameterFlag> {
    let mut flags = Vec::new();
    for (i, spec) in kind.parameters().iter().enumerate() {
        let parameter = format!("{}.{}", kind.name(), spec.name);
        let se = std_errors[i];
        // A parameter the log cannot pin down to within its plausible
        // range says nothing by its value, at a bound or not.
        if !(se.is_finite() && se <= bounds.scale[i]) {
            flags.push(ParameterFlag::NotIdentified { parameter });
            continue;
        }
        let near = NEAR_BOUND * (bounds.upper[i] - bounds.lower[i]);
        let (lo, hi) = (bounds.lower[i], bounds.upper[i]);
        if x[i] - lo <= near || hi - x[i] <= near {
            let bound = if x[i] - lo <= hi - x[i] { lo } else { hi };
            flags.push(ParameterFlag::AtSearchBound {
                parameter: parameter.clone(),
                value: x[i],
                bound,
            });
        }
        // Outside by more than two standard errors: the data, not the
        // sampling, put it there.
        let outside = (spec.plausible.0 - x[i]).max(x[i] - spec.plausible.1);
        if outside > 2.0 * se {
            flags.push(ParameterFlag::OutsidePlausible {
                parameter,
                value: x[i],
                plausible: spec.plausible,
            });
        }
    }
    flags
}

/// Share of the mean square `z` above noise (`rms² − 1`) at `before` that
/// is gone at `after`, 0–1.
fn explained_share(before: f64, after: f64) -> f64 {
    let excess = |rms: f64| (rms * rms - 1.0).max(0.0);
    if excess(before) > 0.0 {
        ((excess(before) - excess(after)) / excess(before)).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Runs the greedy search.
pub fn diagnose(
    model: &EffectModel,
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Result<Diagnosis, DiagnoseError> {
    log.check_comparable()?;
    let cycles = log.cycles.len();
    let mut effects = model.effects;
    let mut found: Vec<Candidate> = Vec::new();
    let mut rounds = Vec::new();
    // The model with the effects found so far, compared once per change.
    let mut current = compare(model, log)?;
    let first_held = part(&current, cycles, true);
    let mut held = first_held.clone();
    while rounds.len() < settings.max_rounds {
        let base_fit = part(&current, cycles, false);
        let base_z: Vec<f64> = base_fit.residuals.iter().map(|r| r.z).collect();
        let base_k: usize = effects.enabled().iter().map(|e| e.parameters().len()).sum();
        let base_bic = bic(&base_fit, base_k);
        let missing: Vec<EffectKind> = EffectKind::ALL
            .into_iter()
            .filter(|k| effects.parameters(*k).is_none())
            .collect();
        let mut screened: Vec<Screened> = missing
            .par_iter()
            .map(|&kind| screen_candidate(model, effects, kind, log, &base_z))
            .collect();
        screened.sort_by(|a, b| b.predicted_gain.total_cmp(&a.predicted_gain));
        let mut ranking: Vec<Candidate> = screened
            .par_iter()
            .filter(|s| s.passed())
            .filter_map(|s| fit_candidate(model, effects, s.kind, log, &held).ok())
            .collect();
        ranking.sort_by(|a, b| a.held_out_rms.total_cmp(&b.held_out_rms));
        let held_penalty = |k: usize| k as f64 * (held.overall.count.max(1) as f64).ln();
        let best = ranking
            .first()
            .filter(|b| b.bic < base_bic && b.held_out_gain > held_penalty(b.values.len()))
            .cloned();
        rounds.push(Round {
            base: effects,
            base_held_out_rms: held.overall.rms,
            base_bic,
            screened,
            ranking,
        });
        let Some(b) = best else { break };
        effects = effects.with_parameters(b.kind, &b.values);
        current = compare(&with_effects(model, effects), log)?;
        held = part(&current, cycles, true);
        found.push(b);
    }
    let noise_like = held.overall.rms <= noise_rms_limit(held.overall.count);
    let evidence = evidence(&current, &log.sensors);
    let clean = noise_like && !evidence.any_significant();
    let explained = explained_share(first_held.overall.rms, held.overall.rms);
    let verdict = if found.is_empty() && clean {
        Verdict::NothingMissing
    } else if !found.is_empty()
        && clean
        && held.overall.rms <= EXPLAINED_RMS
        && explained >= EXPLAINED_SHARE
    {
        let confident = found.iter().all(Candidate::trusted);
        Verdict::Missing { found, confident }
    } else {
        Verdict::Unexplained {
            found,
            held_out_rms: held.overall.rms,
        }
    };
    Ok(Diagnosis {
        rounds,
        verdict,
        final_comparison: current,
        evidence,
    })
}

/// The model's effects after a diagnosis: `base` plus every effect found.
pub fn effects_found(base: Effects, verdict: &Verdict) -> Effects {
    let found = match verdict {
        Verdict::NothingMissing => return base,
        Verdict::Missing { found, .. } => found,
        Verdict::Unexplained { found, .. } => found,
    };
    found
        .iter()
        .fold(base, |e, c| e.with_parameters(c.kind, &c.values))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_search_range_holds_the_neutral_value() {
        // Thermal expansion's plausible range (1.0e-5 to 1.4e-5 /K) does
        // not reach 0: without the rule every thermal fit sat on a bound.
        for kind in EffectKind::ALL {
            let b = SearchBox::of(kind);
            for (i, p) in kind.parameters().iter().enumerate() {
                if p.neutral >= p.admissible.0 && p.neutral <= p.admissible.1 {
                    assert!(
                        b.lower[i] <= p.neutral && p.neutral <= b.upper[i],
                        "{}.{}",
                        kind.name(),
                        p.name
                    );
                }
            }
        }
    }

    #[test]
    fn fits_at_a_bound_or_implausible_are_flagged_and_not_trusted() {
        let kind = EffectKind::Thermal;
        let b = SearchBox::of(kind);
        let p = kind.parameters()[0];
        let se = 1e-7;
        // At the lower bound (the neutral 0).
        let flags = parameter_flags(kind, &b, &[b.lower[0]], &[se]);
        assert!(
            matches!(
                flags[..],
                [
                    ParameterFlag::AtSearchBound { .. },
                    ParameterFlag::OutsidePlausible { .. }
                ]
            ),
            "{flags:?}"
        );
        // Inside the plausible range: no flag.
        let mid = 0.5 * (p.plausible.0 + p.plausible.1);
        assert!(parameter_flags(kind, &b, &[mid], &[se]).is_empty());
        // Just outside, by less than two standard errors: sampling, no flag.
        let near = p.plausible.1 + 1.5 * se;
        assert!(parameter_flags(kind, &b, &[near], &[se]).is_empty());
        // A standard error wider than the plausible range: not identified,
        // and nothing else said about its value.
        let wide = parameter_flags(kind, &b, &[b.lower[0]], &[1.0]);
        assert!(matches!(wide[..], [ParameterFlag::NotIdentified { .. }]));
        let candidate = |flags: Vec<ParameterFlag>| Candidate {
            kind,
            values: vec![mid],
            std_errors: vec![se],
            condition: 1.0,
            held_out_rms: 1.0,
            held_out_gain: 10.0,
            bic: 0.0,
            explained: 1.0,
            converged: true,
            flags,
        };
        assert!(candidate(vec![]).trusted());
        assert!(!candidate(flags).trusted());
        // Its only parameter unidentified: nothing to trust.
        assert!(!candidate(wide).trusted());
    }
}
