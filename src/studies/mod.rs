//! Studies: what the experiments in `experiments/` compute, runs of the
//! model compared with each other or with a synthetic measurement. They
//! read the other layers and are read only by the CLI. Pure: no files.

pub mod cycles;
pub mod deployment_log;
pub mod evaluation;
pub mod fold_bands;
pub mod friction_effect;
pub mod friction_grading;
pub mod friction_vs_measurement;
pub mod log_replay;
pub mod model_learning;
pub mod statistics;

pub use friction_effect::{friction_effect, FrictionEffect, FrictionEffectSettings, StudyError};
