//! Why a plan or a deployment stops short: the causes a
//! [`super::PlanStatus`] carries, each with the data a caller may act on
//! (the member that binds, the radius, the command, the underlying solver
//! status or error), and their words in `describe()`.
//!
//! [`ControllerError`] sits here, not beside the controller in
//! `crate::control`, because a deployment that ends on it says so in its
//! [`SolverFailure`] (and `plan` may not name `control`).

use thiserror::Error;

use super::limits::LimitViolation;
use super::response::ResponseError;
use crate::model::{RelaxStatus, SensitivityError};
use crate::sim::PlantError;

/// Why no admissible command brings the bridge closer, or why the
/// planner's own sequence ended before connection.
#[derive(Debug, Clone, PartialEq)]
pub enum NotReachable {
    /// Nominal planner: every step of its sequence is sent.
    NominalSequenceSpent {
        /// Largest midspan gap at the end of the sequence, m.
        largest_gap_m: f64,
    },
    /// Nominal planner: its next step would take a motor out of its
    /// stroke.
    NominalStepLeavesStroke {
        /// The step, 1 for the first.
        step: usize,
    },
    /// Nominal planner: its next step is not admissible on the model.
    NominalStepRejected {
        /// The step, 1 for the first.
        step: usize,
        /// What the step's trial broke.
        failure: TrialFailure,
    },
    /// Greedy tree: no single-motor move, down to the policy's smallest,
    /// reduces the largest gap.
    NoGreedyMove {
        /// The policy's smallest move, m.
        min_move_m: f64,
        /// Largest gap at the state, m.
        largest_gap_m: f64,
    },
    /// QP planner: no command meets the linearised limits.
    QpInfeasible {
        /// The limits the state already lies beyond (with the measured
        /// offsets), which the step would have to bring back at once
        /// (named as the QP's rows, e.g. `segment A_cc1[2] min`); empty
        /// where none does.
        binding: Vec<String>,
    },
    /// QP planner: the linearised step predicts no reduction of the gaps
    /// (or no move at all).
    NoReducingCommand {
        /// Largest gap at the state, m.
        largest_gap_m: f64,
        /// The constraints active in the step (as in
        /// [`super::QpStep::active_constraints`], e.g. `A_cc0 stroke min`).
        active_constraints: Vec<String>,
    },
    /// QP planner: the responses kept from the last command gave a step
    /// the model did not confirm.
    KeptSensitivitiesUnconfirmed {
        /// Why the model rejected their step.
        last_trial: TrialRejection,
    },
    /// QP planner: the trust region shrank below its minimum without a
    /// step the model confirmed.
    TrustRegionCollapsed {
        /// The trust region's minimum radius, m.
        min_radius_m: f64,
        /// Why the model rejected the last trial.
        last_trial: TrialRejection,
    },
    /// QP planner: there was no linearisation to plan from.
    NoLinearisation,
}

impl NotReachable {
    /// Plain words, after "not reachable: ".
    pub fn describe(&self) -> String {
        match self {
            NotReachable::NominalSequenceSpent { largest_gap_m } => format!(
                "the nominal sequence is spent with a largest gap of {:.1} mm",
                1e3 * largest_gap_m
            ),
            NotReachable::NominalStepLeavesStroke { step } => {
                format!("nominal step {step} leaves a motor's stroke")
            }
            NotReachable::NominalStepRejected { step, failure } => {
                format!("nominal step {step}: {}", failure.describe())
            }
            NotReachable::NoGreedyMove {
                min_move_m,
                largest_gap_m,
            } => format!(
                "no single-motor move down to ±{:.1} mm reduces the largest gap ({:.1} mm)",
                1e3 * min_move_m,
                1e3 * largest_gap_m
            ),
            NotReachable::QpInfeasible { .. } => {
                "no command meets the linearised limits (QP infeasible)".into()
            }
            NotReachable::NoReducingCommand {
                largest_gap_m,
                active_constraints,
            } => {
                let active = if active_constraints.is_empty() {
                    "none".to_string()
                } else {
                    active_constraints.join(", ")
                };
                format!(
                    "no admissible command reduces the gaps (largest gap {:.1} mm); active: {active}",
                    1e3 * largest_gap_m
                )
            }
            NotReachable::KeptSensitivitiesUnconfirmed { last_trial } => {
                format!(
                    "kept sensitivities not confirmed ({})",
                    last_trial.describe()
                )
            }
            NotReachable::TrustRegionCollapsed {
                min_radius_m,
                last_trial,
            } => format!(
                "trust region collapsed below {:.1} mm (last trial: {})",
                1e3 * min_radius_m,
                last_trial.describe()
            ),
            NotReachable::NoLinearisation => "no linearisation gave a command".into(),
        }
    }
}

impl NotReachable {
    /// The limits or motors that bind, when the stop is the controller
    /// refusing to break a limit (named as the QP names its rows: `segment
    /// A_cc1[2] min`, `A_cc0 stroke min`, `A_cc0 reel-in max step`; and
    /// `A_cc1 slack` for a cable the trial may not slacken, which has no
    /// QP row, [`super::slack`]); empty
    /// when the stop has another cause (a spent sequence, a low reduction
    /// ratio, no linearisation) or names nothing.
    pub fn binding(&self) -> Vec<String> {
        let of_trial = |t: &TrialRejection| match t {
            TrialRejection::Inadmissible(TrialFailure::Limit(v)) => vec![v.limit()],
            _ => Vec::new(),
        };
        match self {
            NotReachable::NominalStepRejected {
                failure: TrialFailure::Limit(v),
                ..
            } => vec![v.limit()],
            NotReachable::QpInfeasible { binding } => binding.clone(),
            NotReachable::NoReducingCommand {
                active_constraints, ..
            } => active_constraints
                .iter()
                .filter(|a| !a.ends_with("trust region"))
                .cloned()
                .collect(),
            NotReachable::KeptSensitivitiesUnconfirmed { last_trial }
            | NotReachable::TrustRegionCollapsed { last_trial, .. } => of_trial(last_trial),
            _ => Vec::new(),
        }
    }
}

/// What failed: the model, a solver, or the truth plant.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverFailure {
    /// The tangent sensitivities could not be computed.
    TangentSensitivities(SensitivityError),
    /// The secant (finite-difference) sensitivities could not be computed.
    SecantSensitivities(ResponseError),
    /// The step's QP solver failed numerically on every linearisation.
    QpNumericalTrouble,
    /// A solved QP step breaks a motor limit (never sent).
    QpStepBreaksMotorLimit,
    /// Closed loop: the truth plant failed on a command.
    TruthPlant {
        /// The command, 1 for the first.
        command: usize,
        /// What the plant said.
        error: PlantError,
    },
    /// Closed loop: the controller could not observe its own command.
    Controller {
        /// The command, 1 for the first.
        command: usize,
        /// What the controller said.
        error: ControllerError,
    },
}

impl SolverFailure {
    /// Plain words, after "solver failure: ".
    pub fn describe(&self) -> String {
        match self {
            SolverFailure::TangentSensitivities(e) => format!("sensitivities: {e}"),
            SolverFailure::SecantSensitivities(e) => format!("sensitivities: {e}"),
            SolverFailure::QpNumericalTrouble => "the QP solver failed numerically".into(),
            SolverFailure::QpStepBreaksMotorLimit => "the QP step breaks a motor limit".into(),
            SolverFailure::TruthPlant { command, error } => {
                format!("the truth plant failed on command {command}: {error}")
            }
            SolverFailure::Controller { command, error } => format!("command {command}: {error}"),
        }
    }
}

/// Why a trial command is not admissible on the model.
#[derive(Debug, Clone, PartialEq)]
pub enum TrialFailure {
    /// An increment's solve did not converge (or the model refused the
    /// command: [`RelaxStatus::Diverged`]).
    Model(RelaxStatus),
    /// A limit broken at an increment (the first found).
    Limit(LimitViolation),
}

impl TrialFailure {
    /// Plain words.
    pub fn describe(&self) -> String {
        match self {
            TrialFailure::Model(status) => format!("the model {}", status.describe()),
            TrialFailure::Limit(v) => v.describe(),
        }
    }
}

/// Why the QP planner did not accept a trial step.
#[derive(Debug, Clone, PartialEq)]
pub enum TrialRejection {
    /// The step is not admissible on the model.
    Inadmissible(TrialFailure),
    /// The step reduced the gaps less than predicted.
    LowReductionRatio {
        /// Actual over predicted merit reduction, 1.
        ratio: f64,
        /// The policy's acceptance ratio, 1.
        required: f64,
    },
}

impl TrialRejection {
    /// Plain words.
    pub fn describe(&self) -> String {
        match self {
            TrialRejection::Inadmissible(f) => f.describe(),
            TrialRejection::LowReductionRatio { ratio, required } => {
                format!("reduction ratio {ratio:.2} below {required}")
            }
        }
    }
}

/// Why the controller could not follow a command.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ControllerError {
    /// A command that is not its own decision took its model somewhere it
    /// cannot solve (or reeled a segment through).
    #[error("the controller's model cannot follow the command {command_m:?} m: the model {}", .status.describe())]
    CannotFollow {
        /// The cable motion tried, per motor, m.
        command_m: Vec<f64>,
        /// The solve's status on the model.
        status: RelaxStatus,
    },
    /// A command or readings of the wrong length.
    #[error("{what}: {found} values, the controller expects {expected}")]
    WrongLength {
        /// Which input.
        what: &'static str,
        /// Values given.
        found: usize,
        /// Values expected.
        expected: usize,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MotorDirection;

    fn low_ratio() -> TrialRejection {
        TrialRejection::LowReductionRatio {
            ratio: 0.123,
            required: 0.1,
        }
    }

    fn slack() -> TrialFailure {
        TrialFailure::Limit(LimitViolation::BelowLower {
            member: "segment A_cc0[2]".into(),
            force_n: 4.56,
            lower_n: 10.0,
        })
    }

    #[test]
    fn not_reachable_causes_read_as_before() {
        let cases = [
            (
                NotReachable::NominalSequenceSpent {
                    largest_gap_m: 0.04567,
                },
                "the nominal sequence is spent with a largest gap of 45.7 mm",
            ),
            (
                NotReachable::NominalStepLeavesStroke { step: 3 },
                "nominal step 3 leaves a motor's stroke",
            ),
            (
                NotReachable::NominalStepRejected {
                    step: 2,
                    failure: slack(),
                },
                "nominal step 2: segment A_cc0[2] at 4.6 N, below 10.0 N",
            ),
            (
                NotReachable::NoGreedyMove {
                    min_move_m: 0.0005,
                    largest_gap_m: 0.0312,
                },
                "no single-motor move down to ±0.5 mm reduces the largest gap (31.2 mm)",
            ),
            (
                NotReachable::QpInfeasible {
                    binding: Vec::new(),
                },
                "no command meets the linearised limits (QP infeasible)",
            ),
            (
                NotReachable::NoReducingCommand {
                    largest_gap_m: 0.1404,
                    active_constraints: vec![],
                },
                "no admissible command reduces the gaps (largest gap 140.4 mm); active: none",
            ),
            (
                NotReachable::NoReducingCommand {
                    largest_gap_m: 0.1404,
                    active_constraints: vec!["A_cc0 stroke min".into(), "B_cc1 stroke min".into()],
                },
                "no admissible command reduces the gaps (largest gap 140.4 mm); active: A_cc0 stroke min, B_cc1 stroke min",
            ),
            (
                NotReachable::KeptSensitivitiesUnconfirmed {
                    last_trial: low_ratio(),
                },
                "kept sensitivities not confirmed (reduction ratio 0.12 below 0.1)",
            ),
            (
                NotReachable::TrustRegionCollapsed {
                    min_radius_m: 0.001,
                    last_trial: TrialRejection::Inadmissible(TrialFailure::Model(
                        RelaxStatus::IterationLimit,
                    )),
                },
                "trust region collapsed below 1.0 mm (last trial: the model iteration limit reached before convergence)",
            ),
            (
                NotReachable::NoLinearisation,
                "no linearisation gave a command",
            ),
        ];
        for (cause, text) in cases {
            assert_eq!(cause.describe(), text, "{cause:?}");
        }
    }

    #[test]
    fn solver_failures_read_as_before() {
        let tangent = SensitivityError::UnstableTangent {
            motor: 2,
            direction: MotorDirection::ReelIn,
        };
        let secant = ResponseError::Solver {
            motor: 4,
            status: RelaxStatus::Diverged,
        };
        let plant = PlantError::SeatsUnsettled {
            cycle: 0,
            step: 3,
            change_m: 1.5e-4,
        };
        let cases = [
            (
                SolverFailure::TangentSensitivities(tangent.clone()),
                format!("sensitivities: {tangent}"),
            ),
            (
                SolverFailure::SecantSensitivities(secant),
                "sensitivities: probing motor 4: diverged (non-finite positions or forces)"
                    .to_string(),
            ),
            (
                SolverFailure::QpNumericalTrouble,
                "the QP solver failed numerically".into(),
            ),
            (
                SolverFailure::QpStepBreaksMotorLimit,
                "the QP step breaks a motor limit".into(),
            ),
            (
                SolverFailure::TruthPlant {
                    command: 5,
                    error: plant,
                },
                "the truth plant failed on command 5: cycle 0, step 3: the cable-seat arcs did not settle (1.50e-4 m still changing)".into(),
            ),
            (
                SolverFailure::Controller {
                    command: 7,
                    error: ControllerError::WrongLength {
                        what: "the readings",
                        found: 3,
                        expected: 4,
                    },
                },
                "command 7: the readings: 3 values, the controller expects 4".into(),
            ),
        ];
        for (cause, text) in cases {
            assert_eq!(cause.describe(), text, "{cause:?}");
        }
        assert_eq!(
            format!("{tangent}"),
            "motor 2, ReelIn: the tangent stiffness is singular or unstable"
        );
    }

    #[test]
    fn trial_failures_and_rejections_read_as_before() {
        assert_eq!(
            TrialFailure::Model(RelaxStatus::Diverged).describe(),
            "the model diverged (non-finite positions or forces)"
        );
        assert_eq!(
            slack().describe(),
            "segment A_cc0[2] at 4.6 N, below 10.0 N"
        );
        assert_eq!(
            TrialRejection::Inadmissible(slack()).describe(),
            "segment A_cc0[2] at 4.6 N, below 10.0 N"
        );
        assert_eq!(low_ratio().describe(), "reduction ratio 0.12 below 0.1");
    }

    #[test]
    fn controller_errors_read_as_before() {
        let e = ControllerError::CannotFollow {
            command_m: vec![-0.01, 0.0],
            status: RelaxStatus::UnstableMechanism,
        };
        assert_eq!(
            e.to_string(),
            "the controller's model cannot follow the command [-0.01, 0.0] m: the model unstable mechanism (nodes ran away: prestress lost or cables slack)"
        );
    }
}
