//! An online deployment session: the controller driven one command at a
//! time by a plant outside this process (a rig program, an operator at
//! the motors), with interlocks between them.
//!
//! # A session is its journal
//! Everything that happened is a [`SessionEvent`], in order: the readings
//! of a step, a command issued, approved or rejected, an interlock's stop
//! and an operator's resume, the end. [`Session::replay`] rebuilds the
//! session from its events alone: the [`Controller`] decides and observes
//! each recorded step exactly as a closed-loop deployment does
//! ([`super::closed_loop`]), so a session interrupted anywhere continues
//! with the command it would have issued, and a session given the readings
//! of a `deploy` run issues that run's commands. The operations ([`Session::next_command`],
//! [`Session::record`], …) check what they are asked against the session's
//! phase and return the new events, already applied; the caller stores
//! them (the file format is [`crate::io::session_files`]).
//!
//! # Steps
//! Step 0 is the folded start (its readings come first); step `k ≥ 1` is
//! command `k` and the readings taken after it was executed.
//!
//! # Phases ([`SessionPhase`])
//! `awaiting_start` (no readings yet) → `ready` (the last step's readings
//! are in) → `pending` (command issued, its readings awaited; with
//! approval required it must be approved before it may be executed) →
//! `ready` … until `ended` (the controller stopped: connected, or not
//! reachable with its reason). An interlock (below) moves `ready` to
//! `stopped` until an operator resumes.
//!
//! # Interlocks ([`Interlocks`])
//! - no command is issued while the readings of the last one are missing
//!   (a pending command blocks the next), and readings are accepted only
//!   for the pending command's step (or step 0 at the start);
//! - readings outside a sensor's plausible range, or a load cell whose
//!   reading (less the estimated common bias) puts its member beyond the
//!   limit the controller holds it to, stop the session with the reason;
//!   the readings are kept and the controller learns from them, but
//!   nothing is issued until [`Session::resume`];
//! - a command the model predicts beyond a limit is never issued: the
//!   planners only propose commands their trial on the model admits, and
//!   the session checks the trial's utilisation again before issuing.
//!
//! Pure: no files, no clock; the same events give the same session.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::controller::{Controller, ControllerDecision, Proposal, OWN_COMMAND_TOLERANCE_M};
use super::guidance::Guidance;
use super::measured_offsets::load_cell_row;
use crate::model::{DeploymentState, EffectKind, ForwardModel};
use crate::plan::limits::{force_row_name, Limits};
use crate::plan::{DeploymentProblem, PlanError, Policy};
use crate::sim::{Sensor, SensorTarget};

/// One thing that happened in a session (see the module notes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case", deny_unknown_fields)]
pub enum SessionEvent {
    /// The readings of step `step`, one per sensor in the layout's order
    /// (`None`: not read).
    Readings {
        /// 0: the folded start; `k`: after command `k`.
        step: usize,
        /// One value per sensor, in its unit (N, m, °C).
        values: Vec<Option<f64>>,
        /// What an interlock found in them, if anything: the session
        /// stops after them. One event with the readings, so that no
        /// crash can keep the readings and lose the stop.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        stopped: Option<String>,
    },
    /// Command `step` issued: the drum payout change per motor, m.
    Issued {
        /// The command's number, from 1.
        step: usize,
        /// Payout change per motor, m (positive pays out).
        command_m: Vec<f64>,
    },
    /// An operator approved the pending command `step`.
    Approved {
        /// The command's number.
        step: usize,
    },
    /// An operator rejected the pending command `step`; it was not
    /// executed and the controller plans again from the same state.
    Rejected {
        /// The command's number.
        step: usize,
        /// Why, in the operator's words.
        reason: String,
    },
    /// An operator resumed a stopped session.
    Resumed {
        /// The step it was stopped at.
        step: usize,
        /// The operator's note.
        note: String,
        /// Whether the readings that tripped the interlock were
        /// discarded (the sensors are read again for the same step)
        /// rather than kept (the controller learns from them).
        #[serde(default)]
        discard: bool,
    },
    /// The controller ended the session.
    Ended {
        /// The controller's status label ([`crate::plan::PlanStatus::label`]).
        status: String,
        /// The status in words.
        words: String,
    },
}

/// The readings of one step, in the sensor layout's order, as a plant
/// reports them.
#[derive(Debug, Clone, PartialEq)]
pub struct StepReadings {
    /// The step they belong to (0: the folded start; `k`: after command
    /// `k`).
    pub step: usize,
    /// One per sensor (`None`: not read).
    pub values: Vec<Option<f64>>,
}

/// Where a session stands.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "phase", rename_all = "snake_case")]
pub enum SessionPhase {
    /// Waiting for the folded start's readings (step 0).
    AwaitingStart,
    /// The readings of `step` are in; the next command is `step + 1`.
    Ready {
        /// The last step measured.
        step: usize,
    },
    /// Command `step` issued; its readings are awaited.
    Pending {
        /// The command's number.
        step: usize,
        /// Payout change per motor, m.
        command_m: Vec<f64>,
        /// Whether it may be executed: approved, or no approval required.
        cleared: bool,
    },
    /// An operator discarded the readings of `step` an interlock stopped
    /// on: the sensors are to be read again, the command (if any) not
    /// repeated.
    Remeasure {
        /// The step whose readings are awaited again.
        step: usize,
    },
    /// An interlock stopped the session; nothing is issued until resumed.
    Stopped {
        /// The step whose readings tripped it.
        step: usize,
        /// What tripped.
        reason: String,
    },
    /// The controller ended the session.
    Ended {
        /// The status label (`connected`, `not_reachable`, …).
        status: String,
        /// In words.
        words: String,
    },
}

impl SessionPhase {
    /// The phase's name, as status files write it.
    pub fn label(&self) -> &'static str {
        match self {
            SessionPhase::AwaitingStart => "awaiting_start",
            SessionPhase::Ready { .. } => "ready",
            SessionPhase::Pending { .. } => "pending",
            SessionPhase::Remeasure { .. } => "remeasure",
            SessionPhase::Stopped { .. } => "stopped",
            SessionPhase::Ended { .. } => "ended",
        }
    }
}

/// The interlocks' thresholds (see the module notes). A session keeps
/// those it was created with (`session.toml`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Interlocks {
    /// A load cell's reading, less the estimated common bias, beyond its
    /// member's bound by more than this many standard deviations (the
    /// cell's noise and the bias estimate's, together) stops the session.
    /// Default 3: a member on its bound trips it in 0.13 % of readings,
    /// one beyond by 3 noise SDs (21 N for the 7 N cells) in half.
    pub limit_sigmas: f64,
    /// Largest distance of a position reading from where the controller's
    /// model puts the node, m. Default 0.5, about a hundred times what the
    /// model errors the controller corrects for move the midspan: on the
    /// truth of heavy joints, soft cables and slip −0.05 (the cycles
    /// study of issue 24) the largest measured and predicted gaps differed
    /// by at most 5.3 mm per command over three cycles. Half a metre is a
    /// sensor on the wrong node or a bridge far from any model of it.
    pub max_position_offset_m: f64,
    /// Plausible air temperature, °C: `(low, high)`. Default −40 to 60:
    /// outside it the thermometer, not the weather, is at fault.
    pub temperature_range_c: (f64, f64),
}

impl Default for Interlocks {
    fn default() -> Self {
        Interlocks {
            limit_sigmas: 3.0,
            max_position_offset_m: 0.5,
            temperature_range_c: (-40.0, 60.0),
        }
    }
}

impl Interlocks {
    /// Checks every threshold's range; the error names the field.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(self.limit_sigmas > 0.0 && self.limit_sigmas <= 10.0) {
            return Err((
                "limit_sigmas",
                format!("{} is not in (0, 10]", self.limit_sigmas),
            ));
        }
        if !(self.max_position_offset_m > 0.0 && self.max_position_offset_m <= 10.0) {
            return Err((
                "max_position_offset_m",
                format!("{} m is not in (0, 10]", self.max_position_offset_m),
            ));
        }
        let (low, high) = self.temperature_range_c;
        if !(low.is_finite() && high.is_finite() && low < high) {
            return Err((
                "temperature_range_c",
                format!("[{low}, {high}] °C is not a range (low < high, finite)"),
            ));
        }
        Ok(())
    }

    /// The lowest plausible load-cell reading of a sensor with noise SD
    /// `noise_sd_n`, N: a cable cannot push, so below zero is only the
    /// cell's bias (the effect `load_cell_bias`'s plausible range) and its
    /// noise (5 SDs).
    pub fn lowest_plausible_tension_n(noise_sd_n: f64) -> f64 {
        let (low, _) = EffectKind::LoadCellBias.parameters()[0].plausible;
        low - 5.0 * noise_sd_n
    }
}

/// Everything a session runs with.
#[derive(Debug, Clone, Copy)]
pub struct SessionSetup<'a> {
    /// The controller's model.
    pub model: &'a ForwardModel,
    /// The problem (start, connection, limits).
    pub problem: &'a DeploymentProblem,
    /// The policy.
    pub policy: &'a Policy,
    /// The sensor layout the readings follow.
    pub sensors: &'a [Sensor],
    /// Guidance from past cycles (none: [`Guidance::default`]).
    pub guidance: &'a Guidance,
    /// The model's folded start ([`crate::plan::folded_start`] of this
    /// model, problem and policy), computed once when the session was
    /// created (`None`: folded again here; the same state, bit for bit,
    /// at the cost of a relaxation from the design).
    pub folded_start: Option<&'a DeploymentState>,
    /// Whether every command needs an operator's approval before it may
    /// be executed.
    pub approval_required: bool,
    /// The interlocks' thresholds.
    pub interlocks: Interlocks,
}

/// An operation the session refuses in its present phase, or input it
/// cannot take. The session is unchanged.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SessionRefusal {
    /// `next` before the folded start was measured.
    #[error("the folded start has not been measured: record the readings of step 0 first")]
    AwaitingStart,
    /// Stopped by an interlock.
    #[error("the session is stopped after step {step}: {reason}; an operator must resume it")]
    Stopped {
        /// The step.
        step: usize,
        /// What tripped.
        reason: String,
    },
    /// The session has ended.
    #[error("the session has ended: {words}")]
    Ended {
        /// How.
        words: String,
    },
    /// Readings for a step that is not the one awaited.
    #[error("readings for step {given}, but {expected}")]
    WrongStep {
        /// The step the readings name.
        given: usize,
        /// What the session awaits, in words.
        expected: String,
    },
    /// Readings for a command that must be approved first.
    #[error("command {step} has not been approved: it may not have been executed")]
    NotApproved {
        /// The command.
        step: usize,
    },
    /// Approval or rejection of a command already cleared for execution
    /// (approved, or no approval required): it may be running.
    #[error(
        "command {step} is already cleared for execution (it may be running): record its readings"
    )]
    AlreadyCleared {
        /// The command.
        step: usize,
    },
    /// Approval or rejection with no such pending command.
    #[error("no command {step} is pending ({phase})")]
    NoSuchPending {
        /// The command named.
        step: usize,
        /// The session's phase, in words.
        phase: String,
    },
    /// Resume of a session that is not stopped.
    #[error("the session is not stopped ({phase}): nothing to resume")]
    NotStopped {
        /// The phase.
        phase: String,
    },
    /// The session's own record refused an event built for it (a bug,
    /// reported rather than a panic).
    #[error("the session's journal refused its own event: {0}")]
    Journal(SessionError),
    /// Readings of the wrong length or not finite.
    #[error("sensor \"{sensor}\": {why}")]
    BadReading {
        /// The sensor's id.
        sensor: String,
        /// What is wrong.
        why: String,
    },
    /// Readings with no value of any sensor but the thermometer: the
    /// controller would learn nothing from them.
    #[error("no reading of any sensor but the thermometer: nothing to learn from")]
    NoReadings,
    /// A reading count that is not the layout's.
    #[error("{found} readings, the sensor layout has {expected}")]
    WrongReadingCount {
        /// Given.
        found: usize,
        /// Expected.
        expected: usize,
    },
}

/// A journal that cannot be the record of a session with this setup
/// (written by hand, or by another setup).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SessionError {
    /// An event that its phase does not allow.
    #[error("event {index}: {why}")]
    Inconsistent {
        /// The event's index in the journal (0 for the first).
        index: usize,
        /// Why.
        why: String,
    },
    /// The controller could not start on the model and problem.
    #[error("the controller cannot start: {0}")]
    Start(PlanError),
}

/// Readings an interlock stopped on.
#[derive(Debug, Clone)]
struct HeldReadings {
    /// Their step.
    step: usize,
    /// One per sensor.
    values: Vec<Option<f64>>,
    /// The command they follow (`None`: the start's readings).
    command_m: Option<Vec<f64>>,
}

/// A session rebuilt from its events (see the module notes).
pub struct Session<'a> {
    setup: SessionSetup<'a>,
    controller: Option<Controller<'a>>,
    phase: SessionPhase,
    /// Readings per step recorded so far (step 0 first).
    readings: Vec<Vec<Option<f64>>>,
    /// Commands executed so far (the issued ones whose readings are in).
    executed_m: Vec<Vec<f64>>,
    /// Commands whose issued value differs from the controller's
    /// decision on replay (a journal written by another version).
    diverged: Vec<usize>,
    /// Why the controller could not follow the last executed command
    /// (its decision forgotten), if it could not.
    cannot_follow: Option<String>,
    /// Readings an interlock stopped on, held until an operator keeps or
    /// discards them.
    held: Option<HeldReadings>,
    /// In [`SessionPhase::Remeasure`], the command the awaited readings
    /// follow (`None` at the start).
    remeasured_command: Option<Vec<f64>>,
    /// Events applied.
    events: usize,
    /// The model's folded start (the setup's, or folded here).
    start_state: DeploymentState,
}

impl<'a> Session<'a> {
    /// Checks that a controller can start on the setup's model, problem
    /// and policy (it reaches the folded start), before a session is
    /// opened on them; returns the folded start for the session to keep
    /// ([`SessionSetup::folded_start`]).
    pub fn check_setup(setup: &SessionSetup) -> Result<DeploymentState, SessionError> {
        let state = crate::plan::folded_start(setup.model, setup.problem, setup.policy.increment_m)
            .map_err(SessionError::Start)?;
        crate::plan::PlanContext::new(setup.model, setup.problem, setup.policy, &state)
            .map_err(SessionError::Start)?;
        Ok(state)
    }

    /// A new session, before any event; folds the model unless the setup
    /// keeps its folded start (an error when it cannot reach it).
    pub fn new(setup: SessionSetup<'a>) -> Result<Self, SessionError> {
        let start_state = match setup.folded_start {
            Some(s) => s.clone(),
            None => crate::plan::folded_start(setup.model, setup.problem, setup.policy.increment_m)
                .map_err(SessionError::Start)?,
        };
        Ok(Session {
            start_state,
            setup,
            controller: None,
            phase: SessionPhase::AwaitingStart,
            readings: Vec::new(),
            executed_m: Vec::new(),
            diverged: Vec::new(),
            cannot_follow: None,
            held: None,
            remeasured_command: None,
            events: 0,
        })
    }

    /// The session the events describe.
    pub fn replay(setup: SessionSetup<'a>, events: &[SessionEvent]) -> Result<Self, SessionError> {
        let mut session = Session::new(setup)?;
        for event in events {
            session.apply(event)?;
        }
        Ok(session)
    }

    /// Where it stands.
    pub fn phase(&self) -> &SessionPhase {
        &self.phase
    }

    /// The controller (`None` before the start's readings).
    pub fn controller(&self) -> Option<&Controller<'a>> {
        self.controller.as_ref()
    }

    /// Readings per step recorded so far, step 0 first.
    pub fn readings(&self) -> &[Vec<Option<f64>>] {
        &self.readings
    }

    /// The commands executed so far (issued, and their readings in), m.
    pub fn executed_commands_m(&self) -> &[Vec<f64>] {
        &self.executed_m
    }

    /// Commands whose issued value the controller would not issue now
    /// (its decision differs on replay): empty for a journal this version
    /// wrote.
    pub fn diverged_commands(&self) -> &[usize] {
        &self.diverged
    }

    /// The controller's proposal for the pending command: what it
    /// predicted for it (`None` without a pending command, or when the
    /// command issued is not the one it would issue now).
    pub fn pending_proposal(&mut self) -> Option<Proposal> {
        let SessionPhase::Pending { step, .. } = self.phase else {
            return None;
        };
        if self.diverged.contains(&step) {
            return None;
        }
        match self.controller.as_mut()?.decide() {
            ControllerDecision::Send(p) => Some(p),
            ControllerDecision::Stop(_) => None,
        }
    }

    /// Events applied so far.
    pub fn event_count(&self) -> usize {
        self.events
    }

    /// The setup.
    pub fn setup(&self) -> &SessionSetup<'a> {
        &self.setup
    }

    /// Plans the next command: the pending command if there is one (the
    /// same one, however often asked), else the controller's decision,
    /// issued, or the session's end.
    pub fn next_command(&mut self) -> Result<Vec<SessionEvent>, SessionRefusal> {
        let step = match &self.phase {
            SessionPhase::AwaitingStart => return Err(SessionRefusal::AwaitingStart),
            // Nothing new until the awaited readings come.
            SessionPhase::Pending { .. } | SessionPhase::Remeasure { .. } => return Ok(Vec::new()),
            SessionPhase::Stopped { .. } | SessionPhase::Ended { .. } => {
                return Err(self.closed_refusal())
            }
            SessionPhase::Ready { step } => *step,
        };
        let event = if let Some(why) = &self.cannot_follow {
            SessionEvent::Ended {
                status: "solver_failure".into(),
                words: format!("solver failure: {why}"),
            }
        } else {
            let Some(controller) = self.controller.as_mut() else {
                return Err(SessionRefusal::AwaitingStart);
            };
            match controller.decide() {
                ControllerDecision::Stop(status) => SessionEvent::Ended {
                    status: status.label().into(),
                    words: status.describe(),
                },
                ControllerDecision::Send(p) if p.model_worst_utilisation > 1.0 => {
                    // The planners never propose such a command; if one
                    // did, it is not issued.
                    controller.reject();
                    SessionEvent::Ended {
                        status: "not_reachable".into(),
                        words: format!(
                            "not reachable safely: the command planned for step {} is beyond a limit on the model (utilisation {:.3}); not issued",
                            step + 1,
                            p.model_worst_utilisation
                        ),
                    }
                }
                ControllerDecision::Send(p) => SessionEvent::Issued {
                    step: step + 1,
                    command_m: p.sent_m,
                },
            }
        };
        self.commit(vec![event])
    }

    /// Records the readings of `step`: the folded start (step 0) or the
    /// pending command's, executed. Returns the readings' event and, if an
    /// interlock trips on them, the stop.
    pub fn record(
        &mut self,
        step: usize,
        values: Vec<Option<f64>>,
    ) -> Result<Vec<SessionEvent>, SessionRefusal> {
        let wrong = |expected: String| SessionRefusal::WrongStep {
            given: step,
            expected,
        };
        match &self.phase {
            SessionPhase::AwaitingStart if step == 0 => {}
            SessionPhase::Remeasure { step: k } if step == *k => {}
            SessionPhase::Remeasure { step: k } => {
                return Err(wrong(format!(
                    "step {k}'s readings were discarded: the readings awaited are step {k}'s, read again"
                )))
            }
            SessionPhase::AwaitingStart => {
                return Err(wrong(
                    "the folded start's readings (step 0) come first".into(),
                ))
            }
            SessionPhase::Pending {
                step: k, cleared, ..
            } if step == *k => {
                if !cleared {
                    return Err(SessionRefusal::NotApproved { step });
                }
            }
            SessionPhase::Pending { step: k, .. } => {
                return Err(wrong(format!(
                    "command {k} is pending: the readings awaited are step {k}'s"
                )))
            }
            SessionPhase::Ready { step: k } => {
                return Err(wrong(format!(
                    "no command is pending: step {k} is measured, and `next` issues command {}",
                    k + 1
                )))
            }
            SessionPhase::Stopped { .. } | SessionPhase::Ended { .. } => {
                return Err(self.closed_refusal())
            }
        }
        self.check_values(&values)?;
        let stopped = self.interlock(&values);
        self.commit(vec![SessionEvent::Readings {
            step,
            values,
            stopped,
        }])
    }

    /// Why a stopped or ended session refuses to go on.
    fn closed_refusal(&self) -> SessionRefusal {
        match &self.phase {
            SessionPhase::Stopped { step, reason } => SessionRefusal::Stopped {
                step: *step,
                reason: reason.clone(),
            },
            SessionPhase::Ended { words, .. } => SessionRefusal::Ended {
                words: words.clone(),
            },
            phase => SessionRefusal::NotStopped {
                phase: phase.label().into(),
            },
        }
    }

    /// An operator approves the pending command `step`.
    pub fn approve(&mut self, step: usize) -> Result<Vec<SessionEvent>, SessionRefusal> {
        self.check_uncleared(step)?;
        self.commit(vec![SessionEvent::Approved { step }])
    }

    /// An operator rejects the pending command `step` for `reason`: it is
    /// not executed, and the next [`Self::next_command`] plans again from the same
    /// state ([`Controller::reject`]).
    pub fn reject(
        &mut self,
        step: usize,
        reason: &str,
    ) -> Result<Vec<SessionEvent>, SessionRefusal> {
        self.check_uncleared(step)?;
        self.commit(vec![SessionEvent::Rejected {
            step,
            reason: reason.to_string(),
        }])
    }

    /// An operator resumes a session an interlock stopped: with
    /// `discard`, the readings that tripped it are dropped and the same
    /// step's readings are awaited again (a sensor fault, fixed); without,
    /// the controller takes them as they are.
    pub fn resume(
        &mut self,
        note: &str,
        discard: bool,
    ) -> Result<Vec<SessionEvent>, SessionRefusal> {
        let SessionPhase::Stopped { step, .. } = self.phase else {
            return Err(SessionRefusal::NotStopped {
                phase: self.phase.label().into(),
            });
        };
        self.commit(vec![SessionEvent::Resumed {
            step,
            note: note.to_string(),
            discard,
        }])
    }

    /// Command `step` is pending and not yet cleared: only then may an
    /// operator approve or reject it (a cleared command may be running).
    fn check_uncleared(&self, step: usize) -> Result<(), SessionRefusal> {
        match &self.phase {
            SessionPhase::Pending {
                step: k,
                cleared: false,
                ..
            } if *k == step => Ok(()),
            SessionPhase::Pending {
                step: k,
                cleared: true,
                ..
            } if *k == step => Err(SessionRefusal::AlreadyCleared { step }),
            phase => Err(SessionRefusal::NoSuchPending {
                step,
                phase: phase.label().into(),
            }),
        }
    }

    /// One value per sensor, each finite.
    fn check_values(&self, values: &[Option<f64>]) -> Result<(), SessionRefusal> {
        let sensors = self.setup.sensors;
        if values.len() != sensors.len() {
            return Err(SessionRefusal::WrongReadingCount {
                found: values.len(),
                expected: sensors.len(),
            });
        }
        for (s, v) in sensors.iter().zip(values) {
            if let Some(v) = v {
                if !v.is_finite() {
                    return Err(SessionRefusal::BadReading {
                        sensor: s.id.clone(),
                        why: format!("{v} is not a finite number"),
                    });
                }
            }
        }
        let compared = sensors
            .iter()
            .zip(values)
            .any(|(s, v)| v.is_some() && s.target != SensorTarget::Temperature);
        if !compared {
            return Err(SessionRefusal::NoReadings);
        }
        Ok(())
    }

    /// What trips an interlock on `values`, the readings about to be
    /// recorded, in words (`None`: nothing). Judged before the controller
    /// learns from them: positions against where its model predicts the
    /// nodes (the pending command's trial, or the folded start), load
    /// cells against the limits it holds the members to, less the common
    /// bias estimated from the earlier readings (its prior at the start),
    /// held to the bias's plausible range, so that an overloaded cell
    /// cannot pass for a bias.
    fn interlock(&self, values: &[Option<f64>]) -> Option<String> {
        let model = self.setup.model;
        let s = model.structure();
        let locks = self.setup.interlocks;
        let start_limits;
        let (state, limits) = match &self.controller {
            Some(c) => (
                c.pending_prediction().unwrap_or_else(|| c.state()),
                &c.context().limits,
            ),
            None => {
                start_limits = Limits::new(model, self.setup.problem, &self.start_state);
                (&self.start_state, &start_limits)
            }
        };
        let prior_sd_n = self
            .setup
            .policy
            .control
            .load_cell_bias_prior_sd_n
            .unwrap_or(0.0);
        let (low, high) = EffectKind::LoadCellBias.parameters()[0].plausible;
        let (bias_n, bias_sd_n) = self
            .controller
            .as_ref()
            .and_then(|c| c.load_cell_bias_n())
            .map_or((0.0, prior_sd_n), |(b, sd)| (b.clamp(low, high), sd));
        let mut trips = Vec::new();
        for (sensor, value) in self.setup.sensors.iter().zip(values) {
            let Some(v) = *value else { continue };
            match sensor.target {
                SensorTarget::Temperature => {
                    let (low, high) = locks.temperature_range_c;
                    if !(low..=high).contains(&v) {
                        trips.push(format!(
                            "{} reads {v} °C, outside the plausible {low} to {high} °C",
                            sensor.id
                        ));
                    }
                }
                SensorTarget::Position { node, axis } => {
                    let Some(p) = state.positions_m.get(node) else {
                        continue;
                    };
                    let off = v - p[axis.index()];
                    if off.abs() > locks.max_position_offset_m {
                        trips.push(format!(
                            "{} reads {:.3} m, {:.3} m from where the model puts node {} (plausible within {} m)",
                            sensor.id,
                            v,
                            off,
                            s.nodes[node].id,
                            locks.max_position_offset_m
                        ));
                    }
                }
                target => {
                    let Some(row) = load_cell_row(model, state, target) else {
                        continue;
                    };
                    // Only a tension member's cell has a floor: a strut
                    // reads its compression.
                    let tension_member = limits.euler_n.get(row).is_some_and(|e| e.is_none());
                    let lowest = Interlocks::lowest_plausible_tension_n(sensor.noise_sd);
                    if tension_member && v < lowest {
                        trips.push(format!(
                            "{} reads {v:.1} N, below the plausible {lowest:.1} N (a cable cannot push; the cell's bias and noise cannot reach it)",
                            sensor.id
                        ));
                        continue;
                    }
                    let Some(b) = limits.force.get(row) else {
                        continue;
                    };
                    let force = v - bias_n;
                    let sd = sensor.noise_sd.hypot(bias_sd_n);
                    let k = locks.limit_sigmas;
                    let beyond = if force > b.upper_n + k * sd {
                        Some(("above", b.upper_n))
                    } else if force < b.lower_n - k * sd {
                        Some(("below", b.lower_n))
                    } else {
                        None
                    };
                    if let Some((side, bound)) = beyond {
                        trips.push(format!(
                            "{} reads {v:.1} N ({force:.1} N less the estimated bias): {} is {side} its {bound:.1} N limit by more than {k} SDs ({:.1} N)",
                            sensor.id,
                            force_row_name(s, row),
                            k * sd
                        ));
                    }
                }
            }
        }
        (!trips.is_empty()).then(|| trips.join("; "))
    }

    /// The controller takes the readings of `step`: the start's (no
    /// command) start it, a command's are observed after it.
    fn take_readings(
        &mut self,
        step: usize,
        values: Vec<Option<f64>>,
        command_m: Option<Vec<f64>>,
    ) -> Result<(), SessionError> {
        let index = self.events;
        match command_m {
            None => {
                let setup = self.setup;
                let controller = Controller::guided_from(
                    setup.model,
                    setup.problem,
                    setup.policy,
                    setup.sensors,
                    &values,
                    setup.guidance,
                    self.start_state.clone(),
                )
                .map_err(SessionError::Start)?;
                self.controller = Some(controller);
            }
            Some(command_m) => {
                let controller = self.controller.as_mut().ok_or(SessionError::Inconsistent {
                    index,
                    why: format!("readings of step {step} before the start's"),
                })?;
                // A command the controller cannot follow ends the session
                // at the next decision (its model is where it was).
                if let Err(e) = controller.observe(&command_m, &values) {
                    self.cannot_follow = Some(e.to_string());
                }
                self.executed_m.push(command_m);
            }
        }
        self.readings.push(values);
        self.phase = SessionPhase::Ready { step };
        Ok(())
    }

    /// Holds the readings of `step` an interlock stopped on, until an
    /// operator keeps or discards them.
    fn hold(
        &mut self,
        step: usize,
        values: Vec<Option<f64>>,
        command_m: Option<Vec<f64>>,
        reason: &str,
    ) {
        self.held = Some(HeldReadings {
            step,
            values,
            command_m,
        });
        self.phase = SessionPhase::Stopped {
            step,
            reason: reason.to_string(),
        };
    }

    /// Applies `events` (new ones, built from the phase just checked) and
    /// returns them.
    fn commit(&mut self, events: Vec<SessionEvent>) -> Result<Vec<SessionEvent>, SessionRefusal> {
        for e in &events {
            self.apply(e).map_err(SessionRefusal::Journal)?;
        }
        Ok(events)
    }

    /// Advances the session by one event.
    fn apply(&mut self, event: &SessionEvent) -> Result<(), SessionError> {
        let index = self.events;
        let bad = |why: String| SessionError::Inconsistent { index, why };
        let phase = self.phase.label();
        match (event, &self.phase) {
            (
                SessionEvent::Readings {
                    step: 0,
                    values,
                    stopped,
                },
                SessionPhase::AwaitingStart,
            ) => {
                self.check_values(values)
                    .map_err(|e| bad(format!("readings of step 0: {e}")))?;
                match stopped {
                    None => self.take_readings(0, values.clone(), None)?,
                    Some(reason) => self.hold(0, values.clone(), None, reason),
                }
            }
            (
                SessionEvent::Readings {
                    step,
                    values,
                    stopped,
                },
                SessionPhase::Pending {
                    step: k,
                    command_m,
                    cleared: true,
                },
            ) if step == k => {
                self.check_values(values)
                    .map_err(|e| bad(format!("readings of step {step}: {e}")))?;
                let command_m = Some(command_m.clone());
                match stopped {
                    None => self.take_readings(*step, values.clone(), command_m)?,
                    Some(reason) => self.hold(*step, values.clone(), command_m, reason),
                }
            }
            (
                SessionEvent::Readings {
                    step,
                    values,
                    stopped,
                },
                SessionPhase::Remeasure { step: k },
            ) if step == k => {
                self.check_values(values)
                    .map_err(|e| bad(format!("readings of step {step}: {e}")))?;
                let command_m = self.remeasured_command.take();
                match stopped {
                    None => self.take_readings(*step, values.clone(), command_m)?,
                    Some(reason) => self.hold(*step, values.clone(), command_m, reason),
                }
            }
            (SessionEvent::Issued { step, command_m }, SessionPhase::Ready { step: k })
                if *step == k + 1 =>
            {
                let motors = self.setup.model.structure().continuous_cables.len();
                if command_m.len() != motors || command_m.iter().any(|u| !u.is_finite()) {
                    return Err(bad(format!(
                        "command {step} needs {motors} finite payout changes"
                    )));
                }
                let controller = self
                    .controller
                    .as_mut()
                    .ok_or_else(|| bad("no controller".into()))?;
                // The decision is planned again (the same, for a journal
                // this version wrote) so that the controller holds it
                // when the readings come.
                let own = match controller.decide() {
                    ControllerDecision::Send(p) => p
                        .sent_m
                        .iter()
                        .zip(command_m)
                        .all(|(a, b)| (a - b).abs() <= OWN_COMMAND_TOLERANCE_M),
                    ControllerDecision::Stop(_) => false,
                };
                if !own {
                    self.diverged.push(*step);
                }
                self.phase = SessionPhase::Pending {
                    step: *step,
                    command_m: command_m.clone(),
                    cleared: !self.setup.approval_required,
                };
            }
            (
                SessionEvent::Approved { step },
                SessionPhase::Pending {
                    step: k, command_m, ..
                },
            ) if step == k => {
                self.phase = SessionPhase::Pending {
                    step: *step,
                    command_m: command_m.clone(),
                    cleared: true,
                };
            }
            (SessionEvent::Rejected { step, .. }, SessionPhase::Pending { step: k, .. })
                if step == k =>
            {
                if let Some(c) = self.controller.as_mut() {
                    c.reject();
                }
                self.phase = SessionPhase::Ready { step: step - 1 };
            }
            (
                SessionEvent::Resumed { step, discard, .. },
                SessionPhase::Stopped { step: k, .. },
            ) if step == k => {
                let HeldReadings {
                    step: held_step,
                    values,
                    command_m,
                } = self
                    .held
                    .take()
                    .ok_or_else(|| bad("no readings held".into()))?;
                if held_step != *step {
                    return Err(bad(format!(
                        "readings of step {held_step} held, resumed at step {step}"
                    )));
                }
                if *discard {
                    self.remeasured_command = command_m;
                    self.phase = SessionPhase::Remeasure { step: *step };
                } else {
                    self.take_readings(*step, values, command_m)?;
                }
            }
            (SessionEvent::Ended { status, words }, SessionPhase::Ready { .. }) => {
                self.phase = SessionPhase::Ended {
                    status: status.clone(),
                    words: words.clone(),
                };
            }
            (event, _) => {
                return Err(bad(format!(
                    "{} is not possible in phase {phase}",
                    event_name(event)
                )))
            }
        }
        self.events += 1;
        Ok(())
    }
}

/// The event's name and step, in words.
fn event_name(event: &SessionEvent) -> String {
    match event {
        SessionEvent::Readings { step, .. } => format!("readings of step {step}"),
        SessionEvent::Issued { step, .. } => format!("issuing command {step}"),
        SessionEvent::Approved { step } => format!("approving command {step}"),
        SessionEvent::Rejected { step, .. } => format!("rejecting command {step}"),
        SessionEvent::Resumed { step, .. } => format!("resuming after step {step}"),
        SessionEvent::Ended { .. } => "the end".into(),
    }
}
