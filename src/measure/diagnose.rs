//! Which physical effect is missing: every effect the model lacks, and then
//! every local candidate ([`super::local`]), is fitted to the log through
//! the model, scored on cycles it was not fitted on, and ranked; the best
//! is added and the search repeats. At the end, everything found is fitted
//! again together.
//!
//! # Outliers
//! Readings of the model's comparison beyond
//! [`OutlierSettings::limit_robust_sds`](super::settings::OutlierSettings::limit_robust_sds)
//! robust SDs from their sensor's median, with both clock neighbours
//! within half that of it (a spike, not a run of readings a model error
//! moved), are removed (made missing) before anything is fitted, and
//! listed in [`Diagnosis::outliers`].
//!
//! # Settings
//! Every number that tunes the search is a field of [`DiagnoseSettings`]
//! (its defaults in parentheses below), checked by
//! [`DiagnoseSettings::validate`] before the search starts.
//!
//! # Fitting
//! Levenberg–Marquardt ([`super::fit`]) on the parameters of one candidate
//! (the model's own effects and the candidates found held fixed),
//! minimising `χ² = Σ z²` over the *fit* cycles, with `z` the residual in
//! noise SDs. The Jacobian is by forward differences of whole replays
//! (each a warm run of the forward model); load-cell gains and position
//! drifts act on the readings and need no replay. At the optimum,
//! `(JᵀJ)⁻¹` gives each parameter's standard error, and the condition
//! number of `JᵀJ` says how well the log identifies them.
//!
//! # Screening, in two tiers
//! Each candidate is screened where it is switched on at its neutral value
//! (the model as it is): one Gauss–Newton step from there predicts how much
//! `χ²` on the fit cycles it could remove. The library effects are the
//! first tier. The local candidates are the second, screened in a round
//! where no library effect removes at least
//! [`explained_share`](DiagnoseSettings::explained_share) (½) of the
//! held-out excess and the model is not yet clean (a local failure is what
//! is left to explain); then, of the accepted candidates of either tier,
//! the one that leaves the model clean is taken, else the one with the
//! larger held-out gain beyond its penalty. Member groups,
//! motors (slip, the cable's stiffness, its drum's offset) and sensors
//! first, then the single members (stiffness and rest length) of the
//! [`member_groups_opened`](DiagnoseSettings::member_groups_opened) (2)
//! groups whose screen predicted most and of the continuous cables whose
//! own terms passed (a member cut long shifts its cable's prestress as the
//! drum's offset does). At most
//! [`max_local_fits`](DiagnoseSettings::max_local_fits) (4) local
//! candidates, those predicted to gain most, are fitted.
//!
//! The penalty a candidate of `k` parameters must beat counts the `M`
//! candidates of its tier (all of them, screened or not):
//! `w_k·k·ln n + w_M·ln M`, with `w_k`
//! [`penalty_per_parameter`](DiagnoseSettings::penalty_per_parameter) (1)
//! and `w_M`
//! [`penalty_per_ln_candidates`](DiagnoseSettings::penalty_per_ln_candidates)
//! (2). The largest of `M` useless candidates' gains exceeds `k·ln n` about
//! `M` times as often as one does; the `2·ln M` takes that factor back (a
//! χ² tail falls as `e^(−x/2)`), so trying 330 local candidates raises no
//! more false alarms than trying one. Below, `k·ln n + 2·ln M` stands for
//! the penalty with the default weights.
//!
//! # Scoring
//! Cycles alternate between fitting and held out (the first, third, … are
//! fitted; the second, fourth, … held out; with
//! [`held_out_period`](DiagnoseSettings::held_out_period) `p`, the last
//! of every `p`). The whole log is replayed every time, because friction
//! carries each cycle's history into the next; the split decides which
//! readings each score counts. A candidate is ranked by
//! the held-out RMS of `z` it leaves; it is accepted only if it improves
//! the information criterion `χ² + k·ln n + 2·ln M` on the fit cycles *and*
//! lowers the held-out `χ²` by more than `k·ln n_held + 2·ln M` (the same
//! penalty, on readings it never saw).
//!
//! # Joint refit
//! Candidates found in turn were each fitted with the earlier ones held at
//! their values, so an early one absorbs part of a later one's signal. At
//! the end all of them are fitted together on the fit cycles (one
//! Levenberg–Marquardt over all their parameters, starting where the
//! search left them); the verdict reports these values and the standard
//! errors of the joint fit, and its tests use the joint model.
//!
//! # Verdict
//! "Clean" below means: the held-out RMS `z` is within [`noise_rms_limit`]
//! *and* no per-sensor or per-group test of the final comparison rejects
//! noise ([`super::evidence`], Holm-controlled): a local failure that the
//! overall RMS dilutes still counts.
//! - **nothing missing**: no candidate is accepted and the model is clean;
//! - **effect X is missing** (X may be local, named with its member, motor
//!   or sensor): the candidates accepted leave the model clean *and* either
//!   the model without them was not clean (they explain a failure the
//!   tests saw, however diluted in the overall RMS) or they remove at least
//!   [`explained_share`](DiagnoseSettings::explained_share) of the
//!   held-out mean square `z` above noise (a weak fit that only nudges a
//!   near-noise residual is not a finding), and leave a held-out RMS `z`
//!   within [`explained_rms`](DiagnoseSettings::explained_rms) (1.5). It
//!   is *confident* only if every fitted parameter is off its search
//!   bounds (by [`near_bound`](DiagnoseSettings::near_bound) (0.02) of the
//!   range; a bound that is both the end of the parameter's admissible
//!   range and its neutral value, a backlash of 0, does not count: the
//!   data may well say the effect lacks that part), inside its plausible range (by more than
//!   [`outside_plausible_std_errors`](DiagnoseSettings::outside_plausible_std_errors)
//!   (2) standard errors) and identified, no sensor carries
//!   [`one_sensor_share`](DiagnoseSettings::one_sensor_share) (98 %) of
//!   its held-out gain unless it is a term of that sensor's readings, and
//!   no other local fit explains the held-out cycles as well to within its
//!   penalty (the log cannot tell them apart: of such rivals the one least
//!   outside its plausible ranges is named, the others listed;
//!   [`ParameterFlag`]); the flags are reported in words;
//! - **structured residual**: otherwise, with where it is.
//!
//! Search ranges are the plausible range widened by
//! [`FitSettings::search_widening`](super::settings::FitSettings::search_widening)
//! (half) its width on each side, within the admissible range, and always
//! include the neutral value (the effect absent).
//!
//! # Reports
//! The results serialise (serde) for JSON reports. They do not
//! deserialise: a standard error or a screening gain that could not be
//! estimated is NaN, which JSON writes as `null`.

use std::sync::Arc;

use rayon::prelude::*;
use serde::Serialize;

use crate::measure::log::{LogProblem, MeasurementLog};
use crate::model::effects::ParameterSpec;
use crate::model::{EffectKind, Effects};

use super::compare::{noise_rms_limit, Comparison};
use super::evidence::{evidence, Evidence};
use super::fit::{levenberg_marquardt, predicted_gain, Fit, SearchBox};
use super::local::{
    compare_hypothesis, local_candidates, member_groups, with_reading_terms, Hypothesis, LocalKind,
    Term,
};
use super::outliers::{drop_outliers, find_outliers, without_outliers, Outlier};
pub use super::settings::DiagnoseSettings;
use super::settings::DiagnoseSettingsError;
use crate::sim::{EffectModel, PlantError, SensorTarget};

/// Why a diagnosis could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnoseError {
    /// The log cannot be compared with a model.
    #[error("{0}")]
    Log(#[from] LogProblem),
    /// A replay of the log through the model stopped.
    #[error("{0}")]
    Replay(#[from] PlantError),
    /// A setting is out of its range.
    #[error("{0}")]
    Settings(#[from] DiagnoseSettingsError),
}

/// One candidate fitted to the log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// What was fitted.
    pub term: Term,
    /// Its name, a local one with its member, motor or sensor.
    pub name: String,
    /// Fitted parameters ([`Term::parameters`] order).
    pub values: Vec<f64>,
    /// Their standard errors (NaN where not identifiable).
    pub std_errors: Vec<f64>,
    /// Condition number of `JᵀJ` in scaled parameters.
    pub condition: f64,
    /// RMS `z` on the held-out cycles with the candidate.
    pub held_out_rms: f64,
    /// How much the candidate lowers `χ²` on the held-out cycles.
    pub held_out_gain: f64,
    /// Information criterion on the fit cycles with the candidate:
    /// `χ² + k·ln n + 2·ln M` (`k` all parameters, `M` the candidates of
    /// its tier; weights of [`DiagnoseSettings`]).
    pub bic: f64,
    /// The penalty this candidate's own parameters pay: `k·ln n + 2·ln M`
    /// on the fit cycles (weights of [`DiagnoseSettings`]).
    pub penalty: f64,
    /// Share of the held-out mean square `z` above noise that the candidate
    /// removes, 0–1.
    pub explained: f64,
    /// Whether the fit converged (else the values are the last iterate).
    pub converged: bool,
    /// Whether the model with it is clean: held-out RMS within the noise
    /// limit and no per-sensor test rejecting noise.
    pub leaves_clean: bool,
    /// What keeps the fit from being trusted: parameters at a search bound,
    /// outside their plausible range, or not identified.
    pub flags: Vec<ParameterFlag>,
}

/// A warning on one fitted parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "flag")]
pub enum ParameterFlag {
    /// Within [`DiagnoseSettings::near_bound`] of the search range's width
    /// from one of its ends: the fit was stopped by the range, not by the
    /// data.
    AtSearchBound {
        /// Parameter name.
        parameter: String,
        /// Fitted value.
        value: f64,
        /// The bound it sits at.
        bound: f64,
    },
    /// Outside the effect's plausible range, by more than
    /// [`DiagnoseSettings::outside_plausible_std_errors`] standard errors:
    /// physically unlikely, so the effect probably stands in for something
    /// else.
    OutsidePlausible {
        /// Parameter name.
        parameter: String,
        /// Fitted value.
        value: f64,
        /// The plausible range.
        plausible: (f64, f64),
    },
    /// At a search bound that is both the end of its admissible range and
    /// its neutral value (a backlash of 0 m): the physics stops the fit
    /// there, not the search range, and the value says the effect lacks
    /// this part (a drum that slips without backlash). Reported, and no
    /// reason by itself to distrust the fit.
    AtNeutralLimit {
        /// Parameter name.
        parameter: String,
        /// Fitted value.
        value: f64,
    },
    /// Its standard error is not finite or exceeds
    /// [`DiagnoseSettings::max_identified_std_error`] times its plausible
    /// range's width: the log does not identify it, so its value (at a
    /// bound or not) means nothing. Does not by itself make the fit untrusted
    /// unless no parameter of the effect is identified.
    NotIdentified {
        /// Parameter name.
        parameter: String,
    },
    /// At least [`DiagnoseSettings::one_sensor_share`] of the candidate's
    /// held-out χ² gain comes from one sensor, and the candidate is not a
    /// term of that sensor's readings: a fault of that sensor (one no
    /// candidate describes, such as clipping) would explain it as well.
    /// Not a parameter's flag but the whole candidate's; it is not
    /// trusted.
    CarriedByOneSensor {
        /// The sensor's id.
        sensor: String,
        /// Its share of the held-out χ² gain, 0–1.
        share: f64,
    },
    /// Another fitted candidate explains the held-out cycles as well, to
    /// within the candidate's penalty (`k·ln n + 2·ln M`, the resolution
    /// of the criterion that accepted it): the log does not tell them
    /// apart (a strut cut 4 mm long and its neighbours on the same
    /// cable). The candidate's whole flag; it is not trusted.
    Rival {
        /// The rival's name.
        name: String,
        /// Its held-out RMS, noise SDs.
        held_out_rms: f64,
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
            ParameterFlag::AtNeutralLimit { parameter, value } => write!(
                f,
                "{parameter} = {value:.4e} sits at its neutral limit (its neutral value and the end of its admissible range): the log finds little or none of it"
            ),
            ParameterFlag::CarriedByOneSensor { sensor, share } => write!(
                f,
                "{:.1} % of its held-out gain comes from one sensor, {sensor}: a fault of that sensor would explain it as well",
                100.0 * share
            ),
            ParameterFlag::Rival { name, held_out_rms } => write!(
                f,
                "{name} explains the held-out cycles alike (held-out RMS {held_out_rms:.3} σ): the log does not tell them apart"
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
    /// bound (other than a neutral limit, [`ParameterFlag::AtNeutralLimit`])
    /// or outside its plausible range, and at least one identified and
    /// off its neutral limit (an effect fitted as absent is not trusted:
    /// the verdict says "not confident").
    pub fn trusted(&self) -> bool {
        // Flags that say a parameter tells nothing, not that it misleads.
        let silent = |f: &ParameterFlag| {
            matches!(
                f,
                ParameterFlag::NotIdentified { .. } | ParameterFlag::AtNeutralLimit { .. }
            )
        };
        let uninformative = self.flags.iter().filter(|f| silent(f)).count();
        self.converged && self.flags.iter().all(silent) && uninformative < self.values.len()
    }
}

/// One round of the search.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Round {
    /// The model's effects and local terms at the start of the round.
    pub base: Hypothesis,
    /// Held-out RMS `z` of the model as it is.
    pub base_held_out_rms: f64,
    /// BIC of the model as it is on the fit cycles.
    pub base_bic: f64,
    /// The screen of every candidate the model lacked (local ones only
    /// where the second tier was screened), best first.
    pub screened: Vec<Screened>,
    /// Local candidates in the tier (the `M` of the penalty); 0 where the
    /// second tier was not screened.
    pub local_tier: usize,
    /// Candidates that passed the screen, fitted, best first.
    pub ranking: Vec<Candidate>,
}

/// A candidate screened at its neutral value (see the module notes).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Screened {
    /// The candidate.
    pub term: Term,
    /// Its name.
    pub name: String,
    /// `χ²` on the fit cycles that one Gauss–Newton step predicts the
    /// candidate removes (NaN where the model could not be run).
    pub predicted_gain: f64,
    /// The gain it needs to be fitted: `k·ln n + 2·ln M` (weights of
    /// [`DiagnoseSettings`]).
    pub threshold: f64,
}

impl Screened {
    /// Whether the candidate is worth fitting.
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
    /// These effects were found, in order (with their joint fit).
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
        /// Effects found before getting stuck (with their joint fit).
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
    /// The model's effects and the local terms found, at their joint fit.
    pub hypothesis: Hypothesis,
    /// Readings set aside as outliers before the search
    /// ([`super::outliers`]); the comparisons leave them out.
    pub outliers: Vec<Outlier>,
    /// The final comparison (model with the effects found) on all cycles.
    pub final_comparison: Comparison,
    /// Per-sensor and per-group tests of the final comparison.
    pub evidence: Evidence,
}

/// Whether the log's cycles are split at all: a log of fewer cycles than
/// [`DiagnoseSettings::held_out_period`] (a one-cycle log, by default) is
/// fitted and scored on every cycle.
fn is_split(cycles: usize, settings: &DiagnoseSettings) -> bool {
    cycles >= settings.held_out_period
}

/// Which cycles are held out: the last of every
/// [`DiagnoseSettings::held_out_period`] (the second, fourth, … by
/// default); none where the log is not split (see [`part`]). The whole log
/// is always replayed (friction makes every cycle depend on the ones
/// before); the split only decides which readings each score counts.
pub fn is_held_out(cycle: usize, cycles: usize, settings: &DiagnoseSettings) -> bool {
    let period = settings.held_out_period;
    is_split(cycles, settings) && cycle % period == period - 1
}

/// The readings of one part of the log: fitted (`held = false`) or held
/// out, as a comparison of its own; the whole log for either where it has
/// too few cycles to split.
pub fn part(c: &Comparison, cycles: usize, held: bool, settings: &DiagnoseSettings) -> Comparison {
    let keep = |cycle: usize| {
        if !is_split(cycles, settings) {
            true
        } else {
            is_held_out(cycle, cycles, settings) == held
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

/// The held-out readings' residual statistics of `model` replaying `log`
/// (`z` in noise SDs; every reading where the log is too short to split).
pub fn held_out_stats(
    model: &EffectModel,
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Result<super::compare::Stats, PlantError> {
    let c = super::compare::compare(model, log)?;
    Ok(part(&c, log.cycles.len(), true, settings).overall)
}

/// `best` and the candidates of `ranking` the log does not tell from it
/// ([`is_rival`]): the most plausible of them a priori (least outside the
/// plausible ranges of its parameters; [`implausibility`]) that the
/// criterion accepts as well, ties kept in `best`'s favour, flagged with
/// the others as its rivals. A load cell reading 3 % high was fitted as
/// well by its cable 26 % stiffer (outside the 0.8–1.2 plausible for a
/// rope) as by the cell's gain (1.048, inside 0.95–1.05): the log alone
/// cannot choose, what a cable and a cell plausibly do can.
fn alike_resolved(
    best: Candidate,
    ranking: &[Candidate],
    base_bic: f64,
    n: usize,
    tier: usize,
    settings: &DiagnoseSettings,
) -> Candidate {
    let alike: Vec<&Candidate> = ranking
        .iter()
        .filter(|c| c.term != best.term && is_rival(&best, c, n, tier, settings))
        .collect();
    let acceptable = |c: &&Candidate| {
        accepted(std::slice::from_ref(*c), true, base_bic, n, tier, settings).is_some()
    };
    let mut chosen = std::iter::once(&best)
        .chain(alike.iter().copied())
        .filter(acceptable)
        .min_by(|a, b| implausibility(a).total_cmp(&implausibility(b)))
        .unwrap_or(&best)
        .clone();
    let others: Vec<ParameterFlag> = std::iter::once(&best)
        .chain(alike)
        .filter(|c| c.term != chosen.term)
        .map(|c| ParameterFlag::Rival {
            name: c.name.clone(),
            held_out_rms: c.held_out_rms,
        })
        .collect();
    chosen.flags.extend(others);
    chosen
}

/// How far a candidate's values lie outside their plausible ranges, in
/// half-widths of each range (0 inside), the largest over its parameters.
fn implausibility(c: &Candidate) -> f64 {
    c.term
        .parameters()
        .iter()
        .zip(&c.values)
        .map(|(spec, &v)| {
            let (lo, hi) = spec.plausible;
            let half = 0.5 * (hi - lo);
            if !(half > 0.0) {
                return 0.0;
            }
            ((lo - v).max(v - hi) / half).max(0.0)
        })
        .fold(0.0, f64::max)
}

/// Whether `other` explains the held-out cycles as well as `best` to
/// within `best`'s penalty (its held-out χ² gain short of `best`'s by no
/// more than the penalty of `best`'s parameters on `n` readings in a tier
/// of `tier`): the information criterion cannot tell them apart. Rivals
/// are looked for among the local tier's fits only: a library effect
/// competes with the local tier as a whole (the diagnosis's rule), not
/// as an alternative name for a local cause.
fn is_rival(
    best: &Candidate,
    other: &Candidate,
    n: usize,
    tier: usize,
    settings: &DiagnoseSettings,
) -> bool {
    // Both gains are from the same held-out χ² of the model as it is.
    other.converged
        && best.held_out_gain - other.held_out_gain <= penalty(best.values.len(), n, tier, settings)
}

/// The sensor that gives most of the χ² gain from `before` to `after`
/// (comparisons of the same readings of a log of `sensors` sensors) and
/// its share of the gain summed
/// over the sensors that gain; `None` when none does.
fn largest_sensor_share(
    before: &Comparison,
    after: &Comparison,
    sensors: usize,
) -> Option<(usize, f64)> {
    let mut gain = vec![0.0; sensors];
    for r in &before.residuals {
        gain[r.sensor] += r.z * r.z;
    }
    for r in &after.residuals {
        gain[r.sensor] -= r.z * r.z;
    }
    let total: f64 = gain.iter().filter(|g| **g > 0.0).sum();
    let (sensor, largest) = gain
        .iter()
        .copied()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (total > 0.0 && largest > 0.0).then(|| (sensor, largest / total))
}

/// χ² and count of the comparison's `z`.
fn chi2(c: &Comparison) -> (f64, usize) {
    (
        c.residuals.iter().map(|r| r.z * r.z).sum(),
        c.residuals.len(),
    )
}

/// Whether a model with RMS `other_rms` (noise SDs) over `readings`
/// readings explains them as well as one with `best_rms`: the criterion
/// (χ² plus each model's parameter penalty) of the other exceeds the
/// best's by no more than the penalty of the best's own
/// `best_parameters`, the other having `other_parameters` in their
/// place (the rival rule of the diagnosis for two named alternatives, with no
/// look-elsewhere term: the alternative is not searched for among many).
pub fn explains_alike(
    readings: usize,
    best_rms: f64,
    other_rms: f64,
    best_parameters: usize,
    other_parameters: usize,
    settings: &DiagnoseSettings,
) -> bool {
    let criterion =
        |rms: f64, k: usize| readings as f64 * rms * rms + parameter_penalty(k, readings, settings);
    criterion(other_rms, other_parameters) - criterion(best_rms, best_parameters)
        <= parameter_penalty(best_parameters, readings, settings)
}

fn ln_count(n: usize) -> f64 {
    (n.max(1) as f64).ln()
}

/// The information criterion's penalty of `k` parameters on `n`
/// readings, without the look-elsewhere term.
fn parameter_penalty(k: usize, n: usize, settings: &DiagnoseSettings) -> f64 {
    k as f64 * settings.penalty_per_parameter * ln_count(n)
}

/// The penalty of `k` parameters among `tier` candidates on `n` readings.
fn penalty(k: usize, n: usize, tier: usize, settings: &DiagnoseSettings) -> f64 {
    parameter_penalty(k, n, settings) + settings.penalty_per_ln_candidates * ln_count(tier)
}

/// Replays (or, for a reading term, re-reads) the log with `term` at `x`
/// on top of `h`, whose comparison is `current`.
fn compare_with(
    model: &EffectModel,
    h: &Hypothesis,
    current: &Comparison,
    term: Term,
    x: &[f64],
    log: &MeasurementLog,
) -> Result<Comparison, PlantError> {
    match term {
        Term::Local(l) if l.on_readings() => {
            Ok(with_reading_terms(current, &[(l, x.to_vec())], log))
        }
        _ => compare_hypothesis(model, &h.with(term, x), log),
    }
}

/// Where a fit starts: the middle of the plausible range, but near the
/// neutral value where it lies inside (a small effect is the likelier
/// one), inside the search box.
fn fit_start(specs: &[ParameterSpec], bounds: &SearchBox, s: &DiagnoseSettings) -> Vec<f64> {
    let mut start: Vec<f64> = specs
        .iter()
        .map(|p| {
            if p.neutral >= p.plausible.0 && p.neutral <= p.plausible.1 {
                p.neutral + s.fit.start_offset * (p.plausible.1 - p.plausible.0)
            } else {
                0.5 * (p.plausible.0 + p.plausible.1)
            }
        })
        .collect();
    bounds.clamp(&mut start);
    start
}

fn squared_norm(z: &[f64]) -> f64 {
    z.iter().map(|v| v * v).sum()
}

fn fit_z(c: &Comparison, cycles: usize, settings: &DiagnoseSettings) -> Vec<f64> {
    part(c, cycles, false, settings)
        .residuals
        .iter()
        .map(|r| r.z)
        .collect()
}

/// The comparisons of the last few parameter vectors a fit replayed, by
/// exact value (a fit asks again for points it has run: its start, its
/// optimum).
#[derive(Default)]
struct RecentReplays {
    kept: std::sync::Mutex<std::collections::VecDeque<(Vec<f64>, std::sync::Arc<Comparison>)>>,
}

impl RecentReplays {
    /// Replays kept: a Levenberg–Marquardt iteration runs up to its damping
    /// tries after its last accepted point, each beside the Jacobian's
    /// replays about it where a core idles (`measure::fit`): for the
    /// library's largest term (3 parameters) and 8 tries, 32 replays, so
    /// the fit's optimum is still kept when the fit ends.
    const KEPT: usize = 40;

    fn get_or_run(
        &self,
        x: &[f64],
        run: impl FnOnce() -> Result<Comparison, PlantError>,
    ) -> Result<std::sync::Arc<Comparison>, PlantError> {
        let lock = || self.kept.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, c)) = lock().iter().find(|(y, _)| y.as_slice() == x) {
            return Ok(c.clone());
        }
        let c = std::sync::Arc::new(run()?);
        let mut kept = lock();
        if kept.len() == Self::KEPT {
            kept.pop_front();
        }
        kept.push_back((x.to_vec(), c.clone()));
        Ok(c)
    }
}

/// A round's model: its hypothesis and comparison.
struct Base<'a> {
    model: &'a EffectModel,
    log: &'a MeasurementLog,
    h: &'a Hypothesis,
    current: &'a Comparison,
    settings: &'a DiagnoseSettings,
}

impl Base<'_> {
    fn screen(&self, term: Term, tier: usize) -> Screened {
        let specs = term.parameters();
        let cycles = self.log.cycles.len();
        let s = self.settings;
        let base_z = fit_z(self.current, cycles, s);
        let neutral: Vec<f64> = specs.iter().map(|p| p.neutral).collect();
        let eval = |x: &[f64]| {
            compare_with(self.model, self.h, self.current, term, x, self.log)
                .ok()
                .map(|c| fit_z(&c, cycles, s))
        };
        let bounds = SearchBox::of(specs, &s.fit);
        // At its neutral value a candidate the model lacks is absent: the
        // replay there is the model's own, `base_z`. (One the model has,
        // which `screen_candidate` may be asked for, is replayed there.)
        let at_neutral = if self.h.parameters(term).is_none() {
            Some(base_z.clone())
        } else {
            eval(&neutral)
        };
        let linear = at_neutral.and_then(|r0| predicted_gain(&eval, &neutral, r0, &bounds, &s.fit));
        // Where a neutral value is also the end of its admissible range
        // (μ = 0, a backlash of 0), the linearisation there is one-sided,
        // and for the hysteretic effects it is no guide: on a lab log of
        // the default truth (μ 0.2, 3 mm backlash) it predicted friction
        // a gain of 0, while friction alone removes half the held-out
        // residual. The χ² the fit's own start already removes is a gain
        // the fit can only better (it minimises that χ²), so it counts too.
        // Only where the linear screen alone would not pass: the start's
        // replay costs as much as the screen.
        let threshold = penalty(specs.len(), base_z.len(), tier, s);
        let one_sided = specs
            .iter()
            .any(ParameterSpec::neutral_ends_admissible_range);
        let needed = linear.is_none_or(|g| !(g > threshold));
        let at_start = (one_sided && needed)
            .then(|| eval(&fit_start(specs, &bounds, s)))
            .flatten()
            .filter(|z| z.len() == base_z.len())
            .map(|z| squared_norm(&base_z) - squared_norm(&z));
        let gain = match (linear, at_start) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        Screened {
            term,
            name: term.label(&self.model.structure, &self.log.sensors),
            predicted_gain: gain.unwrap_or(f64::NAN),
            threshold,
        }
    }

    fn fit(&self, term: Term, tier: usize) -> Result<Candidate, PlantError> {
        self.fit_with_replay(term, tier).map(|(c, _)| c)
    }

    /// [`Self::fit`], with the replay of the log at the fitted values:
    /// the next round's model if the candidate is taken.
    fn fit_with_replay(
        &self,
        term: Term,
        tier: usize,
    ) -> Result<(Candidate, std::sync::Arc<Comparison>), PlantError> {
        let specs = term.parameters();
        let cycles = self.log.cycles.len();
        let s = self.settings;
        let bounds = SearchBox::of(specs, &s.fit);
        // The optimum was one of the fit's last points, replayed again
        // below: each a replay of the whole log (a quarter of a second
        // with friction), so the latest ones are kept.
        let recent = RecentReplays::default();
        let replay = |x: &[f64]| {
            recent.get_or_run(x, || {
                compare_with(self.model, self.h, self.current, term, x, self.log)
            })
        };
        let eval = |x: &[f64]| replay(x).ok().map(|c| fit_z(&c, cycles, s));
        let start = fit_start(specs, &bounds, s);
        // Where the start does not run, the fit keeps it, and its replay
        // below gives the error.
        let fit = levenberg_marquardt(&eval, &start, &bounds, &s.fit).unwrap_or(Fit {
            std_errors: vec![f64::NAN; start.len()],
            values: start,
            condition: f64::INFINITY,
            converged: false,
        });
        let all = replay(&fit.values)?;
        let fitted = part(&all, cycles, false, s);
        let held = part(&all, cycles, true, s);
        let base_held = part(self.current, cycles, true, s);
        let k = specs.len();
        let own = penalty(k, fitted.overall.count, tier, s);
        let mut flags = parameter_flags(term, &bounds, &fit.values, &fit.std_errors, s);
        // A term of the readings of one sensor explains that sensor by
        // design; so does the common load-cell bias where one cell reads.
        let load_cells = self
            .log
            .sensors
            .iter()
            .filter(|s| {
                matches!(
                    s.target,
                    SensorTarget::SegmentTension { .. } | SensorTarget::MemberForce { .. }
                )
            })
            .count();
        let reading_term = match term {
            Term::Local(l) => l.on_readings(),
            Term::Global(k) => k == EffectKind::LoadCellBias && load_cells <= 1,
        };
        if let Some((sensor, share)) =
            largest_sensor_share(&base_held, &held, self.log.sensors.len())
        {
            if !reading_term && share >= s.one_sensor_share {
                flags.push(ParameterFlag::CarriedByOneSensor {
                    sensor: self.log.sensors[sensor].id.clone(),
                    share,
                });
            }
        }
        let candidate = Candidate {
            term,
            name: term.label(&self.model.structure, &self.log.sensors),
            flags,
            values: fit.values,
            std_errors: fit.std_errors,
            condition: fit.condition,
            held_out_rms: held.overall.rms,
            held_out_gain: chi2(&base_held).0 - chi2(&held).0,
            bic: chi2(&fitted).0
                + parameter_penalty(self.h.parameter_count(), fitted.overall.count, s)
                + own,
            penalty: own,
            explained: explained_share(base_held.overall.rms, held.overall.rms),
            converged: fit.converged,
            leaves_clean: is_clean(&all, self.log, s),
        };
        Ok((candidate, all))
    }
}

/// Screens effect `kind` on top of the model's effects `base`: the `χ²` on
/// the fit cycles that one Gauss–Newton step from the neutral parameters
/// predicts it removes, with the step kept admissible. The penalty counts
/// the library's effects as the tier. `settings` are taken as valid
/// ([`DiagnoseSettings::validate`]).
pub fn screen_candidate(
    model: &EffectModel,
    base: Effects,
    kind: EffectKind,
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Result<Screened, PlantError> {
    let h = Hypothesis::of(base);
    let current = compare_hypothesis(model, &h, log)?;
    let b = Base {
        model,
        log,
        h: &h,
        current: &current,
        settings,
    };
    Ok(b.screen(Term::Global(kind), EffectKind::ALL.len()))
}

/// Fits effect `kind` on top of the model's effects `base` to the fitted
/// cycles of `log`, then scores it on the held-out ones (the penalty
/// counts the library's effects as the tier). `settings` are taken as
/// valid ([`DiagnoseSettings::validate`]).
pub fn fit_candidate(
    model: &EffectModel,
    base: Effects,
    kind: EffectKind,
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Result<Candidate, PlantError> {
    let h = Hypothesis::of(base);
    let current = compare_hypothesis(model, &h, log)?;
    let b = Base {
        model,
        log,
        h: &h,
        current: &current,
        settings,
    };
    b.fit(Term::Global(kind), EffectKind::ALL.len())
}

/// The warnings on the fitted parameters `x` of `term`.
fn parameter_flags(
    term: Term,
    bounds: &SearchBox,
    x: &[f64],
    std_errors: &[f64],
    settings: &DiagnoseSettings,
) -> Vec<ParameterFlag> {
    let mut flags = Vec::new();
    let prefix = match term {
        Term::Global(k) => k.name(),
        Term::Local(_) => "",
    };
    for (i, spec) in term.parameters().iter().enumerate() {
        let parameter = if prefix.is_empty() {
            spec.name.to_string()
        } else {
            format!("{prefix}.{}", spec.name)
        };
        let se = std_errors[i];
        // A parameter the log cannot pin down to within its plausible
        // range says nothing by its value, at a bound or not.
        if !(se.is_finite() && se <= settings.max_identified_std_error * bounds.scale[i]) {
            flags.push(ParameterFlag::NotIdentified { parameter });
            continue;
        }
        let near = settings.near_bound * (bounds.upper[i] - bounds.lower[i]);
        let (lo, hi) = (bounds.lower[i], bounds.upper[i]);
        if x[i] - lo <= near || hi - x[i] <= near {
            let bound = if x[i] - lo <= hi - x[i] { lo } else { hi };
            flags.push(
                if spec.neutral_ends_admissible_range() && bound == spec.neutral {
                    ParameterFlag::AtNeutralLimit {
                        parameter: parameter.clone(),
                        value: x[i],
                    }
                } else {
                    ParameterFlag::AtSearchBound {
                        parameter: parameter.clone(),
                        value: x[i],
                        bound,
                    }
                },
            );
        }
        // Outside by more than a few standard errors: the data, not the
        // sampling, put it there.
        let outside = (spec.plausible.0 - x[i]).max(x[i] - spec.plausible.1);
        if outside > settings.outside_plausible_std_errors * se {
            flags.push(ParameterFlag::OutsidePlausible {
                parameter,
                value: x[i],
                plausible: spec.plausible,
            });
        }
    }
    flags
}

/// Share of the mean square `z` above noise (`rms² − 1`: pure noise has
/// RMS 1 by the definition of `z`, so the 1 is no setting) at `before`
/// that is gone at `after`, 0–1.
fn explained_share(before: f64, after: f64) -> f64 {
    let excess = |rms: f64| (rms * rms - 1.0).max(0.0);
    if excess(before) > 0.0 {
        ((excess(before) - excess(after)) / excess(before)).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Whether `c` is clean: held-out RMS within the noise limit and no
/// per-sensor test significant.
fn is_clean(c: &Comparison, log: &MeasurementLog, settings: &DiagnoseSettings) -> bool {
    let held = part(c, log.cycles.len(), true, settings);
    held.overall.rms <= noise_rms_limit(held.overall.count, &settings.noise)
        && !evidence(c, &log.sensors, &settings.noise).any_significant()
}

/// The best of `ranking` (held-out RMS order) among `tier`, if it is
/// accepted: it improves the criterion on the fit cycles and lowers the
/// held-out `χ²` by more than its penalty there.
fn accepted(
    ranking: &[Candidate],
    local: bool,
    base_bic: f64,
    held_count: usize,
    tier: usize,
    settings: &DiagnoseSettings,
) -> Option<Candidate> {
    ranking
        .iter()
        .find(|c| matches!(c.term, Term::Local(_)) == local)
        .filter(|b| {
            b.bic < base_bic
                && b.held_out_gain > penalty(b.values.len(), held_count, tier, settings)
        })
        .cloned()
}

/// Runs the greedy search, then the joint refit.
pub fn diagnose(
    model: &EffectModel,
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Result<Diagnosis, DiagnoseError> {
    settings.validate()?;
    log.check_comparable()?;
    let cycles = log.cycles.len();
    let mut h = Hypothesis::of(model.effects.clone());
    // Outliers of the model as it is are set aside (as missing readings)
    // before anything is fitted to them.
    let raw = compare_hypothesis(model, &h, log)?;
    let outliers = find_outliers(&raw, log.sensors.len(), &settings.outliers);
    let cleaned;
    let log = if outliers.is_empty() {
        log
    } else {
        cleaned = without_outliers(log, &outliers);
        cleaned.check_comparable()?;
        &cleaned
    };
    let mut found: Vec<Candidate> = Vec::new();
    let mut rounds = Vec::new();
    let locals = local_candidates(&model.structure, &log.sensors);
    let groups = member_groups(&model.structure);
    // The model with the candidates found so far, compared once per change.
    let mut current = drop_outliers(&raw, &outliers, log.sensors.len());
    let first_held = part(&current, cycles, true, settings);
    let first_clean = is_clean(&current, log, settings);
    while rounds.len() < settings.max_rounds {
        let held = part(&current, cycles, true, settings);
        let base_fit = part(&current, cycles, false, settings);
        let base_bic = chi2(&base_fit).0
            + parameter_penalty(h.parameter_count(), base_fit.overall.count, settings);
        let base = Base {
            model,
            log,
            h: &h,
            current: &current,
            settings,
        };
        let global_tier = EffectKind::ALL.len();
        let missing: Vec<Term> = EffectKind::ALL
            .into_iter()
            .map(Term::Global)
            .filter(|t| h.parameters(*t).is_none())
            .collect();
        let mut screened: Vec<Screened> = missing
            .par_iter()
            .map(|&t| base.screen(t, global_tier))
            .collect();
        // Each fit's replay at its optimum is kept: the taken one is the
        // next round's model, replayed once instead of twice.
        let mut replays: Vec<(Term, Vec<f64>, Arc<Comparison>)> = Vec::new();
        let mut ranking: Vec<Candidate> = screened
            .par_iter()
            .filter(|s| s.passed())
            .filter_map(|s| base.fit_with_replay(s.term, global_tier).ok())
            .collect::<Vec<_>>()
            .into_iter()
            .map(|(c, all)| {
                replays.push((c.term, c.values.clone(), all));
                c
            })
            .collect();
        ranking.sort_by(|a, b| a.held_out_rms.total_cmp(&b.held_out_rms));
        let mut best = accepted(
            &ranking,
            false,
            base_bic,
            held.overall.count,
            global_tier,
            settings,
        );
        let mut local_tier = 0;
        // A library effect that removes most of the excess is taken as it
        // is; one that removes less competes with the local tier.
        let strong = best
            .as_ref()
            .is_some_and(|b| b.explained >= settings.explained_share);
        if settings.local_tier_enable && !strong && !is_clean(&current, log, settings) {
            local_tier = locals.len();
            let open: Vec<Term> = locals
                .iter()
                .filter(|l| {
                    !matches!(
                        l,
                        LocalKind::MemberStiffness { .. } | LocalKind::MemberLength { .. }
                    )
                })
                .map(|&l| Term::Local(l))
                .filter(|t| h.parameters(*t).is_none())
                .collect();
            let mut local_screen: Vec<Screened> = open
                .par_iter()
                .map(|&t| base.screen(t, local_tier))
                .collect();
            // The single members of the groups that predicted most.
            let mut by_group: Vec<&Screened> = local_screen
                .iter()
                .filter(|s| matches!(s.term, Term::Local(LocalKind::MemberGroupStiffness { .. })))
                .collect();
            by_group.sort_by(|a, b| b.predicted_gain.total_cmp(&a.predicted_gain));
            // And the members along a continuous cable whose own terms
            // passed: a member cut long on a cable's path shifts that
            // cable's prestress as its drum's offset does, and only a fit
            // of both tells which the log favours.
            let structure = &model.structure;
            let along_cables: Vec<usize> = local_screen
                .iter()
                .filter(|s| s.passed())
                .filter_map(|s| match s.term {
                    Term::Local(
                        LocalKind::DrumOffset { cable } | LocalKind::CableStiffness { cable },
                    ) => structure.continuous_cables.get(cable),
                    _ => None,
                })
                .flat_map(|c| {
                    structure
                        .members
                        .iter()
                        .enumerate()
                        .filter(|(_, m)| m.nodes.iter().any(|n| c.path.contains(n)))
                        .map(|(i, _)| i)
                })
                .collect();
            let mut opened: Vec<usize> = by_group
                .iter()
                .take(settings.member_groups_opened)
                .filter_map(|s| match s.term {
                    Term::Local(LocalKind::MemberGroupStiffness { group }) => groups.get(group),
                    _ => None,
                })
                .flat_map(|g| g.members.iter().copied())
                .chain(along_cables)
                .collect();
            opened.sort_unstable();
            opened.dedup();
            let members: Vec<Term> = opened
                .iter()
                .flat_map(|&member| {
                    [
                        Term::Local(LocalKind::MemberStiffness { member }),
                        Term::Local(LocalKind::MemberLength { member }),
                    ]
                })
                .filter(|t| h.parameters(*t).is_none())
                .collect();
            local_screen.extend(
                members
                    .par_iter()
                    .map(|&t| base.screen(t, local_tier))
                    .collect::<Vec<_>>(),
            );
            let mut passed: Vec<&Screened> = local_screen.iter().filter(|s| s.passed()).collect();
            passed.sort_by(|a, b| b.predicted_gain.total_cmp(&a.predicted_gain));
            let mut local_ranking: Vec<Candidate> = passed
                .par_iter()
                .take(settings.max_local_fits)
                .filter_map(|s| base.fit_with_replay(s.term, local_tier).ok())
                .collect::<Vec<_>>()
                .into_iter()
                .map(|(c, all)| {
                    replays.push((c.term, c.values.clone(), all));
                    c
                })
                .collect();
            local_ranking.sort_by(|a, b| a.held_out_rms.total_cmp(&b.held_out_rms));
            let best_local = accepted(
                &local_ranking,
                true,
                base_bic,
                held.overall.count,
                local_tier,
                settings,
            );
            // The one that leaves the model clean wins; else the larger
            // held-out gain beyond its own penalty. The tiers compete on
            // the local tier's best fit; which of the local causes the
            // log cannot tell apart is named is decided after.
            let margin = |c: &Candidate, tier: usize| {
                c.held_out_gain - penalty(c.values.len(), held.overall.count, tier, settings)
            };
            best = match (best, best_local) {
                (Some(g), Some(l))
                    if (g.leaves_clean, margin(&g, global_tier))
                        >= (l.leaves_clean, margin(&l, local_tier)) =>
                {
                    Some(g)
                }
                (g, None) => g,
                (_, Some(l)) => Some(alike_resolved(
                    l,
                    &local_ranking,
                    base_bic,
                    held.overall.count,
                    local_tier,
                    settings,
                )),
            };
            screened.extend(local_screen);
            ranking.extend(local_ranking);
            ranking.sort_by(|a, b| a.held_out_rms.total_cmp(&b.held_out_rms));
        }
        screened.sort_by(|a, b| b.predicted_gain.total_cmp(&a.predicted_gain));
        rounds.push(Round {
            base: h.clone(),
            base_held_out_rms: held.overall.rms,
            base_bic,
            screened,
            local_tier,
            ranking,
        });
        let Some(b) = best else { break };
        h = h.with(b.term, &b.values);
        // The fit's replay at these values is the model's with them (the
        // same replay); a term on the readings is re-read from scratch.
        let fitted_replay = replays
            .iter()
            .find(|(t, v, _)| *t == b.term && *v == b.values);
        current = match fitted_replay {
            Some((Term::Global(_), _, c)) => (**c).clone(),
            Some((Term::Local(l), _, c)) if !l.on_readings() => (**c).clone(),
            _ => compare_hypothesis(model, &h, log)?,
        };
        found.push(b);
    }
    if !found.is_empty() {
        if let Some((joint_h, joint)) = joint_refit(model, &h, &mut found, log, settings) {
            h = joint_h;
            current = joint;
        }
    }
    let held = part(&current, cycles, true, settings);
    let noise_like = held.overall.rms <= noise_rms_limit(held.overall.count, &settings.noise);
    let evidence = evidence(&current, &log.sensors, &settings.noise);
    let clean = noise_like && !evidence.any_significant();
    let explained = explained_share(first_held.overall.rms, held.overall.rms);
    let verdict = if found.is_empty() && clean {
        Verdict::NothingMissing
    } else if !found.is_empty()
        && clean
        && held.overall.rms <= settings.explained_rms
        && (explained >= settings.explained_share || !first_clean)
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
        hypothesis: h,
        outliers,
        final_comparison: current,
        evidence,
    })
}

/// Terms `terms` of `h` fitted together on the fit cycles of `log`, from
/// `x0` (their values in order, concatenated): the fit, its hypothesis and
/// comparison, and each term's search box. `None` where the fit could not
/// be run or did not lower the fit cycles' `χ²`.
fn fit_jointly(
    model: &EffectModel,
    h: &Hypothesis,
    terms: &[Term],
    x0: &[f64],
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Option<(Fit, Hypothesis, Comparison, Vec<SearchBox>)> {
    let cycles = log.cycles.len();
    let sizes: Vec<usize> = terms.iter().map(|t| t.parameters().len()).collect();
    let boxes: Vec<SearchBox> = terms
        .iter()
        .map(|t| SearchBox::of(t.parameters(), &settings.fit))
        .collect();
    let bounds = SearchBox::concat(&boxes);
    let with = |x: &[f64]| {
        let mut out = h.clone();
        let mut at = 0;
        for (t, k) in terms.iter().zip(&sizes) {
            out = out.with(*t, &x[at..at + k]);
            at += k;
        }
        out
    };
    let eval = |x: &[f64]| {
        compare_hypothesis(model, &with(x), log)
            .ok()
            .map(|c| fit_z(&c, cycles, settings))
    };
    let mut start = x0.to_vec();
    bounds.clamp(&mut start);
    let before: f64 = eval(&start)?.iter().map(|v| v * v).sum();
    let fit = levenberg_marquardt(&eval, &start, &bounds, &settings.fit)?;
    let after: f64 = eval(&fit.values)?.iter().map(|v| v * v).sum();
    if after > before {
        return None;
    }
    let joint_h = with(&fit.values);
    let joint = compare_hypothesis(model, &joint_h, log).ok()?;
    Some((fit, joint_h, joint, boxes))
}

/// Fits every candidate of `found` together on the fit cycles, from their
/// values in `h`; on success, sets their values, standard errors,
/// condition numbers and parameter flags to the joint fit's (the
/// candidate's own flags, [`ParameterFlag::CarriedByOneSensor`] and
/// [`ParameterFlag::Rival`], stay)
/// and returns the joint
/// hypothesis and its comparison. `None` (the search's values kept) when
/// only one was found, or the joint fit could not be run or did not
/// lower the fit cycles' `χ²`.
fn joint_refit(
    model: &EffectModel,
    h: &Hypothesis,
    found: &mut [Candidate],
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Option<(Hypothesis, Comparison)> {
    if found.len() < 2 {
        return None;
    }
    let terms: Vec<Term> = found.iter().map(|c| c.term).collect();
    let x0: Vec<f64> = found.iter().flat_map(|c| c.values.clone()).collect();
    let (fit, joint_h, joint, boxes) = fit_jointly(model, h, &terms, &x0, log, settings)?;
    let mut at = 0;
    for (c, b) in found.iter_mut().zip(&boxes) {
        let k = c.values.len();
        c.values = fit.values[at..at + k].to_vec();
        c.std_errors = fit.std_errors[at..at + k].to_vec();
        c.condition = fit.condition;
        // Where its own fit's evidence came from is no parameter's, and
        // the joint fit does not separate it: kept.
        let carried: Vec<ParameterFlag> = c
            .flags
            .drain(..)
            .filter(|f| {
                matches!(
                    f,
                    ParameterFlag::CarriedByOneSensor { .. } | ParameterFlag::Rival { .. }
                )
            })
            .collect();
        c.flags = parameter_flags(c.term, b, &c.values, &c.std_errors, settings);
        c.flags.extend(carried);
        at += k;
    }
    Some((joint_h, joint))
}

/// The library effects `kinds` of `model` fitted again together on the fit
/// cycles of `log`, from the values `model` has for them (a warm start:
/// the effects a model learnt on earlier cycles, refitted as a new cycle
/// comes in).
#[derive(Debug, Clone, PartialEq)]
pub struct Refit {
    /// `model`'s effects with the refitted values.
    pub effects: Effects,
    /// Standard errors of each kind's parameters, in `kinds` order (NaN
    /// where the log cannot pin one down).
    pub std_errors: Vec<Vec<f64>>,
    /// Held-out RMS `z` with the refitted values.
    pub held_out_rms: f64,
    /// Whether the fit converged.
    pub converged: bool,
}

/// Refits the library effects `kinds` of `model` together ([`Refit`]);
/// `Ok(None)` where the fit could not be run or did not lower the fit
/// cycles' `χ²` (the values `model` has are then the better ones).
/// `settings` are taken as valid ([`DiagnoseSettings::validate`]).
///
/// # Panics
/// If `model` lacks one of `kinds`: a programming error.
pub fn refit_effects(
    model: &EffectModel,
    kinds: &[EffectKind],
    log: &MeasurementLog,
    settings: &DiagnoseSettings,
) -> Result<Option<Refit>, DiagnoseError> {
    log.check_comparable()?;
    if kinds.is_empty() {
        return Ok(None);
    }
    let h = Hypothesis::of(model.effects.clone());
    let terms: Vec<Term> = kinds.iter().map(|&k| Term::Global(k)).collect();
    let x0: Vec<f64> = kinds
        .iter()
        .flat_map(|&k| {
            model
                .effects
                .parameters(k)
                .unwrap_or_else(|| panic!("refit of {}, which the model lacks", k.name()))
        })
        .collect();
    let Some((fit, joint_h, joint, _)) = fit_jointly(model, &h, &terms, &x0, log, settings) else {
        return Ok(None);
    };
    let mut at = 0;
    let std_errors = kinds
        .iter()
        .map(|k| {
            let n = k.parameters().len();
            at += n;
            fit.std_errors[at - n..at].to_vec()
        })
        .collect();
    Ok(Some(Refit {
        effects: joint_h.effects,
        std_errors,
        held_out_rms: part(&joint, log.cycles.len(), true, settings).overall.rms,
        converged: fit.converged,
    }))
}

/// The model's effects after a diagnosis: `base` plus every library
/// effect found (local terms are not effects of the model file; see
/// [`Diagnosis::hypothesis`]).
pub fn effects_found(base: Effects, verdict: &Verdict) -> Effects {
    let found = match verdict {
        Verdict::NothingMissing => return base,
        Verdict::Missing { found, .. } => found,
        Verdict::Unexplained { found, .. } => found,
    };
    found.iter().fold(base, |e, c| match c.term {
        Term::Global(k) => e.with_parameters(k, &c.values),
        Term::Local(_) => e,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fitted(term: Term, name: &str, values: Vec<f64>, gain: f64) -> Candidate {
        Candidate {
            term,
            name: name.into(),
            std_errors: vec![0.01; values.len()],
            values,
            condition: 1.0,
            held_out_rms: 1.0,
            held_out_gain: gain,
            bic: 0.0,
            penalty: 0.0,
            explained: 0.5,
            converged: true,
            leaves_clean: true,
            flags: Vec::new(),
        }
    }

    /// Of local causes the log cannot tell apart (held-out gains within
    /// the best's penalty), the one inside its plausible range is named and
    /// the others are its rivals; one the criterion separates is none.
    #[test]
    fn causes_the_log_cannot_tell_apart_name_the_plausible_one_and_its_rivals() {
        let settings = DiagnoseSettings::default();
        let (n, tier) = (700, 330);
        let resolution = penalty(1, n, tier, &settings);
        let cable = fitted(
            Term::Local(LocalKind::CableStiffness { cable: 2 }),
            "cable_stiffness(A_cc2)",
            vec![1.26],
            100.0,
        );
        let gain = fitted(
            Term::Local(LocalKind::LoadCellGain { sensor: 2 }),
            "load_cell_gain(load_A_cc2)",
            vec![1.048, -4.0],
            100.0 - 0.5 * resolution,
        );
        let far = fitted(
            Term::Local(LocalKind::MemberLength { member: 7 }),
            "member_length(A_s7)",
            vec![0.001],
            100.0 - 2.0 * resolution,
        );
        assert!(implausibility(&cable) > 0.0);
        assert_eq!(implausibility(&gain), 0.0);
        assert_eq!(implausibility(&far), 0.0);
        assert!(is_rival(&cable, &gain, n, tier, &settings));
        assert!(!is_rival(&cable, &far, n, tier, &settings));
        let ranking = vec![cable.clone(), gain.clone(), far.clone()];
        let chosen = alike_resolved(cable.clone(), &ranking, f64::INFINITY, n, tier, &settings);
        assert_eq!(chosen.term, gain.term);
        assert_eq!(
            chosen.flags,
            vec![ParameterFlag::Rival {
                name: "cable_stiffness(A_cc2)".into(),
                held_out_rms: 1.0
            }]
        );
        assert!(!chosen.trusted());
        // Alone, the best keeps its name and its trust.
        let alone = alike_resolved(
            cable.clone(),
            &[cable.clone(), far],
            f64::INFINITY,
            n,
            tier,
            &settings,
        );
        assert_eq!(alone, cable);
    }

    /// The screen takes the model's own residuals for a candidate at its
    /// neutral value (`predicted_gain`'s `r0`) instead of replaying the
    /// log there. That is exact only if the replay at the neutral value is
    /// the model's own, bit for bit: checked for every library effect the
    /// model lacks and every local term, on a model that already has
    /// friction (a second round's base) and a log of friction and
    /// backlash.
    #[test]
    fn a_candidate_at_its_neutral_value_replays_the_models_own_residuals() {
        use crate::design::{reference_bridge, BridgeParameters};
        use crate::measure::lab::{run_lab, standard_cycles, DAILY_SWING_K};
        use crate::sim::standard_sensors;
        let structure = reference_bridge(&BridgeParameters::default()).unwrap();
        let model = |effects: Effects| EffectModel::for_measurement(structure.clone(), effects);
        let truth = model(
            Effects::default()
                .with_parameters(EffectKind::JointFriction, &[0.15])
                .with_parameters(EffectKind::Motor, &[0.0, 0.002]),
        );
        let sensors = standard_sensors(&structure);
        let cycles = standard_cycles(structure.continuous_cables.len(), &[0.02], 2, DAILY_SWING_K);
        let log = run_lab(&truth, &sensors, &cycles, 5).unwrap();
        let base = model(Effects::default().with_parameters(EffectKind::JointFriction, &[0.1]));
        let h = Hypothesis::of(base.effects.clone());
        let current = compare_hypothesis(&base, &h, &log).unwrap();
        let z = |c: &Comparison| c.residuals.iter().map(|r| r.z).collect::<Vec<f64>>();
        let terms: Vec<Term> = EffectKind::ALL
            .into_iter()
            .map(Term::Global)
            .filter(|t| h.parameters(*t).is_none())
            .chain(
                local_candidates(&structure, &log.sensors)
                    .into_iter()
                    .map(Term::Local),
            )
            .collect();
        assert!(terms.len() > EffectKind::ALL.len());
        for term in terms {
            let neutral: Vec<f64> = term.parameters().iter().map(|p| p.neutral).collect();
            let at_neutral = compare_with(&base, &h, &current, term, &neutral, &log).unwrap();
            assert_eq!(z(&at_neutral), z(&current), "{term:?}");
        }
    }

    #[test]
    fn every_search_range_holds_the_neutral_value() {
        // Thermal expansion's plausible range (1.0e-5 to 1.4e-5 /K) does
        // not reach 0: without the rule every thermal fit sat on a bound.
        let settings = DiagnoseSettings::default();
        for kind in EffectKind::ALL {
            let b = SearchBox::of(kind.parameters(), &settings.fit);
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

    /// A converged fit of `term` that explains everything and leaves the
    /// model clean, with `flags`: what `Candidate::trusted` is tested on.
    fn clean_fit(
        term: Term,
        values: Vec<f64>,
        std_errors: Vec<f64>,
        flags: Vec<ParameterFlag>,
    ) -> Candidate {
        let Term::Global(kind) = term else {
            panic!("a library effect")
        };
        Candidate {
            term,
            name: kind.name().into(),
            penalty: 0.0,
            values,
            std_errors,
            condition: 1.0,
            held_out_rms: 1.0,
            held_out_gain: 10.0,
            bic: 0.0,
            explained: 1.0,
            converged: true,
            leaves_clean: true,
            flags,
        }
    }

    /// Issue 24: a drum that slips without backlash was diagnosed "motor
    /// missing", but "not confident" only because the fitted backlash sat
    /// at its search bound 0, its true value. 0 is the end of backlash's
    /// admissible range and its neutral value: the physics stops the fit
    /// there. Reported, and the fit trusted; a slip fraction at a search
    /// bound is still distrusted.
    #[test]
    fn a_backlash_of_zero_at_its_bound_does_not_make_the_motor_fit_untrusted() {
        let kind = EffectKind::Motor;
        let term = Term::Global(kind);
        let s = DiagnoseSettings::default();
        let b = SearchBox::of(kind.parameters(), &s.fit);
        let ses = [1.6e-3, 2.6e-5];
        let flags = parameter_flags(term, &b, &[0.03, 0.0], &ses, &s);
        assert!(
            matches!(flags[..], [ParameterFlag::AtNeutralLimit { .. }]),
            "{flags:?}"
        );
        let candidate = clean_fit(term, vec![0.03, 0.0], ses.to_vec(), flags);
        assert!(candidate.trusted());
        // Its every part at the neutral limit: the effect fitted as absent.
        let absent = Candidate {
            values: vec![0.0, 0.0],
            flags: vec![
                ParameterFlag::NotIdentified {
                    parameter: "motor.slip_fraction".into(),
                },
                ParameterFlag::AtNeutralLimit {
                    parameter: "motor.backlash_m".into(),
                    value: 0.0,
                },
            ],
            ..candidate.clone()
        };
        assert!(!absent.trusted());
        let at_slip_bound = parameter_flags(term, &b, &[b.upper[0], 0.002], &ses, &s);
        assert!(
            at_slip_bound
                .iter()
                .any(|f| matches!(f, ParameterFlag::AtSearchBound { .. })),
            "{at_slip_bound:?}"
        );
    }

    #[test]
    fn fits_at_a_bound_or_implausible_are_flagged_and_not_trusted() {
        let kind = EffectKind::Thermal;
        let term = Term::Global(kind);
        let s = DiagnoseSettings::default();
        let b = SearchBox::of(kind.parameters(), &s.fit);
        let p = kind.parameters()[0];
        let se = 1e-7;
        // At the lower bound (the neutral 0).
        let flags = parameter_flags(term, &b, &[b.lower[0]], &[se], &s);
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
        assert!(parameter_flags(term, &b, &[mid], &[se], &s).is_empty());
        // Just outside, by less than two standard errors: sampling, no flag.
        let near = p.plausible.1 + 1.5 * se;
        assert!(parameter_flags(term, &b, &[near], &[se], &s).is_empty());
        // A standard error wider than the plausible range: not identified,
        // and nothing else said about its value.
        let wide = parameter_flags(term, &b, &[b.lower[0]], &[1.0], &s);
        assert!(matches!(wide[..], [ParameterFlag::NotIdentified { .. }]));
        let candidate = |flags: Vec<ParameterFlag>| clean_fit(term, vec![mid], vec![se], flags);
        assert!(candidate(vec![]).trusted());
        assert!(!candidate(flags).trusted());
        // Thermal's lower search bound is its neutral 0 but no end of its
        // admissible range: a search bound still.
        assert!(matches!(
            parameter_flags(term, &b, &[b.lower[0]], &[se], &s)[0],
            ParameterFlag::AtSearchBound { .. }
        ));
        // Its only parameter unidentified: nothing to trust.
        assert!(!candidate(wide).trusted());
    }
}
