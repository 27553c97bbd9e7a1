//! The plant of the closed loop on the reference bridge: starting folded,
//! and measuring with the same noise as the synthetic lab.

mod common;

use rand::SeedableRng;

use common::fixtures::reference_structure;
use tensegrity_deploy::measure::lab::run_lab;
use tensegrity_deploy::model::{EffectKind, Effects};
use tensegrity_deploy::sim::{standard_sensors, CycleSchedule, EffectModel, Plant};

/// The folded start: every motor paid out by this much, m.
const FOLDED_PAYOUT_M: f64 = 0.40;

fn bridge_with_friction(mu: f64) -> EffectModel {
    EffectModel::for_measurement(
        reference_structure(),
        Effects::default().with_parameters(EffectKind::JointFriction, &[mu]),
    )
}

#[test]
fn the_plant_starts_folded() {
    let m = bridge_with_friction(0.2);
    let s = &m.structure;
    let n = s.continuous_cables.len();
    let built = Plant::new(&m, None, None).unwrap();
    // How long the fold takes is timed by the bench `relaxation`,
    // `bridge_deploy_40cm_1cm_steps/mu0.2` (the same 40 cm in 1 cm
    // increments at μ = 0.2, reeled back in), not here.
    let plant = Plant::new(&m, Some(&vec![FOLDED_PAYOUT_M; n]), None).unwrap();
    let gap_built = built.state().max_midspan_gap_m(s).unwrap();
    let gap = plant.state().max_midspan_gap_m(s).unwrap();
    println!(
        "folded start ({FOLDED_PAYOUT_M} m on {n} motors, mu 0.2, 0.01 m increments): \
         largest midspan gap {gap:.5} m (as built {gap_built:.4} m)"
    );
    // The start payout is reached exactly (it does not go through the
    // motor model), up to the rounding of summing 40 increments.
    for p in plant.payout_m() {
        assert!((p - FOLDED_PAYOUT_M).abs() < 1e-12, "payout {p} m");
    }
    // Sliding over the joints only moves material along a cable: each
    // cable holds its as-built material plus what its motor paid out.
    for c in 0..n {
        let want = built.state().cable_material_m(c) + FOLDED_PAYOUT_M;
        let got = plant.state().cable_material_m(c);
        assert!((got - want).abs() < 1e-12, "cable {c}: {got} m vs {want} m");
    }
    // Paying out 40 cm of every cable opens the midspan: the halves hang
    // away from each other by more than 10 cm.
    assert!(
        gap > gap_built + 0.1,
        "gap {gap} m (as built {gap_built} m)"
    );
}

#[test]
fn measuring_the_plant_draws_the_noise_the_lab_draws() {
    // One step with no command: the lab's log of it holds the plant's
    // reading plus the same draws from the same seed.
    let m = bridge_with_friction(0.1);
    let sensors = standard_sensors(&m.structure);
    let schedule = CycleSchedule {
        commands: vec![],
        temperature_c: vec![Some(23.0)],
    };
    let log = run_lab(&m, &sensors, &[schedule], 42).unwrap();
    let plant = Plant::new(&m, None, Some(23.0)).unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(42);
    assert_eq!(plant.measure(&sensors, &mut rng), log.cycles[0].readings[0]);
}
