//! The limits a state must respect: member forces, strut buckling and
//! strut-to-strut clearance, evaluated on a state and named for reports.
//!
//! Force rows are numbered members first (as [`Structure::members`]), then
//! continuous-cable segments (flat, as the state's segments), so row `r`
//! means the same force in the limits, the sensitivities and the QP.
//!
//! # Limits the start already breaks
//! The problem's bounds ([`Limits::required`]) are never widened in what
//! decides a run's outcome: a deployment ends meeting every one of them or
//! it has not succeeded ([`super::verdict::RunVerdict`]). A bound that the
//! folded start already breaks (a 50 cm fold leaves every segment of `cc1`
//! slack) is a *start-broken* limit ([`StartBrokenLimit`]), reported as
//! such with whether the run restored it:
//! - until it is restored, it may not be made worse than its start value:
//!   the planner holds it there ([`Limits::force`], the required bounds
//!   widened to the start), and so does the truth's supervisor
//!   ([`Limits::held_bounds`]); falling below the start value is a
//!   violation ([`LimitViolation::WorseThanStart`]);
//! - once a command ends with the limit met, it is *restored*, and from
//!   then on it is held to its required bound like any other, by the
//!   supervisor on the truth's forces and by the planner on its model's
//!   (with the measured offsets, [`Limits::hold_restored`]): falling back
//!   is a violation;
//! - a deployment that ends with a start-broken limit not restored is not
//!   connected, whatever its gaps. A continuous cable the fold left slack
//!   is taken up by its motor before the QP plans on it
//!   ([`super::take_up`]): its tangent response is zero until it is taut.
//!
//! # Which limits matter
//! Every upper (overload) limit is a deployment limit, wherever the member
//! is. The minimum tension is there to keep a member straight and bracing
//! its nodes, and a continuous cable seated over its joints. It is no
//! deployment limit for a cable or spring whose two nodes are both *held
//! by the abutment* in every direction ([`abutment_held_nodes`]): a cable
//! of the abutment ring, joining two supported joints.
//! - With rigid supports no command can change its length, so its force is
//!   a constant of the assembly (a test checks it): a minimum on it is
//!   vacuous.
//! - With flexible supports (the truth's supports are free nodes on
//!   foundation bars of stiffness `1/c`, 20 to 100 kN/m over the plausible
//!   compliances) its force follows the supports' deformation `c·ΔR`, and
//!   it does go slack: the folded bridge's reactions differ from the
//!   as-built ones by hundreds of newtons, and the ring's supports close
//!   in by millimetres. Measured on the reference bridge
//!   (`examples/ring_force_probe.rs`, a test checks it): along a uniform
//!   reel-in from the 40 cm fold the smallest ring cable force is 0 N from
//!   35 cm to 20 cm of payout at every plausible compliance, already 0.8 N
//!   in the folded state at 3e-5 m/N, and back at its 300 N design
//!   prestress at the design. No command sequence the planner finds keeps
//!   it at 5 N (a planner told of the compliance stops "not reachable" at
//!   the first command). A slack ring cable is no hazard the deployment
//!   can cause or avoid: both its nodes stay held in every direction by the
//!   foundation bars (the truth solves stably with it slack); it is a
//!   discontinuous cable, seated over no joint; and its ends move by
//!   millimetres, so it sags by as much. Its minimum is therefore not a
//!   deployment limit (its lower bound is `-inf`); its upper bound is kept,
//!   and its force is reported with every other in `deployment.csv`.
//!
//! Strut pairs that the designed geometry itself holds closer than the
//! clearance limit are held only to the smaller of their designed and
//! start clearances: the reference generator's schematic geometry has
//! struts that cross (0 mm apart), and the design is the goal the planner
//! is asked to reach (the clearance check is off by default).

use nalgebra::Vector3;
use serde::{Serialize, Serializer};

use super::problem::DeploymentProblem;
use crate::model::{DeploymentState, ForwardModel, MemberKind, NodeIndex, Structure};

/// Euler buckling load π²EI/L0² of a strut (rest length), N; `None` for
/// cables and springs. (The same formula as the `buckling_utilisation`
/// column of the simulation results.)
pub fn euler_load_n(kind: &MemberKind, rest_length_m: f64) -> Option<f64> {
    match *kind {
        MemberKind::Strut { ei_nm2, .. } => {
            Some(std::f64::consts::PI.powi(2) * ei_nm2 / (rest_length_m * rest_length_m))
        }
        _ => None,
    }
}

/// Bounds on one force row, N (tension positive); infinite where none.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceBounds {
    /// Smallest admissible force, N.
    pub lower_n: f64,
    /// Largest admissible force, N.
    pub upper_n: f64,
}

/// The limits of one problem on one structure, with the rows the start
/// already breaks (see the module notes).
#[derive(Debug, Clone, PartialEq)]
pub struct Limits {
    /// The bounds the planner holds each force row to (members, then
    /// segments): [`Self::required`], widened to the start's force where
    /// the start breaks them (it may not make them worse, and is not
    /// asked to repair them before it may move at all).
    pub force: Vec<ForceBounds>,
    /// The problem's bounds per force row: what a deployment must end
    /// meeting. The lower bound of a member whose length no command can
    /// change is `-inf` (see the module notes).
    pub required: Vec<ForceBounds>,
    /// Per force row, the start's force, N.
    pub start_n: Vec<f64>,
    /// Per force row, whether the start breaks its required bounds.
    pub start_broken: Vec<bool>,
    /// Per force row, whether it is a member between two nodes held by the
    /// abutment in every direction: a cable or spring there has no minimum
    /// (see the module notes); a strut (a foundation bar) keeps its
    /// buckling bound.
    pub between_supports: Vec<bool>,
    /// Euler load per force row, N (`None` except for struts).
    pub euler_n: Vec<Option<f64>>,
    /// Pairs of struts (member indices) that share no joint; the nodes of
    /// a midspan pair count as one joint, since they meet at connection.
    pub strut_pairs: Vec<[usize; 2]>,
    /// Smallest clearance per strut pair, m.
    pub min_clearance_m: Vec<f64>,
    /// Largest admissible tension, N (for utilisation).
    pub max_tension_n: f64,
    /// Largest admissible buckling utilisation.
    pub max_buckling_utilisation: f64,
}

/// How close a state is to its limits, and what it breaks.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitCheck {
    /// Largest of tension over the maximum tension and strut compression
    /// over the admissible part of its Euler load; 1 is at a limit.
    pub worst_utilisation: f64,
    /// Smallest tension in a cable, spring or segment, N.
    pub min_tension_n: f64,
    /// Smallest strut-to-strut clearance, m.
    pub min_clearance_m: f64,
    /// The limits broken (empty when none).
    pub violations: Vec<LimitViolation>,
}

/// One limit a state breaks, with the member or struts it names. Written
/// (and serialised) as its [`LimitViolation::describe`] text.
#[derive(Debug, Clone, PartialEq)]
pub enum LimitViolation {
    /// A force row below its lower limit (a tension-only member slack, a
    /// strut compressed beyond its admissible buckling load).
    BelowLower {
        /// The force row's name ([`force_row_name`], e.g. `segment A_cc0[2]`).
        member: String,
        /// Its force, N.
        force_n: f64,
        /// The limit, N.
        lower_n: f64,
    },
    /// A force row above its upper limit.
    AboveUpper {
        /// The force row's name ([`force_row_name`]).
        member: String,
        /// Its force, N.
        force_n: f64,
        /// The limit, N.
        upper_n: f64,
    },
    /// A force row the start already broke, made worse than its start
    /// value before it was restored (see the module notes).
    WorseThanStart {
        /// The force row's name ([`force_row_name`]).
        member: String,
        /// Its force, N.
        force_n: f64,
        /// Its force at the start, N.
        start_n: f64,
        /// The required bound, broken since the start, N.
        limit_n: f64,
        /// `true` for a lower bound.
        lower: bool,
    },
    /// Two struts closer than their clearance limit.
    StrutsTooClose {
        /// Id of the first strut.
        strut_a: String,
        /// Id of the second strut.
        strut_b: String,
        /// Their distance, m.
        distance_m: f64,
        /// The smallest admissible distance, m.
        min_m: f64,
    },
    /// A tension no sensor reads fell to less than the policy's margin
    /// times its fall above its lower limit (see
    /// [`super::PlanContext::unmeasured_fall_violations`]).
    UnmeasuredFall {
        /// The force row's name ([`force_row_name`]).
        member: String,
        /// Its force after the fall, N.
        force_n: f64,
        /// The fall, N.
        fall_n: f64,
        /// The policy's `unmeasured_force_fall_margin`, 1.
        margin: f64,
        /// The lower limit, N.
        lower_n: f64,
    },
    /// A continuous cable got slacker than it is held to (see
    /// [`super::slack`]): the model reads it at 0 N either way, the
    /// bridge may still hold it taut.
    SlackGrew {
        /// The continuous cable's id.
        cable: String,
        /// Its slack, m.
        slack_m: f64,
        /// The slack it is held to, m.
        bound_m: f64,
    },
}

impl LimitViolation {
    /// Plain words, as in the deployment tables.
    pub fn describe(&self) -> String {
        match self {
            LimitViolation::BelowLower {
                member,
                force_n,
                lower_n,
            } => format!("{member} at {force_n:.1} N, below {lower_n:.1} N"),
            LimitViolation::AboveUpper {
                member,
                force_n,
                upper_n,
            } => format!("{member} at {force_n:.1} N, above {upper_n:.1} N"),
            LimitViolation::WorseThanStart {
                member,
                force_n,
                start_n,
                limit_n,
                lower,
            } => {
                let (dir, bound) = if *lower {
                    ("below", "minimum")
                } else {
                    ("above", "maximum")
                };
                format!(
                    "{member} at {force_n:.1} N, {dir} its start value {start_n:.1} N (its {limit_n:.1} N {bound} broken since the start)"
                )
            }
            LimitViolation::StrutsTooClose {
                strut_a,
                strut_b,
                distance_m,
                min_m,
            } => format!(
                "struts {strut_a} and {strut_b} {:.1} mm apart, closer than {:.1} mm",
                1e3 * distance_m,
                1e3 * min_m
            ),
            LimitViolation::UnmeasuredFall {
                member,
                force_n,
                fall_n,
                margin,
                lower_n,
            } => format!(
                "{member} (unmeasured) at {force_n:.1} N after a {fall_n:.1} N fall: less than {margin} × the fall above {lower_n:.1} N"
            ),
            LimitViolation::SlackGrew {
                cable,
                slack_m,
                bound_m,
            } => format!(
                "{cable} slack by {:.3} mm, more than the {:.3} mm it is held to",
                1e3 * slack_m,
                1e3 * bound_m
            ),
        }
    }
}

impl Serialize for LimitViolation {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.describe())
    }
}

impl LimitViolation {
    /// The limit broken, one name per limit (the same at every increment
    /// that breaks it): `cable A_c3 min`, `cable A_c3 max`,
    /// `clearance A_s1–A_s7`.
    pub fn limit(&self) -> String {
        match self {
            LimitViolation::BelowLower { member, .. }
            | LimitViolation::UnmeasuredFall { member, .. } => limit_name(member, true),
            LimitViolation::AboveUpper { member, .. } => limit_name(member, false),
            LimitViolation::WorseThanStart { member, lower, .. } => limit_name(member, *lower),
            LimitViolation::StrutsTooClose {
                strut_a, strut_b, ..
            } => format!("clearance {strut_a}–{strut_b}"),
            LimitViolation::SlackGrew { cable, .. } => format!("{cable} slack"),
        }
    }

    /// How far a force went beyond the bound the truth was held to, N
    /// (positive): [`Self::excess`] of a breach of a force bound (below
    /// its minimum, above its maximum, or worse than a start that broke
    /// one); `None` for a clearance, a slack or the model's unmeasured-fall
    /// rule, which are no force bounds of the bridge.
    pub fn force_excess_n(&self) -> Option<f64> {
        match self {
            LimitViolation::BelowLower { .. }
            | LimitViolation::AboveUpper { .. }
            | LimitViolation::WorseThanStart { .. } => Some(self.excess()),
            LimitViolation::UnmeasuredFall { .. }
            | LimitViolation::StrutsTooClose { .. }
            | LimitViolation::SlackGrew { .. } => None,
        }
    }

    /// How far beyond its bound the value is (N for forces, m for
    /// clearances and slack; positive): which of two breaches of one
    /// limit is the worse.
    pub fn excess(&self) -> f64 {
        match self {
            LimitViolation::BelowLower {
                force_n, lower_n, ..
            } => lower_n - force_n,
            LimitViolation::AboveUpper {
                force_n, upper_n, ..
            } => force_n - upper_n,
            LimitViolation::WorseThanStart {
                force_n,
                start_n,
                lower,
                ..
            } => {
                if *lower {
                    start_n - force_n
                } else {
                    force_n - start_n
                }
            }
            LimitViolation::UnmeasuredFall {
                force_n,
                fall_n,
                margin,
                lower_n,
                ..
            } => lower_n + margin * fall_n - force_n,
            LimitViolation::StrutsTooClose {
                distance_m, min_m, ..
            } => min_m - distance_m,
            LimitViolation::SlackGrew {
                slack_m, bound_m, ..
            } => slack_m - bound_m,
        }
    }
}

impl LimitCheck {
    /// `true` when no limit is broken.
    pub fn ok(&self) -> bool {
        self.violations.is_empty()
    }

    /// A check of nothing: no utilisation, no tension, no clearance.
    pub fn empty() -> Self {
        LimitCheck {
            worst_utilisation: 0.0,
            min_tension_n: f64::INFINITY,
            min_clearance_m: f64::INFINITY,
            violations: Vec::new(),
        }
    }
}

/// The name of a force row's lower (`min`) or upper (`max`) limit, as
/// breaches, `binds` and the QP's rows name it: `cable B_ring0_1 max`.
pub fn limit_name(member: &str, lower: bool) -> String {
    format!("{member} {}", if lower { "min" } else { "max" })
}

impl StartBrokenLimit {
    /// The limit's name ([`limit_name`]).
    pub fn limit(&self) -> String {
        limit_name(&self.member, self.lower)
    }
}

/// A limit that the start already broke, and what the run made of it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StartBrokenLimit {
    /// The force row's name ([`force_row_name`]).
    pub member: String,
    /// `true` for a lower bound (a slack member), `false` for an upper.
    pub lower: bool,
    /// The required bound, N.
    pub limit_n: f64,
    /// The force at the start, N.
    pub start_n: f64,
    /// The force at the end, N.
    pub end_n: f64,
    /// Whether the end meets the bound.
    pub restored: bool,
}

impl StartBrokenLimit {
    /// Plain words, e.g. `segment A_cc1[2] slack at the start (3.1 N <
    /// 5.0 N), restored (12.0 N at the end)`.
    pub fn describe(&self) -> String {
        let (state, sign) = if self.lower {
            ("slack", "<")
        } else {
            ("overloaded", ">")
        };
        format!(
            "{} {state} at the start ({:.1} N {sign} {:.1} N), {} ({:.1} N at the end)",
            self.member,
            self.start_n,
            self.limit_n,
            if self.restored {
                "restored"
            } else {
                "not restored"
            },
            self.end_n
        )
    }
}

/// A limit a state breaks by itself, before any command: what
/// [`Limits::broken_at_construction`] reports of the state its limits were
/// built on. Used for the truth's as-built (designed) state, where a
/// drawn truth with a member cut short or long can already be outside
/// its limits: the state the deployment is meant to end near.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StateBreach {
    /// The force row's name ([`force_row_name`]).
    pub member: String,
    /// `true` for a lower bound (a slack member), `false` for an upper.
    pub lower: bool,
    /// The required bound, N.
    pub limit_n: f64,
    /// The force in that state, N.
    pub force_n: f64,
}

impl StateBreach {
    /// The limit's name as a run's `binds` and breaches name it
    /// (`cable B_ring0_1 max`).
    pub fn limit(&self) -> String {
        limit_name(&self.member, self.lower)
    }

    /// Plain words, e.g. `cable B_ring0_1 at 4765.1 N, above its
    /// 3000.0 N maximum`.
    pub fn describe(&self) -> String {
        let (dir, bound) = if self.lower {
            ("below", "minimum")
        } else {
            ("above", "maximum")
        };
        format!(
            "{} at {:.1} N, {dir} its {:.1} N {bound}",
            self.member, self.force_n, self.limit_n
        )
    }
}

/// Closest distance between segments `p0–p1` and `q0–q1`, m, with the
/// parameters `(s, t)` ∈ [0, 1]² of the closest points (Ericson,
/// Real-Time Collision Detection, §5.1.9).
pub fn segment_distance(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64, f64) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    let c = d1.dot(&r);
    let b = d1.dot(&d2);
    let denom = a * e - b * b;
    // Parallel segments: any s; take 0 and clamp t.
    let mut s = if denom > 1e-14 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    let dist = ((p0 + s * d1) - (q0 + t * d2)).norm();
    (dist, s, t)
}

/// Name of force row `row` for reports, e.g. `segment A_cc0[2]`.
pub fn force_row_name(structure: &Structure, row: usize) -> String {
    let n_members = structure.members.len();
    if row < n_members {
        let m = &structure.members[row];
        return format!("{} {}", m.kind.name(), m.id);
    }
    let mut k = row - n_members;
    for c in &structure.continuous_cables {
        if k < c.segment_count() {
            return format!("segment {}[{k}]", c.id);
        }
        k -= c.segment_count();
    }
    format!("row {row}")
}

/// Forces of a state as force rows: members then segments, N.
pub fn force_rows(model: &ForwardModel, state: &DeploymentState) -> Vec<f64> {
    let f = model.member_forces(state);
    let mut rows = f.member_n;
    rows.extend(f.segment_n);
    rows
}

/// [`force_rows`] plus `offsets_n` (one per row, measured minus
/// predicted; missing ones count as 0), N.
pub fn corrected_force_rows(
    model: &ForwardModel,
    state: &DeploymentState,
    offsets_n: &[f64],
) -> Vec<f64> {
    let mut rows = force_rows(model, state);
    for (f, o) in rows.iter_mut().zip(offsets_n) {
        *f += o;
    }
    rows
}

/// The clearance of strut pair `[a, b]` in `positions`, m, with the
/// closest-point parameters.
pub fn strut_clearance(
    structure: &Structure,
    positions: &[Vector3<f64>],
    pair: [usize; 2],
) -> (f64, f64, f64) {
    let [a, b] = pair.map(|m| structure.members[m].nodes);
    segment_distance(
        &positions[a[0]],
        &positions[a[1]],
        &positions[b[0]],
        &positions[b[1]],
    )
}

/// Per node, whether the abutment holds it in every direction: it is
/// fixed in every direction, or struts join it to nodes fixed in every
/// direction along three independent directions (the foundation bars of
/// flexible supports, [`crate::model::flexible_supports`]). Struts, not
/// cables: a cable braces only while taut.
pub fn abutment_held_nodes(structure: &Structure) -> Vec<bool> {
    let grounded = |n: usize| structure.nodes[n].fixed.iter().all(|f| *f);
    let mut directions: Vec<Vec<Vector3<f64>>> = vec![Vec::new(); structure.nodes.len()];
    for m in &structure.members {
        if !matches!(m.kind, MemberKind::Strut { .. }) {
            continue;
        }
        let [a, b] = m.nodes;
        let d = structure.nodes[b].position_m - structure.nodes[a].position_m;
        let Some(d) = d.try_normalize(1e-12) else {
            continue;
        };
        if grounded(a) && !grounded(b) {
            directions[b].push(d);
        }
        if grounded(b) && !grounded(a) {
            directions[a].push(d);
        }
    }
    (0..structure.nodes.len())
        .map(|n| {
            grounded(n) || {
                let d = &directions[n];
                d.len() >= 3 && {
                    let m = nalgebra::DMatrix::from_fn(3, d.len(), |r, c| d[c][r]);
                    m.rank(1e-6) == 3
                }
            }
        })
        .collect()
}

impl Limits {
    /// The limits of `problem` on `model`'s structure, with the rows that
    /// `start` already breaks (see the module notes).
    pub fn new(model: &ForwardModel, problem: &DeploymentProblem, start: &DeploymentState) -> Self {
        let s = model.structure();
        let mut required = Vec::new();
        let mut euler_n = Vec::new();
        let mut between_supports = Vec::new();
        let held = abutment_held_nodes(s);
        for m in &s.members {
            let e = euler_load_n(&m.kind, m.rest_length_m);
            euler_n.push(e);
            let fixed = m.nodes.iter().all(|&n| held[n]);
            between_supports.push(fixed);
            required.push(match e {
                Some(e) => ForceBounds {
                    lower_n: -problem.max_strut_buckling_utilisation * e,
                    upper_n: f64::INFINITY,
                },
                None => ForceBounds {
                    lower_n: if fixed {
                        f64::NEG_INFINITY
                    } else {
                        problem.min_tension_n
                    },
                    upper_n: problem.max_tension_n,
                },
            });
        }
        for _ in 0..s.segment_count() {
            euler_n.push(None);
            between_supports.push(false);
            required.push(ForceBounds {
                lower_n: problem.min_tension_n,
                upper_n: problem.max_tension_n,
            });
        }
        let start_n = force_rows(model, start);
        let start_broken: Vec<bool> = start_n
            .iter()
            .zip(&required)
            .map(|(&f, b)| f < b.lower_n || f > b.upper_n)
            .collect();
        let force = required
            .iter()
            .zip(&start_n)
            .map(|(b, &f)| ForceBounds {
                lower_n: b.lower_n.min(f),
                upper_n: b.upper_n.max(f),
            })
            .collect();
        // Nodes that become one joint at connection.
        let mut joint: Vec<NodeIndex> = (0..s.nodes.len()).collect();
        for [a, b] in &s.midspan_pairs {
            joint[*b] = joint[*a];
        }
        // A zero clearance is no check (distances are never negative).
        let struts: Vec<usize> = (0..s.members.len())
            .filter(|&m| matches!(s.members[m].kind, MemberKind::Strut { .. }))
            .filter(|_| problem.min_strut_clearance_m > 0.0)
            .collect();
        let designed = s.reference_positions();
        let mut strut_pairs = Vec::new();
        let mut min_clearance_m = Vec::new();
        for (i, &a) in struts.iter().enumerate() {
            for &b in &struts[i + 1..] {
                let ja = s.members[a].nodes.map(|n| joint[n]);
                let jb = s.members[b].nodes.map(|n| joint[n]);
                if ja.iter().any(|n| jb.contains(n)) {
                    continue;
                }
                let (d, _, _) = strut_clearance(s, &start.positions_m, [a, b]);
                let (d0, _, _) = strut_clearance(s, &designed, [a, b]);
                strut_pairs.push([a, b]);
                min_clearance_m.push(problem.min_strut_clearance_m.min(d).min(d0));
            }
        }
        Limits {
            force,
            required,
            start_n,
            start_broken,
            between_supports,
            euler_n,
            strut_pairs,
            min_clearance_m,
            max_tension_n: problem.max_tension_n,
            max_buckling_utilisation: problem.max_strut_buckling_utilisation,
        }
    }

    /// The bounds the truth's supervisor holds each force row to, given
    /// which start-broken rows a command has `restored` (one flag per
    /// row): the required bounds, except for a start-broken row not yet
    /// restored, held to its start value ([`Self::force`]).
    pub fn held_bounds(&self, restored: &[bool]) -> Vec<ForceBounds> {
        (0..self.required.len())
            .map(|r| {
                if self.start_broken[r] && !restored.get(r).copied().unwrap_or(false) {
                    self.force[r]
                } else {
                    self.required[r]
                }
            })
            .collect()
    }

    /// Holds every start-broken row that `rows_n` (N, at the end of a
    /// command) meet to its required bound from now on ([`Self::force`]):
    /// the planner's side of *restored* (see the module notes).
    pub fn hold_restored(&mut self, rows_n: &[f64]) {
        let meets = self.meets_required(rows_n, 0.0);
        for (r, ok) in meets.into_iter().enumerate() {
            if ok && self.start_broken[r] {
                self.force[r] = self.required[r];
            }
        }
    }

    /// Per force row, whether `rows_n` (N) meet the required bounds
    /// within `tolerance_n`.
    pub fn meets_required(&self, rows_n: &[f64], tolerance_n: f64) -> Vec<bool> {
        rows_n
            .iter()
            .zip(&self.required)
            .map(|(&f, b)| f >= b.lower_n - tolerance_n && f <= b.upper_n + tolerance_n)
            .collect()
    }

    /// The limits the state these limits were built on breaks by itself
    /// (the rows [`Self::new`] widened), against the required bounds.
    pub fn broken_at_construction(&self, structure: &Structure) -> Vec<StateBreach> {
        (0..self.required.len())
            .filter(|&r| self.start_broken[r])
            .map(|r| {
                let (b, f) = (self.required[r], self.start_n[r]);
                let lower = f < b.lower_n;
                StateBreach {
                    member: force_row_name(structure, r),
                    lower,
                    limit_n: if lower { b.lower_n } else { b.upper_n },
                    force_n: f,
                }
            })
            .collect()
    }

    /// The start-broken limits with the end's force rows `end_rows_n`
    /// (N): restored where the end meets the bound within `tolerance_n`.
    pub fn start_broken_limits(
        &self,
        structure: &Structure,
        end_rows_n: &[f64],
        tolerance_n: f64,
    ) -> Vec<StartBrokenLimit> {
        let meets = self.meets_required(end_rows_n, tolerance_n);
        let rows = (0..self.required.len()).filter(|&r| self.start_broken[r]);
        rows.zip(self.broken_at_construction(structure))
            .map(|(r, b)| StartBrokenLimit {
                member: b.member,
                lower: b.lower,
                limit_n: b.limit_n,
                start_n: b.force_n,
                end_n: end_rows_n.get(r).copied().unwrap_or(f64::NAN),
                restored: meets.get(r).copied().unwrap_or(false),
            })
            .collect()
    }

    /// Checks a state against every limit; `tolerance_n` absorbs the
    /// solver's force tolerance (a force within it of a bound is on it).
    /// `force_offsets_n` are added to the model's force rows (measured −
    /// predicted, see [`super::correction`]); missing rows count as zero.
    pub fn check(
        &self,
        model: &ForwardModel,
        state: &DeploymentState,
        tolerance_n: f64,
        force_offsets_n: &[f64],
    ) -> LimitCheck {
        let rows = corrected_force_rows(model, state, force_offsets_n);
        self.check_rows(model, state, &rows, tolerance_n)
    }

    /// [`Self::check`] on force rows already computed for `state` (with
    /// their offsets, N), for a caller that needs the rows too.
    pub fn check_rows(
        &self,
        model: &ForwardModel,
        state: &DeploymentState,
        rows: &[f64],
        tolerance_n: f64,
    ) -> LimitCheck {
        self.check_rows_held(model, state, rows, tolerance_n, &self.force)
    }

    /// [`Self::check_rows`] with each force row held to `held` (e.g.
    /// [`Self::held_bounds`]) instead of the planner's bounds: a row held
    /// to its start value rather than its required bound that breaks it
    /// is a [`LimitViolation::WorseThanStart`].
    pub fn check_rows_held(
        &self,
        model: &ForwardModel,
        state: &DeploymentState,
        rows: &[f64],
        tolerance_n: f64,
        held: &[ForceBounds],
    ) -> LimitCheck {
        let s = model.structure();
        let mut out = LimitCheck::empty();
        for (r, (&f, b)) in rows.iter().zip(held).enumerate() {
            let use_ = match self.euler_n[r] {
                Some(e) => (-f).max(0.0) / (self.max_buckling_utilisation * e),
                None => {
                    out.min_tension_n = out.min_tension_n.min(f);
                    f / self.max_tension_n
                }
            };
            out.worst_utilisation = out.worst_utilisation.max(use_);
            let req = self.required[r];
            let worse_than_start = |lower: bool| LimitViolation::WorseThanStart {
                member: force_row_name(s, r),
                force_n: f,
                start_n: self.start_n[r],
                limit_n: if lower { req.lower_n } else { req.upper_n },
                lower,
            };
            if !(f >= b.lower_n - tolerance_n) {
                out.violations.push(if b.lower_n < req.lower_n {
                    worse_than_start(true)
                } else {
                    LimitViolation::BelowLower {
                        member: force_row_name(s, r),
                        force_n: f,
                        lower_n: b.lower_n,
                    }
                });
            } else if !(f <= b.upper_n + tolerance_n) {
                out.violations.push(if b.upper_n > req.upper_n {
                    worse_than_start(false)
                } else {
                    LimitViolation::AboveUpper {
                        member: force_row_name(s, r),
                        force_n: f,
                        upper_n: b.upper_n,
                    }
                });
            }
        }
        for (pair, &min) in self.strut_pairs.iter().zip(&self.min_clearance_m) {
            let (d, _, _) = strut_clearance(s, &state.positions_m, *pair);
            out.min_clearance_m = out.min_clearance_m.min(d);
            if !(d >= min - 1e-6) {
                out.violations.push(LimitViolation::StrutsTooClose {
                    strut_a: s.members[pair[0]].id.clone(),
                    strut_b: s.members[pair[1]].id.clone(),
                    distance_m: d,
                    min_m: min,
                });
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limit_violations_read_as_before() {
        let cases = [
            (
                LimitViolation::BelowLower {
                    member: "segment A_cc0[2]".into(),
                    force_n: 9.04,
                    lower_n: 10.0,
                },
                "segment A_cc0[2] at 9.0 N, below 10.0 N",
            ),
            (
                LimitViolation::AboveUpper {
                    member: "cable A_c3".into(),
                    force_n: 1234.56,
                    upper_n: 1200.0,
                },
                "cable A_c3 at 1234.6 N, above 1200.0 N",
            ),
            (
                LimitViolation::StrutsTooClose {
                    strut_a: "A_s1".into(),
                    strut_b: "A_s7".into(),
                    distance_m: 0.01234,
                    min_m: 0.02,
                },
                "struts A_s1 and A_s7 12.3 mm apart, closer than 20.0 mm",
            ),
            (
                LimitViolation::UnmeasuredFall {
                    member: "spring A_k0".into(),
                    force_n: 12.345,
                    fall_n: 30.0,
                    margin: 0.5,
                    lower_n: 10.0,
                },
                "spring A_k0 (unmeasured) at 12.3 N after a 30.0 N fall: less than 0.5 × the fall above 10.0 N",
            ),
            (
                LimitViolation::SlackGrew {
                    cable: "A_cc1".into(),
                    slack_m: 3.2e-3,
                    bound_m: 1.9104e-3,
                },
                "A_cc1 slack by 3.200 mm, more than the 1.910 mm it is held to",
            ),
        ];
        for (v, text) in cases {
            assert_eq!(v.describe(), text, "{v:?}");
            assert_eq!(serde_json::to_value(&v).unwrap(), text);
        }
    }

    /// How far a breach went is read for the force bounds of the bridge
    /// only, from the bound the force was held to.
    #[test]
    fn a_force_excess_is_read_from_force_bounds_only() {
        let below = LimitViolation::BelowLower {
            member: "cable c".into(),
            force_n: 4.9,
            lower_n: 5.0,
        };
        let above = LimitViolation::AboveUpper {
            member: "cable c".into(),
            force_n: 3100.0,
            upper_n: 3000.0,
        };
        let worse_up = LimitViolation::WorseThanStart {
            member: "cable r".into(),
            force_n: 9803.6,
            start_n: 9803.3,
            limit_n: 3000.0,
            lower: false,
        };
        let worse_down = LimitViolation::WorseThanStart {
            member: "segment s".into(),
            force_n: 4.2,
            start_n: 4.7,
            limit_n: 5.0,
            lower: true,
        };
        let not_forces = [
            LimitViolation::StrutsTooClose {
                strut_a: "a".into(),
                strut_b: "b".into(),
                distance_m: 0.001,
                min_m: 0.002,
            },
            LimitViolation::UnmeasuredFall {
                member: "cable u".into(),
                force_n: 50.0,
                fall_n: 200.0,
                margin: 0.4,
                lower_n: 5.0,
            },
            LimitViolation::SlackGrew {
                cable: "A_cc1".into(),
                slack_m: 3.2e-3,
                bound_m: 1.9e-3,
            },
        ];
        let near = |v: Option<f64>, x: f64| v.is_some_and(|v| (v - x).abs() < 1e-9);
        assert!(near(below.force_excess_n(), 0.1));
        assert!(near(above.force_excess_n(), 100.0));
        assert!(near(worse_up.force_excess_n(), 0.3));
        assert!(near(worse_down.force_excess_n(), 0.5));
        for v in not_forces {
            assert_eq!(v.force_excess_n(), None, "{v:?}");
        }
    }

    /// A start-broken row is held to its start value until a command
    /// restores it, then to its required bound; a row the start meets is
    /// held to its bound throughout, and breaking a start value is named
    /// as such.
    #[test]
    fn a_start_broken_row_is_held_to_its_start_value_until_restored() {
        let b = |lower_n, upper_n| ForceBounds { lower_n, upper_n };
        let limits = Limits {
            force: vec![b(2.0, 100.0), b(5.0, 100.0)],
            required: vec![b(5.0, 100.0), b(5.0, 100.0)],
            start_n: vec![2.0, 50.0],
            start_broken: vec![true, false],
            between_supports: vec![false, false],
            euler_n: vec![None, None],
            strut_pairs: Vec::new(),
            min_clearance_m: Vec::new(),
            max_tension_n: 100.0,
            max_buckling_utilisation: 1.0,
        };
        assert_eq!(limits.held_bounds(&[]), vec![b(2.0, 100.0), b(5.0, 100.0)]);
        assert_eq!(
            limits.held_bounds(&[true, false]),
            vec![b(5.0, 100.0), b(5.0, 100.0)]
        );
        assert_eq!(limits.meets_required(&[4.0, 50.0], 1e-6), vec![false, true]);
        // The planner's side: held to the start value until a state meets
        // the bound, then to the bound.
        let mut planner = limits.clone();
        planner.hold_restored(&[4.0, 50.0]);
        assert_eq!(planner.force, limits.force);
        planner.hold_restored(&[5.5, 50.0]);
        assert_eq!(planner.force, limits.required);
        assert_eq!(limits.meets_required(&[5.0, 4.0], 1e-6), vec![true, false]);
        let v = LimitViolation::WorseThanStart {
            member: "segment A_cc1[2]".into(),
            force_n: 1.0,
            start_n: 2.0,
            limit_n: 5.0,
            lower: true,
        };
        assert_eq!(
            v.describe(),
            "segment A_cc1[2] at 1.0 N, below its start value 2.0 N (its 5.0 N minimum broken since the start)"
        );
        assert_eq!(v.limit(), "segment A_cc1[2] min");
        assert!((v.excess() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn segment_distance_matches_hand_cases() {
        let v = |x, y, z| Vector3::new(x, y, z);
        // Skew perpendicular lines one unit apart, crossing mid-segment.
        let (d, s, t) = segment_distance(
            &v(-1.0, 0.0, 0.0),
            &v(1.0, 0.0, 0.0),
            &v(0.0, -1.0, 1.0),
            &v(0.0, 1.0, 1.0),
        );
        assert!((d - 1.0).abs() < 1e-12 && (s - 0.5).abs() < 1e-12 && (t - 0.5).abs() < 1e-12);
        // Collinear, end to end with a gap of 0.5.
        let (d, _, _) = segment_distance(
            &v(0.0, 0.0, 0.0),
            &v(1.0, 0.0, 0.0),
            &v(1.5, 0.0, 0.0),
            &v(3.0, 0.0, 0.0),
        );
        assert!((d - 0.5).abs() < 1e-12, "{d}");
        // Parallel, offset by 2 in y and overlapping in x.
        let (d, _, _) = segment_distance(
            &v(0.0, 0.0, 0.0),
            &v(1.0, 0.0, 0.0),
            &v(0.5, 2.0, 0.0),
            &v(2.0, 2.0, 0.0),
        );
        assert!((d - 2.0).abs() < 1e-12, "{d}");
        // Closest point at an end of one segment: (2,1,0) to the x axis 0..1.
        let (d, s, _) = segment_distance(
            &v(0.0, 0.0, 0.0),
            &v(1.0, 0.0, 0.0),
            &v(2.0, 1.0, 0.0),
            &v(2.0, 3.0, 0.0),
        );
        assert!((d - 2f64.sqrt()).abs() < 1e-12 && s == 1.0, "{d} {s}");
    }
}
