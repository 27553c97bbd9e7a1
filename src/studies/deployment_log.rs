//! A deployment as a measurement log: what `deploy` writes as its `log/`
//! and what a cycle's model error is measured on.

use crate::control::Deployment;
use crate::measure::log::{Cycle, MeasurementLog};
use crate::sim::Sensor;

/// The deployment `d` of the structure named `structure_name`, read by
/// `sensors`, as a one-cycle measurement log: step 0 the designed state
/// (not measured), step 1 the fold to the start, then the commands.
pub fn deployment_log(
    d: &Deployment,
    structure_name: &str,
    sensors: Vec<Sensor>,
) -> MeasurementLog {
    let mut commands = vec![d.start.start_payout_m.clone()];
    commands.extend(d.commands());
    let mut readings = vec![vec![None; sensors.len()]];
    readings.extend(d.readings.iter().cloned());
    MeasurementLog {
        structure: structure_name.to_string(),
        sensors,
        cycles: vec![Cycle {
            label: 1,
            step_labels: (1..=commands.len() as u64).collect(),
            commands,
            readings,
        }],
    }
}
