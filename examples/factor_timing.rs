//! Where the factorisation cost models come from
//! (`numerics::block_matrix::cost`, `DR_NS_PER_ELEMENT` in the solver):
//! per structure (bridges of 2 to 16 modules per half, N×N nets), the time
//! of one DR iteration, of assembling and factorising its tangent with
//! every block dense and every block sparse, and the estimates.
//!
//!     cargo run --release --example factor_timing
//!     cargo run --release --example factor_timing -- solves
//!
//! `solves` times the nets from flat (1e-3 N) by default, with Newton
//! forced (no cost limit), and by pure DR.
use std::time::Instant;
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::stiffness::{assemble_tangent_stiffness, tangent_layout};
use tensegrity_deploy::model::*;
use tensegrity_deploy::numerics::{BlockLayout, BlockLu, BlockMatrix};

fn net(n: usize) -> Structure {
    tensegrity_deploy::design::square_net(&tensegrity_deploy::design::SquareNetParameters {
        nodes_per_side: n,
        ..Default::default()
    })
    .expect("a valid net")
}
fn bridge(m: usize) -> Structure {
    reference_bridge(&BridgeParameters {
        modules_per_half: m,
        spring_stiffness_n_per_m: 20_000.0,
        continuous_cable_tension_n: 1100.0,
        gravity_m_per_s2: 2.0,
        min_stiffness_n_per_m: f64::NEG_INFINITY,
        ..BridgeParameters::default()
    })
    .unwrap()
}
fn time<F: FnMut()>(mut f: F) -> f64 {
    let t = Instant::now();
    let mut k = 0;
    while t.elapsed().as_secs_f64() < 0.3 || k < 3 {
        f();
        k += 1;
    }
    t.elapsed().as_secs_f64() / k as f64
}
fn solves() {
    for n in [5usize, 7, 11, 15, 21, 31] {
        let mut line = format!("net{n}:");
        for (name, iters, ratio) in [
            ("default", 12, 40.0),
            ("forced", 12, 1e12),
            ("pure_dr", 0, 40.0),
        ] {
            let settings = RelaxSettings {
                tol_force_rel: 1e-300,
                tol_force_abs: 1e-3,
                newton_max_iter: iters,
                newton_max_cost_ratio: ratio,
                newton_max_dofs: 100000,
                ..RelaxSettings::default()
            };
            let model = ForwardModel::new(net(n), JointFriction::frictionless(), settings).unwrap();
            let mut ws = Workspace::default();
            let mut st = model.reference_state();
            let r = model.relax(&mut st, &mut ws);
            let t = time(|| {
                let mut st = model.reference_state();
                model.relax(&mut st, &mut ws);
            });
            line += &format!(
                " {name} {:.3} ms ({}+{} {:?})",
                t * 1e3,
                r.newton_iterations,
                r.iterations,
                r.status
            );
        }
        println!("{line}");
    }
}
fn main() {
    if std::env::args().any(|a| a == "solves") {
        return solves();
    }
    let cases: Vec<(String, Structure)> = vec![
        ("bridge2".into(), bridge(2)),
        ("bridge4".into(), bridge(4)),
        ("bridge8".into(), bridge(8)),
        ("bridge16".into(), bridge(16)),
        ("net5".into(), net(5)),
        ("net7".into(), net(7)),
        ("net11".into(), net(11)),
        ("net15".into(), net(15)),
        ("net21".into(), net(21)),
        ("net31".into(), net(31)),
    ];
    for (name, s) in cases {
        let settings = RelaxSettings {
            max_iter: 256,
            tol_force_rel: 1e-300,
            newton_max_iter: 0,
            ..RelaxSettings::default()
        };
        let model = ForwardModel::new(s, JointFriction::constant(0.0).unwrap(), settings).unwrap();
        let elements = model.structure().members.len() + model.structure().segment_count();
        let mut state = model.reference_state();
        for c in 0..model.structure().continuous_cables.len() {
            state.segment_rest_lengths_m[state.segment_offsets[c]] += 0.001;
        }
        let mut ws = Workspace::default();
        let dr = time(|| {
            let mut st = state.clone();
            model.relax(&mut st, &mut ws);
        }) / 256.0;
        let blocks = model.dof_blocks().to_vec();
        let n = model.free_dofs().count;
        let dense_layout = BlockLayout::dense(n, &blocks);
        let sparse_layout = BlockLayout::with_sparse_from(
            n,
            &blocks,
            &tensegrity_deploy::model::stiffness::tangent_coupling(&model),
            0,
        );
        let chosen = tangent_layout(&model);
        let chosen_sparse = (0..blocks.len())
            .filter(|&b| chosen.pattern(b).is_some())
            .count();
        let est = (
            chosen.factorisation_cost_ns(),
            dense_layout.factorisation_cost_ns(),
            sparse_layout.factorisation_cost_ns(),
        );
        let mut res = vec![];
        for (lname, layout) in [("dense", &dense_layout), ("sparse", &sparse_layout)] {
            let mut storage = Some(BlockMatrix::zeros_on(layout));
            let mut ok = true;
            let t = time(|| {
                let mut k = storage.take().unwrap();
                assemble_tangent_stiffness(&model, &state, JointMode::AsMapped, &mut k);
                match BlockLu::factorise(k) {
                    Some(lu) => {
                        ok &= true;
                        storage = Some(lu.into_storage());
                    }
                    None => {
                        ok = false;
                        storage = Some(BlockMatrix::zeros_on(layout));
                    }
                }
            });
            let mut k = BlockMatrix::zeros_on(layout);
            let ta = time(|| {
                k.clear();
                assemble_tangent_stiffness(&model, &state, JointMode::AsMapped, &mut k);
            });
            let chol = BlockLu::factorise(k.clone()).map(|l| l.is_cholesky());
            res.push(format!(
                "{lname} {:.1} us (asm {:.1}) chol={chol:?}",
                t * 1e6,
                ta * 1e6
            ));
        }
        let dense_flops: f64 = blocks
            .iter()
            .map(|b| 2.0 / 3.0 * (b.len() as f64).powi(3))
            .sum();
        let sparse_flops: f64 = (0..blocks.len())
            .filter_map(|b| sparse_layout.pattern(b))
            .map(|p| p.cholesky_flops())
            .sum();
        let nnz: usize = (0..blocks.len())
            .filter_map(|b| sparse_layout.pattern(b))
            .map(|p| p.nonzeros())
            .sum();
        let maxb = blocks.iter().map(|b| b.len()).max().unwrap_or(0);
        println!("{name}: dofs {n} maxblock {maxb} elements {elements} DR/it {:.2} us ({:.1} ns/el) | {} | dense_flops {:.3e} chol_flops {:.3e} nnzA {nnz} chosen_sparse {chosen_sparse} est(chosen,dense,sparse) {est:.0?}",
            dr * 1e6, dr * 1e9 / elements as f64, res.join(" | "), dense_flops, sparse_flops);
    }
}
