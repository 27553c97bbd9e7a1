//! Model against measurement: running a model with effects through a
//! schedule of cycles ([`replay`]), and the synthetic lab that makes logs
//! from a truth model ([`lab`]). Pure: files are read and written in
//! [`crate::io`].

pub mod lab;
pub mod replay;

pub use replay::{CycleSchedule, EffectModel, Readings, ReplayError};
