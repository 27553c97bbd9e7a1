//! The tdeploy side of the peer benchmark (`scripts/peer-benchmark/run.sh`):
//! reads the N×N cable nets that `nets.py` writes, solves each from its
//! flat initial geometry with the default settings and with pure DR
//! (`newton_max_iter = 0`), each to the file's force tolerance, and prints
//! the times, iterations and positions as JSON for `nets.py` to check.
//!
//!     cargo run --release --example peer_nets -- NETS.json
//!
//! Times are the fastest of repeated solves within the file's `repeat_s`.

use std::time::Instant;

use nalgebra::Vector3;
use tensegrity_deploy::model::{
    ForwardModel, JointFriction, Member, MemberKind, Node, RelaxSettings, Structure, Workspace,
};

#[derive(serde::Deserialize)]
struct Net {
    n: usize,
    positions_m: Vec<[f64; 3]>,
    members: Vec<[usize; 2]>,
    fixed: Vec<bool>,
    rest_length_m: Vec<f64>,
    loads_n: Vec<[f64; 3]>,
    ea_n: f64,
    tol_n: f64,
    repeat_s: f64,
}

fn structure(net: &Net) -> Structure {
    let nodes = net
        .positions_m
        .iter()
        .enumerate()
        .map(|(i, p)| Node {
            id: format!("n{i}"),
            position_m: Vector3::from(*p),
            mass_kg: 0.0,
            fixed: [net.fixed[i]; 3],
            load_n: Vector3::from(net.loads_n[i]),
        })
        .collect();
    let members = net
        .members
        .iter()
        .zip(&net.rest_length_m)
        .enumerate()
        .map(|(k, (ab, l0))| Member {
            id: format!("c{k}"),
            kind: MemberKind::Cable { ea_n: net.ea_n },
            nodes: *ab,
            rest_length_m: *l0,
        })
        .collect();
    Structure::new(
        format!("cable net {0}x{0}", net.n),
        nodes,
        members,
        vec![],
        Vector3::zeros(),
        vec![],
    )
    .expect("a valid net")
}

fn solve(net: &Net, settings: RelaxSettings) -> serde_json::Value {
    let model = ForwardModel::new(structure(net), JointFriction::frictionless(), settings)
        .expect("valid settings");
    let mut ws = Workspace::default();
    let (mut best, mut spent) = (f64::INFINITY, 0.0);
    loop {
        let mut state = model.reference_state();
        let start = Instant::now();
        let report = model.relax(&mut state, &mut ws);
        let elapsed = start.elapsed().as_secs_f64();
        best = best.min(elapsed);
        spent += elapsed;
        if spent + best > net.repeat_s {
            let positions: Vec<[f64; 3]> =
                state.positions_m.iter().map(|p| [p.x, p.y, p.z]).collect();
            return serde_json::json!({
                "status": format!("{:?}", report.status),
                "seconds": best,
                "iterations": [report.newton_iterations, report.iterations],
                "positions_m": positions,
            });
        }
    }
}

fn main() {
    let path = std::env::args().nth(1).expect("usage: peer_nets NETS.json");
    let text = std::fs::read_to_string(&path).expect("readable nets file");
    let nets: Vec<Net> = serde_json::from_str(&text).expect("a nets file written by nets.py");
    let mut out = Vec::new();
    for net in &nets {
        // The default settings, with the benchmark's absolute force tolerance.
        let default = RelaxSettings {
            tol_force_rel: 1e-300,
            tol_force_abs: net.tol_n,
            ..RelaxSettings::default()
        };
        let dr = RelaxSettings {
            newton_max_iter: 0,
            ..default.clone()
        };
        out.push(serde_json::json!({
            "n": net.n,
            "default": solve(net, default),
            "dr": solve(net, dr),
        }));
    }
    println!("{}", serde_json::Value::Array(out));
}
