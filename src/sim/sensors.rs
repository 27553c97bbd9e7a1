//! Sensors: what a measurement (or a model's prediction of one) reads off a
//! state of the structure, resolved against the structure's ids.

use crate::model::Structure;

/// What a sensor measures, resolved against the structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorTarget {
    /// Tension of segment `segment` of continuous cable `cable`, N.
    SegmentTension {
        /// Cable index.
        cable: usize,
        /// Segment index along the cable.
        segment: usize,
    },
    /// Axial force of member `member`, N.
    MemberForce {
        /// Member index.
        member: usize,
    },
    /// Coordinate `axis` (0 x, 1 y, 2 z) of node `node`, m.
    Position {
        /// Node index.
        node: usize,
        /// Axis.
        axis: usize,
    },
    /// Air temperature, °C.
    Temperature,
}

/// One sensor of the layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Unique id.
    pub id: String,
    /// What it measures.
    pub target: SensorTarget,
    /// Noise standard deviation, in the sensor's unit.
    pub noise_sd: f64,
}

impl Sensor {
    /// `kind` and `target` as written in `sensors.csv`.
    pub fn kind_and_target(&self, structure: &Structure) -> (String, String) {
        match self.target {
            SensorTarget::SegmentTension { cable, segment } => (
                "tension".into(),
                format!("{}:{segment}", structure.continuous_cables[cable].id),
            ),
            SensorTarget::MemberForce { member } => {
                ("tension".into(), structure.members[member].id.clone())
            }
            SensorTarget::Position { node, axis } => (
                format!("position_{}", ["x", "y", "z"][axis]),
                structure.nodes[node].id.clone(),
            ),
            SensorTarget::Temperature => ("temperature".into(), "-".into()),
        }
    }
}

/// Load-cell noise, N (seed: about 7 N).
pub const LOAD_CELL_NOISE_N: f64 = 7.0;
/// Position noise, m (seed: about 1 mm).
pub const POSITION_NOISE_M: f64 = 0.001;
/// Temperature noise, °C.
pub const TEMPERATURE_NOISE_C: f64 = 0.1;

/// The seed-like sensor layout for `structure` (a reference bridge: its
/// cables `A_cc0`–`A_cc3` carry the load cells).
pub fn standard_sensors(structure: &Structure) -> Vec<Sensor> {
    let mut sensors = Vec::new();
    for (c, cable) in structure.continuous_cables.iter().enumerate().take(4) {
        sensors.push(Sensor {
            id: format!("load_{}", cable.id),
            target: SensorTarget::SegmentTension {
                cable: c,
                segment: cable.segment_count() - 1,
            },
            noise_sd: LOAD_CELL_NOISE_N,
        });
    }
    for &node in structure.midspan_pairs.iter().flatten() {
        for (axis, name) in ["x", "y", "z"].iter().enumerate() {
            sensors.push(Sensor {
                id: format!("{}_{name}", structure.nodes[node].id),
                target: SensorTarget::Position { node, axis },
                noise_sd: POSITION_NOISE_M,
            });
        }
    }
    sensors.push(Sensor {
        id: "temperature".into(),
        target: SensorTarget::Temperature,
        noise_sd: TEMPERATURE_NOISE_C,
    });
    sensors
}
