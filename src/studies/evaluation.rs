//! Offline policy evaluation: policies deploying the same seeded scenarios
//! drawn from a documented distribution, one machine or many (shards).
//!
//! **Scenarios.** Scenario `i` of seed `s` draws from
//! `StdRng::seed_from_u64(scenario_seed(s, i))`, in this order: every
//! parameter of every hidden effect (effects in [`EffectKind::ALL`] order,
//! parameters in the library's order), then the position-sensor noise,
//! the load-cell noise, the start fold and, if a range is given, the
//! temperature; each uniformly within its range `[low, high]`. Then, for
//! every local fault listed (in [`FaultKind::ALL`] order), whether it is
//! present (uniform on [0, 1) below its probability), where (a uniform
//! `part_position` in [0, 1): the fault hits part ⌊position × parts⌋ of
//! its kind on the bridge the truths are drawn on, so the draw needs no
//! structure) and its parameters (drawn whether present or not, so that
//! the stream does not depend on the outcome); then, if a range is given,
//! the fold difference of half B. Draws are appended in this order so
//! that a distribution without faults or uneven folds draws exactly what
//! it drew before they existed. The same
//! seed drives the scenario's sensor noise. Every policy meets the same
//! truth and noise (paired scenarios). A scenario is a function of
//! (distribution, seed, index) alone, so a shard that runs scenarios
//! 2, 5, 8, … draws exactly what a single run draws for them.
//!
//! **Shards.** Shard `k/n` runs the scenarios whose index is `k − 1`
//! modulo `n` (interleaved, so shards of a sweep take about equal time).
//!
//! **Results.** Each run is reduced to a [`RunResult`] of plain numbers;
//! summaries are computed from those alone, so a summary of shards merged
//! from their files is the summary of the single run.

use std::collections::BTreeMap;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::cycles::{run_cycles, CycleObserver, CycleResult};
use super::statistics::{
    exact_sign_test_p, mcnemar_exact_p, median, percentile, scenario_seed, wilson_interval,
};
use crate::control::{
    deploy_closed_loop, deploy_guided, fold_truth, ClosedLoopSetup, DeployError, Deployment,
    Guidance,
};
use crate::learn::{Case, CaseMemory};
use crate::model::faults::node_halves;
use crate::model::parameter_spec::ParameterSpec;
use crate::model::{EffectKind, Effects, FaultKind, Faults, ForwardModel, Half, Structure};
use crate::numerics::NumberRange;
use crate::plan::verdict::AS_BUILT_PREFIX;
use crate::plan::{DeploymentProblem, PerMotor, Policy};
use crate::sim::{standard_sensors, EffectModel, Plant, Sensor, SensorTarget};

/// Where the scenarios come from: a range per drawn quantity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioDistribution {
    /// Hidden effects: `[effects.NAME]` tables of `parameter = [low,
    /// high]`, names as in model files and [`EffectKind::parameters`];
    /// every parameter of a listed effect must be given. An effect not
    /// listed is not hidden.
    #[serde(default)]
    pub effects: BTreeMap<String, BTreeMap<String, [f64; 2]>>,
    /// Noise standard deviation of the midspan position sensors, m.
    /// Default `[0.001, 0.001]`: the standard sensors.
    #[serde(default = "default_position_noise")]
    pub position_noise_m: [f64; 2],
    /// Noise standard deviation of the load cells, N. Default `[7, 7]`.
    #[serde(default = "default_load_cell_noise")]
    pub load_cell_noise_n: [f64; 2],
    /// Start fold: every motor's payout from the designed state, m.
    /// Default `[0.40, 0.40]`.
    #[serde(default = "default_fold")]
    pub fold_m: [f64; 2],
    /// Temperature of the deployment, °C (held throughout); `None` (the
    /// default) leaves the truth at its reference temperature. Matters
    /// only with a hidden `thermal` effect.
    #[serde(default)]
    pub temperature_c: Option<[f64; 2]>,
    /// Local faults ([`crate::model::faults`]): `[faults.NAME]` tables of
    /// a `probability` (that a scenario has the fault, in [0, 1]) and
    /// `parameter = [low, high]` for every parameter of the fault. The
    /// faulty part is drawn uniformly among the parts of its kind. A
    /// fault not listed never occurs.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub faults: BTreeMap<String, FaultDistribution>,
    /// Uneven folds: half B's motors folded `fold_m + d` with `d` drawn
    /// from this range, m, clamped to the `fold_m` range (half A's motors
    /// fold `fold_m`); `None` (the default): every motor folds `fold_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fold_difference_m: Option<[f64; 2]>,
}

/// How one local fault is drawn (see [`ScenarioDistribution::faults`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FaultDistribution {
    /// Probability that a scenario has the fault, in [0, 1].
    pub probability: f64,
    /// `parameter = [low, high]` for every parameter of the fault
    /// ([`FaultKind::parameters`]).
    #[serde(flatten)]
    pub parameters: BTreeMap<String, [f64; 2]>,
}

/// The temperatures a deployment is drawn at when a distribution built by
/// [`ScenarioDistribution::plausible`] hides a thermal effect, °C: a
/// footbridge erected outdoors in a temperate climate, spring to autumn.
pub const PLAUSIBLE_TEMPERATURE_C: [f64; 2] = [0.0, 40.0];

fn default_position_noise() -> [f64; 2] {
    [0.001, 0.001]
}
fn default_load_cell_noise() -> [f64; 2] {
    [7.0, 7.0]
}
fn default_fold() -> [f64; 2] {
    [0.40, 0.40]
}

impl ScenarioDistribution {
    /// Every drawn quantity but the effects' with the range both ends of
    /// its `[low, high]` must lie in (`None`: not drawn). An effect
    /// parameter's range is its admissible one
    /// ([`crate::model::effects::ParameterSpec::admissible`]).
    pub fn ranges(&self) -> [(&'static str, Option<[f64; 2]>, NumberRange); 5] {
        [
            (
                "position_noise_m",
                Some(self.position_noise_m),
                NumberRange::closed(0.0, 1.0),
            ),
            (
                "load_cell_noise_n",
                Some(self.load_cell_noise_n),
                NumberRange::closed(0.0, 1e4),
            ),
            ("fold_m", Some(self.fold_m), NumberRange::closed(0.0, 1.0)),
            (
                "temperature_c",
                self.temperature_c,
                NumberRange::closed(-100.0, 100.0),
            ),
            (
                "fold_difference_m",
                self.fold_difference_m,
                NumberRange::closed(-1.0, 1.0),
            ),
        ]
    }
}

impl Default for ScenarioDistribution {
    /// The deployment experiment's distribution: joint friction, motor
    /// slip and backlash, stiffness errors and joint-mass errors over
    /// their plausible ranges; standard sensors; the 40 cm fold.
    fn default() -> Self {
        ScenarioDistribution::plausible(&[
            EffectKind::JointFriction,
            EffectKind::Motor,
            EffectKind::StiffnessError,
            EffectKind::JointMassError,
        ])
    }
}

/// A distribution field out of its range.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("scenario distribution field `{field}`: {reason}")]
pub struct DistributionError {
    /// Field path, e.g. `effects.motor.slip_fraction`.
    pub field: String,
    /// What is wrong.
    pub reason: String,
}

impl ScenarioDistribution {
    /// `kinds` hidden over their plausible ranges, everything else at the
    /// defaults; with a thermal effect, the temperature drawn from
    /// [`PLAUSIBLE_TEMPERATURE_C`].
    pub fn plausible(kinds: &[EffectKind]) -> Self {
        let effects = kinds
            .iter()
            .map(|k| {
                let ranges = k
                    .parameters()
                    .iter()
                    .map(|p| (p.name.to_string(), [p.plausible.0, p.plausible.1]))
                    .collect();
                (k.name().to_string(), ranges)
            })
            .collect();
        ScenarioDistribution {
            effects,
            position_noise_m: default_position_noise(),
            load_cell_noise_n: default_load_cell_noise(),
            fold_m: default_fold(),
            temperature_c: kinds
                .contains(&EffectKind::Thermal)
                .then_some(PLAUSIBLE_TEMPERATURE_C),
            faults: BTreeMap::new(),
            fold_difference_m: None,
        }
    }

    /// Checks every range: finite, low ≤ high, inside the parameter's
    /// admissible range (noise ≥ 0, fold in [0, 1] m, temperature in
    /// [−100, 100] °C, fold difference in [−1, 1] m); effect, fault and
    /// parameter names known, every parameter of a listed effect or fault
    /// given, a fault's probability in [0, 1]. A thermal effect needs a
    /// temperature range: without one the effect would silently do
    /// nothing (the truth at its reference temperature).
    pub fn validate(&self) -> Result<(), DistributionError> {
        for (name, params) in &self.effects {
            let kind = EffectKind::ALL
                .into_iter()
                .find(|k| k.name() == name)
                .ok_or_else(|| DistributionError {
                    field: format!("effects.{name}"),
                    reason: format!(
                        "unknown effect (known: {})",
                        EffectKind::ALL.map(|k| k.name()).join(", ")
                    ),
                })?;
            check_parameter_ranges(
                &format!("effects.{name}"),
                kind.parameters(),
                params,
                "",
                "hidden effect",
            )?;
        }
        for (field, r, within) in self.ranges() {
            if let Some(r) = r {
                range(field.into(), r, within)?;
            }
        }
        if self.effects.contains_key(EffectKind::Thermal.name()) && self.temperature_c.is_none() {
            return Err(DistributionError {
                field: "temperature_c".into(),
                reason:
                    "missing: a hidden thermal effect needs the temperature range it is drawn at"
                        .into(),
            });
        }
        for (name, fault) in &self.faults {
            let kind = FaultKind::ALL
                .into_iter()
                .find(|k| k.name() == name)
                .ok_or_else(|| DistributionError {
                    field: format!("faults.{name}"),
                    reason: format!(
                        "unknown fault (known: {})",
                        FaultKind::ALL.map(|k| k.name()).join(", ")
                    ),
                })?;
            if !(0.0..=1.0).contains(&fault.probability) {
                return Err(DistributionError {
                    field: format!("faults.{name}.probability"),
                    reason: format!("{} is not a probability in [0, 1]", fault.probability),
                });
            }
            check_parameter_ranges(
                &format!("faults.{name}"),
                kind.parameters(),
                &fault.parameters,
                "probability, ",
                "drawn fault",
            )?;
        }
        Ok(())
    }

    /// The drawn faults with their probabilities and ranges, in
    /// [`FaultKind::ALL`] order (the draw order). Assumes
    /// [`Self::validate`] passed.
    fn fault_ranges(&self) -> Vec<(FaultKind, f64, Vec<[f64; 2]>)> {
        FaultKind::ALL
            .into_iter()
            .filter_map(|k| {
                let f = self.faults.get(k.name())?;
                let ranges = k
                    .parameters()
                    .iter()
                    .map(|s| f.parameters.get(s.name).copied().unwrap_or([s.neutral; 2]))
                    .collect();
                Some((k, f.probability, ranges))
            })
            .collect()
    }

    /// The hidden effects with their ranges, in [`EffectKind::ALL`] order
    /// (the draw order). Assumes [`Self::validate`] passed.
    fn effect_ranges(&self) -> Vec<(EffectKind, Vec<[f64; 2]>)> {
        EffectKind::ALL
            .into_iter()
            .filter_map(|k| {
                let params = self.effects.get(k.name())?;
                let ranges = k
                    .parameters()
                    .iter()
                    .map(|s| params.get(s.name).copied().unwrap_or([s.neutral; 2]))
                    .collect();
                Some((k, ranges))
            })
            .collect()
    }

    /// Scenario `index` of seed `seed` (see the module documentation for
    /// the draw order).
    pub fn draw(&self, seed: u64, index: usize) -> Scenario {
        let seed = scenario_seed(seed, index);
        let mut rng = StdRng::seed_from_u64(seed);
        let mut draw = |[lo, hi]: [f64; 2]| rng.gen_range(lo..=hi);
        let mut effects = Effects::default();
        for (kind, ranges) in self.effect_ranges() {
            let values: Vec<f64> = ranges.into_iter().map(&mut draw).collect();
            effects = effects.with_parameters(kind, &values);
        }
        let position_noise_m = draw(self.position_noise_m);
        let load_cell_noise_n = draw(self.load_cell_noise_n);
        let fold_m = draw(self.fold_m);
        let temperature_c = self.temperature_c.map(&mut draw);
        let faults = self
            .fault_ranges()
            .into_iter()
            .map(|(kind, probability, ranges)| {
                let present = draw([0.0, 1.0]) < probability;
                let part_position = draw([0.0, 1.0]);
                let values = ranges.into_iter().map(&mut draw).collect();
                DrawnFault {
                    kind,
                    present,
                    part_position,
                    values,
                }
            })
            .collect();
        let fold_b_m = self
            .fold_difference_m
            .map(|r| (fold_m + draw(r)).clamp(self.fold_m[0], self.fold_m[1]));
        Scenario {
            index,
            seed,
            effects,
            position_noise_m,
            load_cell_noise_n,
            fold_m,
            temperature_c,
            faults,
            fold_b_m,
        }
    }

    /// The drawn quantities' names, as [`Scenario::drawn_values`] lists
    /// them (`joint_friction.mu`, …, `position_noise_m`, …).
    pub fn drawn_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .effect_ranges()
            .iter()
            .flat_map(|(k, _)| {
                k.parameters()
                    .iter()
                    .map(move |p| format!("{}.{}", k.name(), p.name))
            })
            .collect();
        names.extend(
            ["position_noise_m", "load_cell_noise_n", "fold_m"]
                .iter()
                .map(|s| s.to_string()),
        );
        if self.temperature_c.is_some() {
            names.push("temperature_c".into());
        }
        for (kind, _, _) in self.fault_ranges() {
            names.push(format!("faults.{}.present", kind.name()));
            names.push(format!("faults.{}.part_position", kind.name()));
            names.extend(
                kind.parameters()
                    .iter()
                    .map(|p| format!("faults.{}.{}", kind.name(), p.name)),
            );
        }
        if self.fold_difference_m.is_some() {
            names.push("fold_b_m".into());
        }
        names
    }
}

/// `Ok` if `[a, b]` is a range `low ≤ high` inside `within`, else the
/// error on `field`.
fn range(field: String, [a, b]: [f64; 2], within: NumberRange) -> Result<(), DistributionError> {
    if within.contains(a) && within.contains(b) && a <= b {
        Ok(())
    } else {
        Err(DistributionError {
            field,
            reason: format!("[{a}, {b}] is not a range [low, high] within {within}"),
        })
    }
}

/// Checks the parameter table `params` of an effect or fault at `section`
/// (`effects.motor`): every key one of `specs` (`other_keys` lists the
/// section's keys besides its parameters, for the message), every
/// parameter given, each range inside its admissible range. `what` names
/// the section in the message for a missing parameter.
fn check_parameter_ranges(
    section: &str,
    specs: &[ParameterSpec],
    params: &BTreeMap<String, [f64; 2]>,
    other_keys: &str,
    what: &str,
) -> Result<(), DistributionError> {
    for p in params.keys() {
        if !specs.iter().any(|s| s.name == p) {
            let names: Vec<&str> = specs.iter().map(|s| s.name).collect();
            return Err(DistributionError {
                field: format!("{section}.{p}"),
                reason: format!(
                    "unknown parameter of {} (its parameters: {other_keys}{})",
                    section.rsplit('.').next().unwrap_or(section),
                    names.join(", ")
                ),
            });
        }
    }
    for spec in specs {
        let field = format!("{section}.{}", spec.name);
        let r = params.get(spec.name).ok_or_else(|| DistributionError {
            field: field.clone(),
            reason: format!("missing: give every parameter of a {what}"),
        })?;
        range(
            field,
            *r,
            NumberRange::closed(spec.admissible.0, spec.admissible.1),
        )?;
    }
    Ok(())
}

/// One scenario: its seed and everything drawn for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Index, from 0.
    pub index: usize,
    /// Seed of its draws and of its sensor noise.
    pub seed: u64,
    /// The truth's effects.
    pub effects: Effects,
    /// Position-sensor noise, m.
    pub position_noise_m: f64,
    /// Load-cell noise, N.
    pub load_cell_noise_n: f64,
    /// Start fold, m.
    pub fold_m: f64,
    /// Temperature, °C, if drawn.
    pub temperature_c: Option<f64>,
    /// Every fault of the distribution as drawn, present or not.
    pub faults: Vec<DrawnFault>,
    /// Start fold of half B's motors, m, if folds are uneven (half A's
    /// fold `fold_m`).
    pub fold_b_m: Option<f64>,
}

/// One local fault as a scenario drew it.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawnFault {
    /// Which fault.
    pub kind: FaultKind,
    /// Whether the scenario has it.
    pub present: bool,
    /// Where, in [0, 1): part ⌊position × parts⌋ of its kind.
    pub part_position: f64,
    /// Its parameters, in [`FaultKind::parameters`] order.
    pub values: Vec<f64>,
}

impl DrawnFault {
    /// The faulty part of `structure`: index ⌊position × parts⌋ among the
    /// parts of the fault's kind ([`FaultKind::part_count`]).
    pub fn part(&self, structure: &Structure) -> usize {
        let count = self.kind.part_count(structure);
        ((self.part_position * count as f64) as usize).min(count.saturating_sub(1))
    }
}

impl Scenario {
    /// The truth of this scenario on `structure`: its hidden effects and
    /// the faults it has, on their parts of `structure`.
    pub fn truth(&self, structure: &Structure) -> EffectModel {
        let mut effects = self.effects.clone();
        effects.faults = self
            .faults
            .iter()
            .filter(|f| f.present)
            .fold(Faults::default(), |faults, f| {
                faults.with_fault(f.kind, f.part(structure), &f.values)
            });
        EffectModel::for_measurement(structure.clone(), effects)
    }

    /// The standard sensors of `structure` with this scenario's noise.
    pub fn sensors(&self, structure: &Structure) -> Vec<Sensor> {
        standard_sensors(structure)
            .into_iter()
            .map(|mut sensor| {
                sensor.noise_sd = match sensor.target {
                    SensorTarget::Position { .. } => self.position_noise_m,
                    _ => self.load_cell_noise_n,
                };
                sensor
            })
            .collect()
    }

    /// `base` with this scenario's start fold on `structure`: every
    /// motor at `fold_m`, or, with uneven folds, the motors whose cable
    /// starts in half B at `fold_b_m` (a structure without two halves
    /// folds evenly). A motor's stroke is widened to its start where the
    /// fold lies beyond it: the folded start is a payout the drum reached,
    /// so its stroke holds it (a distribution drawing 60 cm folds against
    /// the default 50 cm stroke would otherwise never start those runs).
    pub fn problem(&self, base: &DeploymentProblem, structure: &Structure) -> DeploymentProblem {
        let folded = self.folded_problem(base, structure);
        let motors = structure.continuous_cables.len();
        let (Some(start), Some(max)) = (
            folded.start_payout_m.expand(motors),
            folded.max_payout_m.expand(motors),
        ) else {
            // A list of the wrong length: the problem's own check says so.
            return folded;
        };
        if start.iter().zip(&max).all(|(s, m)| s <= m) {
            return folded;
        }
        DeploymentProblem {
            max_payout_m: PerMotor::Each(start.iter().zip(&max).map(|(s, m)| s.max(*m)).collect()),
            ..folded
        }
    }

    /// `base` with this scenario's start fold (see [`Self::problem`]).
    fn folded_problem(&self, base: &DeploymentProblem, structure: &Structure) -> DeploymentProblem {
        let start_payout_m = match (self.fold_b_m, node_halves(structure)) {
            (Some(fold_b), Ok(halves)) => PerMotor::Each(
                structure
                    .continuous_cables
                    .iter()
                    .map(|c| match halves[c.path[0]] {
                        Some(Half::B) => fold_b,
                        _ => self.fold_m,
                    })
                    .collect(),
            ),
            _ => PerMotor::All(self.fold_m),
        };
        DeploymentProblem {
            start_payout_m,
            ..base.clone()
        }
    }

    /// Runs `run` on this scenario's closed-loop setup, as [`evaluate`]
    /// deploys it: the controller's `model` and `policy`, `base` with this
    /// scenario's fold, and on `bridge` this scenario's truth, sensors
    /// (with its noise), temperature and noise seed.
    ///
    /// `bridge` is the structure the truths are drawn on: the one the
    /// controller's model file names, *before* that file's effects. The
    /// model's own structure carries them (a calibrated stiffness, flexible
    /// supports), and a truth drawn on it would have its stiffness errors
    /// applied twice and supports added twice.
    pub fn with_setup<R>(
        &self,
        bridge: &Structure,
        model: &ForwardModel,
        base: &DeploymentProblem,
        policy: &Policy,
        run: impl FnOnce(&ClosedLoopSetup) -> R,
    ) -> R {
        self.with_truth_setup(bridge, false, model, base, policy, run)
    }

    /// [`Self::with_setup`], with the truth's increments split at its
    /// joints' slip events when `truth_slip_event_substeps` is set
    /// ([`crate::model::RelaxSettings::slip_event_substeps_enable`]: the truth's path no
    /// longer depends on its 1 cm increment; the controller's model is
    /// left as it is).
    pub fn with_truth_setup<R>(
        &self,
        bridge: &Structure,
        truth_slip_event_substeps: bool,
        model: &ForwardModel,
        base: &DeploymentProblem,
        policy: &Policy,
        run: impl FnOnce(&ClosedLoopSetup) -> R,
    ) -> R {
        let mut truth = self.truth(bridge);
        truth.settings.slip_event_substeps_enable = truth_slip_event_substeps;
        let sensors = self.sensors(bridge);
        let problem = self.problem(base, bridge);
        run(&ClosedLoopSetup {
            model,
            problem: &problem,
            policy,
            truth: &truth,
            sensors: &sensors,
            temperature_c: self.temperature_c,
            seed: self.seed,
        })
    }

    /// The drawn values in the order of
    /// [`ScenarioDistribution::drawn_names`].
    pub fn drawn_values(&self, distribution: &ScenarioDistribution) -> Vec<f64> {
        let mut values: Vec<f64> = distribution
            .effect_ranges()
            .iter()
            .flat_map(|(k, _)| self.effects.parameters(*k).unwrap_or_default())
            .collect();
        values.extend([self.position_noise_m, self.load_cell_noise_n, self.fold_m]);
        values.extend(self.temperature_c);
        for f in &self.faults {
            values.push(if f.present { 1.0 } else { 0.0 });
            values.push(f.part_position);
            values.extend(&f.values);
        }
        values.extend(self.fold_b_m);
        values
    }
}

/// Which part of a sweep one machine runs: shard `index` of `count`
/// (1-based), the scenarios `i` with `i mod count = index − 1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 1-based shard number.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// The whole sweep.
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// Parses `k/n` with 1 ≤ k ≤ n.
    pub fn parse(text: &str) -> Option<Shard> {
        let (k, n) = text.split_once('/')?;
        let (index, count) = (k.trim().parse().ok()?, n.trim().parse().ok()?);
        (1..=count)
            .contains(&index)
            .then_some(Shard { index, count })
    }

    /// The scenario indices of this shard among `total`.
    pub fn scenarios(self, total: usize) -> Vec<usize> {
        (self.index - 1..total).step_by(self.count).collect()
    }
}

/// [`RunResult::status`] of a run that never started (its truth or setup
/// failed).
pub const NOT_STARTED: &str = "not_started";

/// One policy on one scenario, reduced to plain numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// Scenario index.
    pub scenario: usize,
    /// Policy index.
    pub policy: usize,
    /// The run's verdict label ([`crate::plan::RunVerdict::label`]:
    /// `connected`, `limits_broken`, `not_reachable`, `command_limit`,
    /// `solver_failure`, `gap_out_of_tolerance`, `limits_not_restored`),
    /// `cycles_stopped` or `not_started`: what the truth did.
    pub status: String,
    /// The verdict is `connected`: connected by the controller, every true
    /// gap within the tolerance, no truth limit broken and every limit the
    /// start broke restored.
    pub succeeded: bool,
    /// Commands sent.
    pub commands: usize,
    /// Commands after the first that brought the largest measured gap
    /// below 60 mm (`None` if none did).
    pub corrective_commands: Option<usize>,
    /// Largest measured gap at the end, m.
    pub final_measured_gap_m: Option<f64>,
    /// Largest true gap at the end, m.
    pub final_true_gap_m: Option<f64>,
    /// Σ|u| over commands and motors, m.
    pub cable_travel_m: f64,
    /// Worst truth utilisation.
    pub worst_utilisation: f64,
    /// Truth limits broken (count over increments).
    pub truth_violations: usize,
    /// How far a truth force went beyond its bound at worst, N
    /// ([`Deployment::largest_force_breach_n`]; over every cycle with
    /// several; `None`: no force bound broken).
    pub largest_force_breach_n: Option<f64>,
    /// Largest measured gap after the first approach, m (the error a
    /// case memory learns to remove; `None` if no approach was measured).
    pub approach_gap_m: Option<f64>,
    /// What decided a run that did not connect
    /// ([`crate::plan::RunVerdict::binds`]: the limits broken, or the
    /// limits and motors the controller stopped on), in run order; for a
    /// run that did not start, why ([`DeployError::start_binds`]); empty
    /// for a connected run and where nothing is named.
    pub binds: Vec<String>,
    /// Median planning time per command, s (wall clock: the one value
    /// that varies from run to run).
    pub planning_time_median_s: Option<f64>,
}

impl RunResult {
    /// A run that did not start, its `binds` naming why
    /// ([`DeployError::start_binds`]).
    pub fn not_started(scenario: usize, policy: usize, why: &DeployError) -> RunResult {
        RunResult {
            binds: vec![why.start_binds()],
            ..RunResult::of(scenario, policy, None, 0.0)
        }
    }

    /// The numbers of `deployment` (`None`: it did not start).
    pub fn of(
        scenario: usize,
        policy: usize,
        deployment: Option<&Deployment>,
        tolerance_m: f64,
    ) -> RunResult {
        match deployment {
            Some(d) => {
                let verdict = d.verdict(tolerance_m);
                RunResult {
                    scenario,
                    policy,
                    status: verdict.label().to_string(),
                    succeeded: verdict.is_connected(),
                    binds: verdict.binds(),
                    commands: d.records.len(),
                    corrective_commands: d.corrective_commands,
                    final_measured_gap_m: d.final_measured_gap_m(),
                    final_true_gap_m: d.final_true_gap_m(),
                    cable_travel_m: d
                        .records
                        .iter()
                        .flat_map(|r| r.command_m.iter())
                        .map(|u| u.abs())
                        .sum(),
                    worst_utilisation: d.truth_worst_utilisation(),
                    truth_violations: d.truth_limit_violations,
                    largest_force_breach_n: d.largest_force_breach_n(),
                    approach_gap_m: d.approach_gap_m(),
                    planning_time_median_s: median(
                        d.records.iter().map(|r| r.planning_time_s).collect(),
                    ),
                }
            }
            None => RunResult {
                scenario,
                policy,
                status: NOT_STARTED.into(),
                succeeded: false,
                commands: 0,
                corrective_commands: None,
                final_measured_gap_m: None,
                final_true_gap_m: None,
                cable_travel_m: 0.0,
                worst_utilisation: 0.0,
                truth_violations: 0,
                largest_force_breach_n: None,
                approach_gap_m: None,
                binds: Vec::new(),
                planning_time_median_s: None,
            },
        }
    }
}

/// Collects each cycle's [`RunResult`] as [`run_cycles`] reports it.
struct CycleRuns {
    scenario: usize,
    policy: usize,
    tolerance_m: f64,
    results: Vec<RunResult>,
}

impl CycleObserver for CycleRuns {
    fn on_cycle(&mut self, _: &CycleResult, deployment: &Deployment, _: &Case) {
        self.results.push(RunResult::of(
            self.scenario,
            self.policy,
            Some(deployment),
            self.tolerance_m,
        ));
    }
}

impl RunResult {
    /// The result of `cycles` deployment-fold cycles on one scenario from
    /// the results of the cycles that ran (none: the first could not
    /// start, `not_started`): the last cycle's figures, since the cycles
    /// before it are the learning, except that limits broken in any cycle
    /// count (`truth_violations` summed, `worst_utilisation` and
    /// `largest_force_breach_n` the largest)
    /// and fail the run (its status is then `limits_broken`, and `binds`
    /// names the limits broken in every cycle, each once). A run whose
    /// truth could not be folded back before the last cycle has the status
    /// `cycles_stopped` and did not succeed.
    pub fn of_cycles(
        scenario: usize,
        policy: usize,
        per_cycle: Vec<RunResult>,
        cycles: usize,
    ) -> RunResult {
        let ran = per_cycle.len();
        let violations: usize = per_cycle.iter().map(|r| r.truth_violations).sum();
        let utilisation = per_cycle
            .iter()
            .map(|r| r.worst_utilisation)
            .fold(0.0, f64::max);
        let breach = per_cycle
            .iter()
            .filter_map(|r| r.largest_force_breach_n)
            .reduce(f64::max);
        let mut broken: Vec<String> = Vec::new();
        for r in per_cycle.iter().filter(|r| r.truth_violations > 0) {
            for b in &r.binds {
                if !broken.contains(b) {
                    broken.push(b.clone());
                }
            }
        }
        let Some(mut last) = per_cycle.into_iter().last() else {
            return RunResult::of(scenario, policy, None, 0.0);
        };
        if violations > 0 {
            last.status = "limits_broken".into();
            last.binds = broken;
        } else if ran < cycles {
            last.status = "cycles_stopped".into();
        }
        last.succeeded &= ran == cycles && violations == 0;
        last.truth_violations = violations;
        last.largest_force_breach_n = breach;
        last.worst_utilisation = utilisation;
        last
    }
}

/// What binds over policy `policy`'s runs that did not connect: each name
/// of their [`RunResult::binds`] with the number of runs naming it, most
/// frequent first (ties by name), and the number of those runs that name
/// nothing (a stop whose cause is no limit: a spent command budget or
/// nominal sequence, a solver failure, no reducing move; a gap out of
/// tolerance; `cycles_stopped` after a connected cycle). The limits a
/// run's truth breaks as built (`truth as built: LIMIT`) are context, not
/// what decided the run, and are left out ([`as_built_counts`] counts
/// them); a run that did not start keeps its reason
/// (`truth as built: implausible_strain`).
pub fn binding_counts(results: &[RunResult], policy: usize) -> (Vec<(String, usize)>, usize) {
    let mut counts: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    let mut unnamed = 0;
    for r in results
        .iter()
        .filter(|r| r.policy == policy && !r.succeeded)
    {
        let decided: Vec<&String> = r
            .binds
            .iter()
            .filter(|b| r.status == NOT_STARTED || !b.starts_with(AS_BUILT_PREFIX))
            .collect();
        if decided.is_empty() {
            unnamed += 1;
        }
        for name in decided {
            *counts.entry(name.as_str()).or_default() += 1;
        }
    }
    let mut out: Vec<(String, usize)> = counts
        .into_iter()
        .map(|(n, c)| (n.to_string(), c))
        .collect();
    // Stable: names stay in order within a count.
    out.sort_by_key(|(_, count)| std::cmp::Reverse(*count));
    (out, unnamed)
}

/// Of the runs of `policy` that broke truth limits (status
/// `limits_broken`), how many there are and how many name a limit their
/// truth breaks in its own as-built state (a bind after
/// [`AS_BUILT_PREFIX`], [`crate::plan::RunVerdict::binds`]).
pub fn as_built_counts(results: &[RunResult], policy: usize) -> (usize, usize) {
    let broke: Vec<&RunResult> = results
        .iter()
        .filter(|r| r.policy == policy && r.status == "limits_broken")
        .collect();
    let out_as_built = broke
        .iter()
        .filter(|r| r.binds.iter().any(|b| b.starts_with(AS_BUILT_PREFIX)))
        .count();
    (broke.len(), out_as_built)
}

/// What one policy did over all scenarios.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolicySummary {
    /// Runs.
    pub runs: usize,
    /// Successful runs.
    pub successes: usize,
    /// Wilson 95 % interval of the success rate.
    pub success_interval: (f64, f64),
    /// Median commands over successful runs.
    pub commands_median: Option<f64>,
    /// 95th percentile of commands over successful runs.
    pub commands_p95: Option<f64>,
    /// Median corrective commands over successful runs.
    pub corrective_median: Option<f64>,
    /// Median largest measured gap after the first approach over all
    /// started runs, m.
    pub approach_gap_median_m: Option<f64>,
    /// Median final largest true gap over all started runs, m.
    pub final_gap_median_m: Option<f64>,
    /// 95th percentile of it, m.
    pub final_gap_p95_m: Option<f64>,
    /// Median cable travel over started runs, m.
    pub travel_median_m: Option<f64>,
    /// Worst truth utilisation over all runs.
    pub worst_utilisation: f64,
    /// Truth limit violations over all runs.
    pub violations: usize,
    /// Runs that broke a truth limit (status `limits_broken`).
    pub runs_breaking_limits: usize,
    /// Of those, the runs whose truth breaks a limit in its own as-built
    /// state ([`as_built_counts`]).
    pub runs_breaking_limits_as_built: usize,
    /// Median over runs of the median planning time per command, s.
    pub planning_time_median_s: Option<f64>,
}

impl PolicySummary {
    /// Share of the runs that succeeded, 0–1 (0 without runs).
    pub fn success_rate(&self) -> f64 {
        self.successes as f64 / self.runs.max(1) as f64
    }
}

/// The summary of policy `policy` over `results`.
pub fn summarise_results(results: &[RunResult], policy: usize) -> PolicySummary {
    let mine: Vec<&RunResult> = results.iter().filter(|r| r.policy == policy).collect();
    let started: Vec<&RunResult> = mine
        .iter()
        .copied()
        .filter(|r| r.status != NOT_STARTED)
        .collect();
    let ok: Vec<&RunResult> = mine.iter().copied().filter(|r| r.succeeded).collect();
    let commands = || ok.iter().map(|r| r.commands as f64).collect::<Vec<_>>();
    let gaps = || {
        started
            .iter()
            .filter_map(|r| r.final_true_gap_m)
            .collect::<Vec<_>>()
    };
    let (runs_breaking_limits, runs_breaking_limits_as_built) = as_built_counts(results, policy);
    PolicySummary {
        runs: mine.len(),
        successes: ok.len(),
        success_interval: wilson_interval(ok.len(), mine.len()),
        commands_median: median(commands()),
        commands_p95: percentile(commands(), 0.95),
        corrective_median: median(
            ok.iter()
                .filter_map(|r| r.corrective_commands.map(|c| c as f64))
                .collect(),
        ),
        approach_gap_median_m: median(started.iter().filter_map(|r| r.approach_gap_m).collect()),
        final_gap_median_m: median(gaps()),
        final_gap_p95_m: percentile(gaps(), 0.95),
        travel_median_m: median(started.iter().map(|r| r.cable_travel_m).collect()),
        worst_utilisation: mine.iter().map(|r| r.worst_utilisation).fold(0.0, f64::max),
        violations: mine.iter().map(|r| r.truth_violations).sum(),
        runs_breaking_limits,
        runs_breaking_limits_as_built,
        planning_time_median_s: median(
            mine.iter()
                .filter_map(|r| r.planning_time_median_s)
                .collect(),
        ),
    }
}

/// Paired outcome of policies `a` and `b` over the scenarios both ran:
/// (both succeeded, only `a`, only `b`, neither).
pub fn paired_outcomes(results: &[RunResult], a: usize, b: usize) -> (usize, usize, usize, usize) {
    let success: BTreeMap<(usize, usize), bool> = results
        .iter()
        .map(|r| ((r.scenario, r.policy), r.succeeded))
        .collect();
    let scenarios: std::collections::BTreeSet<usize> = results.iter().map(|r| r.scenario).collect();
    let mut counts = (0, 0, 0, 0);
    for s in scenarios {
        match (success.get(&(s, a)), success.get(&(s, b))) {
            (Some(true), Some(true)) => counts.0 += 1,
            (Some(true), Some(false)) => counts.1 += 1,
            (Some(false), Some(true)) => counts.2 += 1,
            (Some(false), Some(false)) => counts.3 += 1,
            // A scenario one policy did not run is not a pair.
            _ => {}
        }
    }
    counts
}

/// How one quantity of policy `b` compares with policy `a`'s on the
/// scenarios both succeeded on (paired: the same truth and noise).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PairedDifference {
    /// Scenarios where `b`'s value is below `a`'s.
    pub b_below: usize,
    /// Scenarios where it is above.
    pub b_above: usize,
    /// Exact two-sided sign test of those counts (ties left out): whether
    /// `b`'s value is below `a`'s more often than above, or less.
    pub sign_test_p: f64,
    /// Mean of `b − a` over the pairs, ties included (many pairs of two
    /// policies end alike, which would put a median at 0); `None`
    /// without a pair.
    pub mean_difference: Option<f64>,
}

impl PairedDifference {
    /// The comparison of paired values `(a, b)`.
    fn of(pairs: &[(f64, f64)]) -> Self {
        let b_below = pairs.iter().filter(|(a, b)| b < a).count();
        let b_above = pairs.iter().filter(|(a, b)| b > a).count();
        let differences: Vec<f64> = pairs.iter().map(|(a, b)| b - a).collect();
        PairedDifference {
            b_below,
            b_above,
            sign_test_p: exact_sign_test_p(b_below, b_above),
            mean_difference: (!differences.is_empty())
                .then(|| differences.iter().sum::<f64>() / differences.len() as f64),
        }
    }
}

/// The runs of policies `a` and `b` on each scenario both succeeded on,
/// in scenario order.
fn succeeded_pairs(results: &[RunResult], a: usize, b: usize) -> Vec<(&RunResult, &RunResult)> {
    let by_run: BTreeMap<(usize, usize), &RunResult> = results
        .iter()
        .filter(|r| r.succeeded && (r.policy == a || r.policy == b))
        .map(|r| ((r.scenario, r.policy), r))
        .collect();
    by_run
        .iter()
        .filter(|((_, p), _)| *p == a)
        .filter_map(|((s, _), ra)| Some((*ra, *by_run.get(&(*s, b))?)))
        .collect()
}

/// The first policy of an evaluation against another on the same
/// scenarios: their paired outcomes and the exact McNemar test of them,
/// and on the scenarios both succeeded on, their final true gaps and
/// commands compared pair by pair (issue 22 judges a controller by all
/// three: success, the gap it ends at, and no more commands).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairedComparison {
    /// The first policy (index).
    pub a: usize,
    /// The other policy (index).
    pub b: usize,
    /// Scenarios both succeeded on.
    pub both: usize,
    /// Scenarios only `a` succeeded on.
    pub only_a: usize,
    /// Scenarios only `b` succeeded on.
    pub only_b: usize,
    /// Scenarios neither succeeded on.
    pub neither: usize,
    /// Exact McNemar p-value of the discordant pairs.
    pub mcnemar_p: f64,
    /// Final true gap (m) on the scenarios both succeeded on.
    pub final_true_gap: PairedDifference,
    /// Commands sent on the scenarios both succeeded on.
    pub commands: PairedDifference,
}

impl PairedComparison {
    /// Scenarios in the comparison.
    pub fn scenarios(&self) -> usize {
        self.both + self.only_a + self.only_b + self.neither
    }
}

/// The first of `policies` policies against each other one over `results`
/// ([`paired_outcomes`], [`mcnemar_exact_p`]).
pub fn first_against_others(results: &[RunResult], policies: usize) -> Vec<PairedComparison> {
    (1..policies)
        .map(|b| {
            let (both, only_a, only_b, neither) = paired_outcomes(results, 0, b);
            let succeeded = succeeded_pairs(results, 0, b);
            let gaps: Vec<(f64, f64)> = succeeded
                .iter()
                .filter_map(|(ra, rb)| Some((ra.final_true_gap_m?, rb.final_true_gap_m?)))
                .collect();
            let commands: Vec<(f64, f64)> = succeeded
                .iter()
                .map(|(ra, rb)| (ra.commands as f64, rb.commands as f64))
                .collect();
            PairedComparison {
                a: 0,
                b,
                both,
                only_a,
                only_b,
                neither,
                mcnemar_p: mcnemar_exact_p(only_a, only_b),
                final_true_gap: PairedDifference::of(&gaps),
                commands: PairedDifference::of(&commands),
            }
        })
        .collect()
}

/// Everything an evaluation runs with.
#[derive(Debug, Clone, Copy)]
pub struct EvaluationSetup<'a> {
    /// The structure every scenario's truth is drawn on: the bridge the
    /// controller's model file names, before its effects (see
    /// [`Scenario::with_setup`]).
    pub bridge: &'a Structure,
    /// The controller's model.
    pub model: &'a ForwardModel,
    /// The policies, compared on the same scenarios.
    pub policies: &'a [Policy],
    /// Where the scenarios come from (validated).
    pub distribution: &'a ScenarioDistribution,
    /// The problem; its start fold is replaced by each scenario's.
    pub problem: &'a DeploymentProblem,
    /// Seed of the scenario draws.
    pub seed: u64,
    /// Deployment-fold cycles per scenario, at least 1. With more than
    /// one, each (scenario, policy) run starts from an empty case memory
    /// and runs [`run_cycles`] on the scenario's truth; its result is
    /// [`RunResult::of_cycles`].
    pub cycles: usize,
    /// Whether every truth splits its increments at its joints' slip
    /// events ([`Scenario::with_truth_setup`]); `false` is the default
    /// truth, one step per 1 cm increment.
    pub truth_slip_event_substeps: bool,
}

/// Runs every policy on the scenarios `indices` in parallel; `run_done` is
/// called as each run ends (any thread, any order). The results come
/// back in (scenario, policy) order whatever the thread count. Each
/// scenario's truth is folded once ([`fold_truth`]) and every policy
/// deploys a copy of it: the same runs as folds of their own, at one fold
/// per scenario instead of one per policy.
pub fn evaluate(
    setup: &EvaluationSetup,
    indices: &[usize],
    run_done: &(dyn Fn() + Sync),
) -> (Vec<Scenario>, Vec<RunResult>) {
    let scenarios: Vec<Scenario> = indices
        .iter()
        .map(|&i| setup.distribution.draw(setup.seed, i))
        .collect();
    let tolerance = setup.problem.connection_tolerance_m;
    let results = scenarios
        .par_iter()
        // One task per scenario: runs take from 0.05 to a few seconds,
        // and chunks of them left a core idle at the end.
        .with_max_len(1)
        .flat_map_iter(|scenario| {
            // The truth's fold (about 40 % of a run on the wide
            // distribution) is the same for every policy: folded once
            // (`fold_truth`, the fold each deployment makes of its own),
            // each policy deploys a copy. Several cycles fold and unfold
            // their own truth.
            let folded = match setup.policies.first() {
                Some(policy) if setup.cycles <= 1 => Some(scenario.with_truth_setup(
                    setup.bridge,
                    setup.truth_slip_event_substeps,
                    setup.model,
                    setup.problem,
                    policy,
                    fold_truth,
                )),
                _ => None,
            };
            let runs: Vec<RunResult> = (0..setup.policies.len())
                .into_par_iter()
                .map(|p| {
                    let result = run_scenario(setup, scenario, p, folded.as_ref(), tolerance);
                    run_done();
                    result
                })
                .collect();
            runs
        })
        .collect();
    (scenarios, results)
}

/// Policy `p`'s run of `scenario`: one deployment from a copy of the
/// `folded` truth (or the reason it could not be folded), or the setup's
/// cycles from an empty case memory.
fn run_scenario(
    setup: &EvaluationSetup,
    scenario: &Scenario,
    p: usize,
    folded: Option<&Result<Plant, DeployError>>,
    tolerance: f64,
) -> RunResult {
    scenario.with_truth_setup(
        setup.bridge,
        setup.truth_slip_event_substeps,
        setup.model,
        setup.problem,
        &setup.policies[p],
        |run| {
            if setup.cycles <= 1 {
                let deployment = match folded {
                    Some(Ok(plant)) => {
                        deploy_guided(run, &Guidance::default(), Some(&mut plant.clone()), &mut ())
                    }
                    Some(Err(e)) => Err(e.clone()),
                    None => deploy_closed_loop(run, &mut ()),
                };
                match deployment {
                    Ok(d) => RunResult::of(scenario.index, p, Some(&d), tolerance),
                    Err(e) => RunResult::not_started(scenario.index, p, &e),
                }
            } else {
                let mut each = CycleRuns {
                    scenario: scenario.index,
                    policy: p,
                    tolerance_m: tolerance,
                    results: Vec::new(),
                };
                // A run that stopped early shows in its cycles'
                // results; one that could not start, by its reason.
                let end = run_cycles(
                    run,
                    setup.cycles,
                    &mut CaseMemory::default(),
                    None,
                    &mut each,
                );
                match end {
                    Err(e) if each.results.is_empty() => {
                        RunResult::not_started(scenario.index, p, &e)
                    }
                    _ => RunResult::of_cycles(scenario.index, p, each.results, setup.cycles),
                }
            }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference bridge and the controller's default model on it
    /// (frictionless).
    fn bridge_and_frictionless_model() -> (Structure, ForwardModel) {
        use crate::design::reference_bridge::{reference_bridge, BridgeParameters};
        use crate::model::{JointFriction, RelaxSettings};
        let bridge = reference_bridge(&BridgeParameters::default()).unwrap();
        let model = ForwardModel::new(
            bridge.clone(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap();
        (bridge, model)
    }

    /// The paired gap and command comparisons count only the scenarios
    /// both policies succeeded on, pair each run with the other policy's
    /// on the same scenario whatever the order of the results, leave ties
    /// out of the sign test but in the mean, and leave a run without a
    /// true gap out of the gap comparison alone.
    #[test]
    fn paired_gaps_and_commands_are_compared_on_the_scenarios_both_succeeded_on() {
        // (scenario, policy, succeeded, final true gap in mm, commands)
        let runs = [
            (0, 0, true, Some(12.0), 8),
            (0, 1, true, Some(4.0), 9),
            (1, 0, true, Some(20.0), 8),
            (1, 1, true, Some(6.0), 9),
            (2, 0, true, Some(5.0), 8),
            (2, 1, true, Some(5.0), 8),
            (3, 0, true, Some(3.0), 7),
            (3, 1, false, Some(30.0), 12),
            (4, 0, true, None, 8),
            (4, 1, true, Some(9.0), 7),
            (5, 0, true, Some(9.0), 8),
            (5, 1, true, Some(10.0), 8),
        ];
        let mut results: Vec<RunResult> = runs
            .iter()
            .map(
                |&(scenario, policy, succeeded, gap_mm, commands)| RunResult {
                    succeeded,
                    commands,
                    final_true_gap_m: gap_mm.map(|g: f64| 1e-3 * g),
                    ..RunResult::of(scenario, policy, None, 0.03)
                },
            )
            .collect();
        // A scenario only the first policy ran (a shard's cut) is no pair.
        results.push(RunResult {
            succeeded: true,
            commands: 8,
            final_true_gap_m: Some(0.001),
            ..RunResult::of(6, 0, None, 0.03)
        });
        // Out of order, and not by policy either: pairs go by scenario.
        results.reverse();
        results.swap(0, 2);
        let [pair] = first_against_others(&results, 2).try_into().unwrap();
        assert_eq!((pair.both, pair.only_a, pair.only_b), (5, 1, 0));
        // Gaps on scenarios 0, 1, 2 and 5 (4 has no gap for policy 0):
        // smaller twice, larger once, one tie.
        let g = pair.final_true_gap;
        assert_eq!((g.b_below, g.b_above), (2, 1));
        assert_eq!(g.sign_test_p, exact_sign_test_p(2, 1));
        let mean_mm = 1e3 * g.mean_difference.unwrap();
        assert!(
            (mean_mm - (-8.0 - 14.0 + 0.0 + 1.0) / 4.0).abs() < 1e-9,
            "{mean_mm}"
        );
        // Commands on scenarios 0, 1, 2, 4 and 5.
        let c = pair.commands;
        assert_eq!((c.b_below, c.b_above), (1, 2));
        assert!((c.mean_difference.unwrap() - 1.0 / 5.0).abs() < 1e-12);
        // One policy: nothing to compare.
        assert!(first_against_others(&results, 1).is_empty());
    }

    /// `evaluate` folds each scenario's truth once and every policy
    /// deploys a copy: the runs are those of each policy folding its own
    /// truth, number for number, with everything that reaches the fold
    /// drawn (a temperature and a thermal truth, uneven folds, the split
    /// truth; two policies). Regression (review, eighteenth session): the
    /// shared fold once took neither the temperature nor the split flag
    /// from the run it stands for, unnoticed by any test; and no policy
    /// at all indexed past the policies.
    #[test]
    fn a_truth_folded_once_per_scenario_deploys_as_folds_of_their_own() {
        let (bridge, model) = bridge_and_frictionless_model();
        let mut distribution = ScenarioDistribution {
            fold_m: [0.30, 0.45],
            fold_difference_m: Some([-0.15, -0.1]),
            temperature_c: Some([0.0, 40.0]),
            ..ScenarioDistribution::default()
        };
        distribution.effects.insert(
            "thermal".into(),
            BTreeMap::from([("expansion_per_k".into(), [1.0e-5, 1.4e-5])]),
        );
        let problem = DeploymentProblem::default();
        let stop_closer = Policy {
            margins: crate::plan::Margins {
                connection_m: 0.015,
                ..Policy::default().margins
            },
            ..Policy::default()
        };
        let policies = [Policy::default(), stop_closer];
        let setup = EvaluationSetup {
            bridge: &bridge,
            model: &model,
            policies: &policies,
            distribution: &distribution,
            problem: &problem,
            seed: 5,
            cycles: 1,
            truth_slip_event_substeps: true,
        };
        let runs = std::sync::atomic::AtomicUsize::new(0);
        let count = || {
            runs.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        };
        let (scenarios, shared) = evaluate(&setup, &[0, 1], &count);
        assert_eq!(runs.into_inner(), 4);
        let own: Vec<RunResult> = scenarios
            .iter()
            .flat_map(|s| {
                assert!(s.temperature_c.is_some() && s.fold_b_m.is_some());
                policies.iter().enumerate().map(|(p, policy)| {
                    s.with_truth_setup(&bridge, true, &model, &problem, policy, |run| {
                        match deploy_closed_loop(run, &mut ()) {
                            Ok(d) => RunResult::of(s.index, p, Some(&d), 0.03),
                            Err(e) => RunResult::not_started(s.index, p, &e),
                        }
                    })
                })
            })
            .collect();
        let timeless = |r: &RunResult| RunResult {
            planning_time_median_s: None,
            ..r.clone()
        };
        assert!(own.iter().all(|r| r.commands > 0), "{own:?}");
        assert_eq!(
            shared.iter().map(timeless).collect::<Vec<_>>(),
            own.iter().map(timeless).collect::<Vec<_>>()
        );
        let none = EvaluationSetup {
            policies: &[],
            ..setup
        };
        assert!(evaluate(&none, &[0, 1], &|| {}).1.is_empty());
    }

    /// `evaluate --slip-event-substeps` splits the truth's increments and
    /// leaves the controller's model as it is.
    #[test]
    fn truth_slip_event_substeps_reach_the_truth_alone() {
        let (bridge, model) = bridge_and_frictionless_model();
        let scenario = ScenarioDistribution::default().draw(1, 0);
        let problem = DeploymentProblem::default();
        let policy = Policy::default();
        for split in [false, true] {
            let (truth, planner) =
                scenario.with_truth_setup(&bridge, split, &model, &problem, &policy, |run| {
                    (
                        run.truth.settings.slip_event_substeps_enable,
                        run.model.settings().slip_event_substeps_enable,
                    )
                });
            assert_eq!((truth, planner), (split, false));
        }
    }

    /// Regression (issue 22, sixth session): `evaluate --model M` drew
    /// every scenario's truth on M's structure, so a model file with a
    /// stiffness error (a calibrated model) had that error applied to the
    /// truths a second time, and the controller was judged on bridges the
    /// distribution never drew. The truth must not depend on the model.
    #[test]
    fn a_controller_model_with_effects_leaves_the_truths_as_drawn() {
        use crate::model::effects::StiffnessErrorEffect;
        let (bridge, nominal) = bridge_and_frictionless_model();
        let calibrated = EffectModel::for_measurement(
            bridge.clone(),
            Effects {
                stiffness_error: Some(StiffnessErrorEffect {
                    strut_scale: 1.0,
                    cable_scale: 0.7,
                    spring_scale: 1.0,
                }),
                ..Effects::default()
            },
        )
        .forward_model()
        .unwrap();
        assert_ne!(
            calibrated.structure(),
            &bridge,
            "the premise: M carries its effect"
        );
        let scenario = ScenarioDistribution::default().draw(1, 0);
        let policy = Policy::default();
        let problem = DeploymentProblem::default();
        let truth_with = |model: &ForwardModel| {
            scenario.with_setup(&bridge, model, &problem, &policy, |setup| {
                assert!(std::ptr::eq(setup.model, model));
                (setup.truth.structure.clone(), setup.truth.effects.clone())
            })
        };
        let (structure, effects) = truth_with(&calibrated);
        assert_eq!(structure, bridge);
        assert_eq!((structure, effects), truth_with(&nominal));
    }

    fn cycle(commands: usize, violations: usize, utilisation: f64) -> RunResult {
        RunResult {
            scenario: 3,
            policy: 1,
            status: "connected".into(),
            succeeded: violations == 0,
            commands,
            corrective_commands: Some(1),
            final_measured_gap_m: Some(0.01),
            final_true_gap_m: Some(0.009),
            cable_travel_m: 4.0,
            worst_utilisation: utilisation,
            truth_violations: violations,
            largest_force_breach_n: (violations > 0).then_some(1.5 * violations as f64),
            approach_gap_m: Some(0.012),
            binds: if violations > 0 {
                vec![format!("cable A_axial_m0_{commands} min")]
            } else {
                Vec::new()
            },
            planning_time_median_s: None,
        }
    }

    /// Of the runs that broke limits, those whose truth is out of its
    /// limits as built are counted by their `truth as built:` bind; a
    /// run that did not start names its as-built failure the same way
    /// and is not counted (it broke nothing).
    #[test]
    fn runs_that_broke_limits_on_truths_out_of_limits_as_built_are_counted() {
        let mut runs = vec![
            cycle(9, 0, 0.4),
            cycle(7, 1, 0.9),
            cycle(7, 2, 0.9),
            cycle(7, 3, 0.9),
        ];
        for r in &mut runs {
            r.policy = 0;
            r.succeeded = false;
            r.status = "limits_broken".into();
        }
        runs[1]
            .binds
            .push(format!("{AS_BUILT_PREFIX}cable B_ring0_1 max"));
        runs[2].status = "not_started".into();
        runs[2].binds = vec![format!("{AS_BUILT_PREFIX}implausible_strain")];
        runs[3].status = "connected".into();
        runs[3].succeeded = true;
        assert_eq!(as_built_counts(&runs, 0), (2, 1));
        assert_eq!(as_built_counts(&runs, 1), (0, 0));
        // What binds leaves the as-built context out, not a run's reason
        // for not starting.
        let (counts, unnamed) = binding_counts(&runs, 0);
        assert_eq!(
            counts,
            vec![
                ("cable A_axial_m0_7 min".to_string(), 1),
                (format!("{AS_BUILT_PREFIX}implausible_strain"), 1),
            ]
        );
        assert_eq!(unnamed, 1);
    }

    /// What binds, over the runs that did not connect: each name with its
    /// runs, most frequent first, and the runs that name nothing.
    #[test]
    fn binding_counts_count_runs_per_name() {
        let mut runs = vec![cycle(9, 0, 0.4), cycle(7, 1, 0.9), cycle(7, 2, 0.9)];
        runs[0].succeeded = false;
        runs[0].status = "command_limit".into();
        runs[2].binds.push("segment A_cc1[3] min".into());
        let (counts, unnamed) = binding_counts(&runs, 1);
        assert_eq!(
            counts,
            vec![
                ("cable A_axial_m0_7 min".to_string(), 2),
                ("segment A_cc1[3] min".to_string(), 1)
            ]
        );
        assert_eq!(unnamed, 1);
        assert_eq!(binding_counts(&runs, 0), (Vec::new(), 0));
    }

    /// The last cycle's figures, but a limit broken while learning counts
    /// against the run, and a run cut short does not succeed.
    #[test]
    fn a_cycles_run_reports_its_last_cycle_and_every_cycles_violations() {
        let whole = RunResult::of_cycles(
            3,
            1,
            vec![
                cycle(9, 0, 0.4),
                cycle(7, 1, 0.6),
                cycle(10, 2, 0.9),
                cycle(8, 0, 0.5),
            ],
            4,
        );
        assert_eq!(whole.commands, 8);
        assert_eq!(whole.truth_violations, 3);
        // The worst breach of any cycle: neither the first cycle's that
        // broke a limit (1.5 N) nor the last cycle's none.
        assert_eq!(whole.largest_force_breach_n, Some(3.0));
        assert_eq!(whole.worst_utilisation, 0.9);
        assert!(!whole.succeeded);
        assert_eq!(whole.status, "limits_broken");
        // What the learning cycles broke, though the last cycle kept every
        // limit.
        assert_eq!(
            whole.binds,
            vec![
                "cable A_axial_m0_7 min".to_string(),
                "cable A_axial_m0_10 min".to_string()
            ]
        );

        let clean = RunResult::of_cycles(3, 1, vec![cycle(9, 0, 0.4), cycle(8, 0, 0.5)], 2);
        assert!(clean.succeeded);
        assert_eq!((clean.commands, clean.truth_violations), (8, 0));
        assert_eq!(clean.largest_force_breach_n, None);

        let cut = RunResult::of_cycles(3, 1, vec![cycle(9, 0, 0.4)], 2);
        assert_eq!(cut.status, "cycles_stopped");
        assert!(!cut.succeeded);

        let none = RunResult::of_cycles(3, 1, Vec::new(), 2);
        assert_eq!(
            (none.status.as_str(), none.succeeded),
            ("not_started", false)
        );
    }

    #[test]
    fn shards_partition_the_scenarios() {
        let mut all: Vec<usize> = (1..=3)
            .flat_map(|k| Shard { index: k, count: 3 }.scenarios(10))
            .collect();
        all.sort();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(Shard::parse("2/3"), Some(Shard { index: 2, count: 3 }));
        for bad in ["0/3", "4/3", "1/0", "a/b", "3"] {
            assert_eq!(Shard::parse(bad), None, "{bad}");
        }
    }

    #[test]
    fn a_scenario_depends_on_seed_and_index_only_and_stays_in_its_ranges() {
        let d = ScenarioDistribution::default();
        d.validate().unwrap();
        assert_eq!(d.draw(7, 5), d.draw(7, 5));
        assert_ne!(d.draw(7, 5), d.draw(7, 6));
        let names = d.drawn_names();
        for i in 0..50 {
            let s = d.draw(7, i);
            let values = s.drawn_values(&d);
            assert_eq!(values.len(), names.len());
            for (kind, ranges) in d.effect_ranges() {
                for (v, [lo, hi]) in s.effects.parameters(kind).unwrap().iter().zip(ranges) {
                    assert!((lo..=hi).contains(v), "{} {v}", kind.name());
                }
            }
            assert_eq!((s.fold_m, s.load_cell_noise_n), (0.40, 7.0));
        }
    }

    fn with_faults_and_uneven_folds(probability: f64) -> ScenarioDistribution {
        let mut d = ScenarioDistribution::default();
        for kind in FaultKind::ALL {
            let parameters = kind
                .parameters()
                .iter()
                .map(|p| (p.name.to_string(), [p.plausible.0, p.plausible.1]))
                .collect();
            d.faults.insert(
                kind.name().into(),
                FaultDistribution {
                    probability,
                    parameters,
                },
            );
        }
        d.fold_m = [0.1, 0.6];
        d.fold_difference_m = Some([-0.15, 0.15]);
        d
    }

    /// Faults and uneven folds are drawn after everything else, so the
    /// effects, noise and fold of a scenario are what the distribution
    /// without them draws; the faults land on real parts with their
    /// parameters in range, and the truth carries the present ones.
    #[test]
    fn faults_and_uneven_folds_are_drawn_after_the_rest_and_reach_the_truth() {
        let s =
            crate::design::reference_bridge(&crate::design::BridgeParameters::default()).unwrap();
        let plain = ScenarioDistribution {
            fold_m: [0.1, 0.6],
            ..ScenarioDistribution::default()
        };
        let always = with_faults_and_uneven_folds(1.0);
        let never = with_faults_and_uneven_folds(0.0);
        always.validate().unwrap();
        let names = always.drawn_names();
        for i in 0..20 {
            let (a, b, n) = (plain.draw(3, i), always.draw(3, i), never.draw(3, i));
            assert_eq!((&a.effects, a.fold_m), (&b.effects, b.fold_m));
            assert_eq!(a.position_noise_m, b.position_noise_m);
            assert_eq!(b.drawn_values(&always).len(), names.len());
            let truth = b.truth(&s).effects.faults;
            assert_eq!(truth.present(), FaultKind::ALL.to_vec());
            assert!(n.truth(&s).effects.faults.is_empty());
            for f in &b.faults {
                let (part, values) = truth.part_and_parameters(f.kind).unwrap();
                assert!(part < f.kind.part_count(&s));
                for (v, spec) in values.iter().zip(f.kind.parameters()) {
                    assert!(spec.plausible.0 <= *v && *v <= spec.plausible.1);
                }
            }
            // Half A's motors at fold_m, half B's at fold_b_m, in range.
            let fold_b = b.fold_b_m.unwrap();
            assert!((0.1..=0.6).contains(&fold_b) && (fold_b - b.fold_m).abs() <= 0.15 + 1e-12);
            let problem = b.problem(&DeploymentProblem::default(), &s);
            for (c, cable) in s.continuous_cables.iter().enumerate() {
                let want = if cable.id.starts_with('B') {
                    fold_b
                } else {
                    b.fold_m
                };
                assert_eq!(problem.start_payout_m.get(c), Some(want), "{}", cable.id);
                // The stroke holds the fold the drum reached, and is the
                // default 0.50 m where the fold lies inside it.
                assert_eq!(
                    problem.max_payout_m.get(c),
                    Some(want.max(0.5)),
                    "{}",
                    cable.id
                );
            }
            let limits = problem.motor_limits(s.continuous_cables.len()).unwrap();
            assert!(limits
                .start_payout_m
                .iter()
                .zip(&limits.max_payout_m)
                .all(|(p, m)| p <= m));
        }
        // With probability 0.3, about a third of the scenarios have each.
        let some = with_faults_and_uneven_folds(0.3);
        let had = (0..300)
            .filter(|&i| some.draw(9, i).faults[0].present)
            .count();
        assert!((60..=120).contains(&had), "{had} of 300");
    }

    #[test]
    fn validation_names_the_field() {
        let mut d = ScenarioDistribution::default();
        d.effects
            .get_mut("motor")
            .unwrap()
            .insert("slip_fraction".into(), [0.1, -0.1]);
        assert_eq!(
            d.validate().unwrap_err().field,
            "effects.motor.slip_fraction"
        );
        let mut d = ScenarioDistribution::default();
        d.effects.get_mut("motor").unwrap().remove("backlash_m");
        assert_eq!(d.validate().unwrap_err().field, "effects.motor.backlash_m");
        let mut d = ScenarioDistribution::default();
        d.effects.insert("gremlins".into(), BTreeMap::new());
        assert_eq!(d.validate().unwrap_err().field, "effects.gremlins");
        let d = ScenarioDistribution {
            fold_m: [0.4, f64::NAN],
            ..ScenarioDistribution::default()
        };
        assert_eq!(d.validate().unwrap_err().field, "fold_m");
        let d = ScenarioDistribution {
            temperature_c: None,
            ..ScenarioDistribution::plausible(&[EffectKind::Thermal])
        };
        assert_eq!(d.validate().unwrap_err().field, "temperature_c");
        ScenarioDistribution::plausible(&[EffectKind::Thermal])
            .validate()
            .unwrap();
        let mut d = with_faults_and_uneven_folds(0.5);
        d.faults.get_mut("member_error").unwrap().probability = -0.1;
        assert_eq!(
            d.validate().unwrap_err().field,
            "faults.member_error.probability"
        );
        let mut d = with_faults_and_uneven_folds(0.5);
        d.faults
            .get_mut("half_difference")
            .unwrap()
            .parameters
            .remove("cable_scale");
        assert_eq!(
            d.validate().unwrap_err().field,
            "faults.half_difference.cable_scale"
        );
    }
}
