//! The structure: nodes, two-node members and continuous cables.
//!
//! A [`Structure`] is immutable topology plus material data. Everything that
//! changes during a deployment (node positions, the rest length of material
//! in each continuous-cable segment) lives in [`crate::model::DeploymentState`].
//! Construction goes through [`Structure::new`], which validates everything a
//! solver relies on, so that the solver itself never has to.

use nalgebra::Vector3;
use thiserror::Error;

/// Index of a node in [`Structure::nodes`].
pub type NodeIndex = usize;

/// A pin-jointed node.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Unique name, used in files and reports.
    pub id: String,
    /// Position in the reference (as-built) state, m.
    pub position_m: Vector3<f64>,
    /// Lumped mass: joint mass plus half of each attached member, kg.
    /// Gravity acts on it; the solver's fictitious masses are separate.
    pub mass_kg: f64,
    /// `true` where the degree of freedom (x, y, z) is held by a support.
    pub fixed: [bool; 3],
    /// Applied load other than self-weight, N.
    pub load_n: Vector3<f64>,
}

impl Node {
    /// `true` if at least one degree of freedom is free.
    pub fn is_free(&self) -> bool {
        self.fixed.iter().any(|f| !f)
    }
}

/// What a two-node member is, with the properties only that kind has.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MemberKind {
    /// Carries tension and compression; `ei_nm2` gives its Euler buckling load.
    Strut {
        /// Axial stiffness E·A, N.
        ea_n: f64,
        /// Bending stiffness E·I, N·m², for the Euler load π²EI/L².
        ei_nm2: f64,
    },
    /// Tension only; slack (zero force) when shorter than its rest length.
    Cable {
        /// Axial stiffness E·A, N.
        ea_n: f64,
    },
    /// Linear tension-only spring.
    Spring {
        /// Stiffness k, N/m.
        stiffness_n_per_m: f64,
    },
}

impl MemberKind {
    /// This kind with its axial stiffness (E·A, or k for a spring) scaled
    /// by the factor for its kind (1); a strut's bending stiffness, which
    /// no stiffness error of the library describes, is kept.
    pub fn with_stiffness_scaled(self, strut: f64, cable: f64, spring: f64) -> MemberKind {
        match self {
            MemberKind::Strut { ea_n, ei_nm2 } => MemberKind::Strut {
                ea_n: ea_n * strut,
                ei_nm2,
            },
            MemberKind::Cable { ea_n } => MemberKind::Cable { ea_n: ea_n * cable },
            MemberKind::Spring { stiffness_n_per_m } => MemberKind::Spring {
                stiffness_n_per_m: stiffness_n_per_m * spring,
            },
        }
    }

    /// Short lowercase name used in files and reports.
    pub fn name(&self) -> &'static str {
        match self {
            MemberKind::Strut { .. } => "strut",
            MemberKind::Cable { .. } => "cable",
            MemberKind::Spring { .. } => "spring",
        }
    }

    /// Axial stiffness k = EA/L0 (struts, cables) or k (springs), N/m.
    pub fn axial_stiffness(&self, rest_length_m: f64) -> f64 {
        match *self {
            MemberKind::Strut { ea_n, .. } | MemberKind::Cable { ea_n } => ea_n / rest_length_m,
            MemberKind::Spring { stiffness_n_per_m } => stiffness_n_per_m,
        }
    }

    /// `true` for members that go slack instead of carrying compression.
    pub fn is_tension_only(&self) -> bool {
        !matches!(self, MemberKind::Strut { .. })
    }
}

/// A member between two nodes with a fixed rest length.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Unique name.
    pub id: String,
    /// Kind and stiffness.
    pub kind: MemberKind,
    /// End nodes.
    pub nodes: [NodeIndex; 2],
    /// Stress-free length, m.
    pub rest_length_m: f64,
}

/// A cable reeled by a motor at `path[0]` (a support node), running over the
/// joints `path[1..n-1]` to its end node `path[n-1]`.
///
/// Segment `i` runs from `path[i]` to `path[i+1]`. The motor changes the rest
/// length of segment 0; material moves between neighbouring segments by
/// sliding over the joint between them (see [`crate::model::friction`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuousCable {
    /// Unique name.
    pub id: String,
    /// Ordered node path, motor first, at least two nodes.
    pub path: Vec<NodeIndex>,
    /// Axial stiffness E·A of the cable, N.
    pub ea_n: f64,
    /// Rest length of material in each segment in the reference state, m.
    pub segment_rest_lengths_m: Vec<f64>,
}

impl ContinuousCable {
    /// Number of segments (path length minus one).
    pub fn segment_count(&self) -> usize {
        self.path.len() - 1
    }
}

/// A complete structure.
#[derive(Debug, Clone, PartialEq)]
pub struct Structure {
    /// Free-form name.
    pub name: String,
    /// Nodes.
    pub nodes: Vec<Node>,
    /// Struts, cables and springs.
    pub members: Vec<Member>,
    /// Motor-driven cables sliding over joints.
    pub continuous_cables: Vec<ContinuousCable>,
    /// Gravitational acceleration, m/s² (e.g. (0, 0, −9.81)).
    pub gravity_m_per_s2: Vector3<f64>,
    /// Pairs of nodes that must meet at midspan (may be empty).
    pub midspan_pairs: Vec<[NodeIndex; 2]>,
}

/// Longest id a node, member or cable may have, characters: every name
/// a report or table builds from ids (a force row `segment A_cc1[3]
/// min`, a clearance between two struts) then stays within the names
/// `runs.csv` reads back.
pub const MAX_ID_CHARS: usize = 32;

/// Checks that `id` can name its entry in every report and table: 1 to
/// [`MAX_ID_CHARS`] printable characters on one line, no `;` (the
/// separator of `runs.csv`'s `binds`), no space at either end.
fn check_id(entry: &str, id: &str) -> Result<(), StructureError> {
    let bad = |reason: &str| {
        Err(StructureError::BadId {
            entry: entry.to_string(),
            id: id.to_string(),
            reason: reason.to_string(),
        })
    };
    let chars = id.chars().count();
    if chars == 0 || chars > MAX_ID_CHARS {
        return bad(&format!("must have 1 to {MAX_ID_CHARS} characters"));
    }
    if id.chars().any(|c| c.is_control() || c == ';') {
        return bad("must be printable text on one line without `;`");
    }
    if id.trim() != id {
        return bad("must not start or end with a space");
    }
    Ok(())
}

/// A structure that a solver cannot be trusted with, naming the entry.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StructureError {
    /// Two entries share an id.
    #[error("{entry}: duplicate id \"{id}\"")]
    DuplicateId {
        /// Where, e.g. `members[3]`.
        entry: String,
        /// The repeated id.
        id: String,
    },
    /// An id that cannot name its entry in reports and tables.
    #[error("{entry}: id \"{id}\" {reason}")]
    BadId {
        /// Where, e.g. `members[3]`.
        entry: String,
        /// The id given.
        id: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A value is NaN or infinite.
    #[error("{entry}: field `{field}` is not a finite number")]
    NotFinite {
        /// Where.
        entry: String,
        /// Which field.
        field: String,
    },
    /// A stiffness, mass or length that must be positive is not.
    #[error("{entry}: field `{field}` must be positive, got {value}")]
    NotPositive {
        /// Where.
        entry: String,
        /// Which field.
        field: String,
        /// The offending value.
        value: f64,
    },
    /// A node index points past the node list.
    #[error("{entry}: node index {index} does not exist")]
    UnknownNode {
        /// Where.
        entry: String,
        /// The index.
        index: usize,
    },
    /// Both ends of a member or segment coincide.
    #[error("{entry}: zero-length member between nodes \"{a}\" and \"{b}\"")]
    ZeroLength {
        /// Where.
        entry: String,
        /// First node id.
        a: String,
        /// Second node id.
        b: String,
    },
    /// A continuous cable visits a node twice.
    #[error("{entry}: path repeats node \"{node}\"")]
    RepeatedPathNode {
        /// Where.
        entry: String,
        /// The repeated node id.
        node: String,
    },
    /// A continuous cable is malformed in another way.
    #[error("{entry}: {reason}")]
    BadContinuousCable {
        /// Where.
        entry: String,
        /// What is wrong.
        reason: String,
    },
    /// A local fault ([`super::faults`]) names a part the structure does
    /// not have.
    #[error("fault `{fault}`: {reason}")]
    BadFault {
        /// The fault's name.
        fault: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A free node with no member attached would fall forever.
    #[error("nodes[{index}] (\"{id}\"): free node is not reached by any member")]
    UnconnectedFreeNode {
        /// Index of the node.
        index: usize,
        /// Its id.
        id: String,
    },
}

/// Geometric length below which a member counts as zero-length, m.
const MIN_MEMBER_LENGTH_M: f64 = 1e-9;

impl Structure {
    /// Validates and builds a structure.
    ///
    /// Rejects duplicate ids, non-finite numbers, non-positive stiffness,
    /// mass or rest length, unknown node indices, zero-length members and
    /// segments, continuous cables that repeat a node, whose motor node is
    /// not fully supported or whose rest-length list does not match the path,
    /// and free nodes that no member reaches.
    pub fn new(
        name: impl Into<String>,
        nodes: Vec<Node>,
        members: Vec<Member>,
        continuous_cables: Vec<ContinuousCable>,
        gravity_m_per_s2: Vector3<f64>,
        midspan_pairs: Vec<[NodeIndex; 2]>,
    ) -> Result<Self, StructureError> {
        let s = Structure {
            name: name.into(),
            nodes,
            members,
            continuous_cables,
            gravity_m_per_s2,
            midspan_pairs,
        };
        s.validate()?;
        Ok(s)
    }

    fn validate(&self) -> Result<(), StructureError> {
        let finite = |entry: &str, field: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(StructureError::NotFinite {
                    entry: entry.to_string(),
                    field: field.to_string(),
                })
            }
        };
        let positive = |entry: &str, field: &str, v: f64| {
            finite(entry, field, v)?;
            if v > 0.0 {
                Ok(())
            } else {
                Err(StructureError::NotPositive {
                    entry: entry.to_string(),
                    field: field.to_string(),
                    value: v,
                })
            }
        };
        let node_exists = |entry: &str, index: usize| {
            if index < self.nodes.len() {
                Ok(())
            } else {
                Err(StructureError::UnknownNode {
                    entry: entry.to_string(),
                    index,
                })
            }
        };
        finite("gravity", "x", self.gravity_m_per_s2.x)?;
        finite("gravity", "y", self.gravity_m_per_s2.y)?;
        finite("gravity", "z", self.gravity_m_per_s2.z)?;

        let mut ids = std::collections::HashSet::new();
        for (i, n) in self.nodes.iter().enumerate() {
            let entry = format!("nodes[{i}] (\"{}\")", n.id);
            check_id(&entry, &n.id)?;
            if !ids.insert(n.id.as_str()) {
                return Err(StructureError::DuplicateId {
                    entry,
                    id: n.id.clone(),
                });
            }
            for (axis, v) in ["x", "y", "z"].iter().zip(n.position_m.iter()) {
                finite(&entry, &format!("position_m.{axis}"), *v)?;
            }
            for (axis, v) in ["x", "y", "z"].iter().zip(n.load_n.iter()) {
                finite(&entry, &format!("load_n.{axis}"), *v)?;
            }
            finite(&entry, "mass_kg", n.mass_kg)?;
            if n.mass_kg < 0.0 {
                return Err(StructureError::NotPositive {
                    entry,
                    field: "mass_kg".into(),
                    value: n.mass_kg,
                });
            }
        }

        let mut reached = vec![false; self.nodes.len()];
        let mut member_ids = std::collections::HashSet::new();
        let check_span = |entry: &str, a: usize, b: usize| {
            node_exists(entry, a)?;
            node_exists(entry, b)?;
            let length = (self.nodes[b].position_m - self.nodes[a].position_m).norm();
            if a == b || length < MIN_MEMBER_LENGTH_M {
                return Err(StructureError::ZeroLength {
                    entry: entry.to_string(),
                    a: self.nodes[a].id.clone(),
                    b: self.nodes[b].id.clone(),
                });
            }
            Ok(())
        };
        // Entries are named by their index among members of the same kind,
        // as a structure file lists them.
        let mut per_kind = [0usize; 3];
        for m in &self.members {
            let slot = match m.kind {
                MemberKind::Strut { .. } => 0,
                MemberKind::Cable { .. } => 1,
                MemberKind::Spring { .. } => 2,
            };
            let i = per_kind[slot];
            per_kind[slot] += 1;
            let entry = format!("{}s[{i}] (\"{}\")", m.kind.name(), m.id);
            check_id(&entry, &m.id)?;
            if !member_ids.insert(m.id.as_str()) {
                return Err(StructureError::DuplicateId {
                    entry,
                    id: m.id.clone(),
                });
            }
            check_span(&entry, m.nodes[0], m.nodes[1])?;
            positive(&entry, "rest_length_m", m.rest_length_m)?;
            match m.kind {
                MemberKind::Strut { ea_n, ei_nm2 } => {
                    positive(&entry, "ea_n", ea_n)?;
                    positive(&entry, "ei_nm2", ei_nm2)?;
                }
                MemberKind::Cable { ea_n } => positive(&entry, "ea_n", ea_n)?,
                MemberKind::Spring { stiffness_n_per_m } => {
                    positive(&entry, "stiffness_n_per_m", stiffness_n_per_m)?
                }
            }
            reached[m.nodes[0]] = true;
            reached[m.nodes[1]] = true;
        }

        for (i, c) in self.continuous_cables.iter().enumerate() {
            let entry = format!("continuous_cables[{i}] (\"{}\")", c.id);
            check_id(&entry, &c.id)?;
            if !member_ids.insert(c.id.as_str()) {
                return Err(StructureError::DuplicateId {
                    entry,
                    id: c.id.clone(),
                });
            }
            if c.path.len() < 2 {
                return Err(StructureError::BadContinuousCable {
                    entry,
                    reason: "path needs at least two nodes".into(),
                });
            }
            positive(&entry, "ea_n", c.ea_n)?;
            let mut seen = std::collections::HashSet::new();
            for &n in &c.path {
                node_exists(&entry, n)?;
                if !seen.insert(n) {
                    return Err(StructureError::RepeatedPathNode {
                        entry,
                        node: self.nodes[n].id.clone(),
                    });
                }
            }
            if c.segment_rest_lengths_m.len() != c.segment_count() {
                return Err(StructureError::BadContinuousCable {
                    entry,
                    reason: format!(
                        "{} segment rest lengths given for a path of {} segments",
                        c.segment_rest_lengths_m.len(),
                        c.segment_count()
                    ),
                });
            }
            for (k, w) in c.path.windows(2).enumerate() {
                check_span(&format!("{entry} segment {k}"), w[0], w[1])?;
                positive(
                    &entry,
                    &format!("segment_rest_lengths_m[{k}]"),
                    c.segment_rest_lengths_m[k],
                )?;
                reached[w[0]] = true;
                reached[w[1]] = true;
            }
            if self.nodes[c.path[0]].is_free() {
                return Err(StructureError::BadContinuousCable {
                    entry,
                    reason: format!(
                        "motor node \"{}\" must be fully supported",
                        self.nodes[c.path[0]].id
                    ),
                });
            }
        }

        for (k, pair) in self.midspan_pairs.iter().enumerate() {
            let entry = format!("midspan_pairs[{k}]");
            node_exists(&entry, pair[0])?;
            node_exists(&entry, pair[1])?;
        }

        if let Some((index, n)) = self
            .nodes
            .iter()
            .enumerate()
            .find(|(i, n)| n.is_free() && !reached[*i])
        {
            return Err(StructureError::UnconnectedFreeNode {
                index,
                id: n.id.clone(),
            });
        }
        Ok(())
    }

    /// Index of the node with this id.
    pub fn node_index(&self, id: &str) -> Option<NodeIndex> {
        self.nodes.iter().position(|n| n.id == id)
    }

    /// Total number of continuous-cable segments.
    pub fn segment_count(&self) -> usize {
        self.continuous_cables
            .iter()
            .map(|c| c.segment_count())
            .sum()
    }

    /// Reference positions of all nodes, m.
    pub fn reference_positions(&self) -> Vec<Vector3<f64>> {
        self.nodes.iter().map(|n| n.position_m).collect()
    }

    /// Total weight vector Σ m·g over all nodes, N.
    pub fn total_weight_n(&self) -> Vector3<f64> {
        self.nodes
            .iter()
            .map(|n| n.mass_kg * self.gravity_m_per_s2)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(id: &str, p: [f64; 3], fixed: bool) -> Node {
        Node {
            id: id.into(),
            position_m: Vector3::from(p),
            mass_kg: 1.0,
            fixed: [fixed; 3],
            load_n: Vector3::zeros(),
        }
    }

    fn cable(id: &str, a: usize, b: usize) -> Member {
        Member {
            id: id.into(),
            kind: MemberKind::Cable { ea_n: 1e5 },
            nodes: [a, b],
            rest_length_m: 1.0,
        }
    }

    fn build(members: Vec<Member>, cc: Vec<ContinuousCable>) -> Result<Structure, StructureError> {
        Structure::new(
            "t",
            vec![
                node("a", [0.0, 0.0, 0.0], true),
                node("b", [1.0, 0.0, 0.0], false),
                node("c", [2.0, 0.0, 0.0], true),
            ],
            members,
            cc,
            Vector3::new(0.0, 0.0, -9.81),
            vec![],
        )
    }

    #[test]
    fn accepts_a_valid_structure() {
        assert!(build(vec![cable("m0", 0, 1), cable("m1", 1, 2)], vec![]).is_ok());
    }

    #[test]
    fn rejects_unknown_node_naming_the_member() {
        let e = build(vec![cable("m0", 0, 7)], vec![]).unwrap_err();
        assert_eq!(
            e,
            StructureError::UnknownNode {
                entry: "cables[0] (\"m0\")".into(),
                index: 7
            }
        );
    }

    /// Ids name rows in reports and in `runs.csv`'s `binds`: one printable
    /// line of 1 to 32 characters, no `;`, no edge spaces (a review found
    /// a 77-character cable id written by `evaluate` and refused by
    /// `merge`, and an id with `; ` split in two).
    #[test]
    fn rejects_an_id_that_cannot_name_its_row() {
        let long = "c".repeat(MAX_ID_CHARS + 1);
        for bad in ["", " m0", "m0 ", "A_cc1; east", "m\n0", long.as_str()] {
            let e = build(vec![cable(bad, 0, 1)], vec![]).unwrap_err();
            assert!(matches!(e, StructureError::BadId { .. }), "{bad:?}: {e}");
        }
        let longest = "c".repeat(MAX_ID_CHARS);
        assert!(build(vec![cable(&longest, 0, 1), cable("m1", 1, 2)], vec![]).is_ok());
    }

    #[test]
    fn rejects_zero_length_member() {
        let e = build(vec![cable("m0", 1, 1)], vec![]).unwrap_err();
        assert!(matches!(e, StructureError::ZeroLength { .. }), "{e}");
    }

    #[test]
    fn rejects_non_positive_stiffness() {
        let mut m = cable("m0", 0, 1);
        m.kind = MemberKind::Cable { ea_n: -1.0 };
        let e = build(vec![m, cable("m1", 1, 2)], vec![]).unwrap_err();
        assert!(e.to_string().contains("ea_n"), "{e}");
    }

    #[test]
    fn rejects_nan_rest_length() {
        let mut m = cable("m0", 0, 1);
        m.rest_length_m = f64::NAN;
        let e = build(vec![m], vec![]).unwrap_err();
        assert!(matches!(e, StructureError::NotFinite { .. }), "{e}");
    }

    #[test]
    fn rejects_unreached_free_node() {
        let e = build(vec![cable("m0", 0, 2)], vec![]).unwrap_err();
        assert!(
            matches!(e, StructureError::UnconnectedFreeNode { index: 1, .. }),
            "{e}"
        );
    }

    #[test]
    fn rejects_continuous_cable_repeating_a_node() {
        let cc = ContinuousCable {
            id: "cc".into(),
            path: vec![0, 1, 0],
            ea_n: 1e5,
            segment_rest_lengths_m: vec![1.0, 1.0],
        };
        let e = build(vec![], vec![cc]).unwrap_err();
        assert!(matches!(e, StructureError::RepeatedPathNode { .. }), "{e}");
    }

    #[test]
    fn rejects_motor_on_free_node() {
        let cc = ContinuousCable {
            id: "cc".into(),
            path: vec![1, 0],
            ea_n: 1e5,
            segment_rest_lengths_m: vec![1.0],
        };
        let e = build(vec![cable("m1", 1, 2)], vec![cc]).unwrap_err();
        assert!(e.to_string().contains("motor node"), "{e}");
    }
}
