//! Control: what runs against a plant, simulated or real. The controller
//! plans each command with a planner of `crate::plan` on its model, sends
//! it, reads the sensors and reconciles its model with what they say.
//!
//! - [`controller`]: the controller alone (decide, observe), separable
//!   from the plant;
//! - [`estimation`]: how far the cables really moved (payout scale per
//!   bridge half, from the measured motion);
//! - [`measured_offsets`]: a measurement turned into the correction of
//!   the model's predictions; [`force_offset_filter`]: the load-cell
//!   offsets smoothed across measurements;
//! - [`guidance`]: what past cycles tell a deployment;
//! - [`session`]: the controller driven one command at a time by a plant
//!   outside the process (a rig, an operator), with interlocks;
//! - [`closed_loop`]: a deployment of a truth plant, planned on the model
//!   and corrected by measurements after every command;
//!   [`truth_watch`]: the truth's supervisor; [`deployment`]: the records
//!   a deployment produces and its observer.
//!
//! Pure numerics: a closed-loop deployment is a function of the model,
//! problem, policy, truth and noise seed (planning times aside).

pub mod closed_loop;
pub mod controller;
pub mod deployment;
pub mod drum_offsets;
pub mod estimation;
pub mod force_offset_filter;
pub mod guidance;
pub mod measured_offsets;
pub mod session;
pub mod support_compliance;
pub mod truth_watch;

/// Defined in `plan` ([`crate::plan::causes`]): a deployment's
/// [`crate::plan::SolverFailure`] may carry it.
pub use crate::plan::ControllerError;
pub use closed_loop::{
    check_same_bridge, deploy_closed_loop, deploy_guided, fold_truth, BridgeMismatch,
    ClosedLoopSetup, DeployError,
};
pub use controller::{
    Controller, ControllerDecision, Observation, Proposal, MAX_FEEDFORWARD_SPLITS,
    OWN_COMMAND_TOLERANCE_M,
};
pub use deployment::{
    DeployObserver, DeployRecord, DeployStart, Deployment, CORRECTIVE_PHASE_GAP_M,
};
pub use estimation::PayoutScaleEstimator;
pub use force_offset_filter::ForceOffsetFilter;
pub use guidance::{CaseTakeUp, Guidance};
pub use measured_offsets::{gap_reading_sd_m, measured_gap_vectors, model_correction};
pub use session::{
    Interlocks, Session, SessionError, SessionEvent, SessionPhase, SessionRefusal, SessionSetup,
    StepReadings,
};
pub use truth_watch::{as_built_breaches, TruthWatch};

/// Fixtures shared by the control layer's unit tests.
#[cfg(test)]
mod fixtures {
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{ForwardModel, JointFriction, RelaxSettings};
    use crate::plan::{DeploymentProblem, PerMotor};

    /// The reference bridge without friction, default solver settings.
    pub fn frictionless_model() -> ForwardModel {
        ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap()
    }

    /// A 10 cm fold: a few increments, so tests on it take a second.
    pub fn short_fold() -> DeploymentProblem {
        DeploymentProblem {
            start_payout_m: PerMotor::All(0.10),
            ..DeploymentProblem::default()
        }
    }
}
