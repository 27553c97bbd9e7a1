//! Simulation of a model with effects: sensors, the plant (a truth model
//! stepped one command at a time), the closed loop's default truth,
//! schedules of commands, and a model with effects run through them. The
//! planner's closed loop and the measurement tools both stand on this
//! layer. Pure: no files.

pub mod default_truth;
pub mod effect_model;
pub mod plant;
pub mod schedule_run;
pub mod sensors;

pub use default_truth::{default_truth, default_truth_effects};
pub use effect_model::{EffectModel, PlantError};
pub use plant::Plant;
pub use schedule_run::{CycleSchedule, Readings, Run, StepFeatures};
pub use sensors::{
    standard_sensors, Axis, Sensor, SensorTarget, LOAD_CELL_NOISE_N, POSITION_NOISE_M,
    TEMPERATURE_NOISE_C,
};
