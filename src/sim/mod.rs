//! Simulation of a model with effects: sensors, the plant (a truth model
//! stepped one command at a time), schedules of commands, and the replay of
//! a model through them. The planner's closed loop and the
//! measurement tools both stand on this layer. Pure: no files.

pub mod plant;
pub mod replay;
pub mod sensors;

pub use plant::{Plant, SEAT_TOLERANCE_M};
pub use replay::{CycleSchedule, EffectModel, Readings, ReplayError, Run, StepFeatures};
pub use sensors::{
    standard_sensors, Sensor, SensorTarget, LOAD_CELL_NOISE_N, POSITION_NOISE_M,
    TEMPERATURE_NOISE_C,
};
