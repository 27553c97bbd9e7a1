//! Model against measurement: running a model with effects through a
//! schedule of cycles ([`replay`]), the synthetic lab that makes logs from
//! a truth model ([`lab`]), and the comparison of a model with a log
//! ([`compare`]). Pure: files are read and written in
//! [`crate::io`].

pub mod compare;
pub mod diagnose;
pub mod friction_study;
pub mod lab;
pub mod replay;

pub use replay::{CycleSchedule, EffectModel, Readings, ReplayError, Run, StepFeatures};
