//! What the memory gives a new cycle: the case to learn from, and the
//! ILC-updated commands and payout-scale prior it leads to.
//!
//! 1. **Retrieval.** The memory's `neighbours` nearest cases that
//!    connected to the new cycle's conditions; of those within
//!    `match_distance` (the same conditions), the most recent, since
//!    iterative learning continues from the last trial; with none that
//!    near, the nearest. Then the acceptance check ([`super::acceptance`]):
//!    where the newest learnt cycle under these conditions refuted the
//!    update, no guidance.
//! 2. **Linearisation at the case's end.** The case's drum commands, made
//!    cable motion by its estimated payout scale, are applied to the
//!    controller's model (`solve_case_end` says where that solve
//!    starts); at that end state the
//!    tangent gives the gaps' and limits' sensitivities to each motor's
//!    payout ([`crate::plan::search::step_data`], the planner's own
//!    linearisation), scaled to drum payout.
//! 3. **The ILC update** ([`super::ilc`]) of the case's commands, their
//!    trailing corrections merged ([`merged_tail`]), against
//!    its final measured gap vectors, within the motor and member limits.
//!
//! The result is a [`Guidance`] for [`crate::control::deploy_guided`]: the
//! updated commands as feedforward and the case's payout scale as the
//! estimator's prior; or why the memory gives none ([`Advice`]).

use nalgebra::DMatrix;
use thiserror::Error;

use super::acceptance::{refutation, Decline};
use super::case::{Case, CaseConditions};
use super::ilc::{learn_commands, IlcData, IlcUpdate};
use super::memory::{CaseMemory, FeatureScales};
use crate::control::PayoutScaleEstimator;
use crate::control::{CaseTakeUp, Guidance};
use crate::model::{DeploymentState, RelaxStatus, SensitivityError, Workspace};
use crate::plan::response::{IndependentParts, PayoutResponse};
use crate::plan::search::step_data;
use crate::plan::{LearntPath, MemorySettings, PlanContext};

/// The model's state at the end of the last case adapted, kept between
/// adaptations. On a frictionless model the state is a function of the
/// payout alone, so the next case's end is reached from it by the
/// difference of the payouts (a few millimetres between cycles), without
/// relaxing the as-built state again. With friction the path matters and
/// the cache is not used.
#[derive(Debug, Clone, Default)]
pub struct EndStateCache {
    last: Option<DeploymentState>,
}

/// What the memory gives a new cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct Adaptation {
    /// Index of the case learnt from.
    pub case_index: usize,
    /// Its scaled distance from the new cycle's conditions.
    pub distance: f64,
    /// The ILC update.
    pub ilc: IlcUpdate,
    /// Feedforward and estimator prior for the deployment.
    pub guidance: Guidance,
}

/// What the memory gives a new cycle: nothing to learn from, a reasoned
/// refusal, or guidance.
#[derive(Debug, Clone, PartialEq)]
pub enum Advice {
    /// The memory holds no case.
    Empty,
    /// The memory holds cases but gives no guidance, for the reason given:
    /// the cycle runs as the memoryless controller would.
    Declined(Decline),
    /// Guidance from one case.
    Guided(Adaptation),
}

impl Advice {
    /// The adaptation, if the memory gave guidance.
    pub fn adaptation(&self) -> Option<&Adaptation> {
        match self {
            Advice::Guided(a) => Some(a),
            _ => None,
        }
    }
}

/// Why a case could not be adapted to the new cycle.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AdaptError {
    /// The case's commands are not for this bridge's motors.
    #[error("case {case}: its commands are for {found} motors, the bridge has {expected}")]
    Motors {
        /// Case index.
        case: usize,
        /// Motors in the case.
        found: usize,
        /// Motors of the bridge.
        expected: usize,
    },
    /// The model cannot follow the case's commands to their end.
    #[error("case {case}: the model, following its commands: {}", .status.describe())]
    EndState {
        /// Case index.
        case: usize,
        /// The solve's status.
        status: RelaxStatus,
    },
    /// No tangent at the end state.
    #[error("case {case}: no sensitivities at its end: {error}")]
    Sensitivity {
        /// Case index.
        case: usize,
        /// Why the tangent failed.
        error: SensitivityError,
    },
}

/// The case a cycle with `conditions` learns from (see the module
/// documentation), with its distance; `None` where no case of the memory
/// connected.
pub fn retrieve(
    memory: &CaseMemory,
    conditions: &CaseConditions,
    settings: &MemorySettings,
    scales: &FeatureScales,
) -> Option<(usize, f64)> {
    let near = memory.nearest_where(conditions, settings.neighbours, scales, |c| c.connected());
    near.iter()
        .filter(|n| n.distance <= settings.match_distance)
        .max_by_key(|n| n.index)
        .or(near.first())
        .map(|n| (n.index, n.distance))
}

/// The adaptation of `memory` to a cycle with `conditions`, planned with
/// `context` from the model's folded `start`, its gaps read with noise SD
/// `gap_reading_sd_m` (m, one pair's gap).
#[allow(clippy::too_many_arguments)]
pub fn adapt(
    memory: &CaseMemory,
    conditions: &CaseConditions,
    context: &PlanContext,
    start: &DeploymentState,
    settings: &MemorySettings,
    scales: &FeatureScales,
    gap_reading_sd_m: f64,
    cache: &mut EndStateCache,
) -> Result<Advice, AdaptError> {
    if memory.cases.is_empty() {
        return Ok(Advice::Empty);
    }
    let Some((case_index, distance)) = retrieve(memory, conditions, settings, scales) else {
        return Ok(Advice::Declined(Decline::NoConnectedCase {
            cases: memory.cases.len(),
        }));
    };
    if let Some(d) = refutation(memory, conditions, settings, scales, gap_reading_sd_m) {
        return Ok(Advice::Declined(d));
    }
    let case = &memory.cases[case_index];
    let motors = start.payout_m.len();
    if let Some(bad) = case.commands_m.iter().find(|u| u.len() != motors) {
        return Err(AdaptError::Motors {
            case: case_index,
            found: bad.len(),
            expected: motors,
        });
    }
    let model = context.model;
    let estimator = PayoutScaleEstimator::with_prior(
        model,
        &case.conditions.payout_scale,
        settings.payout_scale_prior_sd,
        0.0,
    );
    let drum_to_cable: Vec<f64> = estimator.motor_scale().iter().map(|s| 1.0 + s).collect();
    let mut cable_total = vec![0.0; motors];
    for u in &case.commands_m {
        for (m, d) in u.iter().enumerate() {
            cable_total[m] += d * drum_to_cable[m];
        }
    }
    let end =
        solve_case_end(context, start, &cable_total, cache.last.take()).map_err(|status| {
            AdaptError::EndState {
                case: case_index,
                status,
            }
        })?;
    cache.last = Some(end.clone());
    let response =
        PayoutResponse::tangent(model, &end).map_err(|error| AdaptError::Sensitivity {
            case: case_index,
            error,
        })?;
    let max_step = context.motors.largest_step_m();
    let terminal = step_data(context, &end, &response, max_step);
    let to_drum = |mut g: DMatrix<f64>| {
        for (m, k) in drum_to_cable.iter().enumerate() {
            g.column_mut(m).scale_mut(*k);
        }
        g
    };
    let gap_sensitivity = to_drum((&terminal.gap_pay_out + &terminal.gap_reel_in) * 0.5);
    let limits = terminal
        .limits
        .into_iter()
        .map(|mut l| {
            for (m, k) in drum_to_cable.iter().enumerate() {
                l.pay_out[m] *= k;
                l.reel_in[m] *= k;
            }
            l
        })
        .collect();
    let learnt = learnt_path(case, settings, &context.motors.max_step_m);
    let data = IlcData {
        commands_m: learnt.commands_m,
        end_gaps_m: case.final_gap_vectors_m.clone(),
        gap_weights: context.gap_weights.clone(),
        gap_sensitivity,
        limits,
        start_payout_m: context.motors.start_payout_m.clone(),
        min_payout_m: context.motors.min_payout_m.clone(),
        max_payout_m: context.motors.max_payout_m.clone(),
        max_step_m: context.motors.max_step_m.clone(),
        max_total_change_m: settings.ilc_max_change_m,
        motor_group: IndependentParts::of(model).of_cable,
        max_group_spread_m: settings.ilc_max_spread_m,
    };
    let ilc = learn_commands(&data, settings.ilc_regularisation);
    let guidance = Guidance {
        feedforward_m: ilc.commands_m.clone(),
        payout_scale_prior: (!case.conditions.payout_scale.is_empty())
            .then(|| case.conditions.payout_scale.clone()),
        payout_scale_prior_sd: Some(settings.payout_scale_prior_sd),
        feedforward_splits: settings.feedforward_splits,
        case_take_up: learnt.case_take_up,
    };
    Ok(Advice::Guided(Adaptation {
        case_index,
        distance,
        ilc,
        guidance,
    }))
}

/// The learnt approach's commands before the ILC update, and where they
/// hold the case's take-up ([`learnt_path`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LearntCommands {
    /// The commands, per command and motor, m (drum).
    pub commands_m: Vec<Vec<f64>>,
    /// Where they hold the case's take-up.
    pub case_take_up: CaseTakeUp,
}

/// The learnt approach's commands before the ILC update: the case's
/// commands, their trailing corrections merged ([`merged_tail`]), then
/// along the learnt path of `settings` ([`LearntPath`]), and where they
/// hold the case's take-up ([`CaseTakeUp`]).
///
/// The case's take-up is its leading take-ups ([`Case::take_up_commands`]
/// that come before any other command). On the paced path no take-up
/// gets a command of its own: the other commands are paced
/// ([`paced_path`]), the case's take-up is added at their front
/// ([`take_up_in_front`]), where the new cycle's own take-up replaces it,
/// and a later take-up's motion after it (part of the learnt moves: the
/// new cycle's slack shows at its fold, not later). A take-up moves one cable's
/// motor; paced as a command, it became a step of a few millimetres of
/// every motor, which reeled the other cables in while the slack one was
/// still slack (wide 7501 scenarios 67 and 87, cycle 4: far segments of
/// `A_cc0` already below their minimum taken 0.1–0.3 N further below).
/// On the replayed path the leading take-ups are the front as they are.
/// Where the motion does not fit at the front within the drum steps, or
/// the case's take-ups are not known (a memory before format 4), every
/// command is paced and the take-up is [`CaseTakeUp::Inside`].
pub fn learnt_path(case: &Case, settings: &MemorySettings, max_step_m: &[f64]) -> LearntCommands {
    let all = &case.commands_m;
    let corrections = case.outcome.corrective_commands.unwrap_or(0);
    let merged = |commands: &[Vec<f64>], corrections: usize| {
        merged_tail(commands, corrections, max_step_m, settings.ilc_max_change_m)
    };
    let inside = |commands_m| LearntCommands {
        commands_m,
        case_take_up: CaseTakeUp::Inside,
    };
    let Some(take_ups) = &case.take_up_commands else {
        return inside(match settings.learnt_path {
            LearntPath::Replayed => merged(all, corrections),
            LearntPath::Paced => paced_path(&merged(all, corrections), max_step_m),
        });
    };
    let is_take_up = |j: usize| take_ups.binary_search(&j).is_ok();
    // The leading take-ups are the case's take-up, which this cycle's
    // replaces; never the whole case.
    let leading = take_ups
        .iter()
        .enumerate()
        .take_while(|(k, &j)| *k == j)
        .count()
        .min(all.len().saturating_sub(1));
    let motion = |from: usize, to: usize| {
        let mut t = vec![0.0; max_step_m.len()];
        for u in (from..to).filter(|&j| is_take_up(j)).map(|j| &all[j]) {
            for (t, x) in t.iter_mut().zip(u) {
                *t += x;
            }
        }
        t
    };
    let front = |commands_m: Vec<Vec<f64>>, added: Vec<Vec<f64>>| LearntCommands {
        commands_m,
        case_take_up: if leading == 0 {
            CaseTakeUp::None
        } else {
            CaseTakeUp::InFront(added)
        },
    };
    match settings.learnt_path {
        LearntPath::Replayed => {
            let commands_m = merged(all, corrections);
            let added = commands_m[..leading.min(commands_m.len())].to_vec();
            front(commands_m, added)
        }
        LearntPath::Paced => {
            // Every take-up gets no step of its own: the moves are paced,
            // the case's take-up goes in front of them, then the later
            // take-ups' motion (part of the learnt moves, not replaced).
            let moves: Vec<Vec<f64>> = (0..all.len())
                .filter(|&j| !is_take_up(j))
                .map(|j| all[j].clone())
                .collect();
            let first_correction = all.len().saturating_sub(corrections);
            let move_corrections = corrections
                - (first_correction..all.len())
                    .filter(|&j| is_take_up(j))
                    .count();
            let paced_moves = paced_path(&merged(&moves, move_corrections), max_step_m);
            let fitted = take_up_in_front(paced_moves, &motion(0, leading), max_step_m).and_then(
                |(commands_m, added)| {
                    let later = motion(leading, all.len());
                    take_up_in_front(commands_m, &later, max_step_m)
                        .map(|(commands_m, _)| (commands_m, added))
                },
            );
            match fitted {
                Some((commands_m, added)) if !moves.is_empty() => front(commands_m, added),
                _ => inside(paced_path(&merged(all, corrections), max_step_m)),
            }
        }
    }
}

/// Commands (per command and motor, m) and the motion added to each of
/// the first of them (as many rows as commands were added to), m.
pub type CommandsWithAdded = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// `commands_m` with the motion `take_up_m` (per motor, m) added at their
/// front: each motor's into its first command up to its drum step
/// `max_step_m` (m), the rest into the next, and so on; with the motion
/// added to each command (as many rows as commands were added to). `None`
/// where it does not fit, or a step is not positive and finite, or a
/// number is not finite; `commands_m` as they are where there is no motion
/// to add.
pub fn take_up_in_front(
    mut commands_m: Vec<Vec<f64>>,
    take_up_m: &[f64],
    max_step_m: &[f64],
) -> Option<CommandsWithAdded> {
    let finite = |x: &f64| x.is_finite();
    if !take_up_m.iter().all(finite) || !commands_m.iter().flatten().all(finite) {
        return None;
    }
    let mut added: Vec<Vec<f64>> = Vec::new();
    for (m, &motion) in take_up_m.iter().enumerate() {
        if motion == 0.0 {
            continue;
        }
        let step = *max_step_m.get(m)?;
        if !(step > 0.0 && step.is_finite()) {
            return None;
        }
        let mut left = motion;
        for (j, u) in commands_m.iter_mut().enumerate() {
            let x = u.get_mut(m)?;
            let add = left.clamp((-step - *x).min(0.0), (step - *x).max(0.0));
            *x += add;
            left -= add;
            if added.len() <= j {
                added.resize(j + 1, vec![0.0; take_up_m.len()]);
            }
            added[j][m] = add;
            if left == 0.0 {
                break;
            }
        }
        if left.abs() > 1e-12 * step {
            return None;
        }
    }
    Some((commands_m, added))
}

/// The straight path to where `commands_m` end, at their pace: command
/// `j` moves every motor by its total (m) times `w_j / Σ w`, where `w_j`
/// is command `j`'s largest move of a motor as a fraction of that motor's
/// drum step `max_step_m` (m; with one step for all, the largest move
/// itself, scaled). The path the commands took is replaced by the
/// straight line in payout space (every motor one way throughout, no
/// lateral correction of the cycle they came from), and its progress per
/// command is theirs (a closed loop slows down near the design: its last
/// commands stay small). A motor's total is at most `Σ_j |u_jm| ≤ Σ_j
/// w_j·step_m`, so every paced command keeps each motor within `w_j` of
/// its step, as the commands did. Commands that move nothing, or hold a
/// number that is not finite, or a motor without a positive step, are
/// kept as they are.
pub fn paced_path(commands_m: &[Vec<f64>], max_step_m: &[f64]) -> Vec<Vec<f64>> {
    let Some(first) = commands_m.first() else {
        return Vec::new();
    };
    let total: Vec<f64> = (0..first.len())
        .map(|m| {
            commands_m
                .iter()
                .map(|u| u.get(m).copied().unwrap_or(0.0))
                .sum()
        })
        .collect();
    let steps_known = (0..first.len()).all(|m| max_step_m.get(m).is_some_and(|s| *s > 0.0));
    if !steps_known || commands_m.iter().flatten().any(|x| !x.is_finite()) {
        return commands_m.to_vec();
    }
    let pace: Vec<f64> = commands_m
        .iter()
        .map(|u| {
            u.iter()
                .zip(max_step_m)
                .map(|(x, step)| x.abs() / step)
                .fold(0.0, f64::max)
        })
        .collect();
    let whole: f64 = pace.iter().sum();
    if whole == 0.0 {
        return commands_m.to_vec();
    }
    pace.iter()
        .map(|w| total.iter().map(|t| t * w / whole).collect())
        .collect()
}

/// The case's commands with its corrections merged: of the last
/// `corrections + 1` commands (the closed loop's corrective commands and
/// the command they corrected), the last is added to the one before
/// while every motor moves the same way in both (or not at all in one)
/// and the sum stays within its drum step `max_step_m` (m) less `room_m`
/// (m), and so on backwards.
///
/// Why: a case's last commands are often the closed loop's corrections
/// (two small reel-ins after the approach fell short); the ILC update
/// learns where the commands end, so replaying the corrections as
/// separate commands would make every later cycle send them again (on a
/// truth with heavy joints, soft cables and drum slip −5 %, every learnt
/// cycle of seed 1 had 2 corrective commands where the memoryless
/// controller had 1). The merged commands end at the same payouts; only
/// commands that reel the same way are merged, as a reversal inside one
/// command would take another friction path; and a merged command keeps
/// `room_m` below the step (the ILC's largest change of a motor's total,
/// `ilc_max_change_m`), so that the update can still move the last
/// command rather than the approach's.
pub fn merged_tail(
    commands_m: &[Vec<f64>],
    corrections: usize,
    max_step_m: &[f64],
    room_m: f64,
) -> Vec<Vec<f64>> {
    let mut out = commands_m.to_vec();
    let first_mergeable = commands_m.len().saturating_sub(corrections + 1);
    let same_way = |a: f64, b: f64| a == 0.0 || b == 0.0 || a.signum() == b.signum();
    while out.len() >= 2 && out.len() - 2 >= first_mergeable {
        let (last, previous) = (&out[out.len() - 1], &out[out.len() - 2]);
        let mergeable = last.len() == previous.len()
            && last.iter().zip(previous).enumerate().all(|(m, (&a, &b))| {
                max_step_m
                    .get(m)
                    .is_some_and(|max| same_way(a, b) && (a + b).abs() + room_m <= *max)
            });
        if !mergeable {
            break;
        }
        let last = out.pop().expect("two commands");
        let previous = out.last_mut().expect("one command");
        for (p, l) in previous.iter_mut().zip(last) {
            *p += l;
        }
    }
    out
}

/// The controller's model at the end of a case: the state after cable
/// payouts `cable_total_m` (per motor, m) from `start`.
///
/// Only the end state is needed (its limits enter the update), so the path
/// is not checked. A frictionless model's end does not depend on the path,
/// so the solve starts from whichever known equilibrium is nearest in
/// payout: the end of the case adapted before (`cached`), the folded
/// `start`, or the as-built state relaxed (payout 0, near where every
/// deployment ends: one increment instead of the fold's eight), and goes
/// in steps of a drum's largest step. With friction the path matters: it
/// follows the case's payouts from `start` in the policy's increments.
fn solve_case_end(
    context: &PlanContext,
    start: &DeploymentState,
    cable_total_m: &[f64],
    cached: Option<DeploymentState>,
) -> Result<DeploymentState, RelaxStatus> {
    let model = context.model;
    let target_m: Vec<f64> = start
        .payout_m
        .iter()
        .zip(cable_total_m)
        .map(|(p, d)| p + d)
        .collect();
    let distance = |s: &DeploymentState| {
        s.payout_m
            .iter()
            .zip(&target_m)
            .map(|(p, t)| (t - p).abs())
            .fold(0.0, f64::max)
    };
    let mut ws = Workspace::default();
    let (mut end, increment_m) = if model.friction().is_frictionless() {
        let mut nearest = cached
            .filter(|s| s.payout_m.len() == target_m.len())
            .filter(|s| distance(s) < distance(start))
            .unwrap_or_else(|| start.clone());
        let as_built_distance = target_m.iter().fold(0.0, |m: f64, t| m.max(t.abs()));
        if as_built_distance < distance(&nearest) {
            let mut as_built = model.reference_state();
            if model.relax(&mut as_built, &mut ws).status.is_converged() {
                nearest = as_built;
            }
        }
        (nearest, context.motors.largest_step_m())
    } else {
        (start.clone(), context.policy.increment_m)
    };
    let delta_m: Vec<f64> = target_m
        .iter()
        .zip(&end.payout_m)
        .map(|(t, p)| t - p)
        .collect();
    let status = match model.apply_payout(&mut end, &mut ws, &delta_m, increment_m, &mut ()) {
        Ok(r) => r.status,
        Err(_) => RelaxStatus::Diverged,
    };
    if status.is_converged() {
        Ok(end)
    } else {
        Err(status)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::reference_bridge::{reference_bridge, BridgeParameters};
    use crate::learn::case::{Case, CaseLearning, CaseOutcome};
    use crate::model::{ForwardModel, JointFriction, RelaxSettings};
    use crate::plan::{folded_start, DeploymentProblem, Policy};

    fn frictionless_bridge() -> ForwardModel {
        let structure = reference_bridge(&BridgeParameters::default()).expect("bridge");
        ForwardModel::new(
            structure,
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .expect("model")
    }

    /// Issue 24, "learning never makes it worse": a memory whose newest
    /// learnt cycle ended its approach further from the update's
    /// prediction than from no update gives no guidance (the cycle runs
    /// as the memoryless controller would); nor does a memory of cycles
    /// that never connected; a failed cycle is passed over for an
    /// earlier one that connected.
    #[test]
    fn a_refuted_update_or_a_memory_of_failures_gives_no_guidance() {
        let model = frictionless_bridge();
        let problem = DeploymentProblem::default();
        let policy = Policy::default();
        let start = folded_start(&model, &problem, policy.increment_m).expect("fold");
        let context = PlanContext::new(&model, &problem, &policy, &start).expect("context");
        let pairs = model.structure().midspan_pairs.len();
        // Two commands to 1 cm short of the as-built payout; the second
        // ends the approach at `approach_gap_m`, the cycle at `final_gap_m`.
        let half_way: Vec<f64> = start.payout_m.iter().map(|p| 0.5 * (0.01 - p)).collect();
        let cycle = |final_gap_m: f64,
                     approach_gap_m: f64,
                     status: &str,
                     learnt: Option<(usize, f64)>| Case {
            conditions: CaseConditions {
                temperature_c: None,
                fold_m: start.payout_m.clone(),
                start_gap_m: Some(0.14),
                payout_scale: vec![0.0; 2],
            },
            commands_m: vec![half_way.clone(); 2],
            take_up_commands: None,
            measured_gaps_m: vec![vec![Some(0.08); pairs], vec![Some(approach_gap_m); pairs]],
            final_gap_vectors_m: vec![Some([final_gap_m, 0.0, 0.0]); pairs],
            prediction_error_m: vec![Some(0.001); 2],
            outcome: CaseOutcome {
                status: status.into(),
                commands: 2,
                corrective_commands: Some(0),
                final_gap_m: Some(final_gap_m),
                approach_commands: Some(2),
            },
            learning: learnt.map(|(from_case, predicted_m)| CaseLearning {
                from_case,
                from_gap_m: 0.02,
                predicted_gaps_m: vec![Some(predicted_m); pairs],
                learnt_commands: 2,
                approach_completed: true,
            }),
            model: None,
        };
        let query = CaseConditions {
            temperature_c: None,
            fold_m: start.payout_m.clone(),
            start_gap_m: None,
            payout_scale: Vec::new(),
        };
        let gap_sd_m = 0.0014;
        let advise = |memory: &CaseMemory, settings: &MemorySettings| {
            adapt(
                memory,
                &query,
                &context,
                &start,
                settings,
                &FeatureScales::default(),
                gap_sd_m,
                &mut EndStateCache::default(),
            )
            .expect("adaptation")
        };
        let settings = MemorySettings::default();

        let failures = CaseMemory {
            cases: vec![cycle(0.1, 0.1, "not_reachable", None)],
        };
        assert_eq!(
            advise(&failures, &settings),
            Advice::Declined(Decline::NoConnectedCase { cases: 1 })
        );

        // Case 1 (learnt from case 0) ended at 20 mm; case 2 learnt from
        // it, predicted 12 mm and reached 27 mm: 15 mm off against 7 mm,
        // beyond 3 × 1.4 mm.
        let refuted = CaseMemory {
            cases: vec![
                cycle(0.030, 0.030, "connected", None),
                cycle(0.020, 0.025, "connected", Some((0, 0.012))),
                cycle(0.010, 0.027, "connected", Some((1, 0.012))),
            ],
        };
        match advise(&refuted, &settings) {
            Advice::Declined(Decline::Refuted { score, tolerance_m }) => {
                assert_eq!(score.case, 2);
                assert!((score.ilc_error_m - 0.015).abs() < 1e-12);
                assert!((score.replay_error_m - 0.007).abs() < 1e-12);
                assert!((tolerance_m - 3.0 * gap_sd_m).abs() < 1e-15);
            }
            other => panic!("expected a refutation, got {other:?}"),
        }
        let trusting = MemorySettings {
            ilc_acceptance_enable: false,
            ..settings
        };
        let guided = advise(&refuted, &trusting);
        assert_eq!(guided.adaptation().map(|a| a.case_index), Some(2));

        // Reached 13 mm: 1 mm off the prediction, the update stands.
        let borne_out = CaseMemory {
            cases: vec![
                cycle(0.030, 0.030, "connected", None),
                cycle(0.020, 0.025, "connected", Some((0, 0.012))),
                cycle(0.010, 0.013, "connected", Some((1, 0.012))),
                cycle(0.1, 0.1, "command_limit", None),
            ],
        };
        let guided = advise(&borne_out, &settings);
        assert_eq!(
            guided.adaptation().map(|a| a.case_index),
            Some(2),
            "the failed case 3 is passed over"
        );
    }

    /// Issue 24: the memory replayed a case's corrective commands as
    /// commands of their own in every later cycle. Merged: the two small
    /// reel-ins after the approach become one, the totals are kept, a
    /// merge that would exceed the drum step (less the ILC's room) or
    /// reverse a motor is not made, nor one of approach commands.
    #[test]
    fn a_cases_corrective_tail_is_merged_into_one_command() {
        let approach = vec![-0.048; 3];
        let commands = vec![
            approach.clone(),
            approach.clone(),
            vec![-0.023; 3],
            vec![-0.011, -0.012, 0.0],
        ];
        let merged = merged_tail(&commands, 2, &[0.05; 3], 0.004);
        assert_eq!(merged.len(), 3);
        assert_eq!(merged[..2], commands[..2]);
        let totals =
            |c: &[Vec<f64>]| -> Vec<f64> { (0..3).map(|m| c.iter().map(|u| u[m]).sum()).collect() };
        for (a, b) in totals(&merged).iter().zip(totals(&commands)) {
            assert!((a - b).abs() < 1e-15);
        }
        // A reversal in one motor stops the merge.
        let reversing = vec![
            approach.clone(),
            vec![-0.02, -0.02, 0.01],
            vec![-0.01, -0.01, -0.01],
        ];
        assert_eq!(merged_tail(&reversing, 1, &[0.05; 3], 0.004).len(), 3);
        // So does the drum step, less the ILC's room: −34 mm fits a 40 mm
        // step, but leaves the update no room to reel further.
        assert_eq!(merged_tail(&commands, 2, &[0.04; 3], 0.0).len(), 3);
        assert_eq!(merged_tail(&commands, 2, &[0.04; 3], 0.008).len(), 4);
        // Approach commands are not corrections: with none recorded, the
        // same small commands stay as they are.
        assert_eq!(merged_tail(&commands, 0, &[0.05; 3], 0.004).len(), 4);
        // A motor the step list does not cover is never merged.
        assert_eq!(merged_tail(&commands, 2, &[0.05; 2], 0.004).len(), 4);
        // A tiny opposite-sign pair is a reversal, however small.
        let tiny = vec![approach.clone(), vec![-1e-200; 3], vec![1e-200; 3]];
        assert_eq!(merged_tail(&tiny, 2, &[0.05; 3], 0.004).len(), 3);
        assert_eq!(merged_tail(&[], 3, &[0.05; 3], 0.004).len(), 0);
    }

    /// Issue 24 ("never worse"): a learnt approach was the last cycle's
    /// closed loop replayed, its lateral corrections included, on a
    /// bridge that had moved on. The paced path keeps each motor's total
    /// and the commands' pace, and moves every motor one way.
    #[test]
    fn a_learnt_approach_is_the_straight_path_at_the_cases_pace() {
        let closed_loop = vec![
            vec![-0.05, -0.05, -0.05],
            vec![-0.012, 0.002, -0.012],
            vec![-0.05, -0.05, -0.049],
            vec![-0.006, -0.009, 0.003],
        ];
        let paced = paced_path(&closed_loop, &[0.05; 3]);
        let totals =
            |c: &[Vec<f64>]| -> Vec<f64> { (0..3).map(|m| c.iter().map(|u| u[m]).sum()).collect() };
        assert_eq!(paced.len(), closed_loop.len());
        for (a, b) in totals(&paced).iter().zip(totals(&closed_loop)) {
            assert!((a - b).abs() < 1e-15, "{a} against {b}");
        }
        // Pace 50, 12, 50 and 9 mm of 121: motor 0's −118 mm goes
        // −48.8, −11.7, −48.8 and −8.8 mm, every motor one way.
        let whole = 0.05 + 0.012 + 0.05 + 0.009;
        for (u, w) in paced.iter().zip([0.05, 0.012, 0.05, 0.009]) {
            assert!((u[0] - -0.118 * w / whole).abs() < 1e-15, "{u:?}");
            assert!(u.iter().all(|x| *x < 0.0), "{u:?}");
            assert!(u.iter().all(|x| x.abs() <= 0.05), "{u:?}");
        }
        assert!(paced_path(&[], &[0.05; 3]).is_empty());
        // Nothing moved, or not a number: kept as it is.
        assert_eq!(paced_path(&[vec![0.0; 3]], &[0.05; 3]), [vec![0.0; 3]]);
        let nan = vec![vec![-0.05, f64::NAN, -0.05]];
        assert!(paced_path(&nan, &[0.05; 3])[0][1].is_nan());
        // Motors with steps of their own: the pace is each command's
        // largest fraction of a step, so no motor passes its own (motor
        // 1's 20 mm step; paced by the largest move alone, its first
        // command would be 28.6 mm).
        let unequal = vec![vec![0.05, 0.02], vec![0.0, 0.02]];
        for u in paced_path(&unequal, &[0.05, 0.02]) {
            assert!(
                (u[0] - 0.025).abs() < 1e-15 && (u[1] - 0.02).abs() < 1e-15,
                "{u:?}"
            );
        }
    }

    /// The case's take-ups were paced as commands of every motor: the
    /// learnt approach began with a step of a few millimetres of every
    /// motor, taken after this cycle's own take-up, which reeled the other
    /// cables in while the slack one's far segments stuck below their
    /// minimum (wide 7501 scenarios 67 and 87, cycle 4). No take-up gets
    /// a command: the moves are paced and the case's leading take-ups'
    /// motion is added in front, within the drum step (then into the next
    /// command), and the guidance holds what was added; a later take-up's
    /// motion goes in front too, as part of the moves; where it does not fit,
    /// or the case's take-ups are not known (format 3), every command is
    /// paced and the take-up is inside; a case known to have none says so.
    #[test]
    fn a_cases_take_up_goes_in_front_of_the_learnt_approach_not_into_a_step() {
        let closed_loop = vec![
            vec![-0.004, 0.0, 0.0],
            vec![-0.025, -0.025, -0.025],
            vec![-0.05, -0.05, -0.05],
            vec![-0.05, -0.05, -0.05],
        ];
        let case = |commands_m: Vec<Vec<f64>>, take_ups: Option<Vec<usize>>, corrections| {
            let n = commands_m.len();
            Case {
                conditions: CaseConditions {
                    temperature_c: None,
                    fold_m: vec![0.2; 3],
                    start_gap_m: None,
                    payout_scale: vec![],
                },
                commands_m,
                take_up_commands: take_ups,
                measured_gaps_m: vec![vec![None]; n],
                final_gap_vectors_m: vec![None],
                prediction_error_m: vec![None; n],
                outcome: CaseOutcome {
                    status: "connected".into(),
                    commands: n,
                    corrective_commands: Some(corrections),
                    final_gap_m: None,
                    approach_commands: None,
                },
                learning: None,
                model: None,
            }
        };
        let settings = MemorySettings::default();
        let steps = [0.05; 3];
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-15);
        // The three moves, paced as they were (all one way already), the
        // take-up's 4 mm of motor 0 in front of the first.
        let learnt = learnt_path(
            &case(closed_loop.clone(), Some(vec![0]), 0),
            &settings,
            &steps,
        );
        let path = &learnt.commands_m;
        assert_eq!(path.len(), 3, "{path:?}");
        assert!(close(&path[0], &[-0.029, -0.025, -0.025]), "{path:?}");
        assert!(close(&path[1], &[-0.05; 3]) && close(&path[2], &[-0.05; 3]));
        assert_eq!(
            learnt.case_take_up,
            CaseTakeUp::InFront(vec![vec![-0.004, 0.0, 0.0]])
        );
        // A trailing correction merges with the move before it (−10 and
        // −30 mm, within the 50 mm step less the ILC's 4 mm room): three
        // moves, the take-up in front of the first.
        let mut with_correction = closed_loop.clone();
        with_correction[3] = vec![-0.03; 3];
        with_correction.push(vec![-0.01; 3]);
        let learnt = learnt_path(&case(with_correction, Some(vec![0]), 1), &settings, &steps);
        assert_eq!(learnt.commands_m.len(), 3, "{:?}", learnt.commands_m);
        assert!(close(&learnt.commands_m[0], &[-0.029, -0.025, -0.025]));
        // 26 mm of take-up: 25 fit in front of the first move, and the
        // 1 mm left finds no room in the later moves, all at their step:
        // every command is paced, the take-up inside.
        let mut big = closed_loop.clone();
        big[0][0] = -0.026;
        let learnt = learnt_path(&case(big.clone(), Some(vec![0]), 0), &settings, &steps);
        assert_eq!(learnt.commands_m.len(), 4, "{:?}", learnt.commands_m);
        assert_eq!(learnt.case_take_up, CaseTakeUp::Inside);
        // With 60 mm steps all 26 mm go in front of the first move.
        let learnt = learnt_path(&case(big, Some(vec![0]), 0), &settings, &[0.06; 3]);
        assert!(
            close(&learnt.commands_m[0], &[-0.051, -0.025, -0.025]),
            "{:?}",
            learnt.commands_m
        );
        // Take-ups not known (format 3): every command paced, the take-up
        // inside; known to be none: paced the same, and said so.
        let unknown = learnt_path(&case(closed_loop.clone(), None, 0), &settings, &steps);
        assert_eq!(unknown.commands_m.len(), 4);
        assert_eq!(unknown.case_take_up, CaseTakeUp::Inside);
        let none = learnt_path(
            &case(closed_loop.clone(), Some(vec![]), 0),
            &settings,
            &steps,
        );
        assert_eq!(none.commands_m, unknown.commands_m);
        assert_eq!(none.case_take_up, CaseTakeUp::None);
        // A take-up later in the case (a cable slack after the first
        // move) gets no step either: its motion goes in front of the
        // moves, as part of them (the case's take-up is none).
        let later_take_up = vec![
            vec![-0.025; 3],
            vec![0.0, -0.003, 0.0],
            vec![-0.05; 3],
            vec![-0.05; 3],
        ];
        let later = learnt_path(&case(later_take_up, Some(vec![1]), 0), &settings, &steps);
        assert_eq!(later.case_take_up, CaseTakeUp::None);
        assert_eq!(later.commands_m.len(), 3, "{:?}", later.commands_m);
        assert!(close(&later.commands_m[0], &[-0.025, -0.028, -0.025]));
        // Replayed, the leading take-up is the front as it is.
        let replayed = MemorySettings {
            learnt_path: LearntPath::Replayed,
            ..MemorySettings::default()
        };
        let learnt = learnt_path(
            &case(closed_loop.clone(), Some(vec![0]), 0),
            &replayed,
            &steps,
        );
        assert_eq!(learnt.commands_m, closed_loop);
        assert_eq!(
            learnt.case_take_up,
            CaseTakeUp::InFront(vec![vec![-0.004, 0.0, 0.0]])
        );
        // A take-up against the moves' way (they pay out) is added all the
        // same, and what was added is what the controller subtracts.
        let (commands, added) =
            take_up_in_front(vec![vec![0.01; 3]; 3], &[-0.004, 0.0, 0.0], &steps).unwrap();
        assert!(close(&commands[0], &[0.006, 0.01, 0.01]), "{commands:?}");
        assert_eq!(added, vec![vec![-0.004, 0.0, 0.0]]);
        // Nothing to add; no room; steps or numbers that are not usable.
        assert_eq!(
            take_up_in_front(vec![], &[0.0; 3], &steps),
            Some((vec![], vec![]))
        );
        assert_eq!(take_up_in_front(vec![], &[-0.001, 0.0, 0.0], &steps), None);
        let one = vec![vec![-0.01; 3]];
        assert_eq!(
            take_up_in_front(one.clone(), &[-0.001, 0.0, 0.0], &[-0.05; 3]),
            None
        );
        assert_eq!(
            take_up_in_front(one.clone(), &[f64::NAN, 0.0, 0.0], &steps),
            None
        );
        assert_eq!(
            take_up_in_front(vec![vec![f64::NAN; 3]], &[-0.001, 0.0, 0.0], &steps),
            None
        );
    }

    /// The end reached from the as-built state (or from a cached end) must
    /// be the end the case's own path reaches: a frictionless elastic
    /// structure's equilibrium depends on the payout alone. The solver
    /// stops at an out-of-balance force of 1e-6 of the largest member
    /// force; with member stiffnesses of order 1e6–1e7 N/m that leaves
    /// node positions uncertain by well under 1e-7 m, so two paths must
    /// agree to 1e-6 m.
    #[test]
    fn a_frictionless_case_end_does_not_depend_on_where_the_solve_starts() {
        let model = frictionless_bridge();
        let problem = DeploymentProblem::default();
        let policy = Policy::default();
        let start = folded_start(&model, &problem, policy.increment_m).expect("fold");
        let context = PlanContext::new(&model, &problem, &policy, &start).expect("context");
        let motors = start.payout_m.len();
        // Reeled in to 1 cm short of the as-built payout: nearer the
        // as-built state than the fold.
        let total: Vec<f64> = start.payout_m.iter().map(|p| 0.01 - p).collect();
        let mut along_the_path = start.clone();
        let r = model
            .apply_payout(
                &mut along_the_path,
                &mut Workspace::default(),
                &total,
                policy.increment_m,
                &mut (),
            )
            .expect("payout");
        assert!(r.status.is_converged());

        let from_as_built = solve_case_end(&context, &start, &total, None).expect("end");
        assert!(along_the_path.max_position_difference_m(&from_as_built) < 1e-6);

        // A cached end 2 cm away (nearer than both) leads there too.
        let mut cached = start.clone();
        let to_cache: Vec<f64> = total.iter().map(|t| t - 0.02).collect();
        model
            .apply_payout(
                &mut cached,
                &mut Workspace::default(),
                &to_cache,
                0.05,
                &mut (),
            )
            .expect("payout");
        let from_cache = solve_case_end(&context, &start, &total, Some(cached)).expect("end");
        assert!(along_the_path.max_position_difference_m(&from_cache) < 1e-6);
        for m in 0..motors {
            assert!((from_cache.payout_m[m] - along_the_path.payout_m[m]).abs() < 1e-12);
        }
    }
}
