//! Calibration: a model's effects fitted to a measurement log. The one way
//! a calibrated model is made: `tdeploy calibrate` (one effect, written to
//! a new model file) and `tdeploy replay` (the model its counterfactual
//! deploys) both call [`calibrate_on_log`].
//!
//! # Methods ([`CalibrationMethod`])
//! - **Diagnose**: the full diagnosis ([`diagnose`]): every effect the
//!   model lacks screened and fitted, the best ones kept and refitted
//!   jointly; the calibrated model gets [`effects_found`].
//! - **Fit**: the listed effects fitted in turn ([`fit_candidate`]), each
//!   on top of those kept before it. Cheap (one fit each), but without the
//!   diagnosis's joint refit an early effect absorbs part of a later one's
//!   signal. Which fits the model keeps is the method's [`KeepFit`] rule:
//!   - [`KeepFit::IfHeldOutFalls`] (`tdeploy replay --fit`): a fit that
//!     converged and lowered the held-out RMS residual. The replay looks
//!     for the model that explains the log best, so an effect that does
//!     not help is left out.
//!   - [`KeepFit::IfConverged`] (`tdeploy calibrate --add`): every fit
//!     that converged, whether or not it lowered the held-out residual.
//!     The user named the effect; the held-out figures before and after
//!     tell them whether it helped, and a fit that did not converge is
//!     not kept.
//!
//! # Held-out residual
//! Every figure "held out" is the RMS, in noise SDs, of the residuals of
//! the cycles the diagnosis holds out (`measure::diagnose::held_out_stats`;
//! a one-cycle log is its own held-out part): the effects are fitted on
//! the other cycles.

use serde::{Serialize, Serializer};
use thiserror::Error;

use crate::measure::compare::{noise_rms_limit, Stats};
use crate::measure::diagnose::{
    diagnose, effects_found, fit_candidate, held_out_stats, Candidate, DiagnoseError,
    DiagnoseSettings, Verdict,
};
use crate::measure::local::Term;
use crate::measure::log::MeasurementLog;
use crate::model::{EffectKind, Effects};
use crate::sim::{EffectModel, PlantError};

/// How a model is calibrated on a log (see the module notes).
///
/// Serialised (in `tdeploy replay`'s `summary.json`) as
/// `{"diagnose": {"max_rounds": N}}` or `{"fit": [effect names]}`; the
/// [`KeepFit`] rule is not written: a replay always uses
/// [`KeepFit::IfHeldOutFalls`].
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationMethod {
    /// The full diagnosis ([`diagnose`]); the model gets [`effects_found`].
    Diagnose {
        /// Effects to look for at most.
        max_rounds: usize,
    },
    /// These effects fitted in turn ([`fit_candidate`]), each on top of
    /// those kept before it.
    #[serde(serialize_with = "effects_only")]
    Fit {
        /// The effects, in the order they are fitted.
        effects: Vec<EffectKind>,
        /// Which fits the calibrated model keeps.
        keep: KeepFit,
    },
}

/// Which of the effects fitted in turn the calibrated model keeps (see
/// the module notes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeepFit {
    /// A fit that converged and lowered the held-out RMS residual
    /// (`tdeploy replay --fit`).
    IfHeldOutFalls,
    /// Every fit that converged (`tdeploy calibrate --add`).
    IfConverged,
}

impl KeepFit {
    /// Whether a fit that `converged` (or not) is kept, the held-out RMS
    /// residual going from `rms_before` to `rms_after` with it.
    pub fn keeps(self, converged: bool, rms_before: f64, rms_after: f64) -> bool {
        converged
            && match self {
                KeepFit::IfHeldOutFalls => rms_after < rms_before,
                KeepFit::IfConverged => true,
            }
    }
}

/// [`CalibrationMethod::Fit`] as its list of effects alone.
fn effects_only<S: Serializer>(
    effects: &[EffectKind],
    _keep: &KeepFit,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    effects.serialize(serializer)
}

/// One effect fitted in a calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedEffect {
    /// The effect's name.
    pub effect: &'static str,
    /// Its parameters' names.
    pub parameters: Vec<&'static str>,
    /// Fitted values (the effect's units, see its parameters).
    pub values: Vec<f64>,
    /// Their standard errors (NaN where the log cannot pin one down).
    pub std_errors: Vec<f64>,
    /// Whether the fit converged.
    pub converged: bool,
    /// Whether the calibrated model has it.
    pub kept: bool,
}

/// A model calibrated on a log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    /// The method.
    pub method: CalibrationMethod,
    /// The calibrated model's effects.
    #[serde(skip)]
    pub effects: Effects,
    /// The effects fitted.
    pub fitted: Vec<FittedEffect>,
    /// The diagnosis's verdict (diagnosis only), serialised in words
    /// ([`describe_verdict`]).
    #[serde(serialize_with = "verdict_words")]
    pub verdict: Option<Verdict>,
    /// Held-out RMS residual of the model before, noise SDs.
    pub held_out_rms_before: f64,
    /// Held-out RMS residual of the calibrated model, noise SDs.
    pub held_out_rms_after: f64,
    /// Readings in the held-out part of the log (the count behind both
    /// RMS figures).
    #[serde(skip)]
    pub held_out_readings: usize,
}

/// How far a calibrated model stands for the bridge that made the log:
/// judged by its held-out RMS residual against the noise limit of that
/// many readings ([`noise_rms_limit`]), the test `compare` applies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "standing", rename_all = "snake_case")]
pub enum CalibrationStanding {
    /// Its held-out residual is sensor noise: it explains the log.
    Explains {
        /// Whether any effect was calibrated (else the model is the
        /// controller's own).
        calibrated: bool,
        /// Held-out RMS residual, noise SDs.
        held_out_rms: f64,
        /// The noise limit for the held-out readings, noise SDs.
        noise_limit: f64,
    },
    /// Its held-out residual is more than noise: the log refutes it, and
    /// what it predicts is no evidence of what the bridge would do.
    Refuted {
        /// Whether any effect was calibrated.
        calibrated: bool,
        /// Held-out RMS residual, noise SDs.
        held_out_rms: f64,
        /// The noise limit for the held-out readings, noise SDs.
        noise_limit: f64,
    },
}

impl CalibrationStanding {
    /// Whether the model explains the log.
    pub fn explains(&self) -> bool {
        matches!(self, CalibrationStanding::Explains { .. })
    }

    /// In words.
    pub fn describe(&self) -> String {
        let (calibrated, rms, limit, explains) = match *self {
            CalibrationStanding::Explains {
                calibrated,
                held_out_rms,
                noise_limit,
            } => (calibrated, held_out_rms, noise_limit, true),
            CalibrationStanding::Refuted {
                calibrated,
                held_out_rms,
                noise_limit,
            } => (calibrated, held_out_rms, noise_limit, false),
        };
        let numbers = format!(
            "held-out RMS {rms:.2} σ, {} the noise limit {limit:.2} σ",
            if explains { "within" } else { "above" }
        );
        match (calibrated, explains) {
            (true, true) => format!("the calibrated model explains the log ({numbers})"),
            (true, false) => format!("the log refutes the calibrated model ({numbers})"),
            (false, true) => {
                format!(
                    "nothing calibrated; the controller's own model explains the log ({numbers})"
                )
            }
            (false, false) => format!(
                "nothing calibrated, and the log refutes the controller's own model ({numbers})"
            ),
        }
    }
}

/// One end of a calibrated parameter's 95 % confidence interval (the
/// estimate ± 2 standard errors, held to the parameter's admissible
/// range), the other parameters at their estimates.
#[derive(Debug, Clone, PartialEq)]
pub struct IntervalEnd {
    /// Which: e.g. `joint_friction mu = 0.2057 (+2 SE)`.
    pub label: String,
    /// The calibrated effects with that parameter there.
    pub effects: Effects,
}

/// Why a calibration could not be made.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CalibrationError {
    /// The diagnosis failed.
    #[error(transparent)]
    Diagnose(#[from] DiagnoseError),
    /// A replay of the log through the model stopped.
    #[error(transparent)]
    Replay(#[from] PlantError),
}

/// Held-out residual statistics of `model` on `log` (z in noise SDs).
fn held_out(model: &EffectModel, log: &MeasurementLog) -> Result<Stats, PlantError> {
    held_out_stats(model, log, &DiagnoseSettings::default())
}

fn fitted_effect(kind: EffectKind, values: &[f64], se: &[f64], converged: bool) -> FittedEffect {
    FittedEffect {
        effect: kind.name(),
        parameters: kind.parameters().iter().map(|p| p.name).collect(),
        values: values.to_vec(),
        std_errors: se.to_vec(),
        converged,
        kept: false,
    }
}

/// Calibrates `base` (a model with its effects) on `log` by `method`.
pub fn calibrate_on_log(
    base: &EffectModel,
    log: &MeasurementLog,
    method: &CalibrationMethod,
) -> Result<Calibration, CalibrationError> {
    let before = held_out(base, log)?;
    let with = |effects: Effects| EffectModel {
        effects,
        ..base.clone()
    };
    match method {
        CalibrationMethod::Diagnose { max_rounds } => {
            let settings = DiagnoseSettings {
                max_rounds: *max_rounds,
                ..DiagnoseSettings::default()
            };
            let d = diagnose(base, log, &settings)?;
            let effects = effects_found(base.effects.clone(), &d.verdict);
            let found = match &d.verdict {
                Verdict::NothingMissing => &[][..],
                Verdict::Missing { found, .. } | Verdict::Unexplained { found, .. } => &found[..],
            };
            let fitted = found
                .iter()
                .filter_map(|c| match c.term {
                    Term::Global(k) => Some(FittedEffect {
                        kept: true,
                        ..fitted_effect(k, &c.values, &c.std_errors, c.converged)
                    }),
                    // Local terms (one member, one sensor) are not effects
                    // of a model file: effects_found leaves them out.
                    Term::Local(_) => None,
                })
                .collect();
            Ok(Calibration {
                method: method.clone(),
                held_out_rms_after: held_out(&with(effects.clone()), log)?.rms,
                effects,
                fitted,
                verdict: Some(d.verdict.clone()),
                held_out_rms_before: before.rms,
                held_out_readings: before.count,
            })
        }
        CalibrationMethod::Fit {
            effects: kinds,
            keep,
        } => {
            let mut effects = base.effects.clone();
            let mut rms = before.rms;
            let mut fitted = Vec::new();
            for kind in kinds {
                let c = fit_candidate(
                    base,
                    effects.clone(),
                    *kind,
                    log,
                    &DiagnoseSettings::default(),
                )?;
                let mut f = fitted_effect(*kind, &c.values, &c.std_errors, c.converged);
                // The candidate's held-out RMS is that of the model with
                // its effects and this fit: the same replay, not redone.
                f.kept = keep.keeps(c.converged, rms, c.held_out_rms);
                if f.kept {
                    effects = effects.with_parameters(*kind, &c.values);
                    rms = c.held_out_rms;
                }
                fitted.push(f);
            }
            Ok(Calibration {
                method: method.clone(),
                effects,
                fitted,
                verdict: None,
                held_out_rms_before: before.rms,
                held_out_rms_after: rms,
                held_out_readings: before.count,
            })
        }
    }
}

impl Calibration {
    /// How far the calibrated model stands for the bridge
    /// ([`CalibrationStanding`]).
    pub fn standing(&self) -> CalibrationStanding {
        let calibrated = self.fitted.iter().any(|f| f.kept);
        let held_out_rms = self.held_out_rms_after;
        let noise_limit =
            noise_rms_limit(self.held_out_readings, &DiagnoseSettings::default().noise);
        if held_out_rms <= noise_limit {
            CalibrationStanding::Explains {
                calibrated,
                held_out_rms,
                noise_limit,
            }
        } else {
            CalibrationStanding::Refuted {
                calibrated,
                held_out_rms,
                noise_limit,
            }
        }
    }

    /// The ends of every kept parameter's 95 % interval whose standard
    /// error the log pins down (finite and positive), in the order fitted:
    /// what the counterfactual must also survive before its verdict is
    /// more than the estimate's.
    pub fn interval_ends(&self) -> Vec<IntervalEnd> {
        let mut ends = Vec::new();
        for f in self.fitted.iter().filter(|f| f.kept) {
            let Some(kind) = EffectKind::ALL
                .iter()
                .copied()
                .find(|k| k.name() == f.effect)
            else {
                continue;
            };
            let specs = kind.parameters();
            for (i, spec) in specs.iter().enumerate() {
                let (Some(&v), Some(&se)) = (f.values.get(i), f.std_errors.get(i)) else {
                    continue;
                };
                if !(se.is_finite() && se > 0.0) {
                    continue;
                }
                for (sign, word) in [(-1.0, "−2 SE"), (1.0, "+2 SE")] {
                    let (low, high) = spec.admissible;
                    let end = (v + sign * 2.0 * se).clamp(low, high);
                    let mut values = f.values.clone();
                    values[i] = end;
                    ends.push(IntervalEnd {
                        label: format!("{} {} = {end:.4} ({word})", f.effect, spec.name),
                        effects: self.effects.with_parameters(kind, &values),
                    });
                }
            }
        }
        ends
    }
}

/// A diagnosis's verdict in words, as a calibration reports it.
pub fn describe_verdict(verdict: &Verdict) -> String {
    match verdict {
        Verdict::NothingMissing => "nothing missing".to_string(),
        Verdict::Missing { found, confident } => format!(
            "missing: {}{}",
            names(found),
            if *confident { "" } else { " (not confident)" }
        ),
        Verdict::Unexplained {
            found,
            held_out_rms,
        } => format!(
            "structured residual left ({held_out_rms:.2} σ held out) after {}",
            names(found)
        ),
    }
}

/// [`Calibration::verdict`] in words.
fn verdict_words<S: Serializer>(
    verdict: &Option<Verdict>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    verdict.as_ref().map(describe_verdict).serialize(serializer)
}

fn names(found: &[Candidate]) -> String {
    if found.is_empty() {
        return "none".into();
    }
    found
        .iter()
        .map(|c| c.name.clone())
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_standing_says_whether_anything_was_calibrated_and_whether_the_log_refutes_it() {
        let cases = [
            (true, 1.1, "the calibrated model explains the log (held-out RMS 1.10 σ, within the noise limit 1.20 σ)"),
            (false, 1.1, "nothing calibrated; the controller's own model explains the log (held-out RMS 1.10 σ, within the noise limit 1.20 σ)"),
            (true, 1.6, "the log refutes the calibrated model (held-out RMS 1.60 σ, above the noise limit 1.20 σ)"),
            (false, 1.6, "nothing calibrated, and the log refutes the controller's own model (held-out RMS 1.60 σ, above the noise limit 1.20 σ)"),
        ];
        for (calibrated, rms, words) in cases {
            let c = Calibration {
                method: CalibrationMethod::Diagnose { max_rounds: 2 },
                effects: Effects::default(),
                fitted: vec![FittedEffect {
                    kept: calibrated,
                    ..fitted_effect(EffectKind::JointFriction, &[0.1], &[0.01], true)
                }],
                verdict: None,
                held_out_rms_before: 2.0,
                held_out_rms_after: rms,
                // 1 + 4/√(2n) = 1.2 at n = 200.
                held_out_readings: 200,
            };
            let s = c.standing();
            assert_eq!(s.explains(), rms < 1.2);
            assert_eq!(s.describe(), words);
            // Kept parameters with a standard error: both ends of μ.
            let ends = c.interval_ends();
            assert_eq!(ends.len(), if calibrated { 2 } else { 0 });
            if calibrated {
                assert_eq!(ends[0].label, "joint_friction mu = 0.0800 (−2 SE)");
                assert_eq!(
                    ends[1].effects.parameters(EffectKind::JointFriction),
                    Some(vec![0.12000000000000001])
                );
            }
        }
    }

    #[test]
    fn a_fit_is_written_as_its_effects_whatever_its_keep_rule() {
        // `tdeploy replay`'s summary.json has always held `{"fit": [...]}`.
        for keep in [KeepFit::IfHeldOutFalls, KeepFit::IfConverged] {
            let method = CalibrationMethod::Fit {
                effects: vec![EffectKind::JointFriction, EffectKind::Motor],
                keep,
            };
            assert_eq!(
                serde_json::to_string(&method).unwrap(),
                r#"{"fit":["joint_friction","motor"]}"#
            );
        }
        let method = CalibrationMethod::Diagnose { max_rounds: 2 };
        assert_eq!(
            serde_json::to_string(&method).unwrap(),
            r#"{"diagnose":{"max_rounds":2}}"#
        );
    }

    #[test]
    fn verdicts_read_as_before() {
        let cases = [
            (Verdict::NothingMissing, "nothing missing"),
            (
                Verdict::Missing {
                    found: vec![],
                    confident: true,
                },
                "missing: none",
            ),
            (
                Verdict::Missing {
                    found: vec![],
                    confident: false,
                },
                "missing: none (not confident)",
            ),
            (
                Verdict::Unexplained {
                    found: vec![],
                    held_out_rms: 2.346,
                },
                "structured residual left (2.35 σ held out) after none",
            ),
        ];
        for (v, text) in cases {
            assert_eq!(describe_verdict(&v), text);
        }
    }

    #[test]
    fn replay_keeps_a_fit_only_if_it_lowers_the_held_out_residual_calibrate_if_it_converged() {
        let replay = KeepFit::IfHeldOutFalls;
        assert!(replay.keeps(true, 2.0, 1.5));
        assert!(!replay.keeps(true, 2.0, 2.5));
        assert!(!replay.keeps(true, 2.0, 2.0));
        assert!(!replay.keeps(false, 2.0, 1.5));
        let calibrate = KeepFit::IfConverged;
        assert!(calibrate.keeps(true, 2.0, 1.5));
        assert!(calibrate.keeps(true, 2.0, 2.5));
        assert!(!calibrate.keeps(false, 2.0, 1.5));
    }
}
