//! Settings of the model-against-measurement tools: every number that tunes
//! what `compare` calls noise and what `diagnose` finds, each with its
//! meaning, default, unit, the effect of changing it and why the default,
//! and the range it must lie in (declared beside it with [`NumberRange`],
//! checked by [`DiagnoseSettings::validate`], errors naming the field).
//!
//! [`DiagnoseSettings`] holds the search's own choices and three parts
//! that other functions take alone: [`FitSettings`] (the least squares of
//! [`super::fit`]), [`NoiseSettings`] (when residuals are sensor noise:
//! [`super::compare::noise_rms_limit`], [`super::evidence`]) and
//! [`OutlierSettings`] ([`super::outliers`]). `compare` uses the defaults
//! of the last two, so that it and `diagnose` call the same residuals
//! noise.
//!
//! Numbers that define a quantity rather than tune a decision stay named
//! constants where they are used, each saying why: the MAD's 1.4826, the
//! residual features, the noise RMS of 1 that `z` is measured against,
//! the local candidates' parameter ranges (what each candidate is, as the
//! effects' ranges are in `model::effects`), and the least squares'
//! floors against dividing by zero.

use serde::{Deserialize, Serialize};

use crate::numerics::{check_ranges, FieldError, NumberRange, Ranged};

/// Settings of the diagnosis (`tdeploy diagnose`; see
/// [`super::diagnose`] for the search they tune). Defaults are what the
/// hidden-effect and local-fault tests were validated with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DiagnoseSettings {
    /// Greedy rounds: effects (library or local) found at most, one per
    /// round; the search stops earlier when a round accepts nothing. A
    /// model that already passes the noise tests is searched again: the
    /// noise limit leaves up to about 4·√(2n) of held-out χ² unexplained
    /// (about 150 on the lab's logs), while a candidate is accepted for a
    /// gain above its penalty (about 11), so a second effect can hide
    /// under "clean" (friction with a 5 % joint-mass error, test
    /// `a_second_effect_under_the_noise_limit_is_still_found`).
    /// Default 2: a second effect that the first one's signal hid can be
    /// found (the joint refit then separates the two). Each round screens
    /// every candidate and fits those that pass (minutes on the reference
    /// bridge), so more rounds cost time where several effects are
    /// missing. The CLI's `--rounds` sets it (1 to the number of library
    /// effects).
    pub max_rounds: usize,
    /// Cycles per period of the split between fitted and held-out cycles:
    /// the last cycle of every period is held out, the others fitted.
    /// Default 2: fitted and held-out cycles alternate (the first, third,
    /// … fitted), so both halves span the log's amplitudes and its whole
    /// time (a drift, the temperature swing). 3 fits two cycles of three:
    /// more readings to fit, fewer to score on. A log of fewer cycles than
    /// this is fitted and scored on all of them (as a one-cycle log always
    /// is).
    pub held_out_period: usize,
    /// Weight of each parameter in the information criterion
    /// `χ² + w_k·k·ln n + w_M·ln M` (`k` parameters, `n` readings, `M`
    /// candidates of the tier), per ln n: this is `w_k`. Default 1: the
    /// Bayesian information criterion, which picks the true model as the
    /// log grows (a constant weight, as AIC's, keeps over-fitting). Larger:
    /// fewer and stronger findings; smaller: more false alarms.
    pub penalty_per_parameter: f64,
    /// Weight `w_M` of `ln M`, the look-elsewhere term of the criterion.
    /// Default 2: the largest of `M` useless candidates' gains exceeds a
    /// threshold about `M` times as often as one does, and a χ² tail falls
    /// as `e^(−x/2)`, so `2·ln M` takes that factor back: screening 180
    /// local candidates raises no more false alarms than screening one.
    /// 0: no correction (every extra candidate tried is a chance of a
    /// false alarm).
    pub penalty_per_ln_candidates: f64,
    /// Member groups whose single members are screened in the local tier:
    /// those whose group screen predicted the largest gain. Default 2: a
    /// single member's error shows, weaker, in its group's screen, so the
    /// best two groups hold it without screening every member of the
    /// bridge (each screen costs a replay). 0 screens no single member.
    pub member_groups_opened: usize,
    /// Whether the local tier (one member, motor or sensor) is searched at
    /// all. Default true: a local fault (a drum zeroed off, a member cut
    /// long) is what a library effect cannot explain, and `diagnose` names
    /// it. False searches the library effects only: the self-diagnosis
    /// between cycles (`[memory] model_learning_enable`) carries library
    /// effects into the next cycle's model and no local finding (a model
    /// file's faults are not planned through yet), so its hundreds of
    /// local screens would cost most of its time for nothing it uses.
    pub local_tier_enable: bool,
    /// Local candidates fitted per round at most, those the screen
    /// predicts to gain most. Default 4: the screen is exact for the
    /// reading terms (linear) and close for the others, while each fit
    /// costs tens of replays. More: slower, safer where screens mislead.
    pub max_local_fits: usize,
    /// Share of the held-out mean square `z` above noise (`rms² − 1`) that
    /// counts as explaining most of it, 0–1. Default 0.5 ("most"). A
    /// library effect that removes this much is taken without screening
    /// the local tier; and the effects found are called missing only if
    /// they remove this much (or turn a model the tests failed into one
    /// they pass): a weak fit that only nudges a near-noise residual is
    /// no finding. Higher: fewer findings, more local screens.
    pub explained_share: f64,
    /// Held-out RMS `z` (noise SDs) that the effects found must leave for
    /// a finding. Default 1.5: it binds only where the noise limit
    /// `1 + 4/√(2n)` is looser, on fewer than 32 held-out readings, so
    /// that a tiny log cannot call a 2 σ residual explained.
    pub explained_rms: f64,
    /// How near a search bound, as a share of the search range's width, a
    /// fitted parameter counts as sitting on it (and the fit as stopped by
    /// the range, not the data; see `ParameterFlag::AtSearchBound`).
    /// Default 0.02: a fit that stops within 2 % of the range's width
    /// from a bound is taken as held there by it. Larger: more fits
    /// flagged and verdicts not confident.
    pub near_bound: f64,
    /// Standard errors beyond its plausible range at which a fitted
    /// parameter is flagged outside it (the data, not the sampling, put it
    /// there; see `ParameterFlag::OutsidePlausible`). Default 2: sampling
    /// alone puts a value on the plausible edge that far out once in 44.
    /// Larger: fewer flags, more confident verdicts.
    pub outside_plausible_std_errors: f64,
    /// Largest standard error, in widths of its plausible range, at which
    /// a parameter counts as identified by the log; above it the value
    /// says nothing, at a bound or not (`ParameterFlag::NotIdentified`).
    /// Default 1: a log that cannot pin a parameter down to within the
    /// range it may plausibly take has not measured it.
    pub max_identified_std_error: f64,
    /// Share of a candidate's held-out χ² gain coming from one sensor at
    /// which the candidate is flagged as carried by that sensor
    /// (`ParameterFlag::CarriedByOneSensor`, not trusted), unless it is a
    /// term of that sensor's own readings. Default 0.98: a change of the
    /// bridge moves several readings, so when the other sensors together
    /// give under 2 % of the evidence the log cannot tell it from a fault
    /// of that one sensor. Measured on the local-diagnosis cases
    /// (`tests/diagnosis_local.rs`): a load cell clipping at 300 N made a
    /// drum offset of its cable fit with 99.7 % of its gain on that cell
    /// (and a ring cable's stiffness 99.9 %); a cable really 40 % softer
    /// 77.8 %, a drum really 15 mm off 24.1 %, a soft spring 39.8 %.
    /// Lower: more verdicts not confident; 1: never flagged.
    pub one_sensor_share: f64,
    /// The least squares of each fit.
    pub fit: FitSettings,
    /// When residuals count as sensor noise.
    pub noise: NoiseSettings,
    /// Which readings are set aside as outliers before the search.
    pub outliers: OutlierSettings,
}

impl DiagnoseSettings {
    /// Range of [`Self::max_rounds`].
    pub const MAX_ROUNDS_RANGE: NumberRange = NumberRange::count(1, 100);
    /// Range of [`Self::held_out_period`]: at least one fitted cycle per
    /// held-out one.
    pub const HELD_OUT_PERIOD_RANGE: NumberRange = NumberRange::count(2, 100);
    /// Range of [`Self::penalty_per_parameter`]: 0 would accept every
    /// parameter that lowers χ² at all.
    pub const PENALTY_PER_PARAMETER_RANGE: NumberRange = NumberRange::positive_up_to(100.0);
    /// Range of [`Self::penalty_per_ln_candidates`].
    pub const PENALTY_PER_LN_CANDIDATES_RANGE: NumberRange = NumberRange::non_negative_up_to(100.0);
    /// Range of [`Self::member_groups_opened`].
    pub const MEMBER_GROUPS_OPENED_RANGE: NumberRange = NumberRange::count(0, 10_000);
    /// Range of [`Self::max_local_fits`]: a screened tier of which nothing
    /// may be fitted is wasted.
    pub const MAX_LOCAL_FITS_RANGE: NumberRange = NumberRange::count(1, 10_000);
    /// Range of [`Self::explained_share`].
    pub const EXPLAINED_SHARE_RANGE: NumberRange = NumberRange::closed(0.0, 1.0);
    /// Range of [`Self::explained_rms`]: pure noise has RMS 1.
    pub const EXPLAINED_RMS_RANGE: NumberRange = NumberRange::closed(1.0, 100.0);
    /// Range of [`Self::near_bound`]: up to half the range, where every
    /// value is near a bound.
    pub const NEAR_BOUND_RANGE: NumberRange = NumberRange::non_negative_up_to(0.5);
    /// Range of [`Self::outside_plausible_std_errors`].
    pub const OUTSIDE_PLAUSIBLE_STD_ERRORS_RANGE: NumberRange =
        NumberRange::non_negative_up_to(100.0);
    /// Range of [`Self::max_identified_std_error`].
    pub const MAX_IDENTIFIED_STD_ERROR_RANGE: NumberRange = NumberRange::positive_up_to(100.0);
    /// Range of [`Self::one_sensor_share`]: at or below one half, one
    /// sensor could carry most of the evidence of two different causes.
    pub const ONE_SENSOR_SHARE_RANGE: NumberRange = NumberRange::closed(0.5, 1.0).excluding_min();

    /// Each field with its declared range, in declaration order.
    pub fn ranges(&self) -> [Ranged; 12] {
        [
            Ranged::count("max_rounds", self.max_rounds, Self::MAX_ROUNDS_RANGE),
            Ranged::count(
                "held_out_period",
                self.held_out_period,
                Self::HELD_OUT_PERIOD_RANGE,
            ),
            Ranged::real(
                "penalty_per_parameter",
                self.penalty_per_parameter,
                Self::PENALTY_PER_PARAMETER_RANGE,
            ),
            Ranged::real(
                "penalty_per_ln_candidates",
                self.penalty_per_ln_candidates,
                Self::PENALTY_PER_LN_CANDIDATES_RANGE,
            ),
            Ranged::count(
                "member_groups_opened",
                self.member_groups_opened,
                Self::MEMBER_GROUPS_OPENED_RANGE,
            ),
            Ranged::count(
                "max_local_fits",
                self.max_local_fits,
                Self::MAX_LOCAL_FITS_RANGE,
            ),
            Ranged::real(
                "explained_share",
                self.explained_share,
                Self::EXPLAINED_SHARE_RANGE,
            ),
            Ranged::real(
                "explained_rms",
                self.explained_rms,
                Self::EXPLAINED_RMS_RANGE,
            ),
            Ranged::real("near_bound", self.near_bound, Self::NEAR_BOUND_RANGE),
            Ranged::real(
                "outside_plausible_std_errors",
                self.outside_plausible_std_errors,
                Self::OUTSIDE_PLAUSIBLE_STD_ERRORS_RANGE,
            ),
            Ranged::real(
                "max_identified_std_error",
                self.max_identified_std_error,
                Self::MAX_IDENTIFIED_STD_ERROR_RANGE,
            ),
            Ranged::real(
                "one_sensor_share",
                self.one_sensor_share,
                Self::ONE_SENSOR_SHARE_RANGE,
            ),
        ]
    }

    /// Checks every field, the parts' too, against its range; the error
    /// names the first field out of it by its path (`fit.max_iterations`).
    pub fn validate(&self) -> Result<(), DiagnoseSettingsError> {
        check_ranges(&self.ranges())?;
        self.fit.validate().map_err(|e| e.within("fit"))?;
        self.noise.validate().map_err(|e| e.within("noise"))?;
        self.outliers.validate().map_err(|e| e.within("outliers"))?;
        Ok(())
    }
}

impl Default for DiagnoseSettings {
    fn default() -> Self {
        DiagnoseSettings {
            max_rounds: 2,
            held_out_period: 2,
            penalty_per_parameter: 1.0,
            penalty_per_ln_candidates: 2.0,
            member_groups_opened: 2,
            local_tier_enable: true,
            max_local_fits: 4,
            explained_share: 0.5,
            explained_rms: 1.5,
            near_bound: 0.02,
            outside_plausible_std_errors: 2.0,
            max_identified_std_error: 1.0,
            one_sensor_share: 0.98,
            fit: FitSettings::default(),
            noise: NoiseSettings::default(),
            outliers: OutlierSettings::default(),
        }
    }
}

/// Settings of the least squares ([`super::fit`]): search boxes, the
/// forward-difference Jacobian and Levenberg–Marquardt. Lengths are in
/// widths of each parameter's plausible range (the scale the search
/// works in).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitSettings {
    /// How far the search range reaches beyond the plausible range on each
    /// side, plausible widths (always within the admissible range, always
    /// holding the neutral value). Default 0.5: a fit may show a value is
    /// implausible (it is flagged there) rather than stop on the
    /// plausible range's edge. 0: the plausible range itself, so an
    /// implausible truth sits at a bound.
    pub search_widening: f64,
    /// Where a fit starts when the neutral value (the effect absent) lies
    /// in the plausible range: this far from it towards the upper plausible
    /// end, plausible widths (else in the middle of the plausible range).
    /// Default 0.1: a small effect is the likelier one. Larger: starts
    /// nearer the middle of the plausible range.
    pub start_offset: f64,
    /// Forward-difference step of the Jacobian, plausible widths. Default
    /// 1e-3: large against solver noise (residuals move by ~1e-2 noise SDs,
    /// the solver's error by ~1e-6), small against the curvature of every
    /// effect's response. Smaller: solver noise enters the Jacobian;
    /// larger: the screen's prediction and the standard errors lose
    /// accuracy.
    pub difference_step: f64,
    /// Levenberg–Marquardt iterations per fit, each a Jacobian (one replay
    /// per parameter) and up to [`Self::damping_tries`] trial steps.
    /// Default 30; a fit that reaches it is reported as not converged.
    pub max_iterations: usize,
    /// A fit has converged when an accepted step lowers `χ²` by less than
    /// this share of `χ²` (of 1 where `χ²` is below 1). Default 1e-6: the
    /// parameters then lie within about `√(1e-6·χ²)` standard errors of
    /// the optimum, a thousandth of one on a log explained to the noise.
    pub converged_gain_rel: f64,
    /// Damping `λ` of the first step, relative to the diagonal of `JᵀJ`
    /// (Marquardt's scaling). Default 1e-2: close to a Gauss–Newton step
    /// (the screen's own step); a step that fails raises it at once.
    pub initial_damping: f64,
    /// Trial steps per iteration, the damping raised after each rejected
    /// one; an iteration whose trials all fail to lower `χ²` ends the fit
    /// (as converged: no step lowers it). Default 8: with
    /// [`Self::damping_raise`] 4 the damping grows 65 536-fold within an
    /// iteration before the fit gives up on a step.
    pub damping_tries: usize,
    /// Factor on the damping after a rejected trial step. Default 4.
    pub damping_raise: f64,
    /// Factor on the damping where the damped system cannot be solved.
    /// Default 10: a singular system is further from solvable than a step
    /// that only failed to lower `χ²`.
    pub damping_raise_singular: f64,
    /// Divisor of the damping after an accepted step. Default 3: lowering
    /// by less than [`Self::damping_raise`] keeps the damping from
    /// alternating between a step that is accepted and one that is not.
    pub damping_lower: f64,
    /// Floor of the damping after accepted steps. Default 1e-9: keeps the
    /// damped system regular where `JᵀJ` is nearly singular (an effect
    /// the log barely identifies).
    pub min_damping: f64,
}

impl FitSettings {
    /// Range of [`Self::search_widening`].
    pub const SEARCH_WIDENING_RANGE: NumberRange = NumberRange::non_negative_up_to(100.0);
    /// Range of [`Self::start_offset`].
    pub const START_OFFSET_RANGE: NumberRange = NumberRange::closed(0.0, 1.0);
    /// Range of [`Self::difference_step`].
    pub const DIFFERENCE_STEP_RANGE: NumberRange = NumberRange::positive_up_to(0.1);
    /// Range of [`Self::max_iterations`].
    pub const MAX_ITERATIONS_RANGE: NumberRange = NumberRange::count(1, 10_000);
    /// Range of [`Self::converged_gain_rel`].
    pub const CONVERGED_GAIN_REL_RANGE: NumberRange = NumberRange::positive_up_to(0.1);
    /// Range of [`Self::initial_damping`].
    pub const INITIAL_DAMPING_RANGE: NumberRange = NumberRange::positive_up_to(1e6);
    /// Range of [`Self::damping_tries`].
    pub const DAMPING_TRIES_RANGE: NumberRange = NumberRange::count(1, 100);
    /// Range of the damping factors: above 1, so that raising raises.
    pub const DAMPING_FACTOR_RANGE: NumberRange = NumberRange::closed(1.0, 1000.0).excluding_min();
    /// Range of [`Self::min_damping`].
    pub const MIN_DAMPING_RANGE: NumberRange = NumberRange::positive_up_to(1.0);

    /// Each field with its declared range, in declaration order.
    pub fn ranges(&self) -> [Ranged; 11] {
        [
            Ranged::real(
                "search_widening",
                self.search_widening,
                Self::SEARCH_WIDENING_RANGE,
            ),
            Ranged::real("start_offset", self.start_offset, Self::START_OFFSET_RANGE),
            Ranged::real(
                "difference_step",
                self.difference_step,
                Self::DIFFERENCE_STEP_RANGE,
            ),
            Ranged::count(
                "max_iterations",
                self.max_iterations,
                Self::MAX_ITERATIONS_RANGE,
            ),
            Ranged::real(
                "converged_gain_rel",
                self.converged_gain_rel,
                Self::CONVERGED_GAIN_REL_RANGE,
            ),
            Ranged::real(
                "initial_damping",
                self.initial_damping,
                Self::INITIAL_DAMPING_RANGE,
            ),
            Ranged::count(
                "damping_tries",
                self.damping_tries,
                Self::DAMPING_TRIES_RANGE,
            ),
            Ranged::real(
                "damping_raise",
                self.damping_raise,
                Self::DAMPING_FACTOR_RANGE,
            ),
            Ranged::real(
                "damping_raise_singular",
                self.damping_raise_singular,
                Self::DAMPING_FACTOR_RANGE,
            ),
            Ranged::real(
                "damping_lower",
                self.damping_lower,
                Self::DAMPING_FACTOR_RANGE,
            ),
            Ranged::real("min_damping", self.min_damping, Self::MIN_DAMPING_RANGE),
        ]
    }

    /// Checks every field against its range.
    pub fn validate(&self) -> Result<(), FieldError> {
        check_ranges(&self.ranges())
    }
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings {
            search_widening: crate::model::parameter_spec::DEFAULT_SEARCH_WIDENING,
            start_offset: 0.1,
            difference_step: 1e-3,
            max_iterations: 30,
            converged_gain_rel: 1e-6,
            initial_damping: 1e-2,
            damping_tries: 8,
            damping_raise: 4.0,
            damping_raise_singular: 10.0,
            damping_lower: 3.0,
            min_damping: 1e-9,
        }
    }
}

/// When residuals count as sensor noise: the overall RMS limit
/// ([`super::compare::noise_rms_limit`]) and the per-sensor tests
/// ([`super::evidence`]). A comparison is clean only if both pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseSettings {
    /// Sampling SDs above 1 that the RMS of `n` readings of `z` may reach
    /// and still be noise: the limit is `1 + rms_limit_sds/√(2n)` (the RMS
    /// of `n` standard normal draws has SD ≈ `1/√(2n)`). Default 4: pure
    /// noise passes it but for a one-in-30 000 chance. Smaller: small
    /// model errors found, more noise called structure.
    pub rms_limit_sds: f64,
    /// Family-wise error rate of the per-sensor and per-group tests under
    /// Holm's control: the chance that pure noise has any test called
    /// significant. Default 1e-3: one noise-only log in a thousand has a
    /// sensor called significant. Larger: weaker local faults found, more
    /// false alarms.
    pub family_alpha: f64,
}

impl NoiseSettings {
    /// Range of [`Self::rms_limit_sds`].
    pub const RMS_LIMIT_SDS_RANGE: NumberRange = NumberRange::positive_up_to(100.0);
    /// Range of [`Self::family_alpha`].
    pub const FAMILY_ALPHA_RANGE: NumberRange = NumberRange::positive_up_to(0.5);

    /// Each field with its declared range, in declaration order.
    pub fn ranges(&self) -> [Ranged; 2] {
        [
            Ranged::real(
                "rms_limit_sds",
                self.rms_limit_sds,
                Self::RMS_LIMIT_SDS_RANGE,
            ),
            Ranged::real("family_alpha", self.family_alpha, Self::FAMILY_ALPHA_RANGE),
        ]
    }

    /// Checks every field against its range.
    pub fn validate(&self) -> Result<(), FieldError> {
        check_ranges(&self.ranges())
    }
}

impl Default for NoiseSettings {
    fn default() -> Self {
        NoiseSettings {
            rms_limit_sds: 4.0,
            family_alpha: 1e-3,
        }
    }
}

/// Which readings are outliers ([`super::outliers`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutlierSettings {
    /// Distance from its sensor's median `z`, in robust SDs, beyond which
    /// a reading is an outlier. Default 6: under pure noise a reading
    /// passes 6 SDs once in 500 million, so a log of 2000 readings shows
    /// one once in 250 000 logs. Smaller: more spikes set aside, and
    /// sooner a real model error. Its readings just before and after on
    /// the log's clock must lie within half of it (a spike is isolated;
    /// [`super::outliers`]).
    pub limit_robust_sds: f64,
    /// Most outliers a sensor may have, as a share of its readings (at
    /// least one). Default 0.1: outliers are rare; a sensor with more
    /// isolated spikes has a fault (a loose connector), which is
    /// structure to be located, not set aside.
    pub max_share: f64,
}

impl OutlierSettings {
    /// Range of [`Self::limit_robust_sds`]: below 3 ordinary noise would
    /// be taken for spikes.
    pub const LIMIT_ROBUST_SDS_RANGE: NumberRange = NumberRange::closed(3.0, 1000.0);
    /// Range of [`Self::max_share`].
    pub const MAX_SHARE_RANGE: NumberRange = NumberRange::closed(0.0, 1.0);

    /// Each field with its declared range, in declaration order.
    pub fn ranges(&self) -> [Ranged; 2] {
        [
            Ranged::real(
                "limit_robust_sds",
                self.limit_robust_sds,
                Self::LIMIT_ROBUST_SDS_RANGE,
            ),
            Ranged::real("max_share", self.max_share, Self::MAX_SHARE_RANGE),
        ]
    }

    /// Checks every field against its range.
    pub fn validate(&self) -> Result<(), FieldError> {
        check_ranges(&self.ranges())
    }
}

impl Default for OutlierSettings {
    fn default() -> Self {
        OutlierSettings {
            limit_robust_sds: 6.0,
            max_share: 0.1,
        }
    }
}

/// A diagnose setting outside its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("diagnose setting `{field}`: {reason}")]
pub struct DiagnoseSettingsError {
    /// The field's path in [`DiagnoseSettings`], e.g. `fit.max_iterations`.
    pub field: String,
    /// What is wrong, e.g. `must be a whole number in [1, 10000], got 0`.
    pub reason: String,
}

impl From<FieldError> for DiagnoseSettingsError {
    fn from(e: FieldError) -> Self {
        DiagnoseSettingsError {
            field: e.field,
            reason: e.reason,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field's path, and the default with that field out of its
    /// range.
    fn out_of_range() -> Vec<(&'static str, DiagnoseSettings)> {
        let d = DiagnoseSettings::default;
        let with = |f: fn(&mut DiagnoseSettings)| {
            let mut s = d();
            f(&mut s);
            s
        };
        vec![
            ("max_rounds", with(|s| s.max_rounds = 0)),
            ("held_out_period", with(|s| s.held_out_period = 1)),
            (
                "penalty_per_parameter",
                with(|s| s.penalty_per_parameter = 0.0),
            ),
            (
                "penalty_per_ln_candidates",
                with(|s| s.penalty_per_ln_candidates = -1.0),
            ),
            (
                "member_groups_opened",
                with(|s| s.member_groups_opened = 10_001),
            ),
            ("max_local_fits", with(|s| s.max_local_fits = 0)),
            ("explained_share", with(|s| s.explained_share = 1.5)),
            ("explained_rms", with(|s| s.explained_rms = 0.9)),
            ("near_bound", with(|s| s.near_bound = 0.6)),
            (
                "outside_plausible_std_errors",
                with(|s| s.outside_plausible_std_errors = f64::NAN),
            ),
            (
                "max_identified_std_error",
                with(|s| s.max_identified_std_error = 0.0),
            ),
            ("one_sensor_share", with(|s| s.one_sensor_share = 0.5)),
            (
                "fit.search_widening",
                with(|s| s.fit.search_widening = -0.1),
            ),
            ("fit.start_offset", with(|s| s.fit.start_offset = 2.0)),
            ("fit.difference_step", with(|s| s.fit.difference_step = 0.0)),
            ("fit.max_iterations", with(|s| s.fit.max_iterations = 0)),
            (
                "fit.converged_gain_rel",
                with(|s| s.fit.converged_gain_rel = f64::INFINITY),
            ),
            (
                "fit.initial_damping",
                with(|s| s.fit.initial_damping = -1.0),
            ),
            ("fit.damping_tries", with(|s| s.fit.damping_tries = 0)),
            ("fit.damping_raise", with(|s| s.fit.damping_raise = 1.0)),
            (
                "fit.damping_raise_singular",
                with(|s| s.fit.damping_raise_singular = 0.5),
            ),
            ("fit.damping_lower", with(|s| s.fit.damping_lower = 1.0)),
            ("fit.min_damping", with(|s| s.fit.min_damping = 0.0)),
            ("noise.rms_limit_sds", with(|s| s.noise.rms_limit_sds = 0.0)),
            ("noise.family_alpha", with(|s| s.noise.family_alpha = 0.6)),
            (
                "outliers.limit_robust_sds",
                with(|s| s.outliers.limit_robust_sds = 2.0),
            ),
            ("outliers.max_share", with(|s| s.outliers.max_share = -0.1)),
        ]
    }

    /// The paths of every leaf field of `value` (a serialised settings).
    fn leaf_paths(value: &serde_json::Value, prefix: &str, out: &mut Vec<String>) {
        match value {
            serde_json::Value::Object(fields) => {
                for (name, v) in fields {
                    let path = if prefix.is_empty() {
                        name.clone()
                    } else {
                        format!("{prefix}.{name}")
                    };
                    leaf_paths(v, &path, out);
                }
            }
            // A switch (`local_tier_enable`) has no range to leave.
            serde_json::Value::Bool(_) => {}
            _ => out.push(prefix.to_string()),
        }
    }

    #[test]
    fn the_default_validates_and_each_field_out_of_range_is_named() {
        DiagnoseSettings::default().validate().unwrap();
        let cases = out_of_range();
        for (field, settings) in &cases {
            let e = settings.validate().unwrap_err();
            assert_eq!(e.field, *field, "{e}");
            assert!(e.to_string().contains(&format!("`{field}`")), "{e}");
        }
        // Every field has its case.
        let mut fields = Vec::new();
        let value = serde_json::to_value(DiagnoseSettings::default()).unwrap();
        leaf_paths(&value, "", &mut fields);
        let mut named: Vec<String> = cases.iter().map(|(f, _)| f.to_string()).collect();
        fields.sort();
        named.sort();
        assert_eq!(fields, named);
    }

    #[test]
    fn a_count_out_of_range_reads_as_a_whole_number() {
        let mut s = DiagnoseSettings::default();
        s.fit.max_iterations = 0;
        assert_eq!(
            s.validate().unwrap_err().to_string(),
            "diagnose setting `fit.max_iterations`: must be a whole number in [1, 10000], got 0"
        );
    }

    #[test]
    fn settings_read_from_a_partial_file_keep_the_other_defaults() {
        let s: DiagnoseSettings =
            serde_json::from_str(r#"{"max_rounds": 3, "fit": {"max_iterations": 50}}"#).unwrap();
        let want = DiagnoseSettings {
            max_rounds: 3,
            fit: FitSettings {
                max_iterations: 50,
                ..FitSettings::default()
            },
            ..DiagnoseSettings::default()
        };
        assert_eq!(s, want);
        assert!(serde_json::from_str::<DiagnoseSettings>(r#"{"max_round": 3}"#).is_err());
    }
}
