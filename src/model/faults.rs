//! Local faults: defects of one part of the bridge — one motor's drum, one
//! member, one half — where the effects of [`super::effects`] act on every
//! joint, motor or member alike.
//!
//! Each fault names its part by index (resolved from the ids a model file
//! or a scenario gives) and has parameters with units, a neutral value, a
//! plausible range and an admissible range ([`FaultKind::parameters`]),
//! like the effects. Faults act on the structure
//! ([`Faults::apply`], called by
//! [`super::Effects::apply_to_structure`] after the stiffness and mass
//! errors and before the supports are made flexible), so every plant,
//! replay and forward model built from [`super::Effects`] carries them.
//!
//! They are **not** in [`super::EffectKind::ALL`]: the diagnosis screens
//! every kind in that list against every log, and a fault has a discrete
//! part (which motor, which member) besides its parameters, which the
//! diagnosis's fits of continuous parameters cannot search. Keeping them
//! out leaves every diagnosis, its ranking and its cost as they were; a
//! fault is hidden in a truth (a model file's `[faults.*]` tables or a
//! scenario distribution's) and shows in a diagnosis as the effects it
//! resembles.
//!
//! # The faults
//! - **Drum zero error** ([`DrumZeroError`]): the drum of one motor was
//!   zeroed `offset_m` off, so its continuous cable holds `offset_m` more
//!   material than the drum's payout says, from the start and for good
//!   (a positive offset slackens the cable; a negative one tightens it).
//!   The material is added to the cable's first segment, the one the drum
//!   reels, in the as-built state; friction then decides how it spreads.
//! - **Member error** ([`MemberError`]): one strut, cable or spring has a
//!   rest length `rest_length_error_m` longer than designed (cut or swaged
//!   long; negative: short) and/or its axial stiffness (EA, or k of a
//!   spring) scaled by `stiffness_scale` (a creeping swage, a rope from
//!   another reel, a loose end fitting). In a self-stressed bridge a
//!   strut that is too long pushes harder on everything around it and a
//!   cable that is too long goes slacker.
//! - **Half difference** ([`HalfDifference`]): one half of the bridge was
//!   built from another batch of material than the other: its struts'
//!   EA (another delivery of tubes: wall thickness within the tube
//!   standard's tolerance), its cables' EA (another reel of braided rope,
//!   whose effective modulus varies most), its springs' k and its joint
//!   masses (castings of another pour) each scaled, on top of any
//!   bridge-wide stiffness or mass error. Joint friction could differ
//!   too (another batch of seat liners), but the friction law of the
//!   library is one μ for every joint ([`super::JointFriction`]); a
//!   half-specific μ would need a friction law per joint and is not
//!   modelled.
//!
//! # Halves
//! A half is a connected part of the structure (nodes joined by members
//! and continuous cables): half **A** holds the first node of every
//! midspan pair, half **B** the second ([`node_halves`]). On the reference
//! bridge these are the nodes, members and cables whose ids start with
//! `A` and `B`.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::parameter_spec::ParameterSpec;
use super::structure::{Structure, StructureError};

/// One half of a bridge (see the module notes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Half {
    /// The half holding the first node of every midspan pair.
    A,
    /// The half holding the second node of every midspan pair.
    B,
}

impl Half {
    /// Both halves, A first.
    pub const BOTH: [Half; 2] = [Half::A, Half::B];

    /// `"A"` or `"B"`, as files name it.
    pub fn name(self) -> &'static str {
        match self {
            Half::A => "A",
            Half::B => "B",
        }
    }

    /// The half named `name` (`"A"` or `"B"`).
    pub fn parse(name: &str) -> Option<Half> {
        Half::BOTH.into_iter().find(|h| h.name() == name)
    }

    /// 0 for A, 1 for B: the side of a midspan pair.
    pub fn index(self) -> usize {
        match self {
            Half::A => 0,
            Half::B => 1,
        }
    }
}

/// The half of every node of `structure` (`None`: a node in neither, e.g.
/// a foundation node), as the module notes define halves. Errors, in
/// words, when the structure has no midspan pairs or its pairs do not
/// part it into two halves.
pub fn node_halves(structure: &Structure) -> Result<Vec<Option<Half>>, String> {
    let n = structure.nodes.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut join = |a: usize, b: usize| {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra] = rb;
    };
    for m in &structure.members {
        join(m.nodes[0], m.nodes[1]);
    }
    for c in &structure.continuous_cables {
        for w in c.path.windows(2) {
            join(w[0], w[1]);
        }
    }
    let Some(first) = structure.midspan_pairs.first() else {
        return Err("the structure has no midspan pairs, so no halves".into());
    };
    let roots = [root(&mut parent, first[0]), root(&mut parent, first[1])];
    if roots[0] == roots[1] {
        return Err(
            "the two sides of the midspan pairs are joined: the structure has no two halves".into(),
        );
    }
    for pair in &structure.midspan_pairs {
        for (side, &node) in pair.iter().enumerate() {
            if root(&mut parent, node) != roots[side] {
                return Err(format!(
                    "midspan node \"{}\" is not joined to the other nodes of its side",
                    structure.nodes[node].id
                ));
            }
        }
    }
    Ok((0..n)
        .map(|i| {
            let r = root(&mut parent, i);
            Half::BOTH.into_iter().find(|h| roots[h.index()] == r)
        })
        .collect())
}

/// The local faults of the library, in a fixed order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// One motor's drum zeroed off.
    DrumZeroError,
    /// One member's rest length and/or stiffness off.
    MemberError,
    /// One half's stiffness and joint masses differ from the other's.
    HalfDifference,
}

const DRUM_PARAMETERS: [ParameterSpec; 1] = [ParameterSpec {
    name: "offset_m",
    unit: "m",
    neutral: 0.0,
    // Assumed: a drum is zeroed by winding until a mark on the rope
    // reaches it; a tenth of a turn of a drum of about 50 mm diameter is
    // 16 mm. The lab case behind issue 22 was 15 mm.
    plausible: (-0.015, 0.015),
    admissible: (f64::NEG_INFINITY, f64::INFINITY),
}];
const MEMBER_PARAMETERS: [ParameterSpec; 2] = [
    ParameterSpec {
        name: "rest_length_error_m",
        unit: "m",
        neutral: 0.0,
        // Assumed cutting and swaging tolerance of the 1/4-scale members
        // (the lab case: one strut 5 mm long).
        plausible: (-0.005, 0.005),
        admissible: (f64::NEG_INFINITY, f64::INFINITY),
    },
    ParameterSpec {
        name: "stiffness_scale",
        unit: "1",
        neutral: 1.0,
        // One soft member: a creeping swage or a rope from another reel,
        // down to half the nominal stiffness; up to the bridge-wide
        // stiffness error's 1.2.
        plausible: (0.5, 1.2),
        admissible: (1e-3, f64::INFINITY),
    },
];
const HALF_PARAMETERS: [ParameterSpec; 4] = [
    ParameterSpec {
        name: "strut_scale",
        unit: "1",
        neutral: 1.0,
        // Another delivery of tubes: EA within the wall-thickness
        // tolerance of welded steel tube, about ±10 %.
        plausible: (0.9, 1.1),
        admissible: (1e-3, f64::INFINITY),
    },
    ParameterSpec {
        name: "cable_scale",
        unit: "1",
        neutral: 1.0,
        // Another reel of braided rope: the effective modulus is the most
        // uncertain stiffness of the bridge (the bridge-wide range is
        // 0.6–1.2); reel to reel, ±20 %.
        plausible: (0.8, 1.2),
        admissible: (1e-3, f64::INFINITY),
    },
    ParameterSpec {
        name: "spring_scale",
        unit: "1",
        neutral: 1.0,
        // Another batch of springs: ±10 %.
        plausible: (0.9, 1.1),
        admissible: (1e-3, f64::INFINITY),
    },
    ParameterSpec {
        name: "joint_mass_scale",
        unit: "1",
        neutral: 1.0,
        // Joint castings of another pour: ±10 %.
        plausible: (0.9, 1.1),
        admissible: (1e-3, f64::INFINITY),
    },
];

impl FaultKind {
    /// All faults, in order.
    pub const ALL: [FaultKind; 3] = [
        FaultKind::DrumZeroError,
        FaultKind::MemberError,
        FaultKind::HalfDifference,
    ];

    /// Name, as in model files (`[faults.<name>]`).
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::DrumZeroError => "drum_zero_error",
            FaultKind::MemberError => "member_error",
            FaultKind::HalfDifference => "half_difference",
        }
    }

    /// The key that names the fault's part in files: `motor` (a
    /// continuous cable's id), `member` (a member's id) or `half` (`A`
    /// or `B`).
    pub fn part_key(self) -> &'static str {
        match self {
            FaultKind::DrumZeroError => "motor",
            FaultKind::MemberError => "member",
            FaultKind::HalfDifference => "half",
        }
    }

    /// The fault's parameters.
    pub fn parameters(self) -> &'static [ParameterSpec] {
        match self {
            FaultKind::DrumZeroError => &DRUM_PARAMETERS,
            FaultKind::MemberError => &MEMBER_PARAMETERS,
            FaultKind::HalfDifference => &HALF_PARAMETERS,
        }
    }

    /// How many parts of `structure` the fault can hit: its continuous
    /// cables, its members, or 2 halves.
    pub fn part_count(self, structure: &Structure) -> usize {
        match self {
            FaultKind::DrumZeroError => structure.continuous_cables.len(),
            FaultKind::MemberError => structure.members.len(),
            FaultKind::HalfDifference => Half::BOTH.len(),
        }
    }

    /// The id of part `part` of `structure` (see [`Self::part_key`]).
    ///
    /// # Panics
    /// If `part` is not below [`Self::part_count`]: a programming error.
    pub fn part_id(self, structure: &Structure, part: usize) -> String {
        match self {
            FaultKind::DrumZeroError => structure.continuous_cables[part].id.clone(),
            FaultKind::MemberError => structure.members[part].id.clone(),
            FaultKind::HalfDifference => Half::BOTH[part].name().to_string(),
        }
    }

    /// The index of the part with id `id` in `structure`; `None` if it has
    /// none.
    pub fn find_part(self, structure: &Structure, id: &str) -> Option<usize> {
        match self {
            FaultKind::DrumZeroError => structure.continuous_cables.iter().position(|c| c.id == id),
            FaultKind::MemberError => structure.members.iter().position(|m| m.id == id),
            FaultKind::HalfDifference => Half::parse(id).map(Half::index),
        }
    }
}

/// The drum of motor `cable` was zeroed `offset_m` off: its continuous
/// cable holds `offset_m` more material than commanded, from the start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrumZeroError {
    /// Index of the continuous cable (the motor).
    pub cable: usize,
    /// Material beyond what the drum's payout says, m (negative: less).
    pub offset_m: f64,
}

/// Member `member` is `rest_length_error_m` longer than designed and
/// `stiffness_scale` times as stiff.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemberError {
    /// Index of the member in [`Structure::members`].
    pub member: usize,
    /// Rest length beyond the designed one, m (negative: short).
    pub rest_length_error_m: f64,
    /// Scale on the member's EA (strut, cable) or k (spring).
    pub stiffness_scale: f64,
}

/// Half `half` was built from another batch: its members' stiffness (by
/// kind), its continuous cables' EA and its nodes' masses scaled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfDifference {
    /// The half that differs.
    pub half: Half,
    /// Scale on the EA of its struts.
    pub strut_scale: f64,
    /// Scale on the EA of its cables, discontinuous and continuous.
    pub cable_scale: f64,
    /// Scale on the k of its springs.
    pub spring_scale: f64,
    /// Scale on its nodes' lumped masses.
    pub joint_mass_scale: f64,
}

/// The local faults present; `None` is absent. The default has none.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Faults {
    /// One motor's drum zero error.
    pub drum_zero_error: Option<DrumZeroError>,
    /// One member's rest-length and stiffness error.
    pub member_error: Option<MemberError>,
    /// One half differing from the other.
    pub half_difference: Option<HalfDifference>,
}

/// A fault parameter that makes no sense.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("fault `{fault}`, parameter `{parameter}`: {reason}")]
pub struct FaultError {
    /// The fault.
    pub fault: &'static str,
    /// The parameter.
    pub parameter: &'static str,
    /// What is wrong.
    pub reason: String,
}

impl Faults {
    /// `true` when no fault is present.
    pub fn is_empty(&self) -> bool {
        self.present().is_empty()
    }

    /// The faults present, in [`FaultKind::ALL`] order.
    pub fn present(&self) -> Vec<FaultKind> {
        FaultKind::ALL
            .into_iter()
            .filter(|k| self.part_and_parameters(*k).is_some())
            .collect()
    }

    /// The part (index, as [`FaultKind::part_count`] counts them) and
    /// parameter values (in [`FaultKind::parameters`] order) of fault
    /// `kind`; `None` if it is absent.
    pub fn part_and_parameters(&self, kind: FaultKind) -> Option<(usize, Vec<f64>)> {
        match kind {
            FaultKind::DrumZeroError => self.drum_zero_error.map(|f| (f.cable, vec![f.offset_m])),
            FaultKind::MemberError => self
                .member_error
                .map(|f| (f.member, vec![f.rest_length_error_m, f.stiffness_scale])),
            FaultKind::HalfDifference => self.half_difference.map(|f| {
                (
                    f.half.index(),
                    vec![
                        f.strut_scale,
                        f.cable_scale,
                        f.spring_scale,
                        f.joint_mass_scale,
                    ],
                )
            }),
        }
    }

    /// These faults with `kind` present on part `part` at `values` (in
    /// [`FaultKind::parameters`] order).
    ///
    /// # Panics
    /// If `values` has the wrong length, or a half is not 0 or 1: a
    /// programming error.
    pub fn with_fault(&self, kind: FaultKind, part: usize, values: &[f64]) -> Faults {
        assert_eq!(values.len(), kind.parameters().len(), "{}", kind.name());
        let mut out = *self;
        match kind {
            FaultKind::DrumZeroError => {
                out.drum_zero_error = Some(DrumZeroError {
                    cable: part,
                    offset_m: values[0],
                })
            }
            FaultKind::MemberError => {
                out.member_error = Some(MemberError {
                    member: part,
                    rest_length_error_m: values[0],
                    stiffness_scale: values[1],
                })
            }
            FaultKind::HalfDifference => {
                out.half_difference = Some(HalfDifference {
                    half: Half::BOTH[part],
                    strut_scale: values[0],
                    cable_scale: values[1],
                    spring_scale: values[2],
                    joint_mass_scale: values[3],
                })
            }
        }
        out
    }

    /// Checks every parameter of the faults present against its
    /// admissible range ([`ParameterSpec::admissible`]). Whether the parts
    /// exist, and whether the faulty rest lengths stay positive, is
    /// checked against the structure by [`Self::apply`].
    pub fn validate(&self) -> Result<(), FaultError> {
        for kind in self.present() {
            let Some((_, values)) = self.part_and_parameters(kind) else {
                continue;
            };
            for (spec, v) in kind.parameters().iter().zip(values) {
                if let Some(reason) = spec.admissible_reason(v) {
                    return Err(FaultError {
                        fault: kind.name(),
                        parameter: spec.name,
                        reason,
                    });
                }
            }
        }
        Ok(())
    }

    /// `structure` with the faults applied (see the module notes), checked
    /// again as [`Structure::new`] checks a structure: a rest length a
    /// fault made non-positive is an error naming the member. Errors too
    /// when a fault's part is not in `structure` or the structure has no
    /// halves for a half difference. Without faults, a plain copy.
    pub fn apply(&self, structure: &Structure) -> Result<Structure, StructureError> {
        if self.is_empty() {
            return Ok(structure.clone());
        }
        let bad = |kind: FaultKind, reason: String| StructureError::BadFault {
            fault: kind.name(),
            reason,
        };
        let mut s = structure.clone();
        for kind in self.present() {
            let (part, _) = self.part_and_parameters(kind).unwrap_or_default();
            if part >= kind.part_count(&s) {
                return Err(bad(
                    kind,
                    format!(
                        "{} {part} does not exist (the structure has {})",
                        kind.part_key(),
                        kind.part_count(&s)
                    ),
                ));
            }
        }
        if let Some(f) = self.half_difference {
            let halves =
                node_halves(&s).map_err(|reason| bad(FaultKind::HalfDifference, reason))?;
            let inside = |node: usize| halves[node] == Some(f.half);
            for m in &mut s.members {
                if inside(m.nodes[0]) && inside(m.nodes[1]) {
                    m.kind =
                        m.kind
                            .with_stiffness_scaled(f.strut_scale, f.cable_scale, f.spring_scale);
                }
            }
            for c in &mut s.continuous_cables {
                if inside(c.path[0]) {
                    c.ea_n *= f.cable_scale;
                }
            }
            for (i, node) in s.nodes.iter_mut().enumerate() {
                if inside(i) {
                    node.mass_kg *= f.joint_mass_scale;
                }
            }
        }
        if let Some(f) = self.member_error {
            let m = &mut s.members[f.member];
            m.rest_length_m += f.rest_length_error_m;
            let k = f.stiffness_scale;
            m.kind = m.kind.with_stiffness_scaled(k, k, k);
        }
        if let Some(f) = self.drum_zero_error {
            s.continuous_cables[f.cable].segment_rest_lengths_m[0] += f.offset_m;
        }
        Structure::new(
            s.name,
            s.nodes,
            s.members,
            s.continuous_cables,
            s.gravity_m_per_s2,
            s.midspan_pairs,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::structure::{ContinuousCable, Member, MemberKind, Node};
    use crate::model::{ForwardModel, JointFriction, RelaxSettings, Workspace};
    use nalgebra::Vector3;

    fn bridge() -> Structure {
        reference_bridge(&BridgeParameters::default()).unwrap()
    }

    /// The bridge's as-built equilibrium with `faults`, frictionless.
    fn settled(s: &Structure, faults: &Faults) -> (ForwardModel, crate::model::DeploymentState) {
        let model = ForwardModel::new(
            faults.apply(s).unwrap(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap();
        let mut state = model.reference_state();
        let r = model.relax(&mut state, &mut Workspace::default());
        assert!(r.status.is_converged(), "{}", r.status.describe());
        (model, state)
    }

    #[test]
    fn neutral_faults_leave_the_structure_unchanged() {
        let s = bridge();
        for kind in FaultKind::ALL {
            let neutral: Vec<f64> = kind.parameters().iter().map(|p| p.neutral).collect();
            let f = Faults::default().with_fault(kind, 1, &neutral);
            assert_eq!(f.present(), vec![kind]);
            assert_eq!(f.apply(&s).unwrap(), s, "{}", kind.name());
        }
        assert_eq!(Faults::default().apply(&s).unwrap(), s);
    }

    #[test]
    fn every_fault_round_trips_through_its_part_and_parameters() {
        for kind in FaultKind::ALL {
            let values: Vec<f64> = kind
                .parameters()
                .iter()
                .map(|p| 0.5 * (p.plausible.0 + p.plausible.1) + 0.001)
                .collect();
            let f = Faults::default().with_fault(kind, 1, &values);
            assert_eq!(f.part_and_parameters(kind), Some((1, values)));
            f.validate().unwrap();
            for spec in kind.parameters() {
                let (lo, hi) = spec.admissible;
                assert!(lo <= spec.plausible.0 && spec.plausible.1 <= hi);
                assert!(spec.plausible.0 <= spec.neutral && spec.neutral <= spec.plausible.1);
            }
        }
    }

    #[test]
    fn the_reference_bridge_has_two_halves_of_25_nodes_named_by_their_ids() {
        let s = bridge();
        let halves = node_halves(&s).unwrap();
        for (node, half) in s.nodes.iter().zip(&halves) {
            let half = half.expect("every node in a half");
            assert!(node.id.starts_with(half.name()), "{}", node.id);
        }
        assert_eq!(halves.iter().filter(|h| **h == Some(Half::B)).count(), 25);
        for kind in FaultKind::ALL {
            for part in 0..kind.part_count(&s) {
                let id = kind.part_id(&s, part);
                assert_eq!(kind.find_part(&s, &id), Some(part));
            }
            assert_eq!(kind.find_part(&s, "nowhere"), None);
        }
    }

    /// The drum offset is material: the cable holds exactly `offset` more
    /// in the as-built structure and, since sliding only moves material
    /// between segments, in the settled state; a 15 mm offset (the lab
    /// case) slackens that whole cable and no other.
    #[test]
    fn a_drum_zero_error_adds_exactly_its_offset_of_material_and_slackens_the_cable() {
        let s = bridge();
        let (nominal_model, nominal) = settled(&s, &Faults::default());
        let offset = 0.015;
        let c = 7;
        let faults = Faults::default().with_fault(FaultKind::DrumZeroError, c, &[offset]);
        let (model, state) = settled(&s, &faults);
        let material = |st: &crate::model::DeploymentState, cable: usize| -> f64 {
            let o = st.segment_offsets[cable];
            st.segment_rest_lengths_m[o..o + s.continuous_cables[cable].segment_count()]
                .iter()
                .sum()
        };
        for cable in 0..s.continuous_cables.len() {
            let want = material(&nominal, cable) + if cable == c { offset } else { 0.0 };
            assert!(
                (material(&state, cable) - want).abs() < 1e-12,
                "{}",
                s.continuous_cables[cable].id
            );
        }
        let before = nominal_model.member_forces(&nominal).segment_n;
        let after = model.member_forces(&state).segment_n;
        let o = state.segment_offsets[c];
        for seg in o..o + s.continuous_cables[c].segment_count() {
            // With the geometry held, 15 mm on a ~2 m cable of EA 1.2 MN
            // would take 9 kN out of a few hundred: the cable goes
            // slack, whatever the bridge gives.
            assert!(before[seg] > 100.0, "designed tension {}", before[seg]);
            assert!(after[seg] < 0.05 * before[seg], "{} N left", after[seg]);
        }
    }

    /// Two collinear members in series between supports 1 m apart, their
    /// common node free along the line only: a length error ΔL of one
    /// changes the force in both by −k_a·k_b/(k_a + k_b)·ΔL·(1 + T/EA_a)
    /// (the other member is the spring that takes up the misfit; the
    /// long member is softer too), and a stiffness
    /// scale gives the series formula's force. Linear: the members stay
    /// taut and on the line.
    #[test]
    fn a_member_error_changes_the_force_by_the_series_stiffness_times_the_misfit() {
        let node = |id: &str, x: f64, fixed: [bool; 3]| Node {
            id: id.into(),
            position_m: Vector3::new(x, 0.0, 0.0),
            mass_kg: 1.0,
            fixed,
            load_n: Vector3::zeros(),
        };
        let (ea_a, ea_b) = (2.0e5, 6.0e5);
        let (l0_a, l0_b) = (0.499, 0.4995);
        let cable = |id: &str, a: usize, b: usize, ea_n: f64, rest: f64| Member {
            id: id.into(),
            kind: MemberKind::Cable { ea_n },
            nodes: [a, b],
            rest_length_m: rest,
        };
        let s = Structure::new(
            "two cables in series",
            vec![
                node("left", 0.0, [true; 3]),
                node("middle", 0.5, [false, true, true]),
                node("right", 1.0, [true; 3]),
            ],
            vec![cable("a", 0, 1, ea_a, l0_a), cable("b", 1, 2, ea_b, l0_b)],
            Vec::<ContinuousCable>::new(),
            Vector3::zeros(),
            Vec::new(),
        )
        .unwrap();
        // Equilibrium: EA_a/L0_a·(x − L0_a) = EA_b/L0_b·(1 − x − L0_b).
        let force = |l0_a: f64, ea_a: f64| {
            let (ka, kb) = (ea_a / l0_a, ea_b / l0_b);
            let x = (ka * l0_a + kb * (1.0 - l0_b)) / (ka + kb);
            (ka * (x - l0_a), ka * kb / (ka + kb))
        };
        let (t0, k_series) = force(l0_a, ea_a);
        let forces = |faults: Faults| {
            let (model, state) = settled(&s, &faults);
            model.member_forces(&state).member_n
        };
        let base = forces(Faults::default());
        assert!((base[0] - t0).abs() < 1e-6 * t0 && (base[1] - t0).abs() < 1e-6 * t0);

        let dl = 0.0003;
        let long = forces(Faults::default().with_fault(FaultKind::MemberError, 0, &[dl, 1.0]));
        let (t1, _) = force(l0_a + dl, ea_a);
        // T = k_s·(1 − L0_a − L0_b) with 1/k_s = L0_a/EA_a + L0_b/EA_b, so
        // dT/dL0_a = −k_s·(1 + T/EA_a): the misfit grows by ΔL and the
        // longer member is also softer (k = EA/L0). The neglected second
        // order is ~ΔL/L (6e-4); measured 4.5e-4 of the change, so within
        // 0.1 %.
        let change = long[0] - base[0];
        let first_order = -k_series * dl * (1.0 + t0 / ea_a);
        assert!(
            (change - first_order).abs() < 1e-3 * first_order.abs(),
            "{change} N vs {first_order} N"
        );
        assert!((long[0] - t1).abs() < 1e-6 * t0 && (long[1] - t1).abs() < 1e-6 * t0);

        let soft = forces(Faults::default().with_fault(FaultKind::MemberError, 0, &[0.0, 0.5]));
        let (t2, _) = force(l0_a, 0.5 * ea_a);
        assert!((soft[0] - t2).abs() < 1e-6 * t0, "{} vs {t2}", soft[0]);
        assert!(t2 < 0.9 * t0);
    }

    /// On the bridge, a strut 5 mm long pushes harder: its compression
    /// grows, by less than its own k·ΔL (the rest of the bridge gives),
    /// but by a sizeable part of it (the bridge is stiff around it).
    #[test]
    fn a_long_strut_on_the_bridge_takes_more_compression_bounded_by_its_own_stiffness() {
        let s = bridge();
        let m = s
            .members
            .iter()
            .position(|m| m.id == "A_strut_m0_a1")
            .unwrap();
        let dl = 0.005;
        let (_, nominal) = settled(&s, &Faults::default());
        let faults = Faults::default().with_fault(FaultKind::MemberError, m, &[dl, 1.0]);
        let (model, state) = settled(&s, &faults);
        let before = ForwardModel::new(
            s.clone(),
            JointFriction::frictionless(),
            RelaxSettings::default(),
        )
        .unwrap()
        .member_forces(&nominal)
        .member_n[m];
        let after = model.member_forces(&state).member_n[m];
        let k = s.members[m]
            .kind
            .axial_stiffness(s.members[m].rest_length_m);
        let change = after - before;
        assert!(before < 0.0, "a strut is in compression: {before} N");
        assert!(change < 0.0, "more compression: {change} N");
        assert!(-change < k * dl, "{change} N vs k·ΔL = {} N", k * dl);
    }

    #[test]
    fn a_half_difference_scales_that_half_only() {
        let s = bridge();
        let f = Faults::default().with_fault(FaultKind::HalfDifference, 1, &[1.1, 0.8, 0.9, 1.05]);
        let t = f.apply(&s).unwrap();
        for (a, b) in s.members.iter().zip(&t.members) {
            let ratio = b.kind.axial_stiffness(1.0) / a.kind.axial_stiffness(1.0);
            let want = match (a.id.starts_with('B'), a.kind) {
                (false, _) => 1.0,
                (true, MemberKind::Strut { .. }) => 1.1,
                (true, MemberKind::Cable { .. }) => 0.8,
                (true, MemberKind::Spring { .. }) => 0.9,
            };
            assert!((ratio - want).abs() < 1e-12, "{}", a.id);
            assert_eq!(a.rest_length_m, b.rest_length_m);
        }
        for (a, b) in s.continuous_cables.iter().zip(&t.continuous_cables) {
            let want = if a.id.starts_with('B') { 0.8 } else { 1.0 };
            assert!((b.ea_n / a.ea_n - want).abs() < 1e-12, "{}", a.id);
        }
        for (a, b) in s.nodes.iter().zip(&t.nodes) {
            let want = if a.id.starts_with('B') { 1.05 } else { 1.0 };
            assert!((b.mass_kg / a.mass_kg - want).abs() < 1e-12, "{}", a.id);
        }
    }

    #[test]
    fn impossible_faults_are_errors_naming_the_fault_or_member() {
        let s = bridge();
        let f = Faults::default().with_fault(FaultKind::MemberError, 1, &[-10.0, 1.0]);
        let msg = f.apply(&s).unwrap_err().to_string();
        let id = &s.members[1].id;
        assert!(
            msg.contains(id.as_str()) && msg.contains("rest_length_m"),
            "{msg}"
        );
        let f = Faults::default().with_fault(FaultKind::DrumZeroError, 10, &[0.01]);
        assert_eq!(
            f.apply(&s).unwrap_err().to_string(),
            "fault `drum_zero_error`: motor 10 does not exist (the structure has 10)"
        );
        let f = Faults::default().with_fault(FaultKind::MemberError, 1, &[0.0, 0.0]);
        assert_eq!(
            f.validate().unwrap_err().to_string(),
            "fault `member_error`, parameter `stiffness_scale`: must be ≥ 0.001, got 0"
        );
        let f = Faults::default().with_fault(FaultKind::DrumZeroError, 1, &[f64::NAN]);
        assert!(f.validate().unwrap_err().to_string().contains("`offset_m`"));
    }
}
