//! A measurement log in memory: what was commanded and what the sensors
//! read, cycle by cycle and step by step. The file format is in
//! [`crate::io::log`].

use crate::sim::Sensor;

/// The commands of one step: a payout change per continuous cable, m.
pub type StepCommand = Vec<f64>;

/// One deployment-fold cycle: its steps' commands and readings.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    /// Cycle number as logged.
    pub label: u64,
    /// Step numbers as logged (step 0, the state before any command, has no
    /// command and is not listed).
    pub step_labels: Vec<u64>,
    /// Commands per step (same order as `step_labels`).
    pub commands: Vec<StepCommand>,
    /// Readings per step, step 0 first then `step_labels` order; one
    /// `Option` per sensor (layout order).
    pub readings: Vec<Vec<Option<f64>>>,
}

/// A whole log.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementLog {
    /// Name of the structure it was made on.
    pub structure: String,
    /// Sensor layout.
    pub sensors: Vec<Sensor>,
    /// Cycles in order.
    pub cycles: Vec<Cycle>,
}
