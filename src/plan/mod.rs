//! The deployment planner: brings the two halves of the bridge from the
//! folded state to the midspan connection without overloading or
//! slackening a member and within the motors' limits.
//!
//! - [`problem`]: the deployment problem (start, connection, limits);
//! - [`limits`]: member forces, buckling and strut clearance on a state;
//! - [`response`]: one-sided responses to each motor's payout;
//! - [`qp_step`]: one step as a QP on those responses;
//! - [`search`]: sequential convex programming with a trust region;
//!   [`take_up`]: a slack continuous cable reeled in until taut first;
//! - [`baselines`]: nominal even actuation and the greedy tree;
//! - [`policy`]: policies as data, one section per concern (planner,
//!   margins, control, memory);
//! - [`correction`]: the offsets a measurement adds to the model's
//!   predictions (computed in `crate::control`);
//! - [`planner`]: the planners' shared trait, context and trials;
//!   [`planners`]: the planner a policy names; [`outcome`]: plans and
//!   their status; [`causes`]: why a plan stops short; [`verdict`]: the
//!   one verdict on a run (plan or deployment) every command reports;
//! - [`open_loop`]: the folded start and a plan on the model alone.
//!
//! Pure numerics: a plan is a function of (model, problem, policy, state).
//! What runs against a plant (the closed loop, the controller, estimation
//! and the measurement corrections) is `crate::control`.

pub mod baselines;
pub mod causes;
pub mod correction;
pub mod limits;
pub mod open_loop;
pub mod outcome;
pub mod planner;
pub mod planners;
pub mod policy;
pub mod problem;
pub mod qp_step;
pub mod response;
pub mod search;
pub mod slack;
pub mod take_up;
pub mod verdict;

pub use causes::{ControllerError, NotReachable, SolverFailure, TrialFailure, TrialRejection};
pub use correction::ModelCorrection;
pub use limits::LimitViolation;
pub use open_loop::{folded_start, plan_open_loop};
pub use outcome::{CommandRecord, Plan, PlanError, PlanStatus};
pub use planner::{worst_along_path, CommandPlanner, Decision, PlanContext, PlannedCommand, Trial};
pub use planners::planner_for;
pub use policy::{
    ControlSettings, GreedyTreeSettings, LearntPath, Margins, Measurement, MemorySettings,
    NominalSettings, PlannerSettings, Policy, PolicyError, QpPlannerSettings, SensitivityKind,
    TrustRegion, Weights,
};
pub use problem::{DeploymentProblem, MotorLimits, PerMotor, ProblemError};
pub use qp_step::{formulate, solve_step, QpStep, QpStepStatus, StepData, StepWeights};
pub use response::PayoutResponse;
pub use verdict::{Breach, RunOutcome, RunVerdict};
