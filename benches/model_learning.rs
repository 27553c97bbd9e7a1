//! Speed of the self-diagnosis between two cycles (issue 24, item 6:
//! ≤ 10 s): `studies::model_learning::learn_model` on the log of the
//! default truth's cycles 2 and 3 (μ = 0.2, 3 mm backlash; the
//! memoryless controller's deployments, seed 1), against the frictionless
//! reference bridge:
//! - `first`: after cycle 1, nothing learnt yet, the one-cycle log (the
//!   search finds friction and backlash);
//! - `carried`: after cycle 3, with friction and backlash learnt, the
//!   two-cycle log (the refit from their values, then the search for
//!   anything else);
//! - `carried_window_1` and `carried_window_3`: the same with a log of
//!   one and of three cycles (the scaling with log length).
//!
//!     cargo bench --bench model_learning

use criterion::{criterion_group, criterion_main, Criterion};

use tensegrity_deploy::control::{ClosedLoopSetup, Deployment};
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::learn::{Case, CaseMemory, CaseModel, LearntEffect};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::{DeploymentProblem, MemorySettings, Policy};
use tensegrity_deploy::sim::{default_truth, standard_sensors, EffectModel};
use tensegrity_deploy::studies::cycles::{run_cycles, CycleObserver, CycleResult};
use tensegrity_deploy::studies::deployment_log::cycles_log;
use tensegrity_deploy::studies::model_learning::learn_model;

#[derive(Default)]
struct Deployments(Vec<Deployment>);

impl CycleObserver for Deployments {
    fn on_cycle(&mut self, _: &CycleResult, d: &Deployment, _: &Case) {
        self.0.push(d.clone());
    }
}

fn bench(c: &mut Criterion) {
    let structure = reference_bridge(&BridgeParameters::default()).expect("bridge");
    let model = ForwardModel::new(
        structure.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )
    .expect("model");
    let truth = default_truth(structure.clone());
    let sensors = standard_sensors(&structure);
    let problem = DeploymentProblem::default();
    let policy = Policy::default();
    let setup = ClosedLoopSetup {
        model: &model,
        problem: &problem,
        policy: &policy,
        truth: &truth,
        sensors: &sensors,
        temperature_c: None,
        seed: 1,
    };
    let mut kept = Deployments::default();
    run_cycles(&setup, 3, &mut CaseMemory::default(), None, &mut kept).expect("cycles");
    let d: Vec<&Deployment> = kept.0.iter().collect();
    let nominal = EffectModel::for_measurement(structure.clone(), Default::default());
    let log = |from: usize, to: usize| cycles_log(&d[from..to], &structure.name, sensors.clone());
    let settings = MemorySettings {
        model_learning_enable: true,
        ..MemorySettings::default()
    };
    let carried = CaseModel {
        effects: vec![
            LearntEffect {
                effect: "joint_friction".into(),
                values: vec![0.19],
                std_errors: vec![None],
                rival: None,
            },
            LearntEffect {
                effect: "motor".into(),
                values: vec![0.0, 0.0029],
                std_errors: vec![None, None],
                rival: None,
            },
        ],
        base: "reference {}".into(),
        accepted: true,
        held_out: true,
        planned_rms: 2.0,
        fitted_rms: 1.0,
        held_out_readings: 0,
    };
    let mut g = c.benchmark_group("model_learning");
    g.sample_size(10);
    let first = log(0, 1);
    g.bench_function("first", |b| {
        b.iter(|| learn_model(&nominal, None, &first, &settings).expect("learn"))
    });
    for (name, from) in [
        ("carried_window_1", 2),
        ("carried", 1),
        ("carried_window_3", 0),
    ] {
        let window = log(from, 3);
        g.bench_function(name, |b| {
            b.iter(|| learn_model(&nominal, Some(&carried), &window, &settings).expect("learn"))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
