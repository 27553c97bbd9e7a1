//! The forward model: structure, state, joint friction, effects and the
//! equilibrium solver.
//!
//! Pure numerics: no files, no printing, no globals.

pub mod cable_seats;
pub mod effects;
pub mod faults;
pub mod flexible_supports;
pub mod friction;
pub mod friction_effect;
pub mod parameter_spec;
pub mod sliding;
pub mod solver;
pub mod state;
pub mod stiffness;
pub mod structure;

pub use effects::{EffectKind, Effects, MotorModel};
pub use faults::{FaultKind, Faults, Half};
pub use friction::{AngleConvention, FrictionCoefficient, FrictionError, JointFriction};
pub use solver::{
    CommandError, CommandReport, ForwardModel, IncrementObserver, MemberForces, MotorDirection,
    MotorResponse, PayoutSensitivities, RelaxReport, RelaxSettings, RelaxStatus, SensitivityError,
    SettingsError, SlipOnset, SolveMode, Workspace, SEAT_TOLERANCE_M,
};
pub use state::{DeploymentState, JointSlip};
pub use stiffness::{min_stiffness_eigenvalue, tangent_stiffness, JointMode};
pub use structure::{
    ContinuousCable, Member, MemberKind, Node, NodeIndex, Structure, StructureError,
};
