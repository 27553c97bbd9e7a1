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
    cycles_log(&[d], structure_name, sensors)
}

/// Consecutive deployment-fold cycles `deployments` (oldest first) of one
/// truth, each folded back by paying out what it reeled in before the
/// next, as one log of as many cycles: the first as [`deployment_log`]
/// writes it (the fold from the design), each later one starting where
/// the one before ended, its step 1 the fold-back (not measured), then its
/// commands. Replayed from the design, the log takes a model along the
/// path the truth took from the first cycle's start on (the cycles before
/// it, left out, only decide where the real bridge's friction held it).
pub fn cycles_log(
    deployments: &[&Deployment],
    structure_name: &str,
    sensors: Vec<Sensor>,
) -> MeasurementLog {
    let mut log = MeasurementLog {
        structure: structure_name.to_string(),
        sensors,
        cycles: Vec::with_capacity(deployments.len()),
    };
    let mut sent_total: Option<Vec<f64>> = None;
    for (k, d) in deployments.iter().enumerate() {
        let first = match &sent_total {
            None => d.start.start_payout_m.clone(),
            Some(total) => total.iter().map(|t| -t).collect(),
        };
        let mut commands = vec![first];
        commands.extend(d.commands());
        let mut readings = vec![vec![None; log.sensors.len()]];
        readings.extend(d.readings.iter().cloned());
        let mut total = vec![0.0; d.start.start_payout_m.len()];
        for u in d.commands() {
            for (t, x) in total.iter_mut().zip(&u) {
                *t += x;
            }
        }
        sent_total = Some(total);
        log.cycles.push(Cycle {
            label: k as u64 + 1,
            step_labels: (1..=commands.len() as u64).collect(),
            commands,
            readings,
        });
    }
    log
}
