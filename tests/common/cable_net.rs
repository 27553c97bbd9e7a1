//! Loads the 7×7 cable-net reference (`tests/data/cable-net-7x7.json`, a copy
//! of `../shared/reference/cable-net-7x7.json`). Read by the verification
//! test (`tests/cable_net_reference.rs`, through `mod common`) and by the
//! relaxation benchmark (`benches/relaxation.rs`, through `#[path]`).

use nalgebra::Vector3;
use tensegrity_deploy::model::{Member, MemberKind, Node, Structure};

/// The reference file's fields.
#[derive(serde::Deserialize)]
#[allow(dead_code)]
pub struct Reference {
    #[serde(rename = "EA_N")]
    pub ea_n: f64,
    pub nodes_initial_m: Vec<[f64; 3]>,
    pub members: Vec<[usize; 2]>,
    pub fixed_nodes: Vec<usize>,
    pub rest_length_m: Vec<f64>,
    #[serde(rename = "loads_N")]
    pub loads_n: Vec<[f64; 3]>,
    pub nodes_equilibrium_m: Vec<[f64; 3]>,
    #[serde(rename = "tension_equilibrium_N")]
    pub tension_equilibrium_n: Vec<f64>,
}

/// The net as a structure (no gravity, point loads) and the reference data.
pub fn load() -> (Structure, Reference) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/cable-net-7x7.json"
    ))
    .unwrap();
    let r: Reference = serde_json::from_str(&text).unwrap();
    let nodes = r
        .nodes_initial_m
        .iter()
        .enumerate()
        .map(|(i, p)| Node {
            id: format!("n{i}"),
            position_m: Vector3::from(*p),
            mass_kg: 0.0,
            fixed: [r.fixed_nodes.contains(&i); 3],
            load_n: Vector3::from(r.loads_n[i]),
        })
        .collect();
    let members = r
        .members
        .iter()
        .zip(&r.rest_length_m)
        .enumerate()
        .map(|(k, (ab, l0))| Member {
            id: format!("c{k}"),
            kind: MemberKind::Cable { ea_n: r.ea_n },
            nodes: *ab,
            rest_length_m: *l0,
        })
        .collect();
    let s = Structure::new(
        "cable net 7x7",
        nodes,
        members,
        vec![],
        Vector3::zeros(),
        vec![],
    )
    .unwrap();
    (s, r)
}
