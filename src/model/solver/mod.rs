//! The equilibrium solver, one concept per file: [`settings`], [`status`],
//! the [`forward_model`] type, the two-node `element` force law, the
//! `residual` with the friction return mapping, dynamic relaxation
//! ([`relax`]), Newton with the consistent friction tangent (`newton`),
//! commands applied in increments ([`command`]), the cable seats
//! followed through a command ([`seats`]), and the payout
//! sensitivities of an equilibrium ([`sensitivity`]).

pub mod command;
mod counters;
pub(in crate::model) mod element;
pub mod forward_model;
mod newton;
pub mod relax;
mod residual;
pub mod seats;
pub mod sensitivity;
pub mod settings;
pub mod status;
mod workspace;

pub use command::{
    increments_needed, CommandError, CommandReport, IncrementObserver, MAX_INCREMENTS_PER_COMMAND,
};
pub use counters::NewtonCounters;
pub use forward_model::{ForwardModel, MemberForces};
pub use relax::SolveMode;
pub use seats::SEAT_TOLERANCE_M;
pub use sensitivity::{
    MotorDirection, MotorResponse, PayoutSensitivities, SensitivityError, SlipOnset,
};
pub use settings::{RelaxSettings, SettingsError};
pub use status::{RelaxReport, RelaxStatus, PLAUSIBLE_STRAIN};
pub use workspace::Workspace;
