//! Model against measurement: logs in memory ([`log`]), the synthetic lab
//! that makes logs from a truth model ([`lab`]), the comparison of a model
//! with a log ([`compare`]), the search for what the model lacks
//! ([`diagnose`]) and the calibration of a model on a log
//! ([`calibrate`]). Pure: files are read and written in [`crate::io`].

pub mod calibrate;
pub mod compare;
pub mod comparison_verdict;
pub mod diagnose;
pub mod evidence;
pub mod fit;
pub mod lab;
pub mod local;
pub mod log;
pub mod outliers;
pub mod settings;
pub mod tail_probability;

pub use log::{Cycle, MeasurementLog, StepCommand};
