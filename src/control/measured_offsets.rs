//! From one measurement to the correction of the model's predictions:
//! for every quantity the policy measures, measured − predicted (see
//! `crate::plan::correction`), the midspan gap vectors from the position
//! readings and the force rows the load cells read, and the load-cell
//! offsets through their filter.

use nalgebra::Vector3;

use super::force_offset_filter::ForceOffsetFilter;
use crate::model::{DeploymentState, ForwardModel, Structure};
use crate::plan::limits::force_rows;
use crate::plan::{Measurement, ModelCorrection};
use crate::sim::{Axis, Sensor, SensorTarget};

/// Gap vector `x_a − x_b` of each midspan pair from a measurement: the
/// six position readings of its two nodes; `None` where any is missing
/// or no sensor reads it.
pub fn measured_gap_vectors(
    structure: &Structure,
    sensors: &[Sensor],
    readings: &[Option<f64>],
) -> Vec<Option<Vector3<f64>>> {
    let position = |node: usize| -> Option<Vector3<f64>> {
        let mut p = Vector3::zeros();
        for axis in Axis::ALL {
            let s = sensors
                .iter()
                .position(|s| s.target == SensorTarget::Position { node, axis })?;
            p[axis.index()] = (*readings.get(s)?)?;
        }
        Some(p)
    };
    structure
        .midspan_pairs
        .iter()
        .map(|[a, b]| Some(position(*a)? - position(*b)?))
        .collect()
}

/// The noise SD of one midspan pair's measured gap, m: the largest over
/// the pairs and axes of `√(σ_a² + σ_b²)`, the noise SDs of the two
/// position sensors on that axis (a gap is their difference); 0 where no
/// pair is read.
pub fn gap_reading_sd_m(structure: &Structure, sensors: &[Sensor]) -> f64 {
    let sd = |node: usize, axis: Axis| {
        sensors
            .iter()
            .find(|s| s.target == SensorTarget::Position { node, axis })
            .map(|s| s.noise_sd)
    };
    structure
        .midspan_pairs
        .iter()
        .flat_map(|&[a, b]| {
            Axis::ALL.into_iter().filter_map(move |axis| {
                let (sa, sb) = (sd(a, axis)?, sd(b, axis)?);
                Some(sa.hypot(sb))
            })
        })
        .fold(0.0, f64::max)
}

/// The force row (members, then segments) a load cell reads on `model`,
/// if the model has it.
pub(crate) fn load_cell_row(
    model: &ForwardModel,
    state: &DeploymentState,
    target: SensorTarget,
) -> Option<usize> {
    let s = model.structure();
    match target {
        SensorTarget::SegmentTension { cable, segment } => {
            let c = s.continuous_cables.get(cable)?;
            (segment < c.segment_count())
                .then(|| s.members.len() + state.segment_offsets[cable] + segment)
        }
        // A member the effects appended to the truth (a foundation bar)
        // has no row in the model.
        SensorTarget::MemberForce { member } => (member < s.members.len()).then_some(member),
        _ => None,
    }
}

/// The correction of `model`'s predictions at `state` from one
/// measurement: for every quantity `measures` lists, measured −
/// predicted (see [`crate::plan::correction`]).
///
/// - [`Measurement::MidspanPositions`]: each midspan pair's gap vector
///   from the six position readings of its two nodes; a pair with a
///   missing reading keeps offset 0 (its gap is the model's until it is
///   measured again).
/// - [`Measurement::LoadCells`]: the force row of each load cell's
///   segment or member; a missing reading keeps offset 0.
///
/// Everything else is unmeasured and keeps offset 0.
pub fn model_correction(
    model: &ForwardModel,
    state: &DeploymentState,
    sensors: &[Sensor],
    readings: &[Option<f64>],
    measures: &[Measurement],
) -> ModelCorrection {
    let s = model.structure();
    let mut correction =
        ModelCorrection::none(s.midspan_pairs.len(), s.members.len() + s.segment_count());
    if measures.contains(&Measurement::MidspanPositions) {
        let measured = measured_gap_vectors(s, sensors, readings);
        for ((offset, m), [a, b]) in correction
            .gap_offsets_m
            .iter_mut()
            .zip(measured)
            .zip(&s.midspan_pairs)
        {
            if let Some(m) = m {
                *offset = m - (state.positions_m[*a] - state.positions_m[*b]);
            }
        }
    }
    if measures.contains(&Measurement::LoadCells) {
        let predicted = force_rows(model, state);
        for (sensor, reading) in sensors.iter().zip(readings) {
            if let (Some(row), Some(value)) = (load_cell_row(model, state, sensor.target), reading)
            {
                correction.force_offsets_n[row] = value - predicted[row];
                correction.force_measured[row] = true;
            }
        }
    }
    correction
}

/// Filters `correction`'s load-cell offsets through `filter`: the rows
/// read this time (when `measures` has the load cells) carry their
/// sensor's noise.
pub fn filter_force_offsets(
    filter: &mut ForceOffsetFilter,
    correction: &mut ModelCorrection,
    model: &ForwardModel,
    state: &DeploymentState,
    sensors: &[Sensor],
    readings: &[Option<f64>],
    measures: &[Measurement],
) {
    let predicted = force_rows(model, state);
    let mut noise_sd_n = vec![None; predicted.len()];
    // Load cells the policy does not measure left no offset to filter.
    if measures.contains(&Measurement::LoadCells) {
        for (sensor, reading) in sensors.iter().zip(readings) {
            if let (Some(row), Some(_)) = (load_cell_row(model, state, sensor.target), reading) {
                noise_sd_n[row] = Some(sensor.noise_sd);
            }
        }
    }
    filter.filter(correction, &predicted, &noise_sd_n);
}

#[cfg(test)]
mod tests {
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    use super::*;
    use crate::control::fixtures::{frictionless_model, short_fold};
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::plan::planner::PlanContext;
    use crate::plan::{folded_start, Policy};
    use crate::sim::{default_truth, standard_sensors, Plant};

    /// A gap is the difference of two positions read with independent
    /// noise: its SD is √2 times theirs where both are alike, and the
    /// noisier axis of the worse pair where they differ.
    #[test]
    fn the_gap_reading_noise_is_that_of_a_difference_of_two_positions() {
        let structure = reference_bridge(&BridgeParameters::default()).expect("bridge");
        let mut sensors = standard_sensors(&structure);
        let position_sd = |sensors: &[Sensor]| {
            sensors
                .iter()
                .find(|s| matches!(s.target, SensorTarget::Position { .. }))
                .map(|s| s.noise_sd)
                .expect("position sensors")
        };
        let sd = position_sd(&sensors);
        let expected = sd * 2f64.sqrt();
        assert!((gap_reading_sd_m(&structure, &sensors) - expected).abs() < 1e-15);
        // One node's z sensor three times noisier: that pair's z gap
        // reads with √(9 + 1)·σ.
        let [a, _] = structure.midspan_pairs[2];
        for s in sensors.iter_mut() {
            if s.target
                == (SensorTarget::Position {
                    node: a,
                    axis: Axis::Z,
                })
            {
                s.noise_sd *= 3.0;
            }
        }
        let expected = sd * 10f64.sqrt();
        assert!((gap_reading_sd_m(&structure, &sensors) - expected).abs() < 1e-15);
        // No position sensors: no gap is read.
        sensors.retain(|s| !matches!(s.target, SensorTarget::Position { .. }));
        assert_eq!(gap_reading_sd_m(&structure, &sensors), 0.0);
    }

    #[test]
    fn the_correction_is_measured_minus_predicted_and_brings_the_gaps_onto_the_truth() {
        let model = frictionless_model();
        let problem = short_fold();
        let policy = Policy::default();
        let state = folded_start(&model, &problem, policy.increment_m).unwrap();
        let truth = default_truth(reference_bridge(&BridgeParameters::default()).unwrap());
        let s = model.structure();
        let n = s.continuous_cables.len();
        let plant = Plant::new(&truth, Some(&vec![0.10; n]), None).unwrap();
        let sensors = standard_sensors(&truth.structure);
        let clean = plant.read(&sensors);
        let mut context = PlanContext::new(&model, &problem, &policy, &state).unwrap();
        context.correction =
            model_correction(&model, &state, &sensors, &clean, &policy.control.measures);

        // Noise-free positions: the corrected gap vectors are the truth's
        // (to rounding of coordinates of a few metres, 1e-12 m), and the
        // correction is not trivial: friction holds the truth's fold
        // differently from the frictionless model's (0.8 mm at this 10 cm
        // fold, a million times the check's tolerance).
        let truth_x = &plant.state().positions_m;
        let corrected = context.gap_vectors(&state);
        let mut largest_offset = 0.0f64;
        for (p, [a, b]) in s.midspan_pairs.iter().enumerate() {
            let true_gap = truth_x[*a] - truth_x[*b];
            assert!((corrected[p] - true_gap).norm() < 1e-12, "pair {p}");
            largest_offset = largest_offset.max(context.correction.gap_offset_m(p).norm());
        }
        assert!(largest_offset > 1e-4, "offsets {largest_offset} m");

        // Load cells: the four measured rows corrected onto the truth's
        // tensions; every other row untouched.
        let predicted = force_rows(&model, &state);
        let truth_forces = plant.model().member_forces(plant.state());
        let mut corrected_rows = 0;
        for sensor in &sensors {
            if let SensorTarget::SegmentTension { cable, segment } = sensor.target {
                let row = s.members.len() + state.segment_offsets[cable] + segment;
                let t = truth_forces.segment_n[plant.state().segment_offsets[cable] + segment];
                let f = predicted[row] + context.correction.force_offset_n(row);
                assert!((f - t).abs() < 1e-9 * t.abs().max(1.0), "{}", sensor.id);
                corrected_rows += 1;
            }
        }
        assert_eq!(corrected_rows, 4);
        let nonzero = context
            .correction
            .force_offsets_n
            .iter()
            .filter(|o| **o != 0.0)
            .count();
        assert_eq!(nonzero, 4);

        // Noisy readings: the offset is the reading less the prediction,
        // computed here from the readings themselves.
        let mut rng = StdRng::seed_from_u64(3);
        let noisy = plant.measure(&sensors, &mut rng);
        let c = model_correction(&model, &state, &sensors, &noisy, &policy.control.measures);
        let reading = |node: usize, axis: Axis| {
            let k = sensors
                .iter()
                .position(|s| s.target == SensorTarget::Position { node, axis })
                .unwrap();
            noisy[k].unwrap()
        };
        for (p, [a, b]) in s.midspan_pairs.iter().enumerate() {
            for axis in Axis::ALL {
                let measured = reading(*a, axis) - reading(*b, axis);
                let i = axis.index();
                let model_gap = state.positions_m[*a][i] - state.positions_m[*b][i];
                assert!((c.gap_offsets_m[p][i] - (measured - model_gap)).abs() < 1e-15);
            }
        }

        // A missing reading leaves its pair at offset 0, the others as
        // they were; measuring nothing corrects nothing.
        let [a0, _] = s.midspan_pairs[0];
        let k = sensors
            .iter()
            .position(|s| {
                s.target
                    == SensorTarget::Position {
                        node: a0,
                        axis: Axis::Y,
                    }
            })
            .unwrap();
        let mut missing = noisy.clone();
        missing[k] = None;
        let m = model_correction(&model, &state, &sensors, &missing, &policy.control.measures);
        assert_eq!(m.gap_offsets_m[0], Vector3::zeros());
        assert_eq!(m.gap_offsets_m[1..], c.gap_offsets_m[1..]);
        assert_eq!(m.force_offsets_n, c.force_offsets_n);
        let none = model_correction(&model, &state, &sensors, &noisy, &[]);
        assert_eq!(
            none,
            ModelCorrection::none(s.midspan_pairs.len(), predicted.len())
        );
    }
}
