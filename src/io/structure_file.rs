//! The structure file: one JSON document describing one structure.
//!
//! ```json
//! {
//!   "format": "tensegrity-deploy/structure/1",
//!   "name": "…",
//!   "gravity_m_per_s2": [0, 0, -9.81],
//!   "nodes":   [{"id": "A0_0", "position_m": [x, y, z], "mass_kg": 1.2,
//!                "fixed": [true, true, true], "load_n": [0, 0, 0]}],
//!   "struts":  [{"id": "s0", "nodes": ["A0_0", "A1_0"], "ea_n": 2.6e7,
//!                "ei_nm2": 2.3e3, "rest_length_m": 0.59}],
//!   "cables":  [{"id": "c0", "nodes": ["…", "…"], "ea_n": 7e5, "rest_length_m": 1.0}],
//!   "springs": [{"id": "k0", "nodes": ["…", "…"], "stiffness_n_per_m": 4e3, "rest_length_m": 0.5}],
//!   "continuous_cables": [{"id": "cc0", "path": ["A0_0", "A1_4", "…"],
//!                          "ea_n": 7e5, "segment_rest_lengths_m": [0.58, …]}],
//!   "midspan_pairs": [["A4_0", "B4_0"]]
//! }
//! ```
//! `fixed` and `load_n` may be omitted (free, unloaded); `midspan_pairs`
//! may be omitted. Unknown fields are errors, so a misspelt field is never
//! silently ignored. SI units throughout, as the field names say.
//!
//! Every number must lie in its range below (wide: they reject unit slips
//! and corrupt files, not unusual structures), and the structure in its
//! size limits ([`MAX_NODES`], [`MAX_ELEMENTS`]); the error names the entry
//! by kind, index and id, and the field.

use std::path::Path;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::{write_atomically, FileError};
use crate::model::{ContinuousCable, Member, MemberKind, Node, Structure};
use crate::numerics::NumberRange;

/// The format tag this version writes and reads.
pub const STRUCTURE_FORMAT: &str = "tensegrity-deploy/structure/1";

/// Range of a node coordinate, m: ±10 km. Far beyond it the member
/// lengths lose every significant digit of their stretch.
pub const COORDINATE_RANGE_M: NumberRange = NumberRange::closed(-1e4, 1e4);
/// Range of a node's lumped mass, kg.
pub const MASS_RANGE_KG: NumberRange = NumberRange::non_negative_up_to(1e6);
/// Range of each component of a node load, N.
pub const LOAD_RANGE_N: NumberRange = NumberRange::closed(-1e9, 1e9);
/// Range of each component of gravity, m/s².
pub const GRAVITY_RANGE_M_PER_S2: NumberRange = NumberRange::closed(-100.0, 100.0);
/// Range of a member's or segment's rest length, m: from 1 mm (the
/// shortest a motor may reel a first segment to) to 10 km.
pub const REST_LENGTH_RANGE_M: NumberRange = NumberRange::closed(1e-3, 1e4);
/// Range of an axial stiffness EA, N: 1 N (a rubber thread) to 1e12 N.
pub const EA_RANGE_N: NumberRange = NumberRange::closed(1.0, 1e12);
/// Range of a strut's bending stiffness EI, N·m² (its Euler load stays
/// finite and positive).
pub const EI_RANGE_NM2: NumberRange = NumberRange::closed(1e-6, 1e12);
/// Range of a spring's stiffness, N/m.
pub const SPRING_STIFFNESS_RANGE_N_PER_M: NumberRange = NumberRange::closed(1e-6, 1e12);
/// Most nodes of a structure (the reference bridge has 50).
pub const MAX_NODES: usize = 10_000;
/// Most force elements of a structure: members plus continuous-cable
/// segments (the reference bridge has 240).
pub const MAX_ELEMENTS: usize = 100_000;

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StructureDoc {
    format: String,
    name: String,
    gravity_m_per_s2: [f64; 3],
    nodes: Vec<NodeDoc>,
    #[serde(default)]
    struts: Vec<StrutDoc>,
    #[serde(default)]
    cables: Vec<CableDoc>,
    #[serde(default)]
    springs: Vec<SpringDoc>,
    #[serde(default)]
    continuous_cables: Vec<ContinuousDoc>,
    #[serde(default)]
    midspan_pairs: Vec<[String; 2]>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeDoc {
    id: String,
    position_m: [f64; 3],
    mass_kg: f64,
    #[serde(default)]
    fixed: [bool; 3],
    #[serde(default)]
    load_n: [f64; 3],
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StrutDoc {
    id: String,
    nodes: [String; 2],
    ea_n: f64,
    ei_nm2: f64,
    rest_length_m: f64,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CableDoc {
    id: String,
    nodes: [String; 2],
    ea_n: f64,
    rest_length_m: f64,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpringDoc {
    id: String,
    nodes: [String; 2],
    stiffness_n_per_m: f64,
    rest_length_m: f64,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ContinuousDoc {
    id: String,
    path: Vec<String>,
    ea_n: f64,
    segment_rest_lengths_m: Vec<f64>,
}

/// Reads and validates a structure file.
pub fn read_structure(path: &Path) -> Result<Structure, FileError> {
    let text = super::read_text(path)?;
    parse_structure(&text, path)
}

/// Parses and validates structure JSON; `path` names the source in errors.
pub fn parse_structure(text: &str, path: &Path) -> Result<Structure, FileError> {
    let doc: StructureDoc = serde_json::from_str(text).map_err(|e| FileError::Syntax {
        path: path.to_path_buf(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    let invalid = |entry: String, message: String| FileError::Invalid {
        path: path.to_path_buf(),
        entry,
        message,
    };
    if doc.format != STRUCTURE_FORMAT {
        return Err(invalid(
            "format".into(),
            format!("expected \"{STRUCTURE_FORMAT}\", found \"{}\"", doc.format),
        ));
    }
    check_ranges(&doc).map_err(|(entry, message)| invalid(entry, message))?;
    let mut index = std::collections::HashMap::new();
    for (i, n) in doc.nodes.iter().enumerate() {
        index.insert(n.id.as_str(), i);
    }
    let lookup = |entry: &str, id: &str| {
        index
            .get(id)
            .copied()
            .ok_or_else(|| invalid(entry.to_string(), format!("unknown node id \"{id}\"")))
    };
    let pair = |entry: String, ids: &[String; 2]| -> Result<[usize; 2], FileError> {
        Ok([lookup(&entry, &ids[0])?, lookup(&entry, &ids[1])?])
    };

    let nodes = doc
        .nodes
        .iter()
        .map(|n| Node {
            id: n.id.clone(),
            position_m: Vector3::from(n.position_m),
            mass_kg: n.mass_kg,
            fixed: n.fixed,
            load_n: Vector3::from(n.load_n),
        })
        .collect();
    let mut members = Vec::new();
    for (i, m) in doc.struts.iter().enumerate() {
        members.push(Member {
            id: m.id.clone(),
            kind: MemberKind::Strut {
                ea_n: m.ea_n,
                ei_nm2: m.ei_nm2,
            },
            nodes: pair(format!("struts[{i}] (\"{}\")", m.id), &m.nodes)?,
            rest_length_m: m.rest_length_m,
        });
    }
    for (i, m) in doc.cables.iter().enumerate() {
        members.push(Member {
            id: m.id.clone(),
            kind: MemberKind::Cable { ea_n: m.ea_n },
            nodes: pair(format!("cables[{i}] (\"{}\")", m.id), &m.nodes)?,
            rest_length_m: m.rest_length_m,
        });
    }
    for (i, m) in doc.springs.iter().enumerate() {
        members.push(Member {
            id: m.id.clone(),
            kind: MemberKind::Spring {
                stiffness_n_per_m: m.stiffness_n_per_m,
            },
            nodes: pair(format!("springs[{i}] (\"{}\")", m.id), &m.nodes)?,
            rest_length_m: m.rest_length_m,
        });
    }
    let mut cables = Vec::new();
    for (i, c) in doc.continuous_cables.iter().enumerate() {
        let entry = format!("continuous_cables[{i}] (\"{}\")", c.id);
        let path_nodes = c
            .path
            .iter()
            .map(|id| lookup(&entry, id))
            .collect::<Result<Vec<_>, _>>()?;
        cables.push(ContinuousCable {
            id: c.id.clone(),
            path: path_nodes,
            ea_n: c.ea_n,
            segment_rest_lengths_m: c.segment_rest_lengths_m.clone(),
        });
    }
    let midspan_pairs = doc
        .midspan_pairs
        .iter()
        .enumerate()
        .map(|(k, p)| pair(format!("midspan_pairs[{k}]"), p))
        .collect::<Result<Vec<_>, _>>()?;
    Structure::new(
        doc.name,
        nodes,
        members,
        cables,
        Vector3::from(doc.gravity_m_per_s2),
        midspan_pairs,
    )
    .map_err(|e| FileError::Structure {
        path: path.to_path_buf(),
        cause: e,
    })
}

/// Checks the size limits and every number's range; the error is the entry
/// (`nodes[3] ("b")`) and the message naming the field.
fn check_ranges(doc: &StructureDoc) -> Result<(), (String, String)> {
    if doc.nodes.len() > MAX_NODES {
        return Err((
            "nodes".into(),
            format!(
                "{} nodes, over the limit of {MAX_NODES} per structure",
                doc.nodes.len()
            ),
        ));
    }
    let elements = doc.struts.len()
        + doc.cables.len()
        + doc.springs.len()
        + doc
            .continuous_cables
            .iter()
            .map(|c| c.segment_rest_lengths_m.len())
            .sum::<usize>();
    if elements > MAX_ELEMENTS {
        return Err((
            "members".into(),
            format!(
                "{elements} members and segments, over the limit of {MAX_ELEMENTS} per structure"
            ),
        ));
    }
    let check = |entry: &dyn Fn() -> String, field: &str, v: f64, range: NumberRange| {
        range
            .check(v)
            .map_err(|m| (entry(), format!("field `{field}` {m}")))
    };
    for (axis, g) in doc.gravity_m_per_s2.iter().enumerate() {
        check(
            &|| "gravity_m_per_s2".into(),
            &format!("gravity_m_per_s2[{axis}]"),
            *g,
            GRAVITY_RANGE_M_PER_S2,
        )?;
    }
    for (i, n) in doc.nodes.iter().enumerate() {
        let entry = || format!("nodes[{i}] (\"{}\")", n.id);
        for axis in 0..3 {
            check(
                &entry,
                &format!("position_m[{axis}]"),
                n.position_m[axis],
                COORDINATE_RANGE_M,
            )?;
            check(
                &entry,
                &format!("load_n[{axis}]"),
                n.load_n[axis],
                LOAD_RANGE_N,
            )?;
        }
        check(&entry, "mass_kg", n.mass_kg, MASS_RANGE_KG)?;
    }
    for (i, m) in doc.struts.iter().enumerate() {
        let entry = || format!("struts[{i}] (\"{}\")", m.id);
        check(&entry, "ea_n", m.ea_n, EA_RANGE_N)?;
        check(&entry, "ei_nm2", m.ei_nm2, EI_RANGE_NM2)?;
        check(
            &entry,
            "rest_length_m",
            m.rest_length_m,
            REST_LENGTH_RANGE_M,
        )?;
    }
    for (i, m) in doc.cables.iter().enumerate() {
        let entry = || format!("cables[{i}] (\"{}\")", m.id);
        check(&entry, "ea_n", m.ea_n, EA_RANGE_N)?;
        check(
            &entry,
            "rest_length_m",
            m.rest_length_m,
            REST_LENGTH_RANGE_M,
        )?;
    }
    for (i, m) in doc.springs.iter().enumerate() {
        let entry = || format!("springs[{i}] (\"{}\")", m.id);
        check(
            &entry,
            "stiffness_n_per_m",
            m.stiffness_n_per_m,
            SPRING_STIFFNESS_RANGE_N_PER_M,
        )?;
        check(
            &entry,
            "rest_length_m",
            m.rest_length_m,
            REST_LENGTH_RANGE_M,
        )?;
    }
    for (i, c) in doc.continuous_cables.iter().enumerate() {
        let entry = || format!("continuous_cables[{i}] (\"{}\")", c.id);
        check(&entry, "ea_n", c.ea_n, EA_RANGE_N)?;
        for (k, l) in c.segment_rest_lengths_m.iter().enumerate() {
            check(
                &entry,
                &format!("segment_rest_lengths_m[{k}]"),
                *l,
                REST_LENGTH_RANGE_M,
            )?;
        }
    }
    Ok(())
}

/// Serialises a structure to the file format (members grouped by kind).
pub fn structure_to_json(s: &Structure) -> String {
    let ids = |ab: [usize; 2]| [s.nodes[ab[0]].id.clone(), s.nodes[ab[1]].id.clone()];
    let mut doc = StructureDoc {
        format: STRUCTURE_FORMAT.into(),
        name: s.name.clone(),
        gravity_m_per_s2: s.gravity_m_per_s2.into(),
        nodes: s
            .nodes
            .iter()
            .map(|n| NodeDoc {
                id: n.id.clone(),
                position_m: n.position_m.into(),
                mass_kg: n.mass_kg,
                fixed: n.fixed,
                load_n: n.load_n.into(),
            })
            .collect(),
        struts: vec![],
        cables: vec![],
        springs: vec![],
        continuous_cables: s
            .continuous_cables
            .iter()
            .map(|c| ContinuousDoc {
                id: c.id.clone(),
                path: c.path.iter().map(|&i| s.nodes[i].id.clone()).collect(),
                ea_n: c.ea_n,
                segment_rest_lengths_m: c.segment_rest_lengths_m.clone(),
            })
            .collect(),
        midspan_pairs: s.midspan_pairs.iter().map(|p| ids(*p)).collect(),
    };
    for m in &s.members {
        match m.kind {
            MemberKind::Strut { ea_n, ei_nm2 } => doc.struts.push(StrutDoc {
                id: m.id.clone(),
                nodes: ids(m.nodes),
                ea_n,
                ei_nm2,
                rest_length_m: m.rest_length_m,
            }),
            MemberKind::Cable { ea_n } => doc.cables.push(CableDoc {
                id: m.id.clone(),
                nodes: ids(m.nodes),
                ea_n,
                rest_length_m: m.rest_length_m,
            }),
            MemberKind::Spring { stiffness_n_per_m } => doc.springs.push(SpringDoc {
                id: m.id.clone(),
                nodes: ids(m.nodes),
                stiffness_n_per_m,
                rest_length_m: m.rest_length_m,
            }),
        }
    }
    serde_json::to_string_pretty(&doc).expect("a structure always serialises")
}

/// Writes a structure file atomically.
pub fn write_structure(path: &Path, s: &Structure) -> Result<(), FileError> {
    write_atomically(path, structure_to_json(s).as_bytes())
}

/// Writes `s` as [`write_structure`] does, but only where no file is,
/// where the file already holds exactly these bytes, or with `force`
/// ([`super::output::check_new_file`]: `tdeploy structure -o`).
pub fn write_new_structure(path: &Path, s: &Structure, force: bool) -> Result<(), FileError> {
    let json = structure_to_json(s);
    super::output::check_new_file(path, json.as_bytes(), force)?;
    write_atomically(path, json.as_bytes())
}
