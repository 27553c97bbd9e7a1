//! One deployment (or deployment-fold) cycle, as the memory keeps it.

use serde::{Deserialize, Serialize};

use crate::control::{measured_gap_vectors, Deployment};
use crate::model::parameter_spec::DEFAULT_SEARCH_WIDENING;
use crate::model::{EffectKind, Effects, Structure};
use crate::numerics::{FieldError, NumberRange};
use crate::plan::PlanStatus;
use crate::sim::Sensor;

/// Payouts and payout changes a case may hold, m: a problem's payouts lie
/// within ±10 m and its steps are at most 10 m
/// ([`crate::plan::DeploymentProblem::per_motor_ranges`]).
const PAYOUT_RANGE_M: NumberRange = NumberRange::closed(-10.0, 10.0);
/// A fold a case may start from, m: a payout from the designed state,
/// never negative (a cable reeled in past its design length is no fold),
/// at most the problem's 10 m.
const FOLD_RANGE_M: NumberRange = NumberRange::closed(0.0, 10.0);
/// A midspan gap or prediction error, m: the gap of a folded bridge is
/// well under a metre; 10 m bounds any the tools produce.
const GAP_RANGE_M: NumberRange = NumberRange::closed(0.0, 10.0);
/// A component of a midspan gap vector, m.
const GAP_COMPONENT_RANGE_M: NumberRange = NumberRange::closed(-10.0, 10.0);
/// A payout scale estimate `ŝ`, 1: a half's cable moves `(1 + ŝ)` times
/// its drum command (`control::PayoutScaleEstimator`, which starts at 0),
/// so `ŝ` is negative for drums that pay out short and `1 + ŝ` must stay
/// positive; 10 bounds any plausible drum error. (Until the twentieth
/// session this range was `(0, 10]`, read as the factor itself: a case
/// whose estimate was at or below 0, about every other cycle on a bridge
/// whose drums slip, was refused when the memory was next read.)
const PAYOUT_SCALE_RANGE: NumberRange = NumberRange::closed(-1.0, 10.0).excluding_min();
/// A temperature, °C, as the evaluation's distributions allow.
const TEMPERATURE_RANGE_C: NumberRange = NumberRange::closed(-100.0, 100.0);

/// `Ok` if `value` is inside `range` and not subnormal: a number of
/// magnitude below 1e-308 is no measurement the tools write (it comes from
/// a corrupted or hand-made file) and loses precision in arithmetic.
fn check_value(field: String, value: f64, range: NumberRange) -> Result<(), FieldError> {
    range
        .check(value)
        .map_err(|r| FieldError::new(field.clone(), r))?;
    if value != 0.0 && !value.is_normal() {
        return Err(FieldError::new(
            field,
            format!("{value:e} is subnormal: no value the tools write"),
        ));
    }
    Ok(())
}

/// What a cycle started from, as the controller knew it: the features
/// retrieval compares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseConditions {
    /// Temperature of the cycle, °C (`None`: not measured).
    pub temperature_c: Option<f64>,
    /// Start fold: the motors' payout from the designed state, m.
    pub fold_m: Vec<f64>,
    /// Largest measured midspan gap at the start, m (`None`: not measured).
    pub start_gap_m: Option<f64>,
    /// Payout scale `ŝ` of each bridge half as estimated at the cycle's end
    /// (a half's cable moves `(1 + ŝ)` times its drum command; negative
    /// for drums that pay out short), 1.
    pub payout_scale: Vec<f64>,
}

/// How a cycle ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseOutcome {
    /// The final status's label (`connected`, `not_reachable`, …).
    pub status: String,
    /// Commands sent.
    pub commands: usize,
    /// Commands after the first that brought the largest measured gap
    /// below 60 mm.
    pub corrective_commands: Option<usize>,
    /// Largest measured gap at the end, m.
    pub final_gap_m: Option<f64>,
    /// Commands of the first approach (with a feedforward, the take-up
    /// sent before it, if any, and the learnt commands sent; else up to the
    /// first the controller predicted would connect). Absent in version-1
    /// files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub approach_commands: Option<usize>,
}

/// What the memory gave a cycle and what it predicted, so that the
/// prediction can be checked against what the cycle measured
/// ([`Case::learnt_approach_error_m`]). Absent on a cycle that ran without
/// guidance (and on every case of a version-1 memory file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseLearning {
    /// Index in the memory of the case the cycle learnt from.
    pub from_case: usize,
    /// That case's largest end gap as the update read it (the largest of
    /// its final gap vectors' lengths), m: the error it set out to
    /// remove, against which the update's prediction and the gap reached
    /// can be compared.
    pub from_gap_m: f64,
    /// Gap of each midspan pair the ILC update predicted at the end of its
    /// whole learnt approach, m (`None`: that pair's gap was not read in
    /// the case learnt from).
    pub predicted_gaps_m: Vec<Option<f64>>,
    /// Commands the ILC update learnt (the feedforward).
    pub learnt_commands: usize,
    /// Whether every learnt command was sent (some in parts, see
    /// [`crate::control::Guidance::feedforward_splits`]); `false`: the
    /// planner took over before the learnt approach's end.
    pub approach_completed: bool,
}

/// The effects a learnt effect may have a rival among
/// ([`LearntEffect::rival`]): the structural errors the planner plans on
/// from any model file, each of which can stand in for the other.
pub const RIVAL_EFFECTS: [EffectKind; 2] = [EffectKind::StiffnessError, EffectKind::JointMassError];

/// One library effect of a learnt model, as fitted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearntEffect {
    /// The effect's name, as a model file names it (`joint_friction`,
    /// `motor`, … : [`EffectKind::name`]).
    pub effect: String,
    /// Its parameters' values, in [`EffectKind::parameters`] order and
    /// units.
    pub values: Vec<f64>,
    /// Their standard errors, same order (`None` where the log could not
    /// pin one down).
    pub std_errors: Vec<Option<f64>>,
    /// Another library effect that, fitted in this one's place, explains
    /// the log as well (within the diagnosis's penalty on this effect's
    /// parameters): a structural effect with such a rival is carried in
    /// the model-error figure but not planned on
    /// (`studies::cycles::planner_takes`). `None` where no rival was
    /// found or none was looked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rival: Option<String>,
}

impl LearntEffect {
    /// The effect kind it names; `None` for a name no effect has.
    pub fn kind(&self) -> Option<EffectKind> {
        EffectKind::ALL
            .into_iter()
            .find(|k| k.name() == self.effect)
    }
}

/// The model the controller learnt between cycles (the self-diagnosis of
/// `[memory] model_learning_enable`): what the next cycle plans on beyond
/// the controller's model file, and how well it and the model it replaces
/// predicted the readings held out of its fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseModel {
    /// The controller's model file the effects were learnt beyond
    /// ([`model_base`]): a memory reused with another model file does not
    /// carry them onto it.
    pub base: String,
    /// The library effects the next cycle's model carries beyond the
    /// model file's own (each replaces the file's effect of its kind):
    /// those fitted on this cycle's log where `accepted`, else those
    /// carried before it.
    pub effects: Vec<LearntEffect>,
    /// Whether the fit on this cycle's log replaced the model before it.
    pub accepted: bool,
    /// Whether the two RMS below are over readings held out of the fit
    /// (the log's newest cycle); false on a one-cycle log (the first cycle
    /// of a run), whose fit is scored on the readings it was fitted to.
    pub held_out: bool,
    /// RMS residual, noise SDs, of the scored readings of the
    /// self-diagnosis's log against the model this cycle was planned on.
    pub planned_rms: f64,
    /// The same readings against the model fitted on the log (the model
    /// planned on, `planned_rms` again, where nothing was fitted beyond
    /// it).
    pub fitted_rms: f64,
    /// How many readings the two RMS are over.
    pub held_out_readings: usize,
}

impl CaseModel {
    /// Checks every effect against the library: a known name, one value
    /// per parameter inside the range a fit searches
    /// ([`crate::model::effects::ParameterSpec::search_range`] at
    /// [`DEFAULT_SEARCH_WIDENING`]: no learnt value lies outside it),
    /// standard errors finite and not negative, and the RMS finite and not
    /// negative. The error names the field (`model.effects[1].values[0]`).
    pub fn validate(&self) -> Result<(), FieldError> {
        for (i, e) in self.effects.iter().enumerate() {
            let field = |rest: &str| format!("model.effects[{i}].{rest}");
            let Some(kind) = e.kind() else {
                return Err(FieldError::new(
                    field("effect"),
                    format!("{:?} is no effect of the library", e.effect),
                ));
            };
            if self.effects[..i].iter().any(|o| o.effect == e.effect) {
                return Err(FieldError::new(
                    field("effect"),
                    format!("{} is listed twice", e.effect),
                ));
            }
            if let Some(rival) = &e.rival {
                let structural = |name: &str| RIVAL_EFFECTS.iter().any(|k| k.name() == name);
                if !structural(&e.effect) || !structural(rival) || *rival == e.effect {
                    return Err(FieldError::new(
                        field("rival"),
                        format!(
                            "{rival:?} on {}: a rival is the other structural effect \
                             (stiffness_error, joint_mass_error) of a structural one",
                            e.effect
                        ),
                    ));
                }
            }
            let specs = kind.parameters();
            for (name, len) in [
                ("values", e.values.len()),
                ("std_errors", e.std_errors.len()),
            ] {
                if len != specs.len() {
                    return Err(FieldError::new(
                        field(name),
                        format!("{len} entries; {} has {}", e.effect, specs.len()),
                    ));
                }
            }
            for (k, (spec, &x)) in specs.iter().zip(&e.values).enumerate() {
                let (lo, hi) = spec.search_range(DEFAULT_SEARCH_WIDENING);
                if !(x.is_finite() && x >= lo && x <= hi) {
                    return Err(FieldError::new(
                        field(&format!("values[{k}]")),
                        format!(
                            "{x} is outside [{lo}, {hi}], the range {} is learnt in",
                            spec.name
                        ),
                    ));
                }
            }
            for (k, se) in e.std_errors.iter().enumerate() {
                if let Some(se) = *se {
                    if !(se.is_finite() && se >= 0.0) {
                        return Err(FieldError::new(
                            field(&format!("std_errors[{k}]")),
                            format!("{se} is not a standard error (finite, not negative)"),
                        ));
                    }
                }
            }
        }
        for (name, x) in [
            ("planned_rms", self.planned_rms),
            ("fitted_rms", self.fitted_rms),
        ] {
            if !(x.is_finite() && x >= 0.0) {
                return Err(FieldError::new(
                    format!("model.{name}"),
                    format!("{x} is not an RMS (finite, not negative)"),
                ));
            }
        }
        Ok(())
    }

    /// `base` (the controller's model file's effects) with the learnt
    /// effects switched on at their values. Call on a validated model.
    pub fn effects_on(&self, base: &Effects) -> Effects {
        self.effects
            .iter()
            .filter_map(|e| Some((e.kind()?, &e.values)))
            .fold(base.clone(), |acc, (kind, values)| {
                acc.with_parameters(kind, values)
            })
    }
}

/// The identity of a controller's model file as a learnt model records
/// it ([`CaseModel::base`]): its structure's name and its effects, as
/// JSON. Two model files with the same bridge and effects are the same
/// base.
pub fn model_base(structure_name: &str, effects: &Effects) -> String {
    let effects = serde_json::to_string(effects).unwrap_or_default();
    format!("{structure_name} {effects}")
}

/// One cycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// What it started from.
    pub conditions: CaseConditions,
    /// The commands sent, per command and motor, m.
    pub commands_m: Vec<Vec<f64>>,
    /// Which of `commands_m` (0 for the first, ascending) took up slack
    /// cables ([`crate::plan::take_up`]): each slack cable's motor alone
    /// reels in, a step that does not aim at the design. Those that lead
    /// the case are the case's take-up, which a learnt approach holds at
    /// its front for the new cycle's own take-up to replace
    /// ([`super::adaptation::learnt_path`]). `Some(vec![])`: none;
    /// `None`: not known (a case of a memory format before 4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub take_up_commands: Option<Vec<usize>>,
    /// Measured gap of each midspan pair after each command, m (`None`:
    /// a reading missing).
    pub measured_gaps_m: Vec<Vec<Option<f64>>>,
    /// Measured gap vector `x_a − x_b` of each midspan pair at the end, m
    /// (`None`: a reading missing): the error the next cycle's ILC update
    /// removes (see [`super::ilc`]).
    pub final_gap_vectors_m: Vec<Option<[f64; 3]>>,
    /// The model's prediction error after each command: the largest
    /// |predicted − measured| gap over the pairs, m.
    pub prediction_error_m: Vec<Option<f64>>,
    /// How it ended.
    pub outcome: CaseOutcome,
    /// What the memory gave it (`None`: it ran without guidance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learning: Option<CaseLearning>,
    /// The model learnt after it (`None`: the policy does not learn its
    /// model, or the case predates memory format 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<CaseModel>,
}

impl Case {
    /// Checks the case for a bridge of `motors` motors and `pairs` midspan
    /// pairs: every list of the right length (one command row per command,
    /// one value per motor or pair), every number finite, normal and in its
    /// documented range, the status one of [`PlanStatus::LABELS`], the
    /// command counts consistent. The error names the field's JSON path
    /// (`commands_m[3][11]`). A case that fails is never used: retrieval
    /// and the ILC update would compute with its numbers.
    pub fn validate(&self, motors: usize, pairs: usize) -> Result<(), FieldError> {
        let count = |field: &str, len: usize, expected: usize| {
            if len == expected {
                Ok(())
            } else {
                Err(FieldError::new(
                    field,
                    format!("{len} entries; the bridge needs {expected}"),
                ))
            }
        };
        let c = &self.conditions;
        if let Some(t) = c.temperature_c {
            check_value("conditions.temperature_c".into(), t, TEMPERATURE_RANGE_C)?;
        }
        count("conditions.fold_m", c.fold_m.len(), motors)?;
        for (k, &x) in c.fold_m.iter().enumerate() {
            check_value(format!("conditions.fold_m[{k}]"), x, FOLD_RANGE_M)?;
        }
        if let Some(g) = c.start_gap_m {
            check_value("conditions.start_gap_m".into(), g, GAP_RANGE_M)?;
        }
        if c.payout_scale.len() > motors {
            return Err(FieldError::new(
                "conditions.payout_scale",
                format!(
                    "{} entries; at most one per independent part, and the bridge has {motors} motors",
                    c.payout_scale.len()
                ),
            ));
        }
        for (k, &x) in c.payout_scale.iter().enumerate() {
            check_value(
                format!("conditions.payout_scale[{k}]"),
                x,
                PAYOUT_SCALE_RANGE,
            )?;
        }
        let commands = self.commands_m.len();
        for (i, row) in self.commands_m.iter().enumerate() {
            count(&format!("commands_m[{i}]"), row.len(), motors)?;
            for (k, &x) in row.iter().enumerate() {
                check_value(format!("commands_m[{i}][{k}]"), x, PAYOUT_RANGE_M)?;
            }
        }
        let take_ups = self.take_up_commands.as_deref().unwrap_or_default();
        for (i, w) in take_ups.windows(2).enumerate() {
            if w[1] <= w[0] {
                return Err(FieldError::new(
                    format!("take_up_commands[{}]", i + 1),
                    format!("{} after {}: the indices must ascend", w[1], w[0]),
                ));
            }
        }
        if let Some(&k) = take_ups.last() {
            if k >= commands {
                return Err(FieldError::new(
                    format!("take_up_commands[{}]", take_ups.len() - 1),
                    format!("{k}, not a command of the {commands} the case holds (0 is the first)"),
                ));
            }
        }
        count("measured_gaps_m", self.measured_gaps_m.len(), commands)?;
        for (i, row) in self.measured_gaps_m.iter().enumerate() {
            count(&format!("measured_gaps_m[{i}]"), row.len(), pairs)?;
            for (k, x) in row.iter().enumerate() {
                if let Some(x) = *x {
                    check_value(format!("measured_gaps_m[{i}][{k}]"), x, GAP_RANGE_M)?;
                }
            }
        }
        count("final_gap_vectors_m", self.final_gap_vectors_m.len(), pairs)?;
        for (k, v) in self.final_gap_vectors_m.iter().enumerate() {
            for (a, &x) in v.iter().flatten().enumerate() {
                check_value(
                    format!("final_gap_vectors_m[{k}][{a}]"),
                    x,
                    GAP_COMPONENT_RANGE_M,
                )?;
            }
        }
        count(
            "prediction_error_m",
            self.prediction_error_m.len(),
            commands,
        )?;
        for (i, x) in self.prediction_error_m.iter().enumerate() {
            if let Some(x) = *x {
                check_value(format!("prediction_error_m[{i}]"), x, GAP_RANGE_M)?;
            }
        }
        let o = &self.outcome;
        if !PlanStatus::LABELS.contains(&o.status.as_str()) {
            return Err(FieldError::new(
                "outcome.status",
                format!(
                    "{:?} is not a status ({})",
                    o.status,
                    PlanStatus::LABELS.join(", ")
                ),
            ));
        }
        if o.commands != commands {
            return Err(FieldError::new(
                "outcome.commands",
                format!("{} but the case holds {commands} commands", o.commands),
            ));
        }
        if let Some(k) = o.corrective_commands {
            if k > commands {
                return Err(FieldError::new(
                    "outcome.corrective_commands",
                    format!("{k}, more than the {commands} commands sent"),
                ));
            }
        }
        if let Some(g) = o.final_gap_m {
            check_value("outcome.final_gap_m".into(), g, GAP_RANGE_M)?;
        }
        if let Some(k) = o.approach_commands {
            if k > commands {
                return Err(FieldError::new(
                    "outcome.approach_commands",
                    format!("{k}, more than the {commands} commands sent"),
                ));
            }
        }
        if let Some(l) = &self.learning {
            check_value("learning.from_gap_m".into(), l.from_gap_m, GAP_RANGE_M)?;
            count("learning.predicted_gaps_m", l.predicted_gaps_m.len(), pairs)?;
            for (k, x) in l.predicted_gaps_m.iter().enumerate() {
                if let Some(x) = *x {
                    check_value(format!("learning.predicted_gaps_m[{k}]"), x, GAP_RANGE_M)?;
                }
            }
        }
        if let Some(m) = &self.model {
            m.validate()?;
        }
        Ok(())
    }

    /// The ILC update's error at the end of its learnt approach: the
    /// largest |predicted − measured| gap over the pairs, m. `None` unless
    /// the cycle sent the whole learnt approach (otherwise the commands it
    /// predicted for were not the ones sent) and read a pair's gap.
    pub fn learnt_approach_error_m(&self) -> Option<f64> {
        let l = self.learning.as_ref()?;
        let measured = self.learnt_approach_gaps_m()?;
        l.predicted_gaps_m
            .iter()
            .zip(measured)
            .filter_map(|(p, m)| Some((p.as_ref()? - m.as_ref()?).abs()))
            .reduce(f64::max)
    }

    /// Whether the cycle ended connected, as the controller judged it (its
    /// status, not the truth's verdict: a memory holds what the
    /// controller knew).
    pub fn connected(&self) -> bool {
        self.outcome.status == PlanStatus::Connected.label()
    }

    /// The measured gap of each pair at the end of the learnt approach, m
    /// (`None` where [`Self::learnt_approach_error_m`] is: the approach
    /// was cut short, or the cycle was not guided).
    fn learnt_approach_gaps_m(&self) -> Option<&[Option<f64>]> {
        let l = self.learning.as_ref()?;
        if !l.approach_completed {
            return None;
        }
        let k = self.outcome.approach_commands?.checked_sub(1)?;
        self.measured_gaps_m.get(k).map(|g| &g[..])
    }

    /// The error of the prediction the ILC update replaced, at the end of
    /// this cycle's learnt approach: that the commands of `learnt_from`
    /// (the case this cycle learnt from), sent again unchanged, end where
    /// they ended. The largest |‖final gap vector of `learnt_from`‖ −
    /// measured gap| over the pairs, m; `None` where
    /// [`Self::learnt_approach_error_m`] is, or no pair was read in both.
    /// The two errors, compared, say whether the update's linearisation
    /// predicted this bridge better than no update
    /// ([`crate::learn::acceptance`]).
    pub fn replay_error_m(&self, learnt_from: &Case) -> Option<f64> {
        let measured = self.learnt_approach_gaps_m()?;
        learnt_from
            .final_gap_vectors_m
            .iter()
            .zip(measured)
            .filter_map(|(v, m)| {
                let [x, y, z] = (*v)?;
                Some(((x * x + y * y + z * z).sqrt() - m.as_ref()?).abs())
            })
            .reduce(f64::max)
    }

    /// Checks that the case it learnt from is an earlier one: `index` is
    /// this case's index in the memory.
    pub fn validate_learnt_from(&self, index: usize) -> Result<(), FieldError> {
        match &self.learning {
            Some(l) if l.from_case >= index => Err(FieldError::new(
                "learning.from_case",
                format!(
                    "{}, not an earlier case (this is case {index})",
                    l.from_case
                ),
            )),
            _ => Ok(()),
        }
    }

    /// The case of a closed-loop deployment `d` of `structure` read by
    /// `sensors`, run at `temperature_c`.
    pub fn of_deployment(
        d: &Deployment,
        structure: &Structure,
        sensors: &[Sensor],
        temperature_c: Option<f64>,
    ) -> Case {
        let last_readings = d.readings.last().map_or(&[][..], |r| &r[..]);
        let final_gap_vectors_m = measured_gap_vectors(structure, sensors, last_readings)
            .into_iter()
            .map(|g| g.map(|g| [g.x, g.y, g.z]))
            .collect();
        let prediction_error_m = d
            .records
            .iter()
            .map(|r| {
                r.predicted_gaps_m
                    .iter()
                    .zip(&r.measured_gaps_m)
                    .filter_map(|(p, m)| m.map(|m| (p - m).abs()))
                    .reduce(f64::max)
            })
            .collect();
        Case {
            conditions: CaseConditions {
                temperature_c,
                fold_m: d.start.start_payout_m.clone(),
                start_gap_m: d.start.largest_measured_gap_m(),
                payout_scale: d.final_payout_scale.clone(),
            },
            commands_m: d.commands(),
            take_up_commands: Some(d.take_up_commands()),
            measured_gaps_m: d
                .records
                .iter()
                .map(|r| r.measured_gaps_m.clone())
                .collect(),
            final_gap_vectors_m,
            prediction_error_m,
            outcome: CaseOutcome {
                status: d.status.label().to_string(),
                commands: d.records.len(),
                corrective_commands: d.corrective_commands,
                final_gap_m: d.final_measured_gap_m(),
                approach_commands: d.approach_commands,
            },
            learning: None,
            model: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn learnt() -> CaseModel {
        CaseModel {
            effects: vec![
                LearntEffect {
                    effect: "joint_friction".into(),
                    values: vec![0.19],
                    std_errors: vec![Some(0.006)],
                    rival: None,
                },
                LearntEffect {
                    effect: "motor".into(),
                    values: vec![0.001, 0.003],
                    std_errors: vec![None, Some(2e-4)],
                    rival: None,
                },
            ],
            accepted: true,
            held_out: true,
            planned_rms: 1.5,
            fitted_rms: 1.0,
            held_out_readings: 300,
            base: "reference {}".into(),
        }
    }

    /// A stored model is used as the next cycle's, so every number is
    /// checked against the library before it is: each bad field is named.
    #[test]
    fn a_learnt_model_is_checked_against_the_library_naming_the_field() {
        learnt().validate().unwrap();
        let bad = |edit: &dyn Fn(&mut CaseModel), field: &str| {
            let mut m = learnt();
            edit(&mut m);
            let e = m.validate().unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        };
        bad(
            &|m| m.effects[0].effect = "magic".into(),
            "model.effects[0].effect",
        );
        bad(
            &|m| m.effects[1].effect = "joint_friction".into(),
            "model.effects[1].effect",
        );
        bad(
            &|m| m.effects[1].values.pop().map_or((), drop),
            "model.effects[1].values",
        );
        bad(
            &|m| m.effects[0].std_errors.clear(),
            "model.effects[0].std_errors",
        );
        bad(
            &|m| m.effects[0].values[0] = -0.1,
            "model.effects[0].values[0]",
        );
        bad(
            &|m| m.effects[1].values[1] = f64::NAN,
            "model.effects[1].values[1]",
        );
        bad(
            &|m| m.effects[1].std_errors[1] = Some(-1.0),
            "model.effects[1].std_errors[1]",
        );
        bad(&|m| m.fitted_rms = f64::INFINITY, "model.fitted_rms");
        bad(
            &|m| m.effects[0].rival = Some("friction".into()),
            "model.effects[0].rival",
        );
        bad(
            &|m| m.effects[0].rival = Some("joint_friction".into()),
            "model.effects[0].rival",
        );
        // Friction is no structural effect: it has no rival.
        bad(
            &|m| m.effects[0].rival = Some("joint_mass_error".into()),
            "model.effects[0].rival",
        );
        let mut m = learnt();
        m.effects.push(LearntEffect {
            effect: "joint_mass_error".into(),
            values: vec![1.1],
            std_errors: vec![Some(0.02)],
            rival: Some("stiffness_error".into()),
        });
        m.validate().unwrap();
        m.effects[2].rival = Some("joint_mass_error".into());
        assert!(m.validate().is_err());
    }

    /// The learnt effects switch on over the model file's, each replacing
    /// the file's effect of its kind, and leave the others as they were.
    #[test]
    fn a_learnt_model_replaces_the_model_files_effects_of_its_kinds() {
        let file = Effects::default()
            .with_parameters(EffectKind::JointFriction, &[0.1])
            .with_parameters(EffectKind::JointMassError, &[1.1]);
        let e = learnt().effects_on(&file);
        assert_eq!(e.parameters(EffectKind::JointFriction), Some(vec![0.19]));
        assert_eq!(e.parameters(EffectKind::Motor), Some(vec![0.001, 0.003]));
        assert_eq!(e.parameters(EffectKind::JointMassError), Some(vec![1.1]));
        assert_eq!(e.parameters(EffectKind::StiffnessError), None);
    }
}
