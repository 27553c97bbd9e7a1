//! The deployment planner: brings the two halves of the bridge from the
//! folded state to the midspan connection without overloading or
//! slackening a member and within the motors' limits.
//!
//! - [`problem`]: the deployment problem (start, connection, limits);
//! - [`limits`]: member forces, buckling and strut clearance on a state;
//! - [`response`]: one-sided responses to each motor's payout;
//! - [`qp_step`]: one step as a QP on those responses;
//! - [`search`]: sequential convex programming with a trust region;
//! - [`baselines`]: nominal even actuation and the greedy tree;
//! - [`policy`]: policies as data;
//! - [`correction`]: how a measurement corrects the model's predictions;
//! - [`estimation`]: how far the cables really moved (payout scale per
//!   bridge half, from the measured motion);
//! - [`planner`]: the planners' shared trait, trials and the open-loop
//!   driver; [`outcome`]: plans and their status;
//! - [`controller`]: the controller alone (decide, observe), separable
//!   from the plant;
//! - [`closed_loop`]: a deployment of a truth plant, planned on the model
//!   and corrected by measurements after every command.
//!
//! Pure numerics: a plan is a function of (model, problem, policy, state);
//! a closed-loop deployment also of the truth and the noise seed.

pub mod baselines;
pub mod closed_loop;
pub mod controller;
pub mod correction;
pub mod estimation;
pub mod limits;
pub mod outcome;
pub mod planner;
pub mod policy;
pub mod problem;
pub mod qp_step;
pub mod response;
pub mod search;

pub use closed_loop::{
    deploy_closed_loop, deploy_guided, model_correction, ClosedLoopSetup, DeployError,
    DeployObserver, DeployRecord, DeployStart, Deployment, Guidance, TruthWatch,
};
pub use controller::{
    Controller, ControllerDecision, ControllerError, Observation, Proposal, OWN_COMMAND_TOLERANCE_M,
};
pub use correction::ModelCorrection;
pub use estimation::PayoutScaleEstimator;
pub use outcome::{CommandRecord, Plan, PlanError, PlanStatus};
pub use planner::{
    folded_start, plan_open_loop, planner_for, worst_along_path, CommandPlanner, Decision,
    PlanContext, PlannedCommand, Trial,
};
pub use policy::{
    Measurement, MemorySettings, PlannerKind, Policy, PolicyError, SensitivityKind, TrustRegion,
    Weights,
};
pub use problem::{DeploymentProblem, MotorLimits, PerMotor, ProblemError};
pub use qp_step::{formulate, solve_step, QpStep, QpStepStatus, StepData, StepWeights};
pub use response::PayoutResponse;
