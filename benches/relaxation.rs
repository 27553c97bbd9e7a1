//! Speed of the forward model. Run: `cargo bench --bench relaxation`.
//!
//! - one 1 cm payout increment on one cable of the full bridge, μ = 0 and
//!   0.2, warm-started from equilibrium, default tolerance;
//! - a whole deployment: every cable reeled in 40 cm in 1 cm increments,
//!   from the folded state (every cable paid out 40 cm), μ = 0 and 0.2,
//!   and μ = 0.2 with slip-event sub-steps (issue 25 asks at most 1.2×);
//! - the same deployment as eight 5 cm commands over cable seats of 2 cm
//!   radius (joint eccentricity; the seat arcs move with every increment
//!   and every command ends with them followed), μ = 0.2, and the same
//!   with DR alone finishing what
//!   Newton leaves (`dr_newton_restart_enable` off);
//! - the 7×7 cable net from its initial geometry to 1e-6 m accuracy;
//! - N×N cable nets (N = 5, 11, 21; the peer benchmark's nets) from flat
//!   to a 1e-3 N force tolerance, default settings and pure DR;
//! - ten empty steps (no payout change) from an equilibrium, μ = 0.2;
//! - cost per DR iteration on bridges of 2, 4, 8 and 16 modules per half
//!   (a fixed 256 iterations from a perturbed state), to show it grows
//!   linearly with the number of members.
//!
//! Iterations per solve are printed once before timing.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{
    DeploymentState, ForwardModel, JointFriction, RelaxSettings, Workspace,
};

fn bridge_model(mu: f64) -> ForwardModel {
    bridge_model_with(mu, RelaxSettings::default())
}

fn bridge_model_with(mu: f64, settings: RelaxSettings) -> ForwardModel {
    ForwardModel::new(
        reference_bridge(&BridgeParameters::default()).unwrap(),
        JointFriction::constant(mu).unwrap(),
        settings,
    )
    .unwrap()
}

fn single_increment(c: &mut Criterion) {
    for mu in [0.0, 0.2] {
        let model = bridge_model(mu);
        let mut ws = Workspace::default();
        let start = model.reference_state();
        let mut cmd = vec![0.0; model.structure().continuous_cables.len()];
        cmd[0] = -0.01;
        let mut probe = start.clone();
        let r = model
            .apply_payout(&mut probe, &mut ws, &cmd, 0.01, &mut ())
            .unwrap();
        eprintln!(
            "1 cm on one cable, μ = {mu}: {:?}, {} Newton + {} DR iterations",
            r.status, r.newton_iterations, r.iterations
        );
        eprintln!("  {:?}", ws.newton_counters());
        c.bench_function(&format!("bridge_1cm_one_cable_mu{mu}"), |b| {
            b.iter_batched(
                || start.clone(),
                |mut s| {
                    model
                        .apply_payout(&mut s, &mut ws, &cmd, 0.01, &mut ())
                        .unwrap()
                },
                BatchSize::SmallInput,
            )
        });
    }
}

/// The state paying every cable out 40 cm (folding) in 1 cm increments
/// leaves.
fn folded_40cm(model: &ForwardModel, ws: &mut Workspace) -> DeploymentState {
    let n = model.structure().continuous_cables.len();
    let mut folded = model.reference_state();
    let fold = model
        .apply_payout(&mut folded, ws, &vec![0.4; n], 0.01, &mut ())
        .unwrap();
    assert!(fold.status.is_converged(), "folding: {fold:?}");
    folded
}

/// Every cable reeled in 40 cm in 1 cm increments, from the state that
/// paying every cable out 40 cm (folding) leaves.
fn whole_deployment(c: &mut Criterion) {
    let mut group = c.benchmark_group("bridge_deploy_40cm_1cm_steps");
    group.sample_size(10);
    for (mu, located) in [(0.0, false), (0.2, false), (0.2, true)] {
        let model = bridge_model_with(
            mu,
            RelaxSettings {
                slip_event_substeps_enable: located,
                ..RelaxSettings::default()
            },
        );
        let n = model.structure().continuous_cables.len();
        let mut ws = Workspace::default();
        let folded = folded_40cm(&model, &mut ws);
        let mut probe = folded.clone();
        ws.reset_newton_counters();
        let r = model
            .apply_payout(&mut probe, &mut ws, &vec![-0.4; n], 0.01, &mut ())
            .unwrap();
        eprintln!(
            "deploy 40 cm, μ = {mu}, slip-event sub-steps {located}: {:?}, {} increments, {} Newton + {} DR iterations",
            r.status, r.increments, r.newton_iterations, r.iterations
        );
        eprintln!("  {:?}", ws.newton_counters());
        let name = if located {
            format!("mu{mu}_slip_event_substeps")
        } else {
            format!("mu{mu}")
        };
        group.bench_function(name, |b| {
            b.iter_batched(
                || folded.clone(),
                |mut s| {
                    model
                        .apply_payout(&mut s, &mut ws, &vec![-0.4; n], 0.01, &mut ())
                        .unwrap()
                },
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

/// The 40 cm deployment at μ = 0.2 as eight 5 cm commands over cable
/// seats of 2 cm radius: the arcs' material moves with every increment and
/// each command ends with the arcs followed to their fixed point (the
/// truth plant's work on every scenario of
/// `scenarios/wide.toml`). Also with `dr_newton_restart_enable` off (DR
/// alone finishes what Newton leaves), the ratio in one run.
fn deployment_over_seats(c: &mut Criterion) {
    let mut group = c.benchmark_group("bridge_deploy_40cm_1cm_steps");
    group.sample_size(10);
    for restart in [true, false] {
        let settings = RelaxSettings {
            dr_newton_restart_enable: restart,
            ..RelaxSettings::default()
        };
        let model = bridge_model_with(0.2, settings)
            .with_cable_seats(0.02)
            .unwrap();
        let n = model.structure().continuous_cables.len();
        let mut ws = Workspace::default();
        let folded = folded_40cm(&model, &mut ws);
        let deploy = |s: &mut DeploymentState, ws: &mut Workspace| {
            let (mut newton, mut dr) = (0, 0);
            for _ in 0..8 {
                let r = model
                    .apply_payout(s, ws, &vec![-0.05; n], 0.01, &mut ())
                    .unwrap();
                assert!(r.status.is_converged(), "{r:?}");
                newton += r.newton_iterations;
                dr += r.iterations;
            }
            (newton, dr)
        };
        ws.reset_newton_counters();
        let (newton, dr) = deploy(&mut folded.clone(), &mut ws);
        eprintln!(
            "deploy 40 cm in 8 commands over 2 cm seats, μ = 0.2, Newton from DR iterates {restart}: {newton} Newton + {dr} DR iterations"
        );
        eprintln!("  {:?}", ws.newton_counters());
        let name = if restart {
            "mu0.2_seats_8_commands".to_string()
        } else {
            "mu0.2_seats_8_commands_dr_alone".to_string()
        };
        group.bench_function(name, |b| {
            b.iter_batched(
                || folded.clone(),
                |mut s| deploy(&mut s, &mut ws),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

#[path = "../tests/common/cable_net.rs"]
mod cable_net_reference;

fn cable_net() -> ForwardModel {
    let (s, _) = cable_net_reference::load();
    // 1e-7 relative of ~1e4 N tensions: 1e-3 N, which holds positions to
    // well under 1e-6 m (see tests/cable_net_reference.rs).
    let settings = RelaxSettings {
        tol_force_rel: 1e-7,
        ..RelaxSettings::default()
    };
    ForwardModel::new(s, JointFriction::frictionless(), settings).unwrap()
}

fn cable_net_solve(c: &mut Criterion) {
    let model = cable_net();
    let mut ws = Workspace::default();
    let mut probe = model.reference_state();
    let r = model.relax(&mut probe, &mut ws);
    eprintln!(
        "cable net: {:?}, {} Newton + {} DR iterations",
        r.status, r.newton_iterations, r.iterations
    );
    c.bench_function("cable_net_7x7_from_flat", |b| {
        b.iter_batched(
            || model.reference_state(),
            |mut s| model.relax(&mut s, &mut ws),
            BatchSize::SmallInput,
        )
    });
}

/// The peer benchmark's N×N net (scripts/peer-benchmark/nets.py): 1 m
/// grid, perimeter pinned, tension-only cables, EA 1256.636 kN, rest length
/// 0.998 × initial, −1 kN on every free node.
fn square_net(n: usize, newton: bool) -> ForwardModel {
    use tensegrity_deploy::design::{square_net, SquareNetParameters};
    let s = square_net(&SquareNetParameters {
        nodes_per_side: n,
        ..Default::default()
    })
    .unwrap();
    let settings = RelaxSettings {
        tol_force_rel: 1e-300,
        tol_force_abs: 1e-3,
        newton_max_iter: if newton { 12 } else { 0 },
        ..RelaxSettings::default()
    };
    ForwardModel::new(s, JointFriction::frictionless(), settings).unwrap()
}

fn square_nets(c: &mut Criterion) {
    let mut group = c.benchmark_group("net_from_flat");
    group.sample_size(10);
    for n in [5usize, 11, 21] {
        for (newton, name) in [(true, "default"), (false, "pure_dr")] {
            let model = square_net(n, newton);
            let mut ws = Workspace::default();
            let mut probe = model.reference_state();
            let r = model.relax(&mut probe, &mut ws);
            eprintln!(
                "{n}×{n} net, {name}: {:?}, {} Newton + {} DR iterations",
                r.status, r.newton_iterations, r.iterations
            );
            group.bench_function(format!("{n}x{n}_{name}"), |b| {
                b.iter_batched(
                    || model.reference_state(),
                    |mut s| model.relax(&mut s, &mut ws),
                    BatchSize::SmallInput,
                )
            });
        }
    }
    group.finish();
}

/// Ten steps without payout change from an equilibrium with slid joints.
fn empty_steps(c: &mut Criterion) {
    let model = bridge_model(0.2);
    let n = model.structure().continuous_cables.len();
    let mut ws = Workspace::default();
    let mut start = model.reference_state();
    model
        .apply_payout(&mut start, &mut ws, &vec![-0.01; n], 0.01, &mut ())
        .unwrap();
    c.bench_function("bridge_ten_empty_steps_mu0.2", |b| {
        b.iter_batched(
            || start.clone(),
            |mut s| {
                for _ in 0..10 {
                    model
                        .apply_payout(&mut s, &mut ws, &vec![0.0; n], 0.01, &mut ())
                        .unwrap();
                }
                s
            },
            BatchSize::SmallInput,
        )
    });
}

fn per_iteration_scaling(c: &mut Criterion) {
    let mut group = c.benchmark_group("dr_256_iterations");
    for modules in [2usize, 4, 8, 16] {
        // Longer cantilevers need stiffer springs and more prestress to
        // form-find; the same values at every size keep the comparison fair.
        // These are structures to time, not designs: a 16-module (16 m)
        // cantilever admits no prestress under full gravity, and stability is
        // not needed for 256 iterations.
        let p = BridgeParameters {
            modules_per_half: modules,
            spring_stiffness_n_per_m: 20_000.0,
            continuous_cable_tension_n: 1100.0,
            gravity_m_per_s2: 2.0,
            min_stiffness_n_per_m: f64::NEG_INFINITY,
            ..BridgeParameters::default()
        };
        let s = reference_bridge(&p).unwrap();
        let elements = s.members.len() + s.segment_count();
        let settings = RelaxSettings {
            max_iter: 256,
            tol_force_rel: 1e-300,
            newton_max_iter: 0,
            ..RelaxSettings::default()
        };
        let model = ForwardModel::new(s, JointFriction::constant(0.2).unwrap(), settings).unwrap();
        let mut start = model.reference_state();
        // Perturb: pay out every cable 1 mm so the solve has work to do.
        for c in 0..model.structure().continuous_cables.len() {
            start.segment_rest_lengths_m[start.segment_offsets[c]] += 0.001;
        }
        let mut ws = Workspace::default();
        group.bench_function(format!("{modules}_modules_{elements}_elements"), |b| {
            b.iter_batched(
                || start.clone(),
                |mut st| model.relax(&mut st, &mut ws),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    single_increment,
    whole_deployment,
    deployment_over_seats,
    cable_net_solve,
    square_nets,
    empty_steps,
    per_iteration_scaling
);
criterion_main!(benches);
