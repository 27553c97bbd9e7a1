//! Simulation of a model with effects: sensors, the plant (a truth model
//! stepped one command at a time), the closed loop's default truth,
//! schedules of commands, and the replay of a model through them. The
//! planner's closed loop and the measurement tools both stand on this
//! layer. Pure: no files.

pub mod default_truth;
pub mod plant;
pub mod replay;
pub mod sensors;

pub use default_truth::{default_truth, default_truth_effects};
pub use plant::{Plant, SEAT_TOLERANCE_M};
pub use replay::{CycleSchedule, EffectModel, Readings, ReplayError, Run, StepFeatures};
pub use sensors::{
    standard_sensors, Sensor, SensorTarget, LOAD_CELL_NOISE_N, POSITION_NOISE_M,
    TEMPERATURE_NOISE_C,
};
