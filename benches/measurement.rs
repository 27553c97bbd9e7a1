//! Speed of the measurement tools. Run: `cargo bench --bench measurement`.
//!
//! - replaying a 5-cycle log (1, 5, 10, 20 and 40 cm, 5 steps each way,
//!   the standard 35 sensors) through the model, without effects and with
//!   friction μ = 0.1 (target ≤ 1 s);
//! - comparing a model with such a log (replay plus residuals).
//!
//! A whole diagnose is too long for criterion's repetitions; it is timed by
//! `cargo run --release --example diagnose_timing`.

use criterion::{criterion_group, criterion_main, Criterion};
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::measure::compare::compare;
use tensegrity_deploy::measure::lab::{run_lab, standard_cycles, DAILY_SWING_K};
use tensegrity_deploy::model::{EffectKind, Effects, RelaxSettings};
use tensegrity_deploy::sim::standard_sensors;
use tensegrity_deploy::sim::EffectModel;

fn model(effects: Effects) -> EffectModel {
    EffectModel {
        structure: reference_bridge(&BridgeParameters::default()).unwrap(),
        effects,
        settings: RelaxSettings::default(),
        increment_m: 0.01,
    }
}

fn five_cycle_replay(c: &mut Criterion) {
    let mut group = c.benchmark_group("five-cycle log");
    group.sample_size(10);
    let friction = Effects::default().with_parameters(EffectKind::JointFriction, &[0.1]);
    let truth = model(friction.clone());
    let sensors = standard_sensors(&truth.structure);
    let cycles = standard_cycles(
        truth.structure.continuous_cables.len(),
        &[0.01, 0.05, 0.1, 0.2, 0.4],
        5,
        DAILY_SWING_K,
    );
    let log = run_lab(&truth, &sensors, &cycles, 1).unwrap();
    for (name, effects) in [
        ("no effects", Effects::default()),
        ("friction 0.1", friction),
    ] {
        let m = model(effects);
        group.bench_function(format!("replay, {name}"), |b| {
            b.iter(|| m.run(&cycles, &sensors).unwrap())
        });
        group.bench_function(format!("compare, {name}"), |b| {
            b.iter(|| compare(&m, &log).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, five_cycle_replay);
criterion_main!(benches);
