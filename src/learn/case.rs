//! One deployment (or deployment-fold) cycle, as the memory keeps it.

use serde::{Deserialize, Serialize};

use crate::control::{measured_gap_vectors, Deployment};
use crate::model::Structure;
use crate::sim::Sensor;

/// What a cycle started from, as the controller knew it: the features
/// retrieval compares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseConditions {
    /// Temperature of the cycle, °C (`None`: not measured).
    pub temperature_c: Option<f64>,
    /// Start fold: the motors' payout from the designed state, m.
    pub fold_m: Vec<f64>,
    /// Largest measured midspan gap at the start, m (`None`: not measured).
    pub start_gap_m: Option<f64>,
    /// Payout scale of each bridge half as estimated at the cycle's end
    /// (the effect parameters the controller estimates), 1.
    pub payout_scale: Vec<f64>,
}

/// How a cycle ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseOutcome {
    /// The final status's label (`connected`, `not_reachable`, …).
    pub status: String,
    /// Commands sent.
    pub commands: usize,
    /// Commands after the first that brought the largest measured gap
    /// below 60 mm.
    pub corrective_commands: Option<usize>,
    /// Largest measured gap at the end, m.
    pub final_gap_m: Option<f64>,
}

/// One cycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// What it started from.
    pub conditions: CaseConditions,
    /// The commands sent, per command and motor, m.
    pub commands_m: Vec<Vec<f64>>,
    /// Measured gap of each midspan pair after each command, m (`None`:
    /// a reading missing).
    pub measured_gaps_m: Vec<Vec<Option<f64>>>,
    /// Measured gap vector `x_a − x_b` of each midspan pair at the end, m
    /// (`None`: a reading missing): the error the next cycle's ILC update
    /// removes (see [`super::ilc`]).
    pub final_gap_vectors_m: Vec<Option<[f64; 3]>>,
    /// The model's prediction error after each command: the largest
    /// |predicted − measured| gap over the pairs, m.
    pub prediction_error_m: Vec<Option<f64>>,
    /// How it ended.
    pub outcome: CaseOutcome,
}

impl Case {
    /// The case of a closed-loop deployment `d` of `structure` read by
    /// `sensors`, run at `temperature_c`.
    pub fn of_deployment(
        d: &Deployment,
        structure: &Structure,
        sensors: &[Sensor],
        temperature_c: Option<f64>,
    ) -> Case {
        let last_readings = d.readings.last().map_or(&[][..], |r| &r[..]);
        let final_gap_vectors_m = measured_gap_vectors(structure, sensors, last_readings)
            .into_iter()
            .map(|g| g.map(|g| [g.x, g.y, g.z]))
            .collect();
        let prediction_error_m = d
            .records
            .iter()
            .map(|r| {
                r.predicted_gaps_m
                    .iter()
                    .zip(&r.measured_gaps_m)
                    .filter_map(|(p, m)| m.map(|m| (p - m).abs()))
                    .reduce(f64::max)
            })
            .collect();
        Case {
            conditions: CaseConditions {
                temperature_c,
                fold_m: d.start.start_payout_m.clone(),
                start_gap_m: d.start.largest_measured_gap_m(),
                payout_scale: d.final_payout_scale.clone(),
            },
            commands_m: d.commands(),
            measured_gaps_m: d
                .records
                .iter()
                .map(|r| r.measured_gaps_m.clone())
                .collect(),
            final_gap_vectors_m,
            prediction_error_m,
            outcome: CaseOutcome {
                status: d.status.label().to_string(),
                commands: d.records.len(),
                corrective_commands: d.corrective_commands,
                final_gap_m: d.final_measured_gap_m(),
            },
        }
    }
}
