//! What the planners share: the context they plan in, the one trait they
//! implement, and trial commands checked at every increment.
//!
//! A plan is a pure function of (model, problem, policy, start state):
//! planners hold only what they derive from those (a trust-region radius,
//! a step counter), and every probe runs on clones of the state.

use super::causes::TrialFailure;
use super::correction::ModelCorrection;
use super::limits::{corrected_force_rows, force_row_name, LimitCheck, LimitViolation, Limits};
use super::outcome::{PlanError, PlanStatus};
use super::policy::{Policy, PolicyError};
use super::problem::{DeploymentProblem, MotorLimits};
use super::qp_step::QpStepStatus;
use super::slack::{cable_slack_m, slack_growth};
use crate::model::{
    DeploymentState, ForwardModel, IncrementObserver, RelaxReport, RelaxStatus, Workspace,
};

/// Everything a planner plans with, checked once.
#[derive(Debug, Clone)]
pub struct PlanContext<'a> {
    /// The model planned on.
    pub model: &'a ForwardModel,
    /// The problem.
    pub problem: &'a DeploymentProblem,
    /// The policy.
    pub policy: &'a Policy,
    /// Per-motor limits.
    pub motors: MotorLimits,
    /// Member and clearance limits, widened to what the start breaks
    /// until a command restores it ([`Self::hold_restored`]).
    pub limits: Limits,
    /// Weight of each midspan pair's squared gap.
    pub gap_weights: Vec<f64>,
    /// The designed midpoint of each midspan pair (the model's reference
    /// state), m.
    pub design_midpoints_m: Vec<nalgebra::Vector3<f64>>,
    /// Weight η of the pairs' squared midpoint offsets from the design in
    /// the merit and the QP step (the QP planner's `design_position`; 0
    /// for other planners).
    pub design_weight: f64,
    /// Offsets from the last measurement added to every prediction
    /// (zeros open loop; see [`ModelCorrection`]).
    pub correction: ModelCorrection,
}

impl<'a> PlanContext<'a> {
    /// Validates problem and policy against the model's structure; the
    /// limits are widened to what `start` already breaks.
    pub fn new(
        model: &'a ForwardModel,
        problem: &'a DeploymentProblem,
        policy: &'a Policy,
        start: &DeploymentState,
    ) -> Result<Self, PlanError> {
        let s = model.structure();
        if s.midspan_pairs.is_empty() {
            return Err(PlanError::NoMidspanPairs);
        }
        policy.validate()?;
        let motors = problem.motor_limits(s.continuous_cables.len())?;
        let gap_weights = policy
            .gap_weights(s.midspan_pairs.len())
            .ok_or_else(|| PolicyError {
                field: "planner.weights.gap".into(),
                reason: format!(
                    "give one weight or {} (one per midspan pair)",
                    s.midspan_pairs.len()
                ),
            })?;
        let correction =
            ModelCorrection::none(s.midspan_pairs.len(), s.members.len() + s.segment_count());
        let design = model.reference_state();
        let design_midpoints_m = s
            .midspan_pairs
            .iter()
            .map(|[a, b]| 0.5 * (design.positions_m[*a] + design.positions_m[*b]))
            .collect();
        Ok(PlanContext {
            model,
            problem,
            policy,
            motors,
            limits: Limits::new(model, problem, start),
            gap_weights,
            design_midpoints_m,
            design_weight: policy.design_position_weight(),
            correction,
        })
    }

    /// Gap vectors `x_a − x_b` of the midspan pairs as the controller
    /// predicts them: the model's, plus the measured offsets, m.
    pub fn gap_vectors(&self, state: &DeploymentState) -> Vec<nalgebra::Vector3<f64>> {
        self.model
            .structure()
            .midspan_pairs
            .iter()
            .enumerate()
            .map(|(p, [a, b])| {
                state.positions_m[*a] - state.positions_m[*b] + self.correction.gap_offset_m(p)
            })
            .collect()
    }

    /// Lengths of [`Self::gap_vectors`], m.
    pub fn gaps_m(&self, state: &DeploymentState) -> Vec<f64> {
        self.gap_vectors(state).iter().map(|g| g.norm()).collect()
    }

    /// Offset of each midspan pair's midpoint `½(x_a + x_b)` from its
    /// designed position in `state`, m. Orthogonal to the gap `x_a − x_b`,
    /// so the measured gap offsets, which the gaps carry, do not move it.
    pub fn design_offsets(&self, state: &DeploymentState) -> Vec<nalgebra::Vector3<f64>> {
        self.model
            .structure()
            .midspan_pairs
            .iter()
            .zip(&self.design_midpoints_m)
            .map(|([a, b], m)| 0.5 * (state.positions_m[*a] + state.positions_m[*b]) - m)
            .collect()
    }

    /// The merit the QP planner reduces, m²: the weighted sum of squared
    /// `gaps` plus η times the squared midpoint `offsets` from the design.
    pub fn merit(
        &self,
        gaps: &[nalgebra::Vector3<f64>],
        offsets: &[nalgebra::Vector3<f64>],
    ) -> f64 {
        let gap: f64 = gaps
            .iter()
            .zip(&self.gap_weights)
            .map(|(g, w)| w * g.norm_squared())
            .sum();
        let design: f64 = offsets.iter().map(|d| d.norm_squared()).sum();
        gap + self.design_weight * design
    }

    /// [`Self::merit`] of `state`, m².
    pub fn state_merit(&self, state: &DeploymentState) -> f64 {
        self.merit(&self.gap_vectors(state), &self.design_offsets(state))
    }

    /// Holds every start-broken limit that `state` (the end of a command,
    /// with the measured offsets) meets to its required bound from now on
    /// ([`Limits::hold_restored`]).
    pub fn hold_restored(&mut self, state: &DeploymentState) {
        let rows = self.corrected_force_rows(state);
        self.limits.hold_restored(&rows);
    }

    /// `true` when every gap is within the tolerance less the margin.
    pub fn connected(&self, state: &DeploymentState) -> bool {
        let goal = self.problem.connection_tolerance_m - self.policy.margins.connection_m;
        self.gaps_m(state).iter().all(|g| *g <= goal)
    }

    /// Whether `command` keeps every motor in its stroke and step limits
    /// from `state`.
    pub fn command_admissible(&self, state: &DeploymentState, command: &[f64]) -> bool {
        self.drum_command_admissible(state, command, command)
    }

    /// Whether a drum command `drum_m` that moves the cables by `cable_m`
    /// keeps every motor within its step limit (which binds the drum) and
    /// its stroke (which binds the cable payout) from `state`.
    pub fn drum_command_admissible(
        &self,
        state: &DeploymentState,
        drum_m: &[f64],
        cable_m: &[f64],
    ) -> bool {
        let m = &self.motors;
        drum_m.iter().zip(cable_m).enumerate().all(|(c, (u, d))| {
            let p = state.payout_m[c] + d;
            u.abs() <= m.max_step_m[c] * (1.0 + 1e-9)
                && p >= m.min_payout_m[c] - 1e-9
                && p <= m.max_payout_m[c] + 1e-9
        })
    }

    /// Applies `command` to a copy of `state` on the model, checking every
    /// limit at every increment. Each trial starts from a fresh workspace,
    /// so its result is a function of `state` and `command` alone (a
    /// workspace carries the last solve's force scale into tolerances).
    pub fn trial(&self, state: &DeploymentState, command: &[f64]) -> Trial {
        let ws = &mut Workspace::default();
        let mut next = state.clone();
        let mut watch = LimitWatch {
            context: self,
            start_rows_n: self.corrected_force_rows(state),
            start_slack_m: cable_slack_m(self.model, state),
            worst: None,
        };
        let status = match self.model.apply_payout(
            &mut next,
            ws,
            command,
            self.policy.increment_m,
            &mut watch,
        ) {
            Ok(r) => r.status,
            // A command the model refuses (reeled through) counts as a
            // diverged one: never accepted.
            Err(_) => RelaxStatus::Diverged,
        };
        let check = watch.worst.unwrap_or_else(|| {
            self.limits
                .check(self.model, &next, 0.0, &self.correction.force_offsets_n)
        });
        Trial {
            state: next,
            status,
            check,
        }
    }
}

impl PlanContext<'_> {
    /// The model's force rows at `state` plus the measured offsets, N.
    fn corrected_force_rows(&self, state: &DeploymentState) -> Vec<f64> {
        corrected_force_rows(self.model, state, &self.correction.force_offsets_n)
    }

    /// The tensions no sensor reads (cables, springs and segments without
    /// a load cell) whose fall from `start_rows_n` to `rows_n` (force
    /// rows with their offsets, N) leaves less than the policy's
    /// `margins.unmeasured_force_fall` times that fall above their lower
    /// limit (less `tolerance_n`); none with that margin off. The model
    /// sees such a force's level and slope only as well as its effects
    /// match the bridge's, so a fall it predicts to end just above the
    /// limit may end below it.
    pub fn unmeasured_fall_violations(
        &self,
        start_rows_n: &[f64],
        rows_n: &[f64],
        tolerance_n: f64,
    ) -> Vec<LimitViolation> {
        let Some(beta) = self.policy.margins.unmeasured_force_fall else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for (r, ((&f0, &f), b)) in start_rows_n
            .iter()
            .zip(rows_n)
            .zip(&self.limits.force)
            .enumerate()
        {
            if self.limits.euler_n[r].is_some() || self.correction.force_row_measured(r) {
                continue;
            }
            let fall = f0 - f;
            if fall > 0.0 && f - beta * fall < b.lower_n - tolerance_n {
                out.push(LimitViolation::UnmeasuredFall {
                    member: force_row_name(self.model.structure(), r),
                    force_n: f,
                    fall_n: fall,
                    margin: beta,
                    lower_n: b.lower_n,
                });
            }
        }
        out
    }
}

/// A command tried on the model.
#[derive(Debug, Clone)]
pub struct Trial {
    /// The state reached.
    pub state: DeploymentState,
    /// The solver's status (the first non-converged increment stops it).
    pub status: RelaxStatus,
    /// Limits over all increments: worst values and every violation.
    pub check: LimitCheck,
}

impl Trial {
    /// Converged, and no limit broken at any increment.
    pub fn admissible(&self) -> bool {
        self.status.is_converged() && self.check.ok()
    }

    /// Why the trial is not admissible (`None` when it is): the solve
    /// that did not converge, else the first limit broken.
    pub fn failure(&self) -> Option<TrialFailure> {
        if !self.status.is_converged() {
            Some(TrialFailure::Model(self.status))
        } else {
            self.check
                .violations
                .first()
                .cloned()
                .map(TrialFailure::Limit)
        }
    }
}

/// Collects the worst limit values over a command's increments.
struct LimitWatch<'c, 'a> {
    context: &'c PlanContext<'a>,
    /// Force rows at the command's start, with offsets, N.
    start_rows_n: Vec<f64>,
    /// Each continuous cable's slack at the command's start, m: what it is
    /// held to ([`super::slack`]).
    start_slack_m: Vec<f64>,
    worst: Option<LimitCheck>,
}

impl IncrementObserver for LimitWatch<'_, '_> {
    fn on_increment(&mut self, _: usize, _: usize, r: &RelaxReport, state: &DeploymentState) {
        if !r.status.is_converged() {
            return;
        }
        let rows = self.context.corrected_force_rows(state);
        let mut c = self
            .context
            .limits
            .check_rows(self.context.model, state, &rows, r.tolerance_n);
        c.violations.extend(self.context.unmeasured_fall_violations(
            &self.start_rows_n,
            &rows,
            r.tolerance_n,
        ));
        c.violations.extend(slack_growth(
            self.context.model,
            &self.start_slack_m,
            &cable_slack_m(self.context.model, state),
        ));
        self.worst = Some(worst_along_path(self.worst.take(), c));
    }
}

/// The limit check of a path so far (`worst`, `None` before its first
/// state) extended by the check `next` of its next state: the larger
/// utilisation, the smaller tension and clearance, every violation.
pub fn worst_along_path(worst: Option<LimitCheck>, next: LimitCheck) -> LimitCheck {
    match worst {
        None => next,
        Some(mut w) => {
            w.worst_utilisation = w.worst_utilisation.max(next.worst_utilisation);
            w.min_tension_n = w.min_tension_n.min(next.min_tension_n);
            w.min_clearance_m = w.min_clearance_m.min(next.min_clearance_m);
            w.violations.extend(next.violations);
            w
        }
    }
}

/// A command a planner decided on, already tried on the model.
#[derive(Debug, Clone)]
pub struct PlannedCommand {
    /// Payout change per motor, m.
    pub command_m: Vec<f64>,
    /// Predicted gap per pair, m, where the planner predicts.
    pub predicted_gaps_m: Option<Vec<f64>>,
    /// The trial that confirmed it.
    pub trial: Trial,
    /// Constraints active in the decision.
    pub active_constraints: Vec<String>,
    /// QP status (QP planner).
    pub qp_status: Option<QpStepStatus>,
    /// Trust region, m (QP planner).
    pub trust_region_m: Option<f64>,
    /// Trials rejected first.
    pub rejected_trials: usize,
    /// Linearisations computed for it (QP planner: 1 for the tangent
    /// alone, 2 when the secants replaced it; 0 for the baselines).
    pub linearisations: usize,
    /// Whether it takes up slack cables ([`super::take_up`]): each slack
    /// cable's motor reels in its slack alone, a step that does not aim
    /// at the design. A case memory records which of a cycle's commands
    /// these were, so that a learnt approach does not pace them as steps
    /// of every motor ([`crate::learn::Case::take_up_commands`]).
    pub take_up: bool,
}

/// What a planner does next.
#[derive(Debug, Clone)]
pub enum Decision {
    /// Send this command.
    Command(Box<PlannedCommand>),
    /// Stop with this status.
    Stop(PlanStatus),
}

/// The interface every planner implements.
pub trait CommandPlanner {
    /// Decides the next command from `state` (on `context.model`).
    fn next_command(&mut self, context: &PlanContext, state: &DeploymentState) -> Decision;

    /// The last command it decided was rejected before it was sent (an
    /// operator refused it, see [`crate::control::session`]): the next
    /// decision is planned from the same state, more cautiously where the
    /// planner knows how. By default nothing changes, so a planner without
    /// a notion of caution may propose the same command again.
    fn on_command_rejected(&mut self, _command: &PlannedCommand) {}
}
