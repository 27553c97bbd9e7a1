//! Sequential convex programming with a trust region: linearise at the
//! state, solve the QP step, confirm it by a forward re-solve with
//! friction, accept it only if it reduces the gaps as predicted and breaks
//! no limit at any increment; otherwise shrink the region and plan again
//! from the same linearisation. Re-linearise after every accepted step.
//!
//! Acceptance: with merit `m = Σ w‖g‖² + η Σ‖d‖²` (the QP's objective
//! without its regularisation and split penalty: the gaps and the pairs'
//! midpoint offsets from the design), the ratio ρ = (m₀ − m_actual) /
//! (m₀ − m_predicted) decides, by the rule of the QP planner's
//! [`crate::plan::TrustRegion`], whether the step is accepted and how the
//! radius changes. The region collapsing below its minimum, or a step
//! that predicts no reduction, ends the plan as not reachable, naming the
//! active limits.

use nalgebra::Vector3;

use super::causes::{NotReachable, SolverFailure, TrialRejection};
use super::limits::{force_row_name, force_rows, strut_clearance};
use super::outcome::PlanStatus;
use super::planner::{CommandPlanner, Decision, PlanContext, PlannedCommand};
use super::policy::{QpPlannerSettings, SensitivityKind, Weights};
use super::qp_step::{
    solve_step, step_solver_settings, LinearLimit, QpStep, QpStepStatus, StepData, StepWeights,
};
use super::response::PayoutResponse;
use super::take_up::take_up;
use crate::model::{DeploymentState, SlipOnset};

/// Scale of force rows in the QP, N.
const FORCE_SCALE_N: f64 = 100.0;
/// Scale of clearance rows in the QP, m.
const CLEARANCE_SCALE_M: f64 = 0.01;
/// A predicted merit reduction below this, m², is no reduction: (0.1 mm)².
const NO_REDUCTION_M2: f64 = 1e-8;

/// The QP planner's state between commands: its trust region.
#[derive(Debug, Clone)]
pub struct QpPlanner {
    settings: QpPlannerSettings,
    trust_region_m: f64,
    /// The last command's responses, Broyden-updated to the state it
    /// reached, while they predicted it well.
    kept: Option<KeptResponse>,
}

/// Responses carried to the next command.
#[derive(Debug, Clone)]
struct KeptResponse {
    response: PayoutResponse,
    /// The state they are updated to (positions and payout): they are
    /// used only for a command planned from exactly this state.
    positions_m: Vec<Vector3<f64>>,
    payout_m: Vec<f64>,
}

impl QpPlanner {
    /// A planner with `settings`, at their initial trust region.
    pub fn new(settings: &QpPlannerSettings) -> Self {
        QpPlanner {
            settings: settings.clone(),
            trust_region_m: settings.trust_region.initial_m,
            kept: None,
        }
    }
}

/// The step data at `state` from its responses, for a trust region
/// `trust_region_m`. Limits enter only where the largest move the region
/// allows could reach them (twice the linear estimate, for curvature);
/// the others cannot become active and would only slow the solver.
pub fn step_data(
    context: &PlanContext,
    state: &DeploymentState,
    response: &PayoutResponse,
    trust_region_m: f64,
) -> StepData {
    let s = context.model.structure();
    let p = &context.policy.margins;
    let motors = &context.motors;
    let n = state.payout_m.len();
    let reach: Vec<f64> = (0..n)
        .map(|c| 2.0 * trust_region_m.min(motors.max_step_m[c]))
        .collect();
    let mut limits = Vec::new();
    let forces = force_rows(context.model, state);
    for (r, (&model_f, b)) in forces.iter().zip(&context.limits.force).enumerate() {
        let f = model_f + context.correction.force_offset_n(r);
        let out: Vec<f64> = response
            .pay_out
            .iter()
            .map(|e| e.force_n_per_m[r])
            .collect();
        let inn: Vec<f64> = response
            .reel_in
            .iter()
            .map(|e| e.force_n_per_m[r])
            .collect();
        let swing: f64 = (0..n)
            .map(|c| out[c].abs().max(inn[c].abs()) * reach[c])
            .sum();
        // The QP keeps the policy's margin from each limit; a member
        // already inside the margin band may close half its distance to
        // the limit per step (a bound at the current value would freeze a
        // stuck segment that any small move slackens a little).
        let lower = b.lower_n + p.force_n.min(0.5 * (f - b.lower_n).max(0.0));
        let upper = b.upper_n - p.force_n.min(0.5 * (b.upper_n - f).max(0.0));
        // A tension no sensor reads has no offset to correct its level,
        // and the model's slope may be off too: its predicted fall counts
        // (1 + β) times against the lower limit. With F at or above that
        // limit, F + (1 + β)·ΔF ≥ lower implies F + ΔF ≥ lower, so the one
        // row bounds both (a rise passes either way); below it the
        // inflated row would ask for less recovery than the plain one, so
        // the plain row stands. With the margin off the factor is 1: the
        // plain row.
        let inflate = 1.0 + p.unmeasured_force_fall.unwrap_or(0.0);
        let unmeasured_tension = inflate > 1.0
            && f >= lower
            && context.limits.euler_n[r].is_none()
            && !context.correction.force_row_measured(r);
        let fall_swing = if unmeasured_tension {
            inflate * swing
        } else {
            swing
        };
        let near_lower = f - lower <= fall_swing + p.force_n;
        let near_upper = upper - f <= swing + p.force_n;
        if !(near_lower || near_upper) {
            continue;
        }
        if near_lower && unmeasured_tension {
            limits.push(LinearLimit {
                name: force_row_name(s, r),
                value: f,
                pay_out: out.iter().map(|g| inflate * g).collect(),
                reel_in: inn.iter().map(|g| inflate * g).collect(),
                lower,
                upper: f64::INFINITY,
                scale: FORCE_SCALE_N,
            });
            if near_upper {
                limits.push(LinearLimit {
                    name: force_row_name(s, r),
                    value: f,
                    pay_out: out,
                    reel_in: inn,
                    lower: f64::NEG_INFINITY,
                    upper,
                    scale: FORCE_SCALE_N,
                });
            }
            continue;
        }
        limits.push(LinearLimit {
            name: force_row_name(s, r),
            value: f,
            pay_out: out,
            reel_in: inn,
            lower: if near_lower { lower } else { f64::NEG_INFINITY },
            upper: if near_upper { upper } else { f64::INFINITY },
            scale: FORCE_SCALE_N,
        });
    }
    for (pair, &min) in context
        .limits
        .strut_pairs
        .iter()
        .zip(&context.limits.min_clearance_m)
    {
        let (d, sa, tb) = strut_clearance(s, &state.positions_m, *pair);
        if d > min + p.clearance_watch_m || d <= 1e-9 {
            continue;
        }
        let [a, b] = pair.map(|m| s.members[m].nodes);
        let pa = state.positions_m[a[0]] * (1.0 - sa) + state.positions_m[a[1]] * sa;
        let pb = state.positions_m[b[0]] * (1.0 - tb) + state.positions_m[b[1]] * tb;
        let normal = (pa - pb) / d;
        // d(distance) = n·(dpa − dpb) with the closest points held
        // (envelope theorem).
        let slope = |v: &[Vector3<f64>]| {
            let dpa = v[a[0]] * (1.0 - sa) + v[a[1]] * sa;
            let dpb = v[b[0]] * (1.0 - tb) + v[b[1]] * tb;
            normal.dot(&(dpa - dpb))
        };
        limits.push(LinearLimit {
            name: format!(
                "clearance {}–{}",
                s.members[pair[0]].id, s.members[pair[1]].id
            ),
            value: d,
            pay_out: response
                .pay_out
                .iter()
                .map(|e| slope(&e.positions_m_per_m))
                .collect(),
            reel_in: response
                .reel_in
                .iter()
                .map(|e| slope(&e.positions_m_per_m))
                .collect(),
            lower: min + p.clearance_m.min(0.5 * (d - min).max(0.0)),
            upper: f64::INFINITY,
            scale: CLEARANCE_SCALE_M,
        });
    }
    StepData {
        gaps_m: context.gap_vectors(state),
        gap_weights: context.gap_weights.clone(),
        gap_pay_out: response.pair_matrix(&s.midspan_pairs, true),
        gap_reel_in: response.pair_matrix(&s.midspan_pairs, false),
        design_offsets_m: context.design_offsets(state),
        design_pay_out: response.midpoint_matrix(&s.midspan_pairs, true),
        design_reel_in: response.midpoint_matrix(&s.midspan_pairs, false),
        limits,
        payout_m: state.payout_m.clone(),
        min_payout_m: motors.min_payout_m.clone(),
        max_payout_m: motors.max_payout_m.clone(),
        max_step_m: motors.max_step_m.clone(),
        trust_region_m,
        motor_names: s.continuous_cables.iter().map(|c| c.id.clone()).collect(),
    }
}

/// The step weights of the QP planner's `weights`.
pub fn step_weights(weights: &Weights) -> StepWeights {
    StepWeights {
        design_position: weights.design_position,
        regularisation: weights.regularisation,
        split_penalty: weights.split_penalty,
        soft_limit_penalty: weights.soft_limit_penalty,
    }
}

fn norms(v: &[Vector3<f64>]) -> Vec<f64> {
    v.iter().map(|g| g.norm()).collect()
}

/// The responses of `kind` at `state` (secants over `secant_step_m`).
fn responses(
    context: &PlanContext,
    state: &DeploymentState,
    kind: SensitivityKind,
    secant_step_m: f64,
) -> Result<PayoutResponse, SolverFailure> {
    match kind {
        SensitivityKind::Secant => PayoutResponse::finite_difference(
            context.model,
            state,
            secant_step_m,
            context.policy.increment_m,
        )
        .map_err(SolverFailure::SecantSensitivities),
        SensitivityKind::SlidingTangent => PayoutResponse::sliding_tangent(context.model, state)
            .map_err(SolverFailure::TangentSensitivities),
        SensitivityKind::SlipOnset => {
            PayoutResponse::tangent_with(context.model, state, SlipOnset::Loaded)
                .map_err(SolverFailure::TangentSensitivities)
        }
        SensitivityKind::Tangent | SensitivityKind::Auto => {
            PayoutResponse::tangent(context.model, state)
                .map_err(SolverFailure::TangentSensitivities)
        }
    }
}

/// Why a linearisation gave no command.
enum StepFailure {
    /// Stop with this status.
    Stop(PlanStatus),
    /// The model did not confirm the linearisation (no descent predicted,
    /// or the trust region collapsed): another linearisation may do better.
    Unconfirmed(PlanStatus),
}

/// Where a command's linearisation comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Linearisation {
    /// The previous command's responses, updated by what it did.
    Kept,
    /// Computed afresh at the state.
    Fresh(SensitivityKind),
}

impl CommandPlanner for QpPlanner {
    /// A rejected command is treated as a rejected trial: the trust
    /// region it was planned in is shrunk as after a poor reduction
    /// ratio (no smaller than the region's minimum, so that a command can
    /// still be planned), and the kept responses are dropped.
    fn on_command_rejected(&mut self, command: &PlannedCommand) {
        let tr = self.settings.trust_region;
        let radius = command.trust_region_m.unwrap_or(self.trust_region_m);
        self.trust_region_m = tr.after_rejected(radius).max(tr.min_m);
        self.kept = None;
    }

    fn next_command(&mut self, context: &PlanContext, state: &DeploymentState) -> Decision {
        // A slack cable's tangent response is zero: take its slack up
        // first (see `take_up`).
        if let Some(command) = take_up(context, state) {
            self.kept = None;
            return Decision::Command(Box::new(command));
        }
        let kept = self
            .kept
            .take()
            .filter(|k| k.payout_m == state.payout_m && k.positions_m == state.positions_m);
        let mut order = Vec::new();
        if kept.is_some() {
            order.push(Linearisation::Kept);
        }
        let first = self
            .settings
            .sensitivities
            .resolve(!context.model.friction().static_mu.is_zero());
        order.push(Linearisation::Fresh(first));
        // The other kinds are the last resort: the tangent sees nothing at
        // a fold where every joint sticks, secants over 5 cm of single
        // motors miss how the cables of a half act together near the
        // design; where one kind gives no confirmed step, or cannot be
        // computed (a singular or unstable tangent), another may.
        order.extend(first.fallbacks().iter().map(|&k| Linearisation::Fresh(k)));
        let radius = self.trust_region_m;
        let mut kept = kept.map(|k| k.response);
        let mut failures: Vec<(Linearisation, PlanStatus)> = Vec::new();
        for (n, source) in order.into_iter().enumerate() {
            // Every linearisation starts from the radius the command
            // started with.
            self.trust_region_m = radius;
            let response = match source {
                Linearisation::Kept => kept.take(),
                Linearisation::Fresh(kind) => {
                    match responses(context, state, kind, self.settings.sensitivity_step_m) {
                        Ok(r) => Some(r),
                        // Another kind may still linearise here; the
                        // failure is the status only if none does.
                        Err(cause) => {
                            failures.push((source, PlanStatus::SolverFailure { cause }));
                            None
                        }
                    }
                }
            };
            let Some(response) = response else { continue };
            // Kept responses get one trial: if the model does not confirm
            // their first step they are stale, and fresh ones are cheaper
            // than a ladder of shrinking trials.
            let patience = (source == Linearisation::Kept).then_some(1);
            match self.command_from(context, state, &response, n, patience) {
                Ok((command, ratio)) => {
                    self.keep(context, state, response, &command, ratio);
                    return Decision::Command(command);
                }
                Err(StepFailure::Stop(s)) => return Decision::Stop(s),
                Err(StepFailure::Unconfirmed(s)) => failures.push((source, s)),
            }
        }
        Decision::Stop(why_no_linearisation(failures))
    }
}

/// The status of a command no linearisation gave, from each one's failure
/// in the order tried. The first fresh linearisation whose steps the model
/// tried and refused until the trust region collapsed names what bound
/// (the limit of its last trial); else the first whose QP found no
/// reducing step (the active limits); a fallback that could not even be
/// computed (an unstable tangent tried last) is not the reason, and kept
/// responses only say they were stale. A solver failure is the status
/// only when no fresh linearisation got as far as a QP step.
fn why_no_linearisation(failures: Vec<(Linearisation, PlanStatus)>) -> PlanStatus {
    let fresh = |(source, _): &&(Linearisation, PlanStatus)| source != &Linearisation::Kept;
    let reached_a_trial = |(_, status): &&(Linearisation, PlanStatus)| {
        matches!(
            status,
            PlanStatus::NotReachable {
                cause: NotReachable::TrustRegionCollapsed { .. }
            }
        )
    };
    let reached_a_step = |(_, status): &&(Linearisation, PlanStatus)| {
        matches!(status, PlanStatus::NotReachable { .. })
    };
    failures
        .iter()
        .filter(fresh)
        .find(reached_a_trial)
        .or_else(|| failures.iter().filter(fresh).find(reached_a_step))
        .or_else(|| failures.iter().find(fresh))
        .or_else(|| failures.first())
        .map(|(_, status)| status.clone())
        .unwrap_or(PlanStatus::NotReachable {
            cause: NotReachable::NoLinearisation,
        })
}

/// The limits of `data` whose current value already lies beyond their
/// bound, as the QP names its rows (`segment A_cc1[2] min`).
fn beyond_bounds(data: &StepData) -> Vec<String> {
    data.limits
        .iter()
        .filter_map(|l| {
            if l.value < l.lower {
                Some(format!("{} min", l.name))
            } else if l.value > l.upper {
                Some(format!("{} max", l.name))
            } else {
                None
            }
        })
        .collect()
}

impl QpPlanner {
    /// One command from the linearisation `kind` at `state`, shrinking the
    /// trust region until the model confirms a step.
    fn command_from(
        &mut self,
        context: &PlanContext,
        state: &DeploymentState,
        response: &PayoutResponse,
        linearisations_before: usize,
        patience: Option<usize>,
    ) -> Result<(Box<PlannedCommand>, f64), StepFailure> {
        let tr = self.settings.trust_region;
        let mut data = step_data(context, state, response, self.trust_region_m);
        // η from the context, which the merit below uses too.
        let weights = StepWeights {
            design_position: context.design_weight,
            ..step_weights(&self.settings.weights)
        };
        let merit0 = context.merit(&data.gaps_m, &data.design_offsets_m);
        let mut rejected = 0;
        loop {
            data.trust_region_m = self.trust_region_m;
            let step: QpStep = solve_step(&data, &weights, &step_solver_settings());
            match step.status {
                QpStepStatus::Infeasible => {
                    return Err(StepFailure::Stop(PlanStatus::NotReachable {
                        cause: NotReachable::QpInfeasible {
                            binding: beyond_bounds(&data),
                        },
                    }))
                }
                // Degenerate responses (a tangent where every joint
                // sticks) can defeat the solver; another linearisation
                // may not.
                QpStepStatus::NumericalTrouble => {
                    return Err(StepFailure::Unconfirmed(PlanStatus::SolverFailure {
                        cause: SolverFailure::QpNumericalTrouble,
                    }))
                }
                _ => {}
            }
            let predicted =
                merit0 - context.merit(&step.predicted_gaps_m, &step.predicted_design_offsets_m);
            let largest = step.command_m.iter().fold(0.0f64, |a, d| a.max(d.abs()));
            if !(predicted > NO_REDUCTION_M2) || largest < 1e-6 {
                return Err(StepFailure::Unconfirmed(PlanStatus::NotReachable {
                    cause: NotReachable::NoReducingCommand {
                        largest_gap_m: norms(&data.gaps_m).iter().fold(0.0f64, |a, b| a.max(*b)),
                        active_constraints: step.active_constraints,
                    },
                }));
            }
            if !context.command_admissible(state, &step.command_m) {
                // Cannot happen for a solved QP (its bounds are these
                // limits); treat as numerical trouble, never send it.
                return Err(StepFailure::Stop(PlanStatus::SolverFailure {
                    cause: SolverFailure::QpStepBreaksMotorLimit,
                }));
            }
            let trial = context.trial(state, &step.command_m);
            let actual = merit0 - context.state_merit(&trial.state);
            let ratio = actual / predicted;
            if trial.admissible() && tr.accepts(ratio) {
                let radius = self.trust_region_m;
                self.trust_region_m = tr.after_accepted(radius, largest, ratio);
                let command = Box::new(PlannedCommand {
                    command_m: step.command_m,
                    predicted_gaps_m: Some(norms(&step.predicted_gaps_m)),
                    trial,
                    active_constraints: step.active_constraints,
                    qp_status: Some(step.status),
                    trust_region_m: Some(radius),
                    rejected_trials: rejected,
                    linearisations: linearisations_before + 1,
                    take_up: false,
                });
                return Ok((command, ratio));
            }
            let last_trial = match trial.failure() {
                Some(failure) => TrialRejection::Inadmissible(failure),
                None => TrialRejection::LowReductionRatio {
                    ratio,
                    required: tr.acceptance_ratio,
                },
            };
            rejected += 1;
            self.trust_region_m = tr.after_rejected(self.trust_region_m);
            if patience.is_some_and(|p| rejected >= p) {
                return Err(StepFailure::Unconfirmed(PlanStatus::NotReachable {
                    cause: NotReachable::KeptSensitivitiesUnconfirmed { last_trial },
                }));
            }
            if tr.collapsed(self.trust_region_m) {
                return Err(StepFailure::Unconfirmed(PlanStatus::NotReachable {
                    cause: NotReachable::TrustRegionCollapsed {
                        min_radius_m: tr.min_m,
                        last_trial,
                    },
                }));
            }
        }
    }
}

impl QpPlanner {
    /// Keeps `response`, updated by what `command` did on the model, for
    /// the next command if its reduction ratio was within the settings'
    /// `sensitivity_reuse_tolerance` of 1 (never with reuse off).
    fn keep(
        &mut self,
        context: &PlanContext,
        state: &DeploymentState,
        mut response: PayoutResponse,
        command: &PlannedCommand,
        ratio: f64,
    ) {
        let Some(tolerance) = self.settings.sensitivity_reuse_tolerance else {
            return;
        };
        if !((ratio - 1.0).abs() <= tolerance) {
            return;
        }
        let after = &command.trial.state;
        let dx: Vec<Vector3<f64>> = after
            .positions_m
            .iter()
            .zip(&state.positions_m)
            .map(|(a, b)| a - b)
            .collect();
        let df: Vec<f64> = force_rows(context.model, after)
            .iter()
            .zip(force_rows(context.model, state))
            .map(|(a, b)| a - b)
            .collect();
        response.broyden_update(&command.command_m, &dx, &df);
        self.kept = Some(KeptResponse {
            response,
            positions_m: after.positions_m.clone(),
            payout_m: after.payout_m.clone(),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{MotorDirection, SensitivityError};

    fn binding(name: &str) -> PlanStatus {
        PlanStatus::NotReachable {
            cause: NotReachable::NoReducingCommand {
                largest_gap_m: 0.18,
                active_constraints: vec![name.to_string()],
            },
        }
    }

    fn unstable_tangent() -> PlanStatus {
        PlanStatus::SolverFailure {
            cause: SolverFailure::TangentSensitivities(SensitivityError::UnstableTangent {
                motor: 5,
                direction: MotorDirection::PayOut,
            }),
        }
    }

    /// Regression (issue 22, sixth session): on wide seed 777 the
    /// controller planning on the truth's friction stopped five runs with
    /// "solver failure: unstable tangent": the sliding-limit tangent and
    /// the secants had each planned steps the model refused, and the
    /// exact tangent, tried last, could not be computed. What bound the
    /// first linearisation is the reason.
    #[test]
    fn a_fallback_that_cannot_be_computed_does_not_hide_what_bound_the_plan() {
        use Linearisation::{Fresh, Kept};
        use SensitivityKind::{Secant, SlidingTangent, Tangent};
        let failures = vec![
            (Kept, binding("kept")),
            (Fresh(SlidingTangent), unstable_tangent()),
            (Fresh(Secant), binding("segment A_cc1[0] min")),
            (Fresh(Tangent), unstable_tangent()),
        ];
        assert_eq!(
            why_no_linearisation(failures),
            binding("segment A_cc1[0] min")
        );
        // A linearisation whose trials the model refused says more than one
        // whose QP found no reducing step before any trial (review finding).
        let collapsed = PlanStatus::NotReachable {
            cause: NotReachable::TrustRegionCollapsed {
                min_radius_m: 0.002,
                last_trial: TrialRejection::LowReductionRatio {
                    ratio: 0.01,
                    required: 0.1,
                },
            },
        };
        let failures = vec![
            (Fresh(Tangent), binding("no step")),
            (Fresh(Secant), collapsed.clone()),
        ];
        assert_eq!(why_no_linearisation(failures), collapsed);
        // No fresh linearisation reached a step: the first one's failure.
        let failures = vec![
            (Kept, binding("kept")),
            (Fresh(SlidingTangent), unstable_tangent()),
        ];
        assert_eq!(why_no_linearisation(failures), unstable_tangent());
        assert_eq!(
            why_no_linearisation(vec![(Kept, binding("kept"))]),
            binding("kept")
        );
        assert_eq!(
            why_no_linearisation(Vec::new()),
            PlanStatus::NotReachable {
                cause: NotReachable::NoLinearisation
            }
        );
    }
}
