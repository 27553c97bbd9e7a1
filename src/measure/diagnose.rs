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
//! # Scoring
//! Cycles alternate between fitting and held out (the first, third, … are
//! fitted; the second, fourth, … held out). The whole log is replayed every
//! time, because friction carries each cycle's history into the next; the
//! split decides which readings each score counts. A candidate's score is how much
//! it lowers the held-out RMS of `z`; the Bayesian information criterion
//! `χ² + k·ln n` on the fit cycles guards against parameters that buy
//! nothing.
//!
//! # Verdict
//! - **nothing missing**: the model's held-out RMS `z` is within four
//!   sampling SDs of 1 (pure noise);
//! - **effect X is missing**: the best candidate lowers the held-out RMS,
//!   improves the BIC, and leaves a held-out RMS within 1.5 noise SDs;
//! - **structured residual**: otherwise, with where it is.

use rayon::prelude::*;

use crate::io::log::MeasurementLog;
use crate::model::{EffectKind, Effects};

use super::compare::{compare, Comparison};
use super::replay::{EffectModel, ReplayError};

/// Levenberg–Marquardt iterations per fit.
const MAX_LM_ITERATIONS: usize = 30;
/// Held-out RMS `z` a found effect must reach, in noise SDs.
pub const EXPLAINED_RMS: f64 = 1.5;

/// One candidate effect fitted to the log.
#[derive(Debug, Clone, PartialEq)]
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
    /// BIC on the fit cycles with the effect.
    pub bic: f64,
    /// Share of the held-out mean square `z` above noise that the effect
    /// removes, 0–1.
    pub explained: f64,
    /// Whether the fit converged (else the values are the last iterate).
    pub converged: bool,
}

/// One round of the search.
#[derive(Debug, Clone, PartialEq)]
pub struct Round {
    /// The model's effects at the start of the round.
    pub base: Effects,
    /// Held-out RMS `z` of the model as it is.
    pub base_held_out_rms: f64,
    /// BIC of the model as it is on the fit cycles.
    pub base_bic: f64,
    /// Candidates, best first.
    pub ranking: Vec<Candidate>,
}

/// What the search concluded.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The model explains the log to the noise.
    NothingMissing,
    /// These effects were found, in order (with their fits).
    Missing(Vec<Candidate>),
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
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnosis {
    /// Rounds of the greedy search.
    pub rounds: Vec<Round>,
    /// The conclusion.
    pub verdict: Verdict,
    /// The final comparison (model with the effects found) on all cycles.
    pub final_comparison: Comparison,
}

/// Settings of the search.
#[derive(Debug, Clone, PartialEq)]
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

/// Fits effect `kind` on top of `base` to the fitted cycles of `log`, then
/// scores it on the held-out ones.
pub fn fit_candidate(
    model: &EffectModel,
    base: Effects,
    kind: EffectKind,
    log: &MeasurementLog,
    base_held_rms: f64,
) -> Result<Candidate, ReplayError> {
    let fit = log;
    let specs = kind.parameters();
    let k = specs.len();
    let scale: Vec<f64> = specs
        .iter()
        .map(|p| (p.plausible.1 - p.plausible.0).abs().max(1e-12))
        .collect();
    let lower: Vec<f64> = specs
        .iter()
        .zip(&scale)
        .map(|(p, s)| (p.plausible.0 - 0.5 * s).max(p.admissible.0))
        .collect();
    let upper: Vec<f64> = specs
        .iter()
        .zip(&scale)
        .map(|(p, s)| (p.plausible.1 + 0.5 * s).min(p.admissible.1))
        .collect();
    // Start in the middle of the plausible range, but at the neutral value
    // where it lies inside (a small effect is the likelier one).
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
    let clamp = |v: &mut Vec<f64>| {
        for i in 0..k {
            v[i] = v[i].clamp(lower[i], upper[i]);
        }
    };
    let eval = |x: &[f64]| z_vector(model, base.with_parameters(kind, x), fit);
    let mut r = match eval(&x) {
        Some(r) => r,
        None => {
            return Err(
                compare(&with_effects(model, base.with_parameters(kind, &x)), fit)
                    .err()
                    .expect("a failed replay"),
            )
        }
    };
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    let mut lambda = 1e-2;
    let mut converged = false;
    let mut jtj = nalgebra::DMatrix::<f64>::zeros(k, k);
    for _ in 0..MAX_LM_ITERATIONS {
        // Jacobian in scaled parameters by forward differences.
        let mut jac = nalgebra::DMatrix::<f64>::zeros(r.len(), k);
        for i in 0..k {
            let h = 1e-3 * scale[i];
            let mut xp = x.clone();
            xp[i] += if xp[i] + h <= upper[i] { h } else { -h };
            let step = xp[i] - x[i];
            let Some(rp) = eval(&xp) else { continue };
            if rp.len() != r.len() {
                continue;
            }
            for (row, (a, b)) in rp.iter().zip(&r).enumerate() {
                jac[(row, i)] = (a - b) / step * scale[i];
            }
        }
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
            let mut trial: Vec<f64> = (0..k).map(|i| x[i] + delta[i] * scale[i]).collect();
            clamp(&mut trial);
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
    let held_rms = part(&all, log.cycles.len(), true).overall.rms;
    let (std_errors, condition) = match jtj.clone().try_inverse() {
        Some(inv) => {
            let eig = jtj.symmetric_eigen().eigenvalues;
            let (lo, hi) = (eig.min(), eig.max());
            (
                (0..k)
                    .map(|i| inv[(i, i)].max(0.0).sqrt() * scale[i])
                    .collect(),
                if lo > 0.0 { hi / lo } else { f64::INFINITY },
            )
        }
        None => (vec![f64::NAN; k], f64::INFINITY),
    };
    let excess = |rms: f64| (rms * rms - 1.0).max(0.0);
    let explained = if excess(base_held_rms) > 0.0 {
        ((excess(base_held_rms) - excess(held_rms)) / excess(base_held_rms)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Ok(Candidate {
        kind,
        values: x,
        std_errors,
        condition,
        held_out_rms: held_rms,
        bic: bic(
            &fitted,
            base.enabled()
                .iter()
                .map(|e| e.parameters().len())
                .sum::<usize>()
                + k,
        ),
        explained,
        converged,
    })
}

/// Runs the greedy search.
pub fn diagnose(
    model: &EffectModel,
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Result<Diagnosis, ReplayError> {
    let cycles = log.cycles.len();
    let mut effects = model.effects;
    let mut found: Vec<Candidate> = Vec::new();
    let mut rounds = Vec::new();
    let noise_limit = |n: usize| 1.0 + 4.0 / (2.0 * n.max(1) as f64).sqrt();
    let verdict = loop {
        let base_all = compare(&with_effects(model, effects), log)?;
        let base_held = part(&base_all, cycles, true);
        let base_fit = part(&base_all, cycles, false);
        let base_rms = base_held.overall.rms;
        if base_rms <= noise_limit(base_held.overall.count) {
            break if found.is_empty() {
                Verdict::NothingMissing
            } else {
                Verdict::Missing(found.clone())
            };
        }
        if rounds.len() >= settings.max_rounds {
            break if !found.is_empty() && base_rms <= EXPLAINED_RMS {
                Verdict::Missing(found.clone())
            } else {
                Verdict::Unexplained {
                    found: found.clone(),
                    held_out_rms: base_rms,
                }
            };
        }
        let base_k: usize = effects.enabled().iter().map(|e| e.parameters().len()).sum();
        let base_bic = bic(&base_fit, base_k);
        let missing: Vec<EffectKind> = EffectKind::ALL
            .into_iter()
            .filter(|k| effects.parameters(*k).is_none())
            .collect();
        let mut ranking: Vec<Candidate> = missing
            .par_iter()
            .filter_map(|&kind| fit_candidate(model, effects, kind, log, base_rms).ok())
            .collect();
        ranking.sort_by(|a, b| a.held_out_rms.total_cmp(&b.held_out_rms));
        let best = ranking.first().cloned();
        rounds.push(Round {
            base: effects,
            base_held_out_rms: base_rms,
            base_bic,
            ranking,
        });
        match best {
            Some(b) if b.bic < base_bic && b.held_out_rms < base_rms => {
                effects = effects.with_parameters(b.kind, &b.values);
                found.push(b);
            }
            _ => {
                break Verdict::Unexplained {
                    found: found.clone(),
                    held_out_rms: base_rms,
                }
            }
        }
    };
    // A found set that does not reach the noise is not an explanation.
    let verdict = match verdict {
        Verdict::Missing(f) if f.last().map(|c| c.held_out_rms).unwrap_or(0.0) > EXPLAINED_RMS => {
            let rms = f.last().map(|c| c.held_out_rms).unwrap_or(f64::NAN);
            Verdict::Unexplained {
                found: f,
                held_out_rms: rms,
            }
        }
        v => v,
    };
    let final_comparison = compare(&with_effects(model, effects), log)?;
    Ok(Diagnosis {
        rounds,
        verdict,
        final_comparison,
    })
}

/// The model's effects after a diagnosis: `base` plus every effect found.
pub fn effects_found(base: Effects, verdict: &Verdict) -> Effects {
    let found = match verdict {
        Verdict::NothingMissing => return base,
        Verdict::Missing(f) => f,
        Verdict::Unexplained { found, .. } => found,
    };
    found
        .iter()
        .fold(base, |e, c| e.with_parameters(c.kind, &c.values))
}
