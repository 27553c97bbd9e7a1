//! The limits a state must respect: member forces, strut buckling and
//! strut-to-strut clearance, evaluated on a state and named for reports.
//!
//! Force rows are numbered members first (as [`Structure::members`]), then
//! continuous-cable segments (flat, as the state's segments), so row `r`
//! means the same force in the limits, the sensitivities and the QP.
//!
//! A limit that the start state already breaks (the folded bridge's
//! segments carry ~9 N, below a 10 N minimum) is widened to the start
//! value: the planner may not make it worse, but is not asked to repair it
//! before it may move at all. Likewise a strut pair that the designed
//! geometry itself holds closer than the clearance limit is held only to
//! the smaller of its designed and start clearances: the reference
//! generator's schematic geometry has struts that cross (0 mm apart),
//! and the design is the goal the planner is asked to reach.

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

/// The limits of one problem on one structure, widened where the start
/// state already breaks them.
#[derive(Debug, Clone, PartialEq)]
pub struct Limits {
    /// Bounds per force row (members, then segments).
    pub force: Vec<ForceBounds>,
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
        }
    }
}

impl Serialize for LimitViolation {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.describe())
    }
}

impl LimitCheck {
    /// `true` when no limit is broken.
    pub fn ok(&self) -> bool {
        self.violations.is_empty()
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

impl Limits {
    /// The limits of `problem` on `model`'s structure, widened to what
    /// `start` already breaks.
    pub fn new(model: &ForwardModel, problem: &DeploymentProblem, start: &DeploymentState) -> Self {
        let s = model.structure();
        let mut force = Vec::new();
        let mut euler_n = Vec::new();
        for m in &s.members {
            let e = euler_load_n(&m.kind, m.rest_length_m);
            euler_n.push(e);
            force.push(match e {
                Some(e) => ForceBounds {
                    lower_n: -problem.max_strut_buckling_utilisation * e,
                    upper_n: f64::INFINITY,
                },
                None => ForceBounds {
                    lower_n: problem.min_tension_n,
                    upper_n: problem.max_tension_n,
                },
            });
        }
        for _ in 0..s.segment_count() {
            euler_n.push(None);
            force.push(ForceBounds {
                lower_n: problem.min_tension_n,
                upper_n: problem.max_tension_n,
            });
        }
        for (b, f) in force.iter_mut().zip(force_rows(model, start)) {
            b.lower_n = b.lower_n.min(f);
            b.upper_n = b.upper_n.max(f);
        }
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
            euler_n,
            strut_pairs,
            min_clearance_m,
            max_tension_n: problem.max_tension_n,
            max_buckling_utilisation: problem.max_strut_buckling_utilisation,
        }
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
        let s = model.structure();
        let mut out = LimitCheck {
            worst_utilisation: 0.0,
            min_tension_n: f64::INFINITY,
            min_clearance_m: f64::INFINITY,
            violations: Vec::new(),
        };
        for (r, (&f, b)) in rows.iter().zip(&self.force).enumerate() {
            let use_ = match self.euler_n[r] {
                Some(e) => (-f).max(0.0) / (self.max_buckling_utilisation * e),
                None => {
                    out.min_tension_n = out.min_tension_n.min(f);
                    f / self.max_tension_n
                }
            };
            out.worst_utilisation = out.worst_utilisation.max(use_);
            if !(f >= b.lower_n - tolerance_n) {
                out.violations.push(LimitViolation::BelowLower {
                    member: force_row_name(s, r),
                    force_n: f,
                    lower_n: b.lower_n,
                });
            } else if !(f <= b.upper_n + tolerance_n) {
                out.violations.push(LimitViolation::AboveUpper {
                    member: force_row_name(s, r),
                    force_n: f,
                    upper_n: b.upper_n,
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
        ];
        for (v, text) in cases {
            assert_eq!(v.describe(), text, "{v:?}");
            assert_eq!(serde_json::to_value(&v).unwrap(), text);
        }
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
