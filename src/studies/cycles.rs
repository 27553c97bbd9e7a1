//! Repeated deployment-fold cycles on one truth: the learning curve of a
//! policy with a case memory.
//!
//! Each cycle deploys the truth in closed loop from where the last fold
//! left it ([`deploy_guided`]), then folds it back by paying out what the
//! cycle reeled in, in steps of at most a drum step, with no control. With
//! joint friction the folded truth is not the same from cycle to cycle
//! (stick and slip depend on the path), as on the real bridge.
//!
//! Before each cycle a policy with a `[memory]` section adapts the memory
//! to the cycle ([`crate::learn::adapt`]); after it every policy's cycle
//! is stored as a case, so that a memoryless run leaves a memory a memory
//! policy can start from.
//!
//! Randomness: the sensor noise of cycle `k` (1-based) is seeded with
//! [`scenario_seed`]`(seed, k)`; nothing else is drawn.

use serde::{Serialize, Serializer};

use super::deployment_log::{cycles_log, deployment_log};
use super::model_learning::{describe_learnt, learn_model};
use super::statistics::scenario_seed;
use crate::control::{
    deploy_guided, gap_reading_sd_m, ClosedLoopSetup, DeployError, Deployment, Guidance,
};
use crate::learn::{
    adapt, model_base, AdaptError, Advice, Case, CaseConditions, CaseLearning, CaseMemory,
    CaseModel, Decline, EndStateCache, FeatureScales,
};
use crate::measure::compare::compare;
use crate::model::{EffectKind, ForwardModel};
use crate::plan::{folded_start, PlanContext, PlanError};
use crate::sim::{EffectModel, Plant, PlantError};

/// One cycle's figures: a row of the learning curve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CycleResult {
    /// Cycle number, 1 for the first.
    pub cycle: usize,
    /// The deployment's verdict label ([`crate::plan::RunVerdict::label`]:
    /// `connected`, `limits_broken`, …): what the truth did.
    pub status: String,
    /// The verdict in plain words ([`crate::plan::RunVerdict::describe`]:
    /// what the truth did, and for a stop what binds).
    #[serde(skip)]
    pub verdict: String,
    /// Commands sent.
    pub commands: usize,
    /// Commands after the first that brought the largest measured gap
    /// below 60 mm.
    pub corrective_commands: Option<usize>,
    /// Commands of the first approach (with a memory, the take-up sent
    /// before the feedforward, if any, and the feedforward; else up to the
    /// first command predicted to connect).
    pub approach_commands: Option<usize>,
    /// Largest measured gap after the first approach, m.
    pub approach_gap_m: Option<f64>,
    /// Largest measured gap at the end, m.
    pub final_gap_m: Option<f64>,
    /// Largest true gap at the end, m.
    pub final_true_gap_m: Option<f64>,
    /// Limits the truth broke.
    pub truth_limit_violations: usize,
    /// The case learnt from (index in the memory), if any.
    pub learnt_from_case: Option<usize>,
    /// Commands of the learnt approach (the feedforward), if any: an
    /// `approach_commands` below it is a feedforward that ended early (a
    /// learnt command the model found beyond a limit), and
    /// `ilc_predicted_gap_m` was the prediction for the whole approach.
    pub learnt_commands: Option<usize>,
    /// Largest end gap the ILC update predicted, m (for the whole learnt
    /// approach, see `learnt_commands`).
    pub ilc_predicted_gap_m: Option<f64>,
    /// The ILC update's error at the end of its learnt approach: the
    /// largest |predicted − measured| gap over the midspan pairs, m
    /// ([`Case::learnt_approach_error_m`]; empty where the approach was cut
    /// short).
    pub ilc_error_m: Option<f64>,
    /// RMS of the cycle's readings against the controller's model for the
    /// cycle (its model file and, with model learning, every effect learnt
    /// beyond it: the structure and every effect, the motor's and the
    /// sensors' included, of which the planner's forward model takes the
    /// structural ones, [`planner_takes`]), replayed open-loop through the
    /// cycle from the design (the fold to the start, then the commands
    /// sent), in noise SDs: the learning curve of the model's error. Every
    /// reading is held out: nothing was fitted to it. From the second
    /// cycle on, the truth starts where the last fold-back left it and the
    /// replay from the design, so even the truth's own model may read a
    /// little above 1 where friction made the paths differ. `None` where
    /// no model was given or its replay failed.
    pub planning_model_rms: Option<f64>,
    /// The self-diagnosis after the cycle (`[memory]
    /// model_learning_enable`): what it learnt and whether the next cycle
    /// plans on it; `None` where the policy does not learn its model.
    pub model_update: Option<ModelUpdateResult>,
    /// Why the cycle planned on the model file although a model had been
    /// learnt (it could not be planned on), in words.
    #[serde(skip)]
    pub planning_note: Option<String>,
    /// Why the memory gave no guidance although it held cases
    /// (serialised as its message).
    #[serde(serialize_with = "error_message")]
    pub adaptation_error: Option<AdaptError>,
    /// Why the memory declined to guide the cycle although it held cases
    /// (no case connected, or the newest learnt cycle refuted the ILC
    /// update: [`crate::learn::acceptance`]); serialised as its message.
    #[serde(serialize_with = "display_message")]
    pub memory_declined: Option<Decline>,
    /// Wall-clock planning time of the cycle (adaptation and every
    /// command), s: the only value not a function of the inputs.
    #[serde(skip)]
    pub planning_time_s: f64,
}

/// What the self-diagnosis after a cycle did ([`learn_model`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelUpdateResult {
    /// Whether the model fitted on the cycle's log replaced the one the
    /// cycle was planned on (it predicted the held-out readings better).
    pub accepted: bool,
    /// Whether the self-diagnosis ran (else `verdict` says why not).
    pub ran: bool,
    /// Whether the two RMS are over readings held out of the fit (false
    /// on a one-cycle log: in-sample).
    pub held_out: bool,
    /// Whether it fitted anything beyond the model the cycle was planned
    /// on (false: nothing learnt).
    pub changed: bool,
    /// Held-out RMS residual of the self-diagnosis's log against the
    /// model the cycle was planned on, noise SDs (NaN where it did not
    /// run).
    pub planned_rms: f64,
    /// The same readings against the model fitted on the log.
    pub fitted_rms: f64,
    /// The effects the next cycle's model carries beyond the controller's
    /// model file, in words ([`describe_learnt`]).
    pub carried: String,
    /// The part of them the planner takes ([`planner_takes`]), in words.
    pub planner_takes: String,
    /// The diagnosis's verdict in words, or why it failed.
    pub verdict: String,
    /// Why something found was not learnt, in words.
    pub note: Option<String>,
    /// Wall-clock time of the self-diagnosis, s (not a function of the
    /// inputs).
    #[serde(skip)]
    pub time_s: f64,
}

/// Receives each cycle as it ends (the CLI stores the case and moves its
/// progress bar; numerics never print).
pub trait CycleObserver {
    /// Called before the first cycle where the model learnt before is not
    /// taken up (why, in words).
    fn on_start(&mut self, _note: &str) {}
    /// Called after cycle `result.cycle`, with its deployment and the case
    /// it added to the memory.
    fn on_cycle(&mut self, result: &CycleResult, deployment: &Deployment, case: &Case);
}

impl CycleObserver for () {
    fn on_cycle(&mut self, _: &CycleResult, _: &Deployment, _: &Case) {}
}

/// Why the cycles stopped early.
#[derive(Debug, Clone, PartialEq)]
pub struct CyclesEnd {
    /// The cycles run.
    pub results: Vec<CycleResult>,
    /// `None` when every cycle ran; otherwise why the run stopped (the
    /// truth could not be folded back).
    pub stopped: Option<FoldBackFailure>,
}

/// The truth could not be folded back after a cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct FoldBackFailure {
    /// The cycle after which the fold failed, 1 for the first.
    pub after_cycle: usize,
    /// What the truth plant said.
    pub error: PlantError,
}

impl FoldBackFailure {
    /// Plain words.
    pub fn describe(&self) -> String {
        format!(
            "folding back after cycle {}: {}",
            self.after_cycle, self.error
        )
    }
}

/// An optional error as its message.
fn error_message<S: Serializer>(
    error: &Option<AdaptError>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    display_message(error, serializer)
}

/// An optional value as its message.
fn display_message<S: Serializer, T: std::fmt::Display>(
    value: &Option<T>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    value.as_ref().map(|e| e.to_string()).serialize(serializer)
}

/// Runs `cycles` cycles of `setup` (its truth's hidden effects fixed for
/// every cycle; its seed that of the sensor noise, see the module
/// documentation), learning into `memory` (cases are appended to it).
/// With `planning`, the controller's model as the measurement tools replay
/// it (the model file `setup.model` was built from; not checked), each
/// cycle's readings are compared with the model it was planned on
/// ([`CycleResult::planning_model_rms`]), and a policy with
/// [`crate::plan::MemorySettings::model_learning_enable`] learns that
/// model between cycles ([`learn_model`]), starting from the latest model
/// stored in `memory`. Without `planning` no model is learnt (each
/// cycle's [`CycleResult::model_update`] says so).
/// Errors only when the first deployment cannot start.
pub fn run_cycles(
    setup: &ClosedLoopSetup,
    cycles: usize,
    memory: &mut CaseMemory,
    planning: Option<&EffectModel>,
    observer: &mut dyn CycleObserver,
) -> Result<CyclesEnd, DeployError> {
    let (problem, policy) = (setup.problem, setup.policy);
    let structure = setup.model.structure();
    let gap_reading_sd = gap_reading_sd_m(structure, setup.sensors);
    let motors = problem
        .motor_limits(structure.continuous_cables.len())
        .map_err(PlanError::from)?;
    let mut plant = Plant::new(
        setup.truth,
        Some(&motors.start_payout_m),
        setup.temperature_c,
    )
    .map_err(DeployError::TruthStart)?;
    let learns_model = policy.memory.filter(|m| m.model_learning_enable);
    let (mut carried, start_note) = match (learns_model, planning) {
        (Some(_), Some(nominal)) => learnt_start(memory, nominal),
        _ => (None, None),
    };
    if let Some(note) = &start_note {
        observer.on_start(note);
    }
    let scales = FeatureScales::default();
    let mut end_states = EndStateCache::default();
    // The model file's folded start and planning context, made once.
    let nominal_start = folded_start(setup.model, problem, policy.increment_m)?;
    let nominal_context = PlanContext::new(setup.model, problem, policy, &nominal_start)?;
    // The models of the learnt effects they were made for, kept until the
    // learnt model changes (a fold to the start costs a relaxation).
    let mut plan: Option<LearntPlan> = None;
    let mut plan_of: Vec<crate::learn::LearntEffect> = Vec::new();
    let mut recent: std::collections::VecDeque<Deployment> = Default::default();
    let mut results = Vec::new();
    for cycle in 1..=cycles {
        let clock = std::time::Instant::now();
        // The model this cycle plans on: what was learnt beyond the model
        // file, or the model file's.
        let mut planning_note = None;
        let wanted = match (&carried, planning) {
            (Some(c), Some(_)) => c.effects.clone(),
            _ => Vec::new(),
        };
        if wanted != plan_of {
            let before = plan.as_ref().map(|l| l.planner_effects.clone());
            plan = match (&carried, planning) {
                (Some(c), Some(nominal)) if !wanted.is_empty() => {
                    match learnt_plan(nominal, c, problem, policy) {
                        Ok(l) => Some(l),
                        Err(e) => {
                            planning_note = Some(format!(
                                "the model learnt before cannot be planned on ({e}): this cycle plans on the model file, and the learning starts again"
                            ));
                            carried = None;
                            None
                        }
                    }
                }
                _ => None,
            };
            plan_of = if plan.is_some() { wanted } else { Vec::new() };
            if plan.as_ref().map(|l| l.planner_effects.clone()) != before {
                // The cached end state was relaxed on another model.
                end_states = EndStateCache::default();
            }
        }
        let learnt_context;
        let (model, start, context) = match plan.as_ref().and_then(|l| l.planner.as_ref()) {
            Some((m, start)) => {
                learnt_context = PlanContext::new(m, problem, policy, start)?;
                (m, start, &learnt_context)
            }
            None => (setup.model, &nominal_start, &nominal_context),
        };
        let replayed = plan.as_ref().map(|l| &l.replayed).or(planning);
        // The start gap is measured inside the deployment; retrieval
        // compares what is known before it.
        let conditions = CaseConditions {
            temperature_c: setup.temperature_c,
            fold_m: motors.start_payout_m.clone(),
            start_gap_m: None,
            payout_scale: Vec::new(),
        };
        let (advice, adaptation_error) = match &policy.memory {
            Some(settings) => {
                match adapt(
                    memory,
                    &conditions,
                    context,
                    start,
                    settings,
                    &scales,
                    gap_reading_sd,
                    &mut end_states,
                ) {
                    Ok(a) => (a, None),
                    Err(e) => (Advice::Empty, Some(e)),
                }
            }
            None => (Advice::Empty, None),
        };
        let memory_declined = match &advice {
            Advice::Declined(d) => Some(*d),
            _ => None,
        };
        let adaptation = advice.adaptation();
        let adaptation_time_s = clock.elapsed().as_secs_f64();
        let guidance = adaptation
            .as_ref()
            .map_or_else(Guidance::default, |a| a.guidance.clone());
        let run = ClosedLoopSetup {
            model,
            seed: scenario_seed(setup.seed, cycle),
            ..*setup
        };
        let d = deploy_guided(&run, &guidance, Some(&mut plant), &mut ())?;
        let mut case = Case::of_deployment(&d, structure, setup.sensors, setup.temperature_c);
        case.learning = adaptation.as_ref().map(|a| CaseLearning {
            from_case: a.case_index,
            from_gap_m: a.ilc.last_end_gap_m,
            predicted_gaps_m: a.ilc.predicted_end_gaps_m.clone(),
            learnt_commands: a.ilc.commands_m.len(),
            approach_completed: d.learnt_approach_completed.unwrap_or(false),
        });
        let planning_model_rms = replayed.and_then(|m| planning_model_rms(m, &d, setup));
        if learns_model.is_some() {
            recent.push_back(d.clone());
            // The older cycle fitted, the newest held out (see
            // `model_learning`: why two).
            while recent.len() > 2 {
                recent.pop_front();
            }
        }
        let model_update = learns_model.map(|settings| {
            let clock = std::time::Instant::now();
            let Some(nominal) = planning else {
                return ModelUpdateResult::failed(
                    "no model to replay the log through (the model file was not given)".into(),
                    &carried,
                    0.0,
                );
            };
            let window: Vec<&Deployment> = recent.iter().collect();
            let log = cycles_log(&window, &nominal.structure.name, setup.sensors.to_vec());
            match learn_model(nominal, carried.as_ref(), &log, &settings) {
                Ok(update) => {
                    let result = ModelUpdateResult {
                        accepted: update.model.accepted,
                        ran: true,
                        held_out: update.model.held_out,
                        changed: update.changed,
                        planned_rms: update.model.planned_rms,
                        fitted_rms: update.model.fitted_rms,
                        carried: describe_learnt(&update.model.effects),
                        planner_takes: describe_learnt(&planner_part(&update.model, nominal)),
                        verdict: update.verdict,
                        note: update.note,
                        time_s: clock.elapsed().as_secs_f64(),
                    };
                    case.model = Some(update.model.clone());
                    carried = Some(update.model);
                    result
                }
                Err(e) => ModelUpdateResult::failed(
                    e.to_string(),
                    &carried,
                    clock.elapsed().as_secs_f64(),
                ),
            }
        });
        let verdict = d.verdict(setup.problem.connection_tolerance_m);
        let result = CycleResult {
            cycle,
            status: verdict.label().to_string(),
            verdict: verdict.describe(),
            commands: d.records.len(),
            corrective_commands: d.corrective_commands,
            approach_commands: d.approach_commands,
            approach_gap_m: d.approach_gap_m(),
            final_gap_m: d.final_measured_gap_m(),
            final_true_gap_m: d.final_true_gap_m(),
            truth_limit_violations: d.truth_limit_violations,
            learnt_from_case: adaptation.as_ref().map(|a| a.case_index),
            learnt_commands: adaptation.as_ref().map(|a| a.ilc.commands_m.len()),
            ilc_predicted_gap_m: adaptation.as_ref().map(|a| a.ilc.predicted_end_gap_m),
            ilc_error_m: case.learnt_approach_error_m(),
            planning_model_rms,
            model_update,
            planning_note,
            adaptation_error,
            memory_declined,
            planning_time_s: adaptation_time_s
                + d.records.iter().map(|r| r.planning_time_s).sum::<f64>(),
        };
        observer.on_cycle(&result, &d, &case);
        memory.cases.push(case);
        results.push(result);
        if cycle == cycles {
            break;
        }
        if let Err(error) = fold_back(&mut plant, &d.commands(), &motors.max_step_m, setup) {
            return Ok(CyclesEnd {
                results,
                stopped: Some(FoldBackFailure {
                    after_cycle: cycle,
                    error,
                }),
            });
        }
    }
    Ok(CyclesEnd {
        results,
        stopped: None,
    })
}

impl ModelUpdateResult {
    /// `accepted` (the next cycle plans on the model fitted on this
    /// cycle's log), `not_better` (the fit did not predict the held-out
    /// readings better: the model before is carried on), `nothing_learnt`
    /// (nothing trusted beyond that model was found) or `not_run` (the
    /// self-diagnosis could not run).
    pub fn outcome(&self) -> &'static str {
        match (self.ran, self.changed, self.accepted) {
            (false, _, _) => "not_run",
            (true, _, true) => "accepted",
            (true, true, false) => "not_better",
            (true, false, false) => "nothing_learnt",
        }
    }

    /// A self-diagnosis that could not run: the model carried on
    /// unchanged, `why` as its verdict.
    fn failed(why: String, carried: &Option<CaseModel>, time_s: f64) -> ModelUpdateResult {
        ModelUpdateResult {
            accepted: false,
            ran: false,
            held_out: false,
            changed: false,
            planned_rms: f64::NAN,
            fitted_rms: f64::NAN,
            carried: describe_learnt(carried.as_ref().map_or(&[][..], |c| &c.effects[..])),
            planner_takes: String::new(),
            verdict: format!("not run: {why}"),
            note: None,
            time_s,
        }
    }
}

/// Whether the planner takes a learnt effect of `kind` beyond the model
/// file `nominal`: the stiffness and joint-mass errors always; friction
/// only where the model file plans with friction (planning through
/// stick-slip is what fails, issue 22); flexible supports only where the
/// model file has them (they add support nodes the controller's bridge
/// lacks otherwise); cable seats only where the model file has them (a
/// frictionless model over seats stops as many runs the default connects
/// safely as it keeps from breaking limits, `docs/controller.md`, how a
/// run is judged); the motor, thermal and load-cell effects never (they
/// act in the plant and the readings, not in the forward model).
pub fn planner_takes(kind: EffectKind, nominal: &EffectModel) -> bool {
    match kind {
        EffectKind::StiffnessError | EffectKind::JointMassError => true,
        EffectKind::JointFriction
        | EffectKind::SupportFlexibility
        | EffectKind::JointEccentricity => nominal.effects.parameters(kind).is_some(),
        EffectKind::Motor | EffectKind::Thermal | EffectKind::LoadCellBias => false,
    }
}

/// The learnt effects of `learnt` the planner takes beyond `nominal`:
/// those of a kind it takes ([`planner_takes`]) with no rival the log
/// could not tell from them (`LearntEffect::rival`).
fn planner_part(learnt: &CaseModel, nominal: &EffectModel) -> Vec<crate::learn::LearntEffect> {
    learnt
        .effects
        .iter()
        .filter(|e| e.rival.is_none() && e.kind().is_some_and(|k| planner_takes(k, nominal)))
        .cloned()
        .collect()
}

/// A cycle's models after a learnt model.
struct LearntPlan {
    /// The planner's model, with its folded start: the model file with the
    /// learnt effects it takes (`None` where it takes none: the model
    /// file's, as without learning).
    planner: Option<(ForwardModel, crate::model::DeploymentState)>,
    /// The planner's effects beyond the model file (to tell a change of
    /// model).
    planner_effects: Vec<crate::learn::LearntEffect>,
    /// The measurement tools': the model file with every learnt effect.
    replayed: EffectModel,
}

/// The models a cycle runs on after `learnt` ([`planner_takes`]), its
/// folded start and a check that it can be planned on; the error in words.
fn learnt_plan(
    nominal: &EffectModel,
    learnt: &CaseModel,
    problem: &crate::plan::DeploymentProblem,
    policy: &crate::plan::Policy,
) -> Result<LearntPlan, String> {
    let replayed = EffectModel {
        effects: learnt.effects_on(&nominal.effects),
        ..nominal.clone()
    };
    let taken = CaseModel {
        effects: planner_part(learnt, nominal),
        ..learnt.clone()
    };
    let planner = if taken.effects.is_empty() {
        None
    } else {
        let planned = EffectModel {
            effects: taken.effects_on(&nominal.effects),
            ..nominal.clone()
        };
        let planner = planned.forward_model().map_err(|e| e.to_string())?;
        let start =
            folded_start(&planner, problem, policy.increment_m).map_err(|e| e.to_string())?;
        PlanContext::new(&planner, problem, policy, &start).map_err(|e| e.to_string())?;
        Some((planner, start))
    };
    Ok(LearntPlan {
        planner,
        planner_effects: taken.effects,
        replayed,
    })
}

/// The model a run starts from: the newest case's, if it was learnt
/// beyond this model file (`nominal`); else none, with why (a case
/// learnt beyond another model file, or a newest case that learnt no
/// model, when an older one did).
fn learnt_start(memory: &CaseMemory, nominal: &EffectModel) -> (Option<CaseModel>, Option<String>) {
    let base = model_base(&nominal.structure.name, &nominal.effects);
    match memory.cases.last().map(|c| &c.model) {
        Some(Some(m)) if m.base == base => (Some(m.clone()), None),
        Some(Some(_)) => (
            None,
            Some("the memory's newest model was learnt beyond another model file: starting from this one".into()),
        ),
        Some(None) if memory.cases.iter().any(|c| c.model.is_some()) => (
            None,
            Some("the memory's newest case learnt no model (a policy without model learning ran it): starting from the model file".into()),
        ),
        _ => (None, None),
    }
}

/// RMS `z` of deployment `d`'s readings against `planning` replayed
/// through it; `None` where the replay fails or no reading compares.
fn planning_model_rms(
    planning: &EffectModel,
    d: &Deployment,
    setup: &ClosedLoopSetup,
) -> Option<f64> {
    let log = deployment_log(d, &planning.structure.name, setup.sensors.to_vec());
    let c = compare(planning, &log).ok()?;
    (c.overall.count > 0).then_some(c.overall.rms)
}

/// Folds the truth back: pays out what `commands_m` reeled in (their sum,
/// negated), in equal steps of at most each drum's step limit.
fn fold_back(
    plant: &mut Plant,
    commands_m: &[Vec<f64>],
    max_step_m: &[f64],
    setup: &ClosedLoopSetup,
) -> Result<(), PlantError> {
    let motors = max_step_m.len();
    let mut total = vec![0.0; motors];
    for u in commands_m {
        for (t, d) in total.iter_mut().zip(u) {
            *t -= d;
        }
    }
    let steps = total
        .iter()
        .zip(max_step_m)
        .map(|(t, s)| (t.abs() / s * (1.0 - 1e-12)).ceil() as usize)
        .max()
        .unwrap_or(0);
    for _ in 0..steps {
        let step: Vec<f64> = total.iter().map(|t| t / steps as f64).collect();
        plant.apply(&step, setup.temperature_c, &mut ())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{MotorDirection, SensitivityError};

    /// Which learnt effects the planner takes: the structural ones always;
    /// friction, supports and seats only where the model file has them;
    /// motor, thermal and load-cell effects never.
    #[test]
    fn the_planner_takes_a_learnt_seat_only_over_a_model_with_seats() {
        use crate::design::{reference_bridge, BridgeParameters};
        let plain = EffectModel::for_measurement(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            crate::model::Effects::default(),
        );
        let seated = EffectModel {
            effects: plain
                .effects
                .with_parameters(EffectKind::JointEccentricity, &[0.02]),
            ..plain.clone()
        };
        for kind in EffectKind::ALL {
            let expected = match kind {
                EffectKind::StiffnessError | EffectKind::JointMassError => (true, true),
                EffectKind::JointEccentricity => (false, true),
                _ => (false, false),
            };
            assert_eq!(
                (planner_takes(kind, &plain), planner_takes(kind, &seated)),
                expected,
                "{}",
                kind.name()
            );
        }
    }

    #[test]
    fn a_fold_back_failure_and_an_adaptation_error_read_as_before() {
        let stop = FoldBackFailure {
            after_cycle: 2,
            error: PlantError::SeatsUnsettled {
                cycle: 0,
                step: 1,
                change_m: 2e-3,
            },
        };
        assert_eq!(
            stop.describe(),
            "folding back after cycle 2: cycle 0, step 1: the cable-seat arcs did not settle (2.00e-3 m still changing)"
        );
        let error = AdaptError::Sensitivity {
            case: 3,
            error: SensitivityError::UnstableTangent {
                motor: 1,
                direction: MotorDirection::PayOut,
            },
        };
        let text = "case 3: no sensitivities at its end: motor 1, PayOut: the tangent stiffness is singular or unstable";
        assert_eq!(error.to_string(), text);
        let result = CycleResult {
            cycle: 1,
            status: "connected".into(),
            verdict: String::new(),
            commands: 8,
            corrective_commands: None,
            approach_commands: None,
            approach_gap_m: None,
            final_gap_m: None,
            final_true_gap_m: None,
            truth_limit_violations: 0,
            learnt_from_case: None,
            learnt_commands: None,
            ilc_predicted_gap_m: None,
            ilc_error_m: None,
            planning_model_rms: None,
            model_update: None,
            planning_note: None,
            adaptation_error: Some(error),
            memory_declined: Some(Decline::NoConnectedCase { cases: 2 }),
            planning_time_s: 0.0,
        };
        let json = serde_json::to_value(&result).unwrap();
        assert_eq!(json["adaptation_error"], text);
        assert_eq!(
            json["memory_declined"],
            "none of the memory's 2 cases connected: no approach to learn from"
        );
        let json = serde_json::to_value(CycleResult {
            adaptation_error: None,
            ..result
        })
        .unwrap();
        assert!(json["adaptation_error"].is_null());
    }
}
