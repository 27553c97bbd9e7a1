//! Sensors: what a measurement (or a model's prediction of one) reads off a
//! state of the structure, resolved against the structure's ids.

use crate::model::Structure;
use crate::numerics::NumberRange;

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

impl SensorTarget {
    /// The noise standard deviations a sensor of this kind may declare, in
    /// its unit. The lower end is open: residuals are divided by the noise,
    /// so zero would make them infinite. The upper end is where a reading
    /// stops saying anything about the bridge, and past which the readings
    /// the tools simulate with that noise stop being numbers a structure
    /// can be put through (a position noise of 1e297 m made `replay --fit`
    /// relax a bridge at positions of that size, past 60 s):
    /// - positions: 0.1 m, three times the ±30 mm connection tolerance and
    ///   a sixth of the deepest fold (60 cm);
    /// - forces: 10 kN, above every design force of the reference bridge's
    ///   members (the struts carry a few kN);
    /// - temperature: 10 °C, the span of a day's air temperature.
    pub fn noise_sd_range(&self) -> NumberRange {
        match self {
            SensorTarget::SegmentTension { .. } | SensorTarget::MemberForce { .. } => {
                NumberRange::positive_up_to(MAX_FORCE_NOISE_N)
            }
            SensorTarget::Position { .. } => NumberRange::positive_up_to(MAX_POSITION_NOISE_M),
            SensorTarget::Temperature => NumberRange::positive_up_to(MAX_TEMPERATURE_NOISE_C),
        }
    }
}

/// Largest noise SD of a force sensor, N (see [`SensorTarget::noise_sd_range`]).
pub const MAX_FORCE_NOISE_N: f64 = 1e4;
/// Largest noise SD of a position sensor, m.
pub const MAX_POSITION_NOISE_M: f64 = 0.1;
/// Largest noise SD of a temperature sensor, °C.
pub const MAX_TEMPERATURE_NOISE_C: f64 = 10.0;

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
