//! What a plan is: its status, and one record per command.

use serde::ser::SerializeStruct;
use serde::{Serialize, Serializer};
use thiserror::Error;

use super::causes::{NotReachable, SolverFailure};
use super::policy::PolicyError;
use super::problem::ProblemError;
use super::qp_step::QpStepStatus;
use crate::model::{CommandError, DeploymentState, RelaxStatus, SettingsError};

/// How a plan ended. Its JSON form is `{"status": label}`, with
/// `"reason"`: the cause's words for the two that have a cause.
#[derive(Debug, Clone, PartialEq)]
pub enum PlanStatus {
    /// Every midspan pair is within the connection tolerance less the
    /// policy's margin.
    Connected,
    /// No admissible command brings the bridge closer, or the planner's
    /// own sequence is spent; the cause says which limit or why. Where
    /// limits or motors bind ([`NotReachable::binding`]) its words are
    /// `not reachable safely: …` naming them: the controller stopped
    /// rather than break them.
    NotReachable {
        /// Why.
        cause: NotReachable,
    },
    /// The policy's command budget is spent before connection.
    CommandLimit,
    /// The model, the QP solver or the truth plant failed.
    SolverFailure {
        /// What failed.
        cause: SolverFailure,
    },
}

impl PlanStatus {
    /// Every [`Self::label`], in declaration order.
    pub const LABELS: [&'static str; 4] = [
        "connected",
        "not_reachable",
        "command_limit",
        "solver_failure",
    ];

    /// `true` for [`PlanStatus::Connected`].
    pub fn is_connected(&self) -> bool {
        matches!(self, PlanStatus::Connected)
    }

    /// Short name, as the `status` tag of its JSON form (`connected`,
    /// `not_reachable`, `command_limit`, `solver_failure`).
    pub fn label(&self) -> &'static str {
        match self {
            PlanStatus::Connected => "connected",
            PlanStatus::NotReachable { .. } => "not_reachable",
            PlanStatus::CommandLimit => "command_limit",
            PlanStatus::SolverFailure { .. } => "solver_failure",
        }
    }

    /// Plain words for the command line.
    pub fn describe(&self) -> String {
        match self {
            PlanStatus::Connected => "connected: every midspan pair within tolerance".into(),
            PlanStatus::NotReachable { cause } => {
                let binding = cause.binding();
                if binding.is_empty() {
                    format!("not reachable: {}", cause.describe())
                } else {
                    format!(
                        "not reachable safely: {} bind{} ({})",
                        binding.join(", "),
                        if binding.len() == 1 { "s" } else { "" },
                        cause.describe()
                    )
                }
            }
            PlanStatus::CommandLimit => {
                "command limit: the policy's largest number of commands is spent".into()
            }
            PlanStatus::SolverFailure { cause } => {
                format!("solver failure: {}", cause.describe())
            }
        }
    }

    /// The cause's words, for the statuses that have a cause.
    fn reason(&self) -> Option<String> {
        match self {
            PlanStatus::NotReachable { cause } => Some(cause.describe()),
            PlanStatus::SolverFailure { cause } => Some(cause.describe()),
            PlanStatus::Connected | PlanStatus::CommandLimit => None,
        }
    }
}

impl Serialize for PlanStatus {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let reason = self.reason();
        let mut out =
            serializer.serialize_struct("PlanStatus", 1 + usize::from(reason.is_some()))?;
        out.serialize_field("status", self.label())?;
        if let Some(reason) = reason {
            out.serialize_field("reason", &reason)?;
        }
        out.end()
    }
}

/// One planned command and what it did on the model.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandRecord {
    /// Payout change per motor, m (positive pays out).
    pub command_m: Vec<f64>,
    /// Gap per midspan pair the planner predicted, m (`None` for planners
    /// that predict nothing).
    pub predicted_gaps_m: Option<Vec<f64>>,
    /// Gap per midspan pair after the command on the model, m.
    pub gaps_m: Vec<f64>,
    /// Worst member utilisation along the command's increments (tension
    /// over maximum, strut compression over its admissible Euler part).
    pub worst_utilisation: f64,
    /// Smallest cable, spring or segment tension along the command, N.
    pub min_tension_n: f64,
    /// Smallest strut-to-strut clearance along the command, m.
    pub min_clearance_m: f64,
    /// Constraints active in the planning step (QP) or deciding it.
    pub active_constraints: Vec<String>,
    /// Status of the step's QP (QP planner only).
    pub qp_status: Option<QpStepStatus>,
    /// Trust-region radius the command was planned in, m (QP planner).
    pub trust_region_m: Option<f64>,
    /// Trials rejected before this command was accepted.
    pub rejected_trials: usize,
    /// Wall-clock planning time, s (the only value not a pure function of
    /// the inputs).
    pub planning_time_s: f64,
}

/// An open-loop plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// How it ended.
    pub status: PlanStatus,
    /// Gap per midspan pair at the start, m.
    pub start_gaps_m: Vec<f64>,
    /// One record per command, in order.
    pub records: Vec<CommandRecord>,
    /// The model state after the last command.
    pub final_state: DeploymentState,
}

impl Plan {
    /// The command sequence: payout change per command and motor, m.
    pub fn commands(&self) -> Vec<Vec<f64>> {
        self.records.iter().map(|r| r.command_m.clone()).collect()
    }
}

/// Inputs a planner cannot work with.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PlanError {
    /// The problem is invalid for this structure.
    #[error(transparent)]
    Problem(#[from] ProblemError),
    /// The policy is invalid for this structure.
    #[error(transparent)]
    Policy(#[from] PolicyError),
    /// The solver settings are invalid.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The structure has no midspan pairs to bring together.
    #[error("the structure has no midspan pairs to connect")]
    NoMidspanPairs,
    /// The folded start could not be reached on the model.
    #[error("folding to the start state: {}", .0.describe())]
    Start(RelaxStatus),
    /// A command the model refused (a planner bug or a bad start).
    #[error(transparent)]
    Command(#[from] CommandError),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_labels_are_the_json_tags() {
        let all = [
            PlanStatus::Connected,
            PlanStatus::NotReachable {
                cause: NotReachable::QpInfeasible {
                    binding: Vec::new(),
                },
            },
            PlanStatus::CommandLimit,
            PlanStatus::SolverFailure {
                cause: SolverFailure::QpNumericalTrouble,
            },
        ];
        for s in &all {
            let json = serde_json::to_value(s).unwrap();
            assert_eq!(json["status"], s.label(), "{s:?}");
        }
        assert_eq!(all.map(|s| s.label()), PlanStatus::LABELS);
    }

    #[test]
    fn statuses_read_and_serialise_as_before() {
        let not_reachable = PlanStatus::NotReachable {
            cause: NotReachable::NoLinearisation,
        };
        assert_eq!(
            not_reachable.describe(),
            "not reachable: no linearisation gave a command"
        );
        assert_eq!(
            serde_json::to_string(&not_reachable).unwrap(),
            r#"{"status":"not_reachable","reason":"no linearisation gave a command"}"#
        );
        let failure = PlanStatus::SolverFailure {
            cause: SolverFailure::QpStepBreaksMotorLimit,
        };
        assert_eq!(
            failure.describe(),
            "solver failure: the QP step breaks a motor limit"
        );
        assert_eq!(
            serde_json::to_string(&failure).unwrap(),
            r#"{"status":"solver_failure","reason":"the QP step breaks a motor limit"}"#
        );
        assert_eq!(
            serde_json::to_string_pretty(&PlanStatus::Connected).unwrap(),
            "{\n  \"status\": \"connected\"\n}"
        );
        assert_eq!(
            serde_json::to_string(&PlanStatus::CommandLimit).unwrap(),
            r#"{"status":"command_limit"}"#
        );
    }
}
