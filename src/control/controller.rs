//! The controller of a closed-loop deployment, separable from the plant:
//! what it knows (its model state, the payout-scale estimate, the
//! correction from the last measurement, the filtered load-cell offsets,
//! the planner's own state) and the two things it does:
//!
//! - [`Controller::decide`]: the command it would plan on its model and
//!   the drum command it would send for it;
//! - [`Controller::observe`]: advance with what was really sent and
//!   measured.
//!
//! [`super::closed_loop::deploy_closed_loop`] drives it against a truth
//! plant; a replay ([`crate::studies::log_replay`]) drives it with a logged
//! deployment, so the same code decides in both.
//!
//! A sent command that is not the controller's own decision (a logged
//! command that differs, or one sent while it would have stopped) is
//! applied to its model as the cable motion `sent × (1 + ŝ)` that the
//! payout-scale estimate says it made, re-solved from the model state, as
//! the closed loop already treats a command cut by the step limit.
//!
//! Everything is a function of the inputs and of the order of the calls:
//! the same model, problem, policy, sensors and readings give the same
//! decisions (planning times aside).

use std::time::Instant;

use std::collections::VecDeque;

use super::drum_offsets::{
    apply_drum_offsets, estimate_drum_offsets, DrumOffsetEstimate, DrumOffsetPrior,
};
use super::estimation::PayoutScaleEstimator;
use super::force_offset_filter::ForceOffsetFilter;
use super::guidance::{CaseTakeUp, Guidance};
use super::measured_offsets::{filter_force_offsets, model_correction};
use crate::model::{DeploymentState, ForwardModel};
use crate::plan::take_up::take_up;
use crate::plan::{
    folded_start, planner_for, CommandPlanner, ControllerError, Decision, DeploymentProblem,
    PlanContext, PlanError, PlanStatus, PlannedCommand, Policy, QpStepStatus, Trial,
};
use crate::sim::Sensor;

/// Largest difference per motor between a sent command and the
/// controller's decision for which the sent command counts as its own, m:
/// a nanometre, far below any drum's resolution and far above the
/// rounding of a command written to a log and read back (none: logs
/// write the shortest text that reads back to the same number).
pub const OWN_COMMAND_TOLERANCE_M: f64 = 1e-9;

/// A command the controller would send, with what it expects of it.
#[derive(Debug, Clone, PartialEq)]
pub struct Proposal {
    /// The cable motion planned and checked on the model, per motor, m.
    pub planned_m: Vec<f64>,
    /// The drum command for it, per motor, m: the planned motion divided
    /// by `1 + ŝ` (the payout-scale estimate) and cut to the step limit.
    pub sent_m: Vec<f64>,
    /// Gap per midspan pair predicted for the command: the model's trial
    /// plus the correction in force, m.
    pub predicted_gaps_m: Vec<f64>,
    /// Worst member utilisation along the command on the model (with the
    /// force correction).
    pub model_worst_utilisation: f64,
    /// Status of the step's QP (QP planner).
    pub qp_status: Option<QpStepStatus>,
    /// Trust region the command was planned in, m (QP planner).
    pub trust_region_m: Option<f64>,
    /// Trials rejected before the command was accepted.
    pub rejected_trials: usize,
    /// Constraints active in the decision.
    pub active_constraints: Vec<String>,
    /// Whether it takes up slack cables
    /// ([`crate::plan::PlannedCommand::take_up`]).
    pub take_up: bool,
    /// Wall-clock planning time, s (the one value that is not a function
    /// of the inputs).
    pub planning_time_s: f64,
}

/// What the controller does next.
#[derive(Debug, Clone, PartialEq)]
pub enum ControllerDecision {
    /// Send this command.
    Send(Proposal),
    /// Send nothing more: connected (as the controller predicts, with
    /// the measured offsets), the command budget spent, or the planner's
    /// stop.
    Stop(PlanStatus),
}

/// What one observation did.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Whether the sent command was the controller's own decision
    /// (within [`OWN_COMMAND_TOLERANCE_M`]).
    pub own_decision: bool,
    /// The cable motion the model applied for it, per motor, m.
    pub applied_m: Vec<f64>,
    /// Gap per pair the controller predicted for the sent command, with
    /// the correction in force before the new readings, m.
    pub predicted_gaps_m: Vec<f64>,
}

/// Most halvings of one learnt command ([`Guidance::feedforward_splits`]):
/// a sixteenth of a command is below any step a drum makes usefully.
pub const MAX_FEEDFORWARD_SPLITS: usize = 4;

/// The controller's own decision, kept until the next observation.
struct Pending {
    command: Box<PlannedCommand>,
    proposal: Proposal,
    /// Whether it is a feedforward command (not the planner's).
    feedforward: bool,
    /// Whether it is the take-up sent before a feedforward
    /// ([`Controller::take_up_before_feedforward`]).
    take_up_before_feedforward: bool,
}

/// The controller of a closed-loop deployment (see the module notes).
pub struct Controller<'a> {
    context: PlanContext<'a>,
    sensors: &'a [Sensor],
    planner: Box<dyn CommandPlanner>,
    estimator: Option<PayoutScaleEstimator>,
    force_filter: ForceOffsetFilter,
    state: DeploymentState,
    last_readings: Vec<Option<f64>>,
    commands_observed: usize,
    pending: Option<Pending>,
    /// Feedforward drum commands not yet sent (see [`Guidance`]), each
    /// with how many times it was halved from the learnt command.
    feedforward: VecDeque<(Vec<f64>, usize)>,
    /// Halvings allowed per learnt command
    /// ([`Guidance::feedforward_splits`]).
    feedforward_splits: usize,
    /// Whether feedforward commands were given up (the planner took over
    /// before the learnt approach's end).
    feedforward_cut: bool,
    /// Whether the guidance had a feedforward at all.
    guided_approach: bool,
    /// Feedforward commands decided so far.
    feedforward_sent: usize,
    /// Where the feedforward holds the case's take-up
    /// ([`Guidance::case_take_up`]); [`CaseTakeUp::None`] once this
    /// cycle's take-up has replaced one held in front.
    case_take_up: CaseTakeUp,
    /// Commands sent before the feedforward: take-ups of cables the model
    /// sees slack.
    take_ups_first: usize,
    /// Whether the operator rejected the take-up before the feedforward:
    /// the learnt approach then goes ahead without it.
    take_up_declined: bool,
    /// Without a feedforward, the number of the first command predicted
    /// to connect.
    first_connecting: Option<usize>,
    /// The drum offsets estimated at the start (`None`: not estimated).
    drum_offsets: Option<DrumOffsetEstimate>,
}

impl<'a> Controller<'a> {
    /// A controller planning on `model` from the problem's folded start,
    /// with `start_readings` of `sensors` (one per sensor) measured there.
    ///
    /// Errors when the problem, the policy or the model is unusable, or
    /// the model cannot reach the folded start.
    pub fn new(
        model: &'a ForwardModel,
        problem: &'a DeploymentProblem,
        policy: &'a Policy,
        sensors: &'a [Sensor],
        start_readings: &[Option<f64>],
    ) -> Result<Self, PlanError> {
        Self::guided(
            model,
            problem,
            policy,
            sensors,
            start_readings,
            &Guidance::default(),
        )
    }

    /// [`Self::new`] with `guidance` from past cycles: a feedforward of
    /// drum commands to send first and a prior of the payout scale.
    pub fn guided(
        model: &'a ForwardModel,
        problem: &'a DeploymentProblem,
        policy: &'a Policy,
        sensors: &'a [Sensor],
        start_readings: &[Option<f64>],
        guidance: &Guidance,
    ) -> Result<Self, PlanError> {
        let folded = folded_start(model, problem, policy.increment_m)?;
        Self::guided_from(
            model,
            problem,
            policy,
            sensors,
            start_readings,
            guidance,
            folded,
        )
    }

    /// [`Self::guided`] from `folded`, the model's folded start
    /// ([`folded_start`] of the same model, problem and policy) computed
    /// before: an online session keeps it rather than fold the model again
    /// at every command (see [`super::session`]).
    pub fn guided_from(
        model: &'a ForwardModel,
        problem: &'a DeploymentProblem,
        policy: &'a Policy,
        sensors: &'a [Sensor],
        start_readings: &[Option<f64>],
        guidance: &Guidance,
        folded: DeploymentState,
    ) -> Result<Self, PlanError> {
        let s = model.structure();
        let mut state = folded;
        // How much material each cable holds, from the start readings.
        let drum_offsets = policy
            .control
            .drum_offset_prior_sd_m
            .and_then(|offset_sd_m| {
                let prior = DrumOffsetPrior {
                    offset_sd_m,
                    load_cell_bias_sd_n: policy.control.load_cell_bias_prior_sd_n,
                    force_error_fraction: policy.control.force_model_error_fraction,
                };
                estimate_drum_offsets(model, &state, sensors, start_readings, &prior)
            });
        if let Some(e) = &drum_offsets {
            // A model that cannot hold the estimated material plans on
            // what the drums say.
            if let Ok(moved) = apply_drum_offsets(model, &state, &e.offset_m, policy.increment_m) {
                state = moved;
            }
        }
        let mut context = PlanContext::new(model, problem, policy, &state)?;
        let mut force_filter = ForceOffsetFilter::new(
            s.members.len() + s.segment_count(),
            policy.control.force_model_error_fraction,
            policy.control.load_cell_bias_prior_sd_n,
        );
        context.correction = model_correction(
            model,
            &state,
            sensors,
            start_readings,
            &policy.control.measures,
        );
        filter_force_offsets(
            &mut force_filter,
            &mut context.correction,
            model,
            &state,
            sensors,
            start_readings,
            &policy.control.measures,
        );
        // The payout scale is learnt from measured midspan motion; without
        // it there is nothing to learn from.
        let drift_sd = policy.control.payout_scale_drift_sd;
        let estimator = policy.control.payout_scale_estimate_sd().map(|prior_sd| {
            match &guidance.payout_scale_prior {
                Some(prior) => PayoutScaleEstimator::with_prior(
                    model,
                    prior,
                    guidance.payout_scale_prior_sd.unwrap_or(prior_sd),
                    drift_sd,
                ),
                None => PayoutScaleEstimator::new(model, prior_sd, drift_sd),
            }
        });
        let planner = planner_for(&context, &state);
        Ok(Controller {
            context,
            sensors,
            planner,
            estimator,
            force_filter,
            state,
            last_readings: start_readings.to_vec(),
            commands_observed: 0,
            pending: None,
            feedforward: guidance
                .feedforward_m
                .iter()
                .map(|u| (u.clone(), 0))
                .collect(),
            // A session's guidance file is checked on reading; the bound
            // holds for guidance built by hand too (each halving is one
            // more model trial per decision).
            feedforward_splits: guidance.feedforward_splits.min(MAX_FEEDFORWARD_SPLITS),
            feedforward_cut: false,
            guided_approach: !guidance.feedforward_m.is_empty(),
            feedforward_sent: 0,
            case_take_up: guidance.case_take_up.clone(),
            take_ups_first: 0,
            take_up_declined: false,
            first_connecting: None,
            drum_offsets,
        })
    }

    /// The drum offsets it estimated from the start readings and planned
    /// with (`None` with the estimate off or impossible).
    pub fn drum_offsets(&self) -> Option<&DrumOffsetEstimate> {
        self.drum_offsets.as_ref()
    }

    /// The model state the controller believes the bridge is in.
    pub fn state(&self) -> &DeploymentState {
        &self.state
    }

    /// The state its pending decision predicts (its confirmed trial on the
    /// model), if it has decided and not yet observed.
    pub fn pending_prediction(&self) -> Option<&DeploymentState> {
        self.pending.as_ref().map(|p| &p.command.trial.state)
    }

    /// The context it plans in (model, problem, policy, limits, the
    /// correction from the last measurement).
    pub fn context(&self) -> &PlanContext<'a> {
        &self.context
    }

    /// Commands observed so far.
    pub fn commands_observed(&self) -> usize {
        self.commands_observed
    }

    /// The payout-scale estimate `ŝ` per motor, 1 (zeros without an
    /// estimator).
    pub fn payout_scale(&self) -> Vec<f64> {
        match &self.estimator {
            Some(e) => e.motor_scale(),
            None => vec![0.0; self.state.payout_m.len()],
        }
    }

    /// The payout scale of each independent part as estimated now (index
    /// = part id; empty without an estimator), 1.
    pub fn part_payout_scale(&self) -> Vec<f64> {
        self.estimator
            .as_ref()
            .map_or_else(Vec::new, |e| e.part_scale().to_vec())
    }

    /// The load cells' common bias as estimated now: mean and standard
    /// deviation, N (`None` with the estimate off).
    pub fn load_cell_bias_n(&self) -> Option<(f64, f64)> {
        self.force_filter.bias_n()
    }

    /// Commands of the first approach: with a feedforward, the take-up
    /// sent before it (if any) and the feedforward commands decided (a
    /// halved learnt command's parts counted one by one); otherwise the
    /// number of the first command the controller predicted would connect
    /// (`None`: none yet).
    pub fn approach_commands(&self) -> Option<usize> {
        if self.guided_approach {
            Some(self.take_ups_first + self.feedforward_sent)
        } else {
            self.first_connecting
        }
    }

    /// With a feedforward, whether every learnt command was sent (some
    /// in parts); `false` where the planner took over before the learnt
    /// approach's end. `None` without a feedforward.
    pub fn learnt_approach_completed(&self) -> Option<bool> {
        self.guided_approach
            .then_some(!self.feedforward_cut && self.feedforward.is_empty())
    }

    /// The controller's model state, consumed.
    pub fn into_state(self) -> DeploymentState {
        self.state
    }

    /// The command the controller would send now, or why it would send
    /// none. Planning advances the planner's own state (its trust
    /// region), so a decision is planned once: asking again before the
    /// next [`Self::observe`] returns the same decision.
    pub fn decide(&mut self) -> ControllerDecision {
        if let Some(p) = &self.pending {
            return ControllerDecision::Send(p.proposal.clone());
        }
        let clock = Instant::now();
        let connected = self.context.connected(&self.state);
        let take_up_first = if connected {
            None
        } else {
            self.take_up_before_feedforward()
        };
        // The next feedforward command as cable motion, tried on the
        // model; `None` once the feedforward is sent or given up.
        let fed = if take_up_first.is_some() {
            None
        } else {
            let fed = self.next_feedforward_in_parts();
            if fed.is_none() {
                // Beyond a limit on the model (or all sent): the planner
                // takes over.
                self.give_up_feedforward();
            }
            fed
        };
        let fed = match fed {
            // Connected already: the feedforward goes on only while it is
            // predicted to reduce the largest gap.
            Some((_, _, ref trial)) if connected => {
                let largest = |g: Vec<f64>| g.into_iter().fold(0.0, f64::max);
                let now = largest(self.context.gaps_m(&self.state));
                let next = largest(self.context.gaps_m(&trial.state));
                (next < now).then_some(fed).flatten()
            }
            fed => fed,
        };
        if connected && fed.is_none() {
            return ControllerDecision::Stop(PlanStatus::Connected);
        }
        if self.commands_observed >= self.context.policy.max_commands {
            return ControllerDecision::Stop(PlanStatus::CommandLimit);
        }
        let is_take_up = take_up_first.is_some();
        let (c, feedforward_m) = match (take_up_first, fed) {
            (Some(c), _) => (Box::new(c), None),
            (None, Some((sent, cable, trial))) => {
                self.feedforward.pop_front();
                self.feedforward_sent += 1;
                let planned = PlannedCommand {
                    command_m: cable,
                    predicted_gaps_m: None,
                    trial,
                    active_constraints: Vec::new(),
                    qp_status: None,
                    trust_region_m: None,
                    rejected_trials: 0,
                    linearisations: 0,
                    take_up: false,
                };
                (Box::new(planned), Some(sent))
            }
            (None, None) => match self.planner.next_command(&self.context, &self.state) {
                Decision::Stop(status) => return ControllerDecision::Stop(status),
                Decision::Command(c) => (c, None),
            },
        };
        let planning_time_s = clock.elapsed().as_secs_f64();
        if !self.guided_approach
            && self.first_connecting.is_none()
            && self.context.connected(&c.trial.state)
        {
            self.first_connecting = Some(self.commands_observed + 1);
        }
        // The planner plans cable motion; the drums are sent what should
        // make it, as far as the estimate knows. The step limit binds the
        // drum, which the planner's check (on cable motion) does not see.
        // A feedforward command is sent as it was learnt.
        let is_feedforward = feedforward_m.is_some();
        let sent_m = match (feedforward_m, &self.estimator) {
            (Some(sent), _) => sent,
            (None, Some(e)) => e
                .motor_command(&c.command_m)
                .iter()
                .zip(&self.context.motors.max_step_m)
                .map(|(u, max)| u.clamp(-max, *max))
                .collect(),
            (None, None) => c.command_m.clone(),
        };
        let proposal = Proposal {
            planned_m: c.command_m.clone(),
            sent_m,
            predicted_gaps_m: self.context.gaps_m(&c.trial.state),
            model_worst_utilisation: c.trial.check.worst_utilisation,
            qp_status: c.qp_status,
            trust_region_m: c.trust_region_m,
            rejected_trials: c.rejected_trials,
            active_constraints: c.active_constraints.clone(),
            take_up: c.take_up,
            planning_time_s,
        };
        self.pending = Some(Pending {
            command: c,
            proposal: proposal.clone(),
            feedforward: is_feedforward,
            take_up_before_feedforward: is_take_up,
        });
        ControllerDecision::Send(proposal)
    }

    /// The planner's take-up of a cable the model sees slack
    /// ([`crate::plan::take_up`]), while no feedforward command has been
    /// sent (as many as the slack needs: each is at most a drum step).
    /// Spread over the learnt approach, a take-up reels the other cables
    /// in while the slack one is still slack, and its segments, already
    /// below their minimum, fall further (`scenarios/wide.toml` seed 7502
    /// scenario 20: 0.1 N below their start in every learnt cycle, 24
    /// violations, none without the memory). What it does to the learnt
    /// commands once observed: [`Self::after_take_up`].
    fn take_up_before_feedforward(&self) -> Option<PlannedCommand> {
        if !self.guided_approach
            || self.take_up_declined
            || self.feedforward_sent > 0
            || self.feedforward.is_empty()
        {
            return None;
        }
        take_up(&self.context, &self.state)
    }

    /// What an observed take-up before the feedforward does to the learnt
    /// commands, by where they hold the case's take-up
    /// ([`CaseTakeUp`]): held in front, the first one replaces it (its
    /// additions subtracted; the learnt moves are sent as learnt, and
    /// slack beyond the case's is taken up in addition); inside, each is
    /// taken out in proportion ([`Self::keep_learnt_totals_after`]); none,
    /// nothing (slack the case did not have). Where the command observed
    /// was not the controller's own take-up (a resumed session's journal
    /// may hold another in its place), it is taken out in proportion
    /// whatever the case: whatever it was, the learnt commands still end
    /// at their learnt totals, and no learnt step is sent twice.
    fn after_take_up(&mut self, sent_m: &[f64], own_decision: bool) {
        if !own_decision {
            self.keep_learnt_totals_after(sent_m);
            return;
        }
        match std::mem::replace(&mut self.case_take_up, CaseTakeUp::None) {
            CaseTakeUp::InFront(added) => {
                for ((u, _), a) in self.feedforward.iter_mut().zip(&added) {
                    for (x, d) in u.iter_mut().zip(a) {
                        *x -= d;
                    }
                }
                self.drop_empty_feedforward();
            }
            CaseTakeUp::Inside => {
                self.keep_learnt_totals_after(sent_m);
                self.case_take_up = CaseTakeUp::Inside;
            }
            CaseTakeUp::None => {}
        }
    }

    /// Takes the drum motion `sent_m` out of the feedforward not yet
    /// sent: each motor's commands scaled by `(t − sent)/t`, `t` its total
    /// in the feedforward, so that it still ends at its learnt total and
    /// keeps its pace (a paced approach stays the straight path, now from
    /// where the take-up left the motor). A motor the feedforward moves
    /// less than `sent` is not moved by it (its commands scaled by 0: the
    /// take-up went past its learnt total, and the motor ends there); a
    /// motor it moves the other way, or not at all, is left as it is.
    fn keep_learnt_totals_after(&mut self, sent_m: &[f64]) {
        for (m, &sent) in sent_m.iter().enumerate() {
            let total: f64 = self.feedforward.iter().filter_map(|(u, _)| u.get(m)).sum();
            if sent == 0.0 || total * sent <= 0.0 {
                continue;
            }
            let factor = ((total - sent) / total).max(0.0);
            for (u, _) in self.feedforward.iter_mut() {
                if let Some(x) = u.get_mut(m) {
                    *x *= factor;
                }
            }
        }
        self.drop_empty_feedforward();
    }

    /// Drops learnt commands left with no motion; a feedforward left with
    /// none is cut (no learnt approach was sent, so none is scored).
    fn drop_empty_feedforward(&mut self) {
        let had_commands = !self.feedforward.is_empty();
        self.feedforward
            .retain(|(u, _)| u.iter().any(|x| *x != 0.0));
        self.feedforward_cut |= had_commands && self.feedforward.is_empty();
    }

    /// The last decision was rejected before it was sent (an operator
    /// refused it): it is forgotten, the planner is told
    /// ([`crate::plan::CommandPlanner::on_command_rejected`]) and the next
    /// [`Self::decide`] plans again from the same state. A rejected
    /// feedforward command is given up, as one beyond a limit is. Returns
    /// whether there was a decision to reject.
    pub fn reject(&mut self) -> bool {
        let Some(p) = self.pending.take() else {
            return false;
        };
        if p.feedforward {
            // The rejected command was taken off the queue when it was
            // decided: the learnt approach is cut even if it was the last.
            self.feedforward_cut = true;
            self.give_up_feedforward();
        } else if p.take_up_before_feedforward {
            // Not the planner's step to shrink its trust region for: the
            // learnt approach goes ahead without the take-up.
            self.take_up_declined = true;
        } else {
            self.planner.on_command_rejected(&p.command);
        }
        true
    }

    /// Drops the feedforward commands not sent (the planner takes over).
    fn give_up_feedforward(&mut self) {
        self.feedforward_cut |= !self.feedforward.is_empty();
        self.feedforward.clear();
    }

    /// [`Self::next_feedforward`]; where the model refuses the next
    /// command, it is halved (both halves queued, the first tried) while
    /// it has been halved fewer than `feedforward_splits` times, so that
    /// the learnt total goes on in parts the model takes.
    fn next_feedforward_in_parts(&mut self) -> Option<(Vec<f64>, Vec<f64>, Trial)> {
        loop {
            if let Some(fed) = self.next_feedforward() {
                return Some(fed);
            }
            let (front, halvings) = self.feedforward.front()?.clone();
            if halvings >= self.feedforward_splits {
                return None;
            }
            let half: Vec<f64> = front.iter().map(|u| 0.5 * u).collect();
            self.feedforward.pop_front();
            self.feedforward.push_front((half.clone(), halvings + 1));
            self.feedforward.push_front((half, halvings + 1));
        }
    }

    /// The next feedforward command (drum, cable motion `sent·(1 + ŝ)`,
    /// its trial on the model) if the model takes it within every limit.
    fn next_feedforward(&self) -> Option<(Vec<f64>, Vec<f64>, Trial)> {
        let (sent, _) = self.feedforward.front()?;
        let scale = self.payout_scale();
        let cable: Vec<f64> = sent
            .iter()
            .zip(&scale)
            .map(|(u, s)| u * (1.0 + s))
            .collect();
        if !self
            .context
            .drum_command_admissible(&self.state, sent, &cable)
        {
            return None;
        }
        let trial = self.context.trial(&self.state, &cable);
        trial.admissible().then(|| (sent.clone(), cable, trial))
    }

    /// Advances with the drum command `sent_m` that was really sent and
    /// the `readings` (one per sensor) measured after it: the model state
    /// moves to where the command took the bridge, the payout-scale
    /// estimate and the correction are updated.
    ///
    /// A command within [`OWN_COMMAND_TOLERANCE_M`] of the last decision
    /// is that decision (its confirmed trial is the prediction). Any other
    /// is applied to the model as the cable motion `sent × (1 + ŝ)`; an
    /// error if the model cannot follow it (the controller is then as it
    /// was before the call, its decision forgotten).
    pub fn observe(
        &mut self,
        sent_m: &[f64],
        readings: &[Option<f64>],
    ) -> Result<Observation, ControllerError> {
        let motors = self.state.payout_m.len();
        if sent_m.len() != motors {
            return Err(ControllerError::WrongLength {
                what: "the sent command",
                found: sent_m.len(),
                expected: motors,
            });
        }
        if readings.len() != self.sensors.len() {
            return Err(ControllerError::WrongLength {
                what: "the readings",
                found: readings.len(),
                expected: self.sensors.len(),
            });
        }
        let pending = self.pending.take();
        let take_up_pending = pending
            .as_ref()
            .is_some_and(|p| p.take_up_before_feedforward);
        let own = pending.filter(|p| {
            p.proposal
                .sent_m
                .iter()
                .zip(sent_m)
                .all(|(a, b)| (a - b).abs() <= OWN_COMMAND_TOLERANCE_M)
        });
        let own_decision = own.is_some();
        let (planned_m, predicted) = match own {
            Some(p) => {
                let c = *p.command;
                (c.command_m, c.trial.state)
            }
            None => {
                let planned: Vec<f64> = sent_m
                    .iter()
                    .zip(self.payout_scale())
                    .map(|(u, s)| u * (1.0 + s))
                    .collect();
                let trial: Trial = self.context.trial(&self.state, &planned);
                if !trial.status.is_converged() {
                    return Err(ControllerError::CannotFollow {
                        command_m: planned,
                        status: trial.status,
                    });
                }
                (planned, trial.state)
            }
        };
        if take_up_pending {
            // Whatever was sent in the take-up's place stands for it in
            // the approach's count.
            self.take_ups_first += 1;
            self.after_take_up(sent_m, own_decision);
        }
        let predicted_gaps_m = self.context.gaps_m(&predicted);
        let previous_state = std::mem::replace(&mut self.state, predicted);
        if let Some(e) = self.estimator.as_mut() {
            let update = e.update(
                self.sensors,
                &self.last_readings,
                readings,
                &previous_state,
                &self.state,
                &planned_m,
                sent_m,
            );
            if update.motion_factor.iter().any(|f| *f != 1.0) {
                let made: Vec<f64> = planned_m
                    .iter()
                    .zip(&update.motion_factor)
                    .map(|(u, f)| u * f)
                    .collect();
                // Where the command really took the bridge; if the model
                // cannot follow, its own prediction stands.
                let followed = self.context.trial(&previous_state, &made);
                if followed.status.is_converged() {
                    self.state = followed.state;
                }
            }
        }
        let (model, policy) = (self.context.model, self.context.policy);
        self.context.correction = model_correction(
            model,
            &self.state,
            self.sensors,
            readings,
            &policy.control.measures,
        );
        filter_force_offsets(
            &mut self.force_filter,
            &mut self.context.correction,
            model,
            &self.state,
            self.sensors,
            readings,
            &policy.control.measures,
        );
        // A start-broken limit this command restored is held to its bound
        // from now on, as the truth's supervisor holds it.
        self.context.hold_restored(&self.state);
        self.last_readings = readings.to_vec();
        self.commands_observed += 1;
        Ok(Observation {
            own_decision,
            applied_m: planned_m,
            predicted_gaps_m,
        })
    }
}

#[cfg(test)]
mod tests {
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    use super::*;
    use crate::control::fixtures::{frictionless_model, short_fold};
    use crate::sim::{default_truth, standard_sensors, Plant};

    /// Review of the feedforward halves: a learnt command is taken off the
    /// queue when it is decided, so an operator's rejection of the last
    /// one left the queue empty and the approach reported as completed.
    /// Rejected, the learnt approach is cut; sent, it is completed.
    #[test]
    fn rejecting_the_last_learnt_command_cuts_the_learnt_approach() {
        let model = frictionless_model();
        let problem = short_fold();
        let policy = Policy::default();
        let sensors = standard_sensors(model.structure());
        let truth = default_truth(model.structure().clone());
        let plant = Plant::new(&truth, Some(&[0.10; 10]), None).unwrap();
        let first = plant.measure(&sensors, &mut StdRng::seed_from_u64(1));
        let guidance = Guidance {
            feedforward_m: vec![vec![-0.02; 10]],
            feedforward_splits: 2,
            ..Guidance::default()
        };
        let controller =
            || Controller::guided(&model, &problem, &policy, &sensors, &first, &guidance).unwrap();
        let mut c = controller();
        assert!(matches!(c.decide(), ControllerDecision::Send(_)));
        assert!(c.reject());
        assert_eq!(c.learnt_approach_completed(), Some(false));
        let mut c = controller();
        let ControllerDecision::Send(p) = c.decide() else {
            panic!("no command");
        };
        assert_eq!(p.sent_m, guidance.feedforward_m[0]);
        assert_eq!(c.learnt_approach_completed(), Some(true));
    }

    /// A 58 cm fold leaves a cable slack on the model: a guided controller
    /// proposes the planner's take-up before the learnt commands, marked a
    /// take-up (so the case records it) and counted in the approach. What
    /// it does to the learnt commands depends on where they hold the
    /// case's take-up: in front, it replaces it (the additions subtracted
    /// exactly); none, nothing; inside or unknown, it is taken out in
    /// proportion (the totals kept). Another command sent in its place
    /// (a resumed session's journal) is taken out in proportion whatever
    /// the case (review of the twenty-first session: a resumed session
    /// re-sent a learnt step; review of the twenty-second: taking out only
    /// the case's take-up brought that back). Rejected, the learnt
    /// approach goes ahead without it.
    #[test]
    fn a_take_up_before_the_learnt_approach_replaces_the_cases_take_up() {
        let model = frictionless_model();
        let problem = DeploymentProblem {
            start_payout_m: crate::plan::PerMotor::All(0.58),
            max_payout_m: crate::plan::PerMotor::All(0.6),
            ..DeploymentProblem::default()
        };
        let policy = Policy::default();
        let sensors = standard_sensors(model.structure());
        // No readings: the controller plans on its model's fold alone
        // (the load cells' offsets would hold a slack far segment at 0 N
        // and stop the planner at this fold, known limitations 18).
        let first = vec![None; sensors.len()];
        let moves = vec![vec![-0.02; 10]; 3];
        // The case's take-up in front: 25 mm of motor 1, 5 mm of motor 6,
        // both in the first learnt command.
        let mut added = vec![vec![0.0; 10]];
        added[0][1] = -0.025;
        added[0][6] = -0.005;
        let mut learnt = moves.clone();
        learnt[0][1] = -0.045;
        learnt[0][6] = -0.025;
        let guidance = |case_take_up: CaseTakeUp| Guidance {
            feedforward_m: learnt.clone(),
            feedforward_splits: 2,
            case_take_up,
            ..Guidance::default()
        };
        let in_front = guidance(CaseTakeUp::InFront(added.clone()));
        let controller = |g: &Guidance| {
            Controller::guided(&model, &problem, &policy, &sensors, &first, g).unwrap()
        };
        let commands = |c: &Controller| -> Vec<Vec<f64>> {
            c.feedforward.iter().map(|(u, _)| u.clone()).collect()
        };
        let totals = |c: &[Vec<f64>]| -> Vec<f64> {
            (0..10).map(|m| c.iter().map(|u| u[m]).sum()).collect()
        };
        let close = |a: &[Vec<f64>], b: &[Vec<f64>]| {
            a.len() == b.len()
                && a.iter()
                    .flatten()
                    .zip(b.iter().flatten())
                    .all(|(x, y)| (x - y).abs() < 1e-15)
        };

        let mut c = controller(&in_front);
        let ControllerDecision::Send(take_up) = c.decide() else {
            panic!("no command: {:?}", c.decide());
        };
        assert_ne!(take_up.sent_m, learnt[0], "the take-up comes first");
        assert!(take_up.take_up, "the proposal says it is a take-up");
        let moved: Vec<usize> = (0..10).filter(|&m| take_up.sent_m[m] != 0.0).collect();
        assert!(
            !moved.is_empty() && moved.len() < 10,
            "{:?}",
            take_up.sent_m
        );
        c.observe(&take_up.sent_m, &first).unwrap();
        assert_eq!(c.approach_commands(), Some(1));
        assert!(close(&commands(&c), &moves), "{:?}", commands(&c));

        // A case that took up no slack: the learnt commands as learnt.
        let mut c = controller(&guidance(CaseTakeUp::None));
        assert!(matches!(c.decide(), ControllerDecision::Send(_)));
        c.observe(&take_up.sent_m, &first).unwrap();
        assert_eq!(c.approach_commands(), Some(1));
        assert_eq!(commands(&c), learnt);

        // Inside or not known: out in proportion, the totals kept.
        let proportional = |sent: &[f64], c: &Controller| {
            for (m, (t, t0)) in totals(&commands(c)).iter().zip(totals(&learnt)).enumerate() {
                let expected = if t0 * sent[m] > 0.0 {
                    (t0 - sent[m]).min(0.0)
                } else {
                    t0
                };
                assert!(
                    (t - expected).abs() < 1e-12,
                    "motor {m}: {t} against {expected}"
                );
            }
        };
        let mut c = controller(&guidance(CaseTakeUp::Inside));
        assert!(matches!(c.decide(), ControllerDecision::Send(_)));
        c.observe(&take_up.sent_m, &first).unwrap();
        assert_eq!(c.approach_commands(), Some(1));
        proportional(&take_up.sent_m, &c);

        // Not the take-up: out in proportion, though the case's is in
        // front.
        let mut c = controller(&in_front);
        assert!(matches!(c.decide(), ControllerDecision::Send(_)));
        let instead = vec![-0.01; 10];
        c.observe(&instead, &first).unwrap();
        assert_eq!(c.approach_commands(), Some(1));
        proportional(&instead, &c);

        let mut c = controller(&in_front);
        assert!(matches!(c.decide(), ControllerDecision::Send(_)));
        assert!(c.reject());
        let ControllerDecision::Send(next) = c.decide() else {
            panic!("no command");
        };
        assert_ne!(
            next.sent_m, take_up.sent_m,
            "the take-up is not proposed again"
        );
        assert_eq!(c.approach_commands(), Some(1), "a learnt command decided");
    }
}
