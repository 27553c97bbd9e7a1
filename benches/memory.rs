//! Speed of the case memory: retrieving the 5 nearest of 10 000 stored
//! cases; one retrieval and adaptation (linearisation at the case's end
//! and the ILC QP) with 10 000 cases stored (issue target ≤ 5 ms); and
//! reading a memory file of 1 000 cases with every checksum verified.
//!
//!     cargo bench --bench memory

use criterion::{criterion_group, criterion_main, Criterion};

use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::memory_file::{append_case, read_memory};
use tensegrity_deploy::learn::{
    adapt, Case, CaseConditions, CaseMemory, CaseOutcome, EndStateCache, FeatureScales,
};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::{
    folded_start, DeploymentProblem, MemorySettings, PlanContext, Policy,
};

/// Noise SD of one measured pair gap, m: the standard sensors' 1 mm on
/// both nodes.
const GAP_SD_M: f64 = 0.0014;

fn case(k: usize) -> Case {
    // Spread over temperature and payout scale by a fixed pattern.
    let t = (k * 37 % 400) as f64 / 10.0;
    let s = ((k * 53 % 100) as f64 - 50.0) / 1000.0;
    Case {
        conditions: CaseConditions {
            temperature_c: Some(t),
            fold_m: vec![0.4; 10],
            start_gap_m: Some(0.142),
            payout_scale: vec![s, -s],
        },
        commands_m: vec![vec![-0.05; 10]; 8],
        take_up_commands: None,
        measured_gaps_m: vec![vec![Some(0.1); 5]; 8],
        final_gap_vectors_m: vec![Some([0.01, 0.0, 0.0]); 5],
        prediction_error_m: vec![Some(0.002); 9],
        outcome: CaseOutcome {
            status: "connected".into(),
            commands: 9,
            corrective_commands: Some(1),
            final_gap_m: Some(0.008),
            approach_commands: None,
        },
        learning: None,
        model: None,
    }
}

fn bench(c: &mut Criterion) {
    let memory = CaseMemory {
        cases: (0..10_000).map(case).collect(),
    };
    let query = case(12_345).conditions;
    let scales = FeatureScales::default();
    c.bench_function("memory/nearest_5_of_10000", |b| {
        b.iter(|| memory.nearest(&query, 5, &scales))
    });
    let structure = reference_bridge(&BridgeParameters::default()).expect("bridge");
    let model = ForwardModel::new(
        structure,
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )
    .expect("model");
    let problem = DeploymentProblem::default();
    let settings = MemorySettings::default();
    let policy = Policy {
        memory: Some(settings),
        ..Policy::default()
    };
    let start = folded_start(&model, &problem, policy.increment_m).expect("fold");
    let context = PlanContext::new(&model, &problem, &policy, &start).expect("context");
    let adapt_with = |cache: &mut EndStateCache| {
        adapt(
            &memory, &query, &context, &start, &settings, &scales, GAP_SD_M, cache,
        )
    };
    let advice = adapt_with(&mut EndStateCache::default()).expect("adaptation");
    let retrieved = advice.adaptation().expect("a case");
    assert!(retrieved.ilc.status.is_solved());
    // Cold: the model follows the case's commands from the folded start.
    c.bench_function("memory/retrieve_and_adapt_10000_cold", |b| {
        b.iter(|| adapt_with(&mut EndStateCache::default()))
    });
    // Warm, as from the second cycle on: the cache holds the end of the
    // case adapted before. Two queries that retrieve cases with payout
    // scales 0.02 apart (the end payouts 8 mm apart, more than between
    // cycles) take turns; one iteration is two adaptations.
    let other = case(12_346).conditions;
    let first = adapt_with(&mut EndStateCache::default())
        .expect("adaptation")
        .adaptation()
        .cloned();
    let second = adapt(
        &memory,
        &other,
        &context,
        &start,
        &settings,
        &scales,
        GAP_SD_M,
        &mut EndStateCache::default(),
    )
    .expect("adaptation")
    .adaptation()
    .cloned();
    let index = |a: Option<tensegrity_deploy::learn::Adaptation>| a.map(|a| a.case_index);
    let (a, b) = (
        index(first).expect("a case"),
        index(second).expect("a case"),
    );
    let scale = |k: usize| memory.cases[k].conditions.payout_scale[0];
    assert!(
        (scale(a) - scale(b)).abs() >= 0.01,
        "{} {}",
        scale(a),
        scale(b)
    );
    let mut cache = EndStateCache::default();
    c.bench_function("memory/retrieve_and_adapt_10000_warm_x2", |b| {
        b.iter(|| {
            adapt_with(&mut cache).expect("adaptation");
            adapt(
                &memory, &other, &context, &start, &settings, &scales, GAP_SD_M, &mut cache,
            )
        })
    });
    let dir = tempfile::tempdir().expect("temporary folder");
    let path = dir.path().join("memory.tdm");
    for k in 0..1000 {
        append_case(&path, &case(k)).expect("append");
    }
    c.bench_function("memory/read_1000_cases", |b| {
        b.iter(|| read_memory(&path).expect("read"))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
