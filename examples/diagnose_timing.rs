//! Timed diagnose of a 5-cycle log with two hidden effects (the issue's
//! speed target: ≤ 60 s on 2 cores). Friction μ = 0.1 and support
//! compliance 3e-5 m/N are hidden in the truth; the log has the
//! standard sensors and 5 cycles of 1, 5, 10, 20 and 40 cm in 5 steps each
//! way. Run with a thread count to see the scaling:
//!
//!     RAYON_NUM_THREADS=2 cargo run --release --example diagnose_timing

use std::time::Instant;

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::measure::diagnose::{diagnose, DiagnoseSettings};
use tensegrity_deploy::measure::lab::{run_lab, standard_cycles, DAILY_SWING_K};
use tensegrity_deploy::model::{EffectKind, Effects, RelaxSettings};
use tensegrity_deploy::sim::standard_sensors;
use tensegrity_deploy::sim::EffectModel;

fn main() {
    let structure = reference_bridge(&BridgeParameters::default()).expect("reference bridge");
    let model = |effects: Effects| EffectModel {
        structure: structure.clone(),
        effects,
        settings: RelaxSettings::default(),
        increment_m: 0.01,
    };
    let truth = model(
        Effects::default()
            .with_parameters(EffectKind::JointFriction, &[0.1])
            .with_parameters(EffectKind::SupportFlexibility, &[3e-5]),
    );
    let sensors = standard_sensors(&structure);
    let cycles = standard_cycles(
        structure.continuous_cables.len(),
        &[0.01, 0.05, 0.1, 0.2, 0.4],
        5,
        DAILY_SWING_K,
    );
    let log = run_lab(&truth, &sensors, &cycles, 1).expect("lab");
    let baseline = model(Effects::default());
    let start = Instant::now();
    let replay = truth.run(&cycles, &sensors).expect("replay");
    let replay_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let d = diagnose(&baseline, &log, &DiagnoseSettings::default()).expect("diagnose");
    let diagnose_s = start.elapsed().as_secs_f64();
    let fitted: usize = d.rounds.iter().map(|r| r.ranking.len()).sum();
    println!(
        "threads {}: replay of the 5-cycle log (truth) {:.3} s ({} steps); diagnose {:.1} s ({} rounds, {} candidates fitted); verdict {:?}",
        rayon::current_num_threads(),
        replay_s,
        replay.iter().map(|c| c.len()).sum::<usize>(),
        diagnose_s,
        d.rounds.len(),
        fitted,
        match &d.verdict {
            tensegrity_deploy::measure::diagnose::Verdict::Missing { found: f, .. } =>
                f.iter().map(|c| format!("{} {:?} ± {:?}", c.name, c.values, c.std_errors)).collect::<Vec<_>>().join(", "),
            v => format!("{v:?}"),
        }
    );
}
