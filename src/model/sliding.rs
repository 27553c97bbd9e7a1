//! Return mapping of continuous-cable sliding at the joints.
//!
//! For fixed node positions the tension of a segment depends only on its rest
//! length `s`: `T(s) = EA·(L − s)/s` while taut, 0 when slack. Moving material
//! `Δ` from segment `b` into its upstream neighbour `a` lowers `T_a` and raises
//! `T_b`. Trial state: the joint holds. If the trial tension ratio lies
//! outside the capstan cone, material slides, towards the higher-tension
//! side, exactly as far as puts the ratio on the bound. This is the return
//! mapping of rate-independent friction: path dependent, no hardening.
//!
//! A cable's joints are coupled through shared segments, so the mapping
//! sweeps the joints Gauss–Seidel style; the DR loop that calls it every
//! iteration finishes what a sweep leaves.

use nalgebra::Vector3;

use super::friction::JointFriction;
use super::state::JointSlip;

/// Tension of a segment with geometric length `length_m` and rest length
/// `rest_m`, N. Zero when slack.
#[inline]
pub fn segment_tension(ea_n: f64, length_m: f64, rest_m: f64) -> f64 {
    if length_m > rest_m {
        ea_n * (length_m - rest_m) / rest_m
    } else {
        0.0
    }
}

/// Interior angle θ at a joint, rad, from the unit directions of the
/// incoming segment (pointing into the joint) and the outgoing one (pointing
/// away). π for a straight cable.
#[inline]
pub fn interior_angle(dir_in: &Vector3<f64>, dir_out: &Vector3<f64>) -> f64 {
    (-dir_in.dot(dir_out)).clamp(-1.0, 1.0).acos()
}

/// Most Gauss–Seidel sweeps over a cable's joints per call.
const MAX_SWEEPS: usize = 100;
/// Active-set rounds before the mapping falls back to sweeps.
const MAX_ACTIVE_SET_ROUNDS: usize = 8;

/// The start of a return mapping: the material distribution and joint slip
/// states at the start of the load increment.
#[derive(Debug, Clone, Copy)]
pub struct IncrementStart<'a> {
    /// Rest length of each segment at the start of the increment, m.
    pub rest_m: &'a [f64],
    /// Slip state of each joint at the start (index 0 unused).
    pub slip: &'a [JointSlip],
}

/// Which way a joint between tensions `t_a` (upstream) and `t_b` would
/// slide (towards the higher tension): `(towards_motor, T_high, T_low,
/// already sliding that way at the increment's start)`. The last decides
/// whether the static or the kinetic bound applies.
fn would_slide(t_a: f64, t_b: f64, start_slip: JointSlip) -> (bool, f64, f64, bool) {
    let towards_motor = t_a >= t_b;
    let sliding_this_way = matches!(
        (start_slip, towards_motor),
        (JointSlip::TowardsMotor, true) | (JointSlip::TowardsEnd, false)
    );
    if towards_motor {
        (true, t_a, t_b, sliding_this_way)
    } else {
        (false, t_b, t_a, sliding_this_way)
    }
}

/// Joints a cable may have before [`JointCones`] spills to the heap.
const INLINE_JOINTS: usize = 32;

/// The capstan bounds of a cable's joints for one geometry (index 0
/// unused), computed once per mapping: the angle (an `acos`) and the bound
/// (an `exp`) are most of a mapping's cost.
struct JointCones {
    inline: [[f64; 2]; INLINE_JOINTS],
    heap: Vec<[f64; 2]>,
    n: usize,
}

impl JointCones {
    fn new(dirs: &[Vector3<f64>], friction: &JointFriction) -> Self {
        let n = dirs.len();
        let mut cones = JointCones {
            inline: [[1.0; 2]; INLINE_JOINTS],
            heap: Vec::new(),
            n,
        };
        if n > INLINE_JOINTS {
            cones.heap = vec![[1.0; 2]; n];
        }
        let same = friction.static_mu == friction.kinetic_mu;
        for j in 1..n {
            let theta = interior_angle(&dirs[j - 1], &dirs[j]);
            let kinetic = friction.ratio_bound(theta, true);
            let stat = if same {
                kinetic
            } else {
                friction.ratio_bound(theta, false)
            };
            cones.slot(j)[0] = kinetic;
            cones.slot(j)[1] = stat;
        }
        cones
    }

    fn slot(&mut self, j: usize) -> &mut [f64; 2] {
        if self.n > INLINE_JOINTS {
            &mut self.heap[j]
        } else {
            &mut self.inline[j]
        }
    }

    /// The bound at joint `j`: kinetic while sliding, else static.
    fn bound(&self, j: usize, sliding: bool) -> f64 {
        let b = if self.n > INLINE_JOINTS {
            self.heap[j]
        } else {
            self.inline[j]
        };
        if sliding {
            b[0]
        } else {
            b[1]
        }
    }
}

/// Applies the friction return mapping to one continuous cable.
///
/// `lengths_m`, `dirs`: geometric length and unit direction (from `path[i]`
/// to `path[i+1]`) of each segment. `rest_m` holds the rest lengths: on
/// entry any guess (the last mapping's result is a good one), on exit the
/// mapped values; `slip` receives the joints' slip states.
///
/// The mapping is relative to `start`: joint `j` has moved
/// `Δ_j = Σ_{i<j} (rest_i − start_i)` of material into segment `j−1` since
/// the increment began, and the mapped state is the one in which every joint
/// either has `Δ_j = 0` with its tension ratio inside the capstan cone, or
/// sits on the bound of the side it slid towards. The answer depends on the
/// start and the current geometry only, not on the guess or on how the
/// geometry got here (backward Euler). Each joint is solved in turn from
/// `Δ_j = 0` given its neighbours (so a joint that over-slid earlier in the
/// sweep slides back), and sweeps repeat until one finds nothing to change.
///
/// The answer is found by active sets: `slip` on entry is a guess of the
/// joints' states (the last mapping's are a good one; stuck at the start of
/// an increment), the material is distributed for it exactly
/// ([`map_cable_with_slip`]), and joints that contradict the result are
/// flipped, until none does. Should that not settle in
/// [`MAX_ACTIVE_SET_ROUNDS`] rounds, Gauss–Seidel sweeps finish: each joint
/// is solved in turn from `Δ_j = 0` given its neighbours (so a joint that
/// over-slid earlier slides back), until a sweep finds nothing to change.
///
/// A joint exactly on its cone's edge counts as sliding (always so at
/// μ = 0): any further load slides it, which is what a tangent needs.
///
/// Returns the friction force left unbalanced at the joints, N: 0 from the
/// active-set solution, else the largest tension change of the last sweep.
#[allow(clippy::too_many_arguments)]
pub fn map_cable(
    ea_n: f64,
    lengths_m: &[f64],
    dirs: &[Vector3<f64>],
    rest_m: &mut [f64],
    slip: &mut [JointSlip],
    start: IncrementStart<'_>,
    friction: &JointFriction,
    tol_n: f64,
) -> f64 {
    let cones = JointCones::new(dirs, friction);
    for _ in 0..MAX_ACTIVE_SET_ROUNDS {
        distribute(ea_n, lengths_m, rest_m, slip, start, &cones);
        if !revise_slip(ea_n, lengths_m, rest_m, slip, start, &cones, tol_n) {
            return 0.0;
        }
    }
    map_cable_by_sweeps(ea_n, lengths_m, dirs, rest_m, slip, start, friction, tol_n)
}

/// Flips the joints whose slip state contradicts the material distribution
/// [`map_cable_with_slip`] gave for it: a stuck joint whose tension ratio
/// reaches its cone's edge (within `tol_n`) starts sliding towards its
/// higher tension; a sliding joint whose material moved the wrong way (by
/// more than `tol_n` of tension) sticks. Returns whether any joint changed.
#[allow(clippy::too_many_arguments)]
fn revise_slip(
    ea_n: f64,
    lengths_m: &[f64],
    rest_m: &[f64],
    slip: &mut [JointSlip],
    start: IncrementStart<'_>,
    cones: &JointCones,
    tol_n: f64,
) -> bool {
    let mut changed = false;
    let mut moved = 0.0;
    for j in 1..rest_m.len() {
        moved += rest_m[j - 1] - start.rest_m[j - 1];
        let revised = match slip[j] {
            JointSlip::Stuck => {
                let t_a = segment_tension(ea_n, lengths_m[j - 1], rest_m[j - 1]);
                let t_b = segment_tension(ea_n, lengths_m[j], rest_m[j]);
                let (towards_motor, hi, lo, sliding_this_way) =
                    would_slide(t_a, t_b, start.slip[j]);
                let b = cones.bound(j, sliding_this_way);
                if hi - b * lo >= -tol_n && hi > 0.0 {
                    if towards_motor {
                        JointSlip::TowardsMotor
                    } else {
                        JointSlip::TowardsEnd
                    }
                } else {
                    JointSlip::Stuck
                }
            }
            // Without friction at this angle either direction is right.
            s if cones.bound(j, true) == 1.0 => s,
            JointSlip::TowardsMotor if -moved * ea_n / rest_m[j - 1] > tol_n => JointSlip::Stuck,
            JointSlip::TowardsEnd if moved * ea_n / rest_m[j] > tol_n => JointSlip::Stuck,
            s => s,
        };
        if revised != slip[j] {
            slip[j] = revised;
            changed = true;
        }
    }
    changed
}

/// The sweeping form of [`map_cable`]: the fallback when active sets do not
/// settle. Returns the largest segment-tension change the last sweep made, N.
#[allow(clippy::too_many_arguments)]
fn map_cable_by_sweeps(
    ea_n: f64,
    lengths_m: &[f64],
    dirs: &[Vector3<f64>],
    rest_m: &mut [f64],
    slip: &mut [JointSlip],
    start: IncrementStart<'_>,
    friction: &JointFriction,
    tol_n: f64,
) -> f64 {
    let n = rest_m.len();
    if n < 2 {
        return 0.0;
    }
    let mut worst = 0.0;
    for _ in 0..MAX_SWEEPS {
        worst = 0.0;
        // Material moved into segments 0..j−1 since the start.
        let mut moved_before = 0.0;
        for j in 1..n {
            let (a, b) = (j - 1, j);
            let moved = moved_before + rest_m[a] - start.rest_m[a];
            // The joint's own trial: its slide undone, neighbours as they are.
            let (trial_a, trial_b) = (rest_m[a] - moved, rest_m[b] + moved);
            let theta = interior_angle(&dirs[a], &dirs[b]);
            let t_a = segment_tension(ea_n, lengths_m[a], trial_a);
            let t_b = segment_tension(ea_n, lengths_m[b], trial_b);
            let (towards_motor, t_hi, t_lo, sliding_this_way) =
                would_slide(t_a, t_b, start.slip[j]);
            let start_bound = friction.ratio_bound(theta, sliding_this_way);
            let violation = t_hi - start_bound * t_lo;
            let slide_label = if towards_motor {
                JointSlip::TowardsMotor
            } else {
                JointSlip::TowardsEnd
            };
            let (new_a, new_b, new_slip) = if violation < -tol_n {
                (trial_a, trial_b, JointSlip::Stuck)
            } else if violation <= tol_n {
                // On the cone's edge without moving (always so at μ = 0):
                // any further load slides it, so it counts as sliding for
                // the tangent.
                (trial_a, trial_b, slide_label)
            } else {
                // Slide from the trial onto the kinetic bound.
                let bound = friction.ratio_bound(theta, true);
                let (s_hi, l_hi, s_lo, l_lo) = if towards_motor {
                    (trial_a, lengths_m[a], trial_b, lengths_m[b])
                } else {
                    (trial_b, lengths_m[b], trial_a, lengths_m[a])
                };
                let delta = slide_to_bound(ea_n, l_hi, s_hi, l_lo, s_lo, bound, tol_n);
                if towards_motor {
                    (trial_a + delta, trial_b - delta, slide_label)
                } else {
                    (trial_a - delta, trial_b + delta, slide_label)
                }
            };
            // What this joint changed, in force: the sweep's convergence test.
            let change = (segment_tension(ea_n, lengths_m[a], new_a)
                - segment_tension(ea_n, lengths_m[a], rest_m[a]))
            .abs()
            .max(
                (segment_tension(ea_n, lengths_m[b], new_b)
                    - segment_tension(ea_n, lengths_m[b], rest_m[b]))
                .abs(),
            );
            if change > worst {
                worst = change;
            }
            rest_m[a] = new_a;
            rest_m[b] = new_b;
            slip[j] = new_slip;
            moved_before += rest_m[a] - start.rest_m[a];
        }
        if worst <= tol_n {
            break;
        }
    }
    worst
}

/// Material distribution of one cable for a *given* slip state of its
/// joints: the smooth problem an active-set Newton solves.
///
/// Segments joined by sliding joints form clusters. A cluster keeps the
/// material it started the increment with (its end joints are stuck or are
/// the cable's ends), and its tensions keep the ratios the sliding joints
/// impose, `T_i = w_i·T` (`T_{j−1} = b·T_j` sliding towards the motor,
/// `T_j = b·T_{j−1}` towards the end, `b` the kinetic bound). `T` solves
/// `Σ_i EA·L_i/(EA + w_i·T) = S`, which is monotone, by safeguarded Newton.
/// A cluster whose material exceeds its length is slack in every segment:
/// the material is shared out in proportion to length.
///
/// Whether the slip state was the right one, [`map_cable`] at the same
/// geometry says.
#[allow(clippy::too_many_arguments)]
pub fn map_cable_with_slip(
    ea_n: f64,
    lengths_m: &[f64],
    dirs: &[Vector3<f64>],
    rest_m: &mut [f64],
    slip: &[JointSlip],
    start: IncrementStart<'_>,
    friction: &JointFriction,
) {
    distribute(
        ea_n,
        lengths_m,
        rest_m,
        slip,
        start,
        &JointCones::new(dirs, friction),
    );
}

/// [`map_cable_with_slip`] with the cones computed.
fn distribute(
    ea_n: f64,
    lengths_m: &[f64],
    rest_m: &mut [f64],
    slip: &[JointSlip],
    start: IncrementStart<'_>,
    cones: &JointCones,
) {
    let n = rest_m.len();
    let mut first = 0;
    while first < n {
        let mut last = first;
        while last + 1 < n && slip[last + 1] != JointSlip::Stuck {
            last += 1;
        }
        // Tension ratios along the cluster.
        let mut w = [1.0f64; 64];
        let m = last - first + 1;
        let mut weights = Vec::new();
        let w: &mut [f64] = if m <= w.len() {
            &mut w[..m]
        } else {
            weights.resize(m, 1.0);
            &mut weights
        };
        for j in first + 1..=last {
            let b = cones.bound(j, true);
            let i = j - first;
            w[i] = match slip[j] {
                JointSlip::TowardsMotor => w[i - 1] / b,
                _ => w[i - 1] * b,
            };
        }
        if first == last {
            // A stuck segment keeps its material exactly.
            rest_m[first] = start.rest_m[first];
            first = last + 1;
            continue;
        }
        let material: f64 = start.rest_m[first..=last].iter().sum();
        let length: f64 = lengths_m[first..=last].iter().sum();
        if length <= material {
            // Slack as a whole: sliding joints let every segment go slack
            // (a joint with one slack side holds no tension on the other),
            // so the material is shared out in proportion to length.
            let scale = material / length;
            for (r, l) in rest_m[first..=last]
                .iter_mut()
                .zip(&lengths_m[first..=last])
            {
                *r = scale * l;
            }
        } else {
            let lens = &lengths_m[first..=last];
            let excess = |t: f64| -> (f64, f64) {
                let mut f = -material;
                let mut df = 0.0;
                for (l, wi) in lens.iter().zip(w.iter()) {
                    let denom = ea_n + wi * t;
                    f += ea_n * l / denom;
                    df -= ea_n * l * wi / (denom * denom);
                }
                (f, df)
            };
            // f(T) = Σ EA·L_i/(EA + w_i·T) − S is convex and decreasing with
            // f(0) > 0, so Newton from T = 0 climbs to the root from the left
            // without overshooting; nearly linear for T ≪ EA, it takes 2–4
            // steps.
            let mut t = 0.0f64;
            for _ in 0..50 {
                let (f, df) = excess(t);
                let step = -f / df;
                t += step;
                if !(step.abs() > 1e-12 * t.max(1.0)) {
                    break;
                }
            }
            for (i, r) in rest_m[first..=last].iter_mut().enumerate() {
                *r = ea_n * lens[i] / (ea_n + w[i] * t);
            }
        }
        first = last + 1;
    }
}

/// Material Δ ≥ 0 to move from the low-tension segment into the
/// high-tension one so that `T_hi = bound·T_lo`.
///
/// `g(Δ) = T_hi(s_hi + Δ) − bound·T_lo(s_lo − Δ)` is decreasing; `g(0) > 0`
/// and `g(L_hi − s_hi) ≤ 0` (the high side just slack) bracket the root.
/// Safeguarded Newton: the tension–rest-length curves are nearly linear over
/// the tiny slides of one iteration, so it converges in two or three steps.
fn slide_to_bound(
    ea_n: f64,
    l_hi: f64,
    s_hi: f64,
    l_lo: f64,
    s_lo: f64,
    bound: f64,
    tol_n: f64,
) -> f64 {
    let g = |d: f64| {
        segment_tension(ea_n, l_hi, s_hi + d) - bound * segment_tension(ea_n, l_lo, s_lo - d)
    };
    let dg = |d: f64| {
        let mut v = 0.0;
        if l_hi > s_hi + d {
            v -= ea_n * l_hi / ((s_hi + d) * (s_hi + d));
        }
        if l_lo > s_lo - d {
            v -= bound * ea_n * l_lo / ((s_lo - d) * (s_lo - d));
        }
        v
    };
    let mut lo = 0.0;
    // Never move more material than the low side holds.
    let mut hi = (l_hi - s_hi).min(0.999 * s_lo);
    let mut d = 0.0;
    let target = 1e-3 * tol_n;
    for _ in 0..60 {
        let gd = g(d);
        if gd.abs() <= target {
            break;
        }
        if gd > 0.0 {
            lo = d;
        } else {
            hi = d;
        }
        let slope = dg(d);
        let newton = if slope < 0.0 {
            d - gd / slope
        } else {
            f64::NAN
        };
        d = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo <= 1e-15 * (s_hi + s_lo) {
            break;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::friction::JointFriction;

    fn straight_dirs(n: usize) -> Vec<Vector3<f64>> {
        vec![Vector3::x(); n]
    }

    fn stuck(rest_m: &[f64]) -> IncrementStart<'_> {
        IncrementStart {
            rest_m,
            slip: &[JointSlip::Stuck; 8][..rest_m.len()],
        }
    }

    #[test]
    fn over_slid_joint_slides_back() {
        // Regression: a Gauss–Seidel sweep that only ever slides forward
        // leaves joint 1 over-slid once joint 2 has moved, so the result
        // depended on the DR path and did not converge as increments shrank.
        // Mapped from the start, the answer must not depend on the guess.
        let dirs = [Vector3::x(), Vector3::y(), Vector3::x()];
        let lengths = [1.0, 1.0, 1.0];
        let ea = 1e6;
        let t = |n: f64| 1.0 / (1.0 + n / ea);
        let start = [t(900.0), t(500.0), t(300.0)];
        let f = JointFriction::constant(0.2).unwrap();
        let mut from_start = start;
        let mut slip = [JointSlip::Stuck; 3];
        map_cable(
            ea,
            &lengths,
            &dirs,
            &mut from_start,
            &mut slip,
            stuck(&start),
            &f,
            1e-9,
        );
        // A wild guess (all material shifted to the end) maps to the same state.
        let mut from_guess = [start[0] - 1e-4, start[1], start[2] + 1e-4];
        map_cable(
            ea,
            &lengths,
            &dirs,
            &mut from_guess,
            &mut slip,
            stuck(&start),
            &f,
            1e-9,
        );
        for i in 0..3 {
            assert!(
                (from_start[i] - from_guess[i]).abs() < 1e-12,
                "{from_start:?} vs {from_guess:?}"
            );
        }
        let sum = |r: &[f64]| r.iter().sum::<f64>();
        assert!((sum(&from_start) - sum(&start)).abs() < 1e-15);
    }

    #[test]
    fn frictionless_mapping_equalises_tension() {
        let lengths = [1.0, 1.0, 1.0];
        let mut rest = [0.999, 0.9995, 0.998];
        let mut slip = [JointSlip::Stuck; 3];
        let total: f64 = rest.iter().sum();
        let f = JointFriction::frictionless();
        let start = rest;
        let left = map_cable(
            1e6,
            &lengths,
            &straight_dirs(3),
            &mut rest,
            &mut slip,
            IncrementStart {
                rest_m: &start,
                slip: &[JointSlip::Stuck; 3],
            },
            &f,
            1e-9,
        );
        assert!(left < 1e-6, "violation left {left}");
        let t: Vec<f64> = (0..3).map(|i| segment_tension(1e6, 1.0, rest[i])).collect();
        assert!(
            (t[0] - t[1]).abs() < 1e-6 && (t[1] - t[2]).abs() < 1e-6,
            "{t:?}"
        );
        let after: f64 = rest.iter().sum();
        assert!(
            (after - total).abs() < 1e-15,
            "sliding must conserve material"
        );
    }

    #[test]
    fn joint_inside_the_cone_does_not_slide() {
        // 90° wrap, μ = 0.2: bound e^(0.2·π/2) ≈ 1.37. Ratio 1.2 holds.
        let dirs = [Vector3::x(), Vector3::y()];
        let lengths = [1.0, 1.0];
        let ea = 1e6;
        let s_b = 1.0 / (1.0 + 500.0 / ea);
        let s_a = 1.0 / (1.0 + 600.0 / ea);
        let mut rest = [s_a, s_b];
        let mut slip = [JointSlip::Stuck; 2];
        let f = JointFriction::constant(0.2).unwrap();
        let start = rest;
        map_cable(
            ea,
            &lengths,
            &dirs,
            &mut rest,
            &mut slip,
            stuck(&start),
            &f,
            1e-9,
        );
        assert_eq!(rest, [s_a, s_b]);
        assert_eq!(slip[1], JointSlip::Stuck);
    }

    #[test]
    fn joint_outside_the_cone_slides_onto_the_bound() {
        let dirs = [Vector3::x(), Vector3::y()];
        let lengths = [1.0, 1.0];
        let ea = 1e6;
        let mut rest = [1.0 / (1.0 + 900.0 / ea), 1.0 / (1.0 + 500.0 / ea)];
        let mut slip = [JointSlip::Stuck; 2];
        let f = JointFriction::constant(0.2).unwrap();
        let start = rest;
        map_cable(
            ea,
            &lengths,
            &dirs,
            &mut rest,
            &mut slip,
            stuck(&start),
            &f,
            1e-9,
        );
        let t_a = segment_tension(ea, 1.0, rest[0]);
        let t_b = segment_tension(ea, 1.0, rest[1]);
        let bound = (0.2 * std::f64::consts::FRAC_PI_2).exp();
        assert!((t_a / t_b - bound).abs() < 1e-9, "ratio {}", t_a / t_b);
        assert_eq!(slip[1], JointSlip::TowardsMotor);
    }
}

#[cfg(test)]
mod slip_state_tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The active-set mapping and the sweeping one solve the same
        /// problem; where both converge they must agree.
        #[test]
        fn active_sets_and_sweeps_agree(
            // Negative "tensions" start a segment slack by that much.
            t in proptest::collection::vec(-300.0f64..1500.0, 5),
            bend in proptest::collection::vec(-0.6f64..0.6, 5),
            mu in 0.0f64..0.4,
        ) {
            let dirs: Vec<Vector3<f64>> = bend
                .iter()
                .enumerate()
                .map(|(i, b)| Vector3::new(1.0, *b, 0.3 * (i as f64 - 2.0) * b).normalize())
                .collect();
            let lengths = [0.6, 0.7, 0.65, 0.5, 0.55];
            let ea = 7e5;
            let start: Vec<f64> = lengths.iter().zip(&t).map(|(l, n)| l / (1.0 + n / ea)).collect();
            let f = JointFriction::constant(mu).unwrap();
            let stuck = [JointSlip::Stuck; 5];
            let begin = IncrementStart { rest_m: &start, slip: &stuck };
            let mut active = start.clone();
            let mut slip_a = stuck;
            map_cable(ea, &lengths, &dirs, &mut active, &mut slip_a, begin, &f, 1e-9);
            let mut swept = start.clone();
            let mut slip_s = stuck;
            let left = map_cable_by_sweeps(ea, &lengths, &dirs, &mut swept, &mut slip_s, begin, &f, 1e-9);
            prop_assume!(left <= 1e-9);
            for i in 0..5 {
                let (a, b) = (segment_tension(ea, lengths[i], active[i]), segment_tension(ea, lengths[i], swept[i]));
                prop_assert!((a - b).abs() < 1e-6, "segment {}: {} vs {} ({:?} vs {:?})", i, a, b, slip_a, slip_s);
            }
        }
    }

    #[test]
    fn mapping_with_the_mappings_own_slip_states_reproduces_it() {
        let dirs: Vec<Vector3<f64>> = [
            Vector3::new(1.0, 0.2, 0.0),
            Vector3::new(1.0, -0.3, 0.1),
            Vector3::new(0.8, 0.4, -0.2),
            Vector3::new(1.0, 0.0, 0.3),
        ]
        .iter()
        .map(|d| d.normalize())
        .collect();
        let lengths = [0.6, 0.7, 0.65, 0.5];
        let ea = 7e5;
        let t = |l: f64, n: f64| l / (1.0 + n / ea);
        for tensions in [
            [900.0, 500.0, 480.0, 300.0],
            [300.0, 520.0, 800.0, 790.0],
            [550.0, 550.0, 560.0, 900.0],
        ] {
            let start: Vec<f64> = lengths
                .iter()
                .zip(tensions)
                .map(|(l, n)| t(*l, n))
                .collect();
            let f = JointFriction::constant(0.2).unwrap();
            let stuck = [JointSlip::Stuck; 4];
            let begin = IncrementStart {
                rest_m: &start,
                slip: &stuck,
            };
            let mut mapped = start.clone();
            let mut slip = [JointSlip::Stuck; 4];
            map_cable(ea, &lengths, &dirs, &mut mapped, &mut slip, begin, &f, 1e-9);
            let mut again = start.clone();
            map_cable_with_slip(ea, &lengths, &dirs, &mut again, &slip, begin, &f);
            for i in 0..4 {
                let (a, b) = (
                    segment_tension(ea, lengths[i], mapped[i]),
                    segment_tension(ea, lengths[i], again[i]),
                );
                assert!(
                    (a - b).abs() < 1e-6,
                    "{tensions:?} {slip:?}: segment {i}: {a} vs {b}"
                );
            }
        }
    }
}
