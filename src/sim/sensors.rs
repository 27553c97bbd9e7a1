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
    /// Coordinate `axis` of node `node`, m.
    Position {
        /// Node index.
        node: usize,
        /// Axis.
        axis: Axis,
    },
    /// Air temperature, °C.
    Temperature,
}

/// A coordinate axis of the bridge's frame. A type of its own, not an
/// index: an axis of 3 or more used to index past a position's three
/// coordinates and panic in the estimators that read a sensor's
/// coordinate (only a library caller building a [`Sensor`] by hand could
/// pass one; sensor files name the axis).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// x: along the span.
    X,
    /// y: across the span.
    Y,
    /// z: up.
    Z,
}

impl Axis {
    /// The three axes in coordinate order.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// The coordinate's index in a position vector: 0, 1 or 2.
    pub fn index(self) -> usize {
        self as usize
    }

    /// `x`, `y` or `z`, as in sensor kinds (`position_x`) and ids.
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }
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
                format!("position_{}", axis.name()),
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
        for axis in Axis::ALL {
            sensors.push(Sensor {
                id: format!("{}_{}", structure.nodes[node].id, axis.name()),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};

    #[test]
    fn an_axis_is_one_of_the_three_coordinates_with_its_file_name() {
        let names: Vec<_> = Axis::ALL.iter().map(|a| (a.index(), a.name())).collect();
        assert_eq!(names, [(0, "x"), (1, "y"), (2, "z")]);
    }

    #[test]
    fn the_standard_layout_names_each_position_sensor_after_its_node_and_axis() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let sensors = standard_sensors(&s);
        let node = s.midspan_pairs[0][0];
        let positions: Vec<_> = sensors
            .iter()
            .filter_map(|x| match x.target {
                SensorTarget::Position { node: n, axis } if n == node => {
                    Some((x.id.clone(), x.kind_and_target(&s).0, axis))
                }
                _ => None,
            })
            .collect();
        let id = &s.nodes[node].id;
        assert_eq!(
            positions,
            Axis::ALL
                .iter()
                .map(|a| (
                    format!("{id}_{}", a.name()),
                    format!("position_{}", a.name()),
                    *a
                ))
                .collect::<Vec<_>>()
        );
    }
}
