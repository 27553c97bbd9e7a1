//! The equilibrium solver: the forward model type, dynamic relaxation with
//! kinetic damping ([`relax`]), Newton with the consistent friction tangent
//! ahead of it ([`newton`]), and commands applied in increments
//! ([`command`]).

pub mod command;
mod newton;
pub mod relax;

pub use command::{CommandError, CommandReport, IncrementObserver};
pub use relax::{
    ForwardModel, MemberForces, RelaxReport, RelaxSettings, RelaxStatus, SettingsError, Workspace,
};
