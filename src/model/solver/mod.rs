//! The equilibrium solver: the forward model type, dynamic relaxation with
//! kinetic damping ([`relax`]), Newton with the consistent friction tangent
//! ahead of it ([`newton`]), commands applied in increments
//! ([`command`]), and payout sensitivities of an equilibrium ([`sensitivity`]).

pub mod command;
mod newton;
pub mod relax;
pub mod sensitivity;

pub use command::{CommandError, CommandReport, IncrementObserver};
pub use relax::{
    ForwardModel, MemberForces, RelaxReport, RelaxSettings, RelaxStatus, SettingsError, Workspace,
};
pub use sensitivity::{MotorDirection, MotorResponse, PayoutSensitivities, SensitivityError};
