//! The forward model: structure, joint friction and the DR solver.
//!
//! Pure numerics: no files, no printing, no globals.

pub mod cable_seats;
pub mod command;
pub mod effects;
pub mod flexible_supports;
pub mod friction;
mod newton;
pub mod relax;
pub mod sliding;
pub mod state;
pub mod stiffness;
pub mod structure;

pub use command::{CommandError, CommandReport, IncrementObserver};
pub use effects::{EffectKind, Effects, MotorModel};
pub use friction::{AngleConvention, FrictionCoefficient, FrictionError, JointFriction};
pub use relax::{ForwardModel, MemberForces, RelaxReport, RelaxSettings, RelaxStatus, Workspace};
pub use state::{DeploymentState, JointSlip};
pub use stiffness::{min_stiffness_eigenvalue, tangent_stiffness, FreeDofs, JointMode};
pub use structure::{
    ContinuousCable, Member, MemberKind, Node, NodeIndex, Structure, StructureError,
};
pub mod form_finding;
pub mod friction_rig;
pub mod reference_bridge;
pub use reference_bridge::{
    reference_bridge, BridgeError, BridgeParameters, BridgeTopology, SpringPlacement,
};
