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
/// unused), each computed when first asked for and kept for the rest of
/// the mapping: the angle (an `acos`) and the bound (an `exp`) are most of
/// a mapping's cost, and a joint that sticks with room to spare never
/// needs them (see [`Self::reaches_edge`]).
struct JointCones<'a> {
    dirs: &'a [Vector3<f64>],
    friction: &'a JointFriction,
    /// `[kinetic, static]` bounds of each joint; NaN until computed.
    inline: [[f64; 2]; INLINE_JOINTS],
    heap: Vec<[f64; 2]>,
}

impl<'a> JointCones<'a> {
    fn new(dirs: &'a [Vector3<f64>], friction: &'a JointFriction) -> Self {
        let n = dirs.len();
        JointCones {
            dirs,
            friction,
            inline: [[f64::NAN; 2]; INLINE_JOINTS],
            heap: if n > INLINE_JOINTS {
                vec![[f64::NAN; 2]; n]
            } else {
                Vec::new()
            },
        }
    }

    /// The bound at joint `j`: kinetic while sliding, else static.
    fn bound(&mut self, j: usize, sliding: bool) -> f64 {
        let (dirs, friction) = (self.dirs, self.friction);
        let b = if dirs.len() > INLINE_JOINTS {
            &mut self.heap[j]
        } else {
            &mut self.inline[j]
        };
        if b[0].is_nan() {
            let theta = interior_angle(&dirs[j - 1], &dirs[j]);
            b[0] = friction.ratio_bound(theta, true);
            b[1] = if friction.static_mu == friction.kinetic_mu {
                b[0]
            } else {
                friction.ratio_bound(theta, false)
            };
        }
        if sliding {
            b[0]
        } else {
            b[1]
        }
    }

    /// Whether joint `j`, between tensions `hi ≥ lo`, reaches its cone's
    /// edge within `tol_n`: `hi − b·lo ≥ −tol_n` for its bound `b`
    /// (kinetic if `sliding`, else static). Decided without the bound where
    /// a floor of it ([`JointFriction::ratio_bound_floor`]) already says
    /// no: `floor ≤ b` makes `hi − floor·lo ≥ hi − b·lo` in floating point
    /// too (the products and the difference round monotonically), so the
    /// answer is the same as from the bound itself, NaN included.
    fn reaches_edge(&mut self, j: usize, sliding: bool, hi: f64, lo: f64, tol_n: f64) -> bool {
        let cos_interior = -self.dirs[j - 1].dot(&self.dirs[j]);
        let floor = self.friction.ratio_bound_floor(cos_interior, sliding);
        if hi - floor * lo < -tol_n {
            return false;
        }
        hi - self.bound(j, sliding) * lo >= -tol_n
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
/// `MAX_ACTIVE_SET_ROUNDS` rounds, Gauss–Seidel sweeps finish: each joint
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
    let mut cones = JointCones::new(dirs, friction);
    for _ in 0..MAX_ACTIVE_SET_ROUNDS {
        distribute(ea_n, lengths_m, rest_m, slip, start, &mut cones);
        if !revise_slip(ea_n, lengths_m, rest_m, slip, start, &mut cones, tol_n) {
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
    cones: &mut JointCones<'_>,
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
                if cones.reaches_edge(j, sliding_this_way, hi, lo, tol_n) && hi > 0.0 {
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
        &mut JointCones::new(dirs, friction),
    );
}

/// [`map_cable_with_slip`] with the cones computed. `rest_m` on entry is
/// only a starting guess for the cluster tensions (see
/// [`cluster_tension`]); the result does not depend on it.
fn distribute(
    ea_n: f64,
    lengths_m: &[f64],
    rest_m: &mut [f64],
    slip: &[JointSlip],
    start: IncrementStart<'_>,
    cones: &mut JointCones<'_>,
) {
    let n = rest_m.len();
    let mut first = 0;
    while first < n {
        let mut last = first;
        while last + 1 < n && slip[last + 1] != JointSlip::Stuck {
            last += 1;
        }
        if first == last {
            // A stuck segment keeps its material exactly (the common case:
            // no weights to build, nothing to solve).
            rest_m[first] = start.rest_m[first];
        } else {
            distribute_cluster(
                ea_n,
                &lengths_m[first..=last],
                &mut rest_m[first..=last],
                &slip[first..=last],
                &start.rest_m[first..=last],
                |j| cones.bound(first + j, true),
            );
        }
        first = last + 1;
    }
}

/// Segments a sliding cluster may have before its tension ratios spill to
/// the heap.
const INLINE_CLUSTER: usize = 16;

/// Distributes the material `start_rest_m` of one cluster of segments
/// joined by sliding joints (`slip[0]` is the joint before the cluster and
/// ignored) over it, with `kinetic_bound(j)` the kinetic bound at the
/// cluster's joint `j` (1-based within the cluster).
fn distribute_cluster(
    ea_n: f64,
    lens: &[f64],
    rest_m: &mut [f64],
    slip: &[JointSlip],
    start_rest_m: &[f64],
    mut kinetic_bound: impl FnMut(usize) -> f64,
) {
    let m = lens.len();
    let material: f64 = start_rest_m.iter().sum();
    let length: f64 = lens.iter().sum();
    if length <= material {
        // Slack as a whole: sliding joints let every segment go slack
        // (a joint with one slack side holds no tension on the other),
        // so the material is shared out in proportion to length.
        let scale = material / length;
        for (r, l) in rest_m.iter_mut().zip(lens) {
            *r = scale * l;
        }
        return;
    }
    // Tension ratios along the cluster, w_0 = 1.
    let mut inline = [1.0f64; INLINE_CLUSTER];
    let mut heap = Vec::new();
    let w: &mut [f64] = if m <= INLINE_CLUSTER {
        &mut inline[..m]
    } else {
        heap.resize(m, 1.0);
        &mut heap
    };
    for i in 1..m {
        let b = kinetic_bound(i);
        w[i] = match slip[i] {
            JointSlip::TowardsMotor => w[i - 1] / b,
            _ => w[i - 1] * b,
        };
    }
    // The tension the guess gives the first segment (w_0 = 1): close to
    // the answer when the guess is the last mapping's result.
    let guess = segment_tension(ea_n, lens[0], rest_m[0]);
    let (t, _) = cluster_tension(ea_n, lens, w, material, guess);
    for ((r, l), wi) in rest_m.iter_mut().zip(lens).zip(w.iter()) {
        *r = ea_n * l / (ea_n + wi * t);
    }
}

/// The cluster tension `T ≥ 0`, N, at which segments of lengths `lens`
/// with tensions `w_i·T` hold `material` m in all:
/// `f(T) = Σ EA·L_i/(EA + w_i·T) − material = 0`, for a cluster that is
/// taut (`Σ L_i > material`, so `f(0) > 0`).
///
/// `f` is convex and decreasing, so Newton from a point left of the root
/// climbs to it monotonically without overshooting, and from a point right
/// of it overshoots once, to the left (the tangent of a convex function
/// lies below it), then climbs. The start is `guess_n` (the last mapping's
/// tension: one or two steps from the root over a DR iteration's motion)
/// where it is a finite non-negative number, else 0; an overshoot below 0
/// is clamped to 0, where `f > 0`. Nearly linear for `T ≪ EA`, it takes
/// 2–4 steps from 0. Returns `T` and the evaluations of `f` it took.
fn cluster_tension(
    ea_n: f64,
    lens: &[f64],
    w: &[f64],
    material: f64,
    guess_n: f64,
) -> (f64, usize) {
    let excess = |t: f64| -> (f64, f64) {
        let mut f = -material;
        let mut df = 0.0;
        for (l, wi) in lens.iter().zip(w) {
            let denom = ea_n + wi * t;
            let part = ea_n * l / denom;
            f += part;
            df -= part * wi / denom;
        }
        (f, df)
    };
    let mut t = if guess_n.is_finite() && guess_n > 0.0 {
        guess_n
    } else {
        0.0
    };
    // Exact Newton left of the root stays left with f falling. Once f is
    // down to its rounding (a few ε·S: T to ~1e-10 N at EA ~ 1e6 N, as
    // much as 1e-12·T at a few hundred newtons, so the step test may never
    // pass) a step that crosses the root or does not lower f is noise: the
    // better of the last two iterates is as close as T gets. Without this
    // test, such solves ran all 50 steps (once most of a mapping's cost).
    // f sums m + 1 numbers of the material's size, so it is known to a few
    // ε·S and T to that over |f′|: a smaller step is noise, from either
    // side of the root (a start at the root stops after one evaluation).
    let f_rounding = 4.0 * (lens.len() + 1) as f64 * f64::EPSILON * material;
    let mut evaluations = 0;
    let mut previous: Option<(f64, f64)> = None;
    for _ in 0..50 {
        let (f, df) = excess(t);
        evaluations += 1;
        if let Some((f_prev, t_prev)) = previous {
            if f_prev > 0.0 && !(f > 0.0 && f < f_prev) {
                if !(f.abs() <= f_prev) {
                    t = t_prev;
                }
                break;
            }
        }
        if f == 0.0 {
            break;
        }
        previous = Some((f, t));
        let next = t - f / df;
        // A NaN stays a NaN (and reaches the residual's divergence test).
        let next = if next < 0.0 { 0.0 } else { next };
        let moved = next - t;
        t = next;
        if !(moved.abs() > (1e-12 * t.max(1.0)).max(f_rounding / df.abs())) {
            break;
        }
    }
    (t, evaluations)
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

    proptest! {
        /// Newton for a cluster's tension from any guess (the last
        /// mapping's tension, a wild one, none) ends where the cold start
        /// from T = 0 does: rest lengths to 1e-12 relative, T to its
        /// rounding. The guess only saves steps.
        #[test]
        fn warm_started_cluster_tension_equals_the_cold_one(
            tensions in proptest::collection::vec(50.0f64..2000.0, 1..6),
            log_ratio in proptest::collection::vec(-0.4f64..0.4, 6),
            guess_factor in 0.0f64..3.0,
            guess_shift in -5.0f64..5.0,
            ea in 5e5f64..3e6,
        ) {
            let m = tensions.len();
            let lens: Vec<f64> = (0..m).map(|i| 0.5 + 0.05 * i as f64).collect();
            let mut w = vec![1.0; m];
            for i in 1..m {
                w[i] = w[i - 1] * log_ratio[i].exp();
            }
            let material: f64 = lens.iter().zip(&tensions).map(|(l, t)| l / (1.0 + t / ea)).sum();
            let (cold, cold_evaluations) = cluster_tension(ea, &lens, &w, material, 0.0);
            // Nearly linear at strains ~1e-3: a handful of steps from 0,
            // and at most two from the answer itself (once the 50-step
            // limit, in rounding noise).
            prop_assert!(cold_evaluations <= 6, "{} evaluations", cold_evaluations);
            prop_assert!(cluster_tension(ea, &lens, &w, material, cold).1 <= 2);
            // The residual at the cold answer is at rounding level.
            let f: f64 = lens.iter().zip(&w).map(|(l, wi)| ea * l / (ea + wi * cold)).sum::<f64>() - material;
            prop_assert!(f.abs() < 1e-13 * material, "f = {}", f);
            // T itself is only defined to the rounding of f over its slope
            // (f sums m + 1 numbers near the material, a few ε·S, over
            // |f'| ≈ ΣL/EA): about 1e-10 N here. The rest lengths it gives, what the
            // mapping returns, agree far closer than 1e-12 relative.
            let slope: f64 = lens.iter().zip(&w).map(|(l, wi)| ea * l * wi / (ea + wi * cold).powi(2)).sum();
            let t_tol = 10.0 * (m + 1) as f64 * f64::EPSILON * material / slope;
            for guess in [cold, cold * guess_factor, cold + guess_shift, 1e9, f64::NAN, -1.0] {
                let (warm, _) = cluster_tension(ea, &lens, &w, material, guess);
                prop_assert!((warm - cold).abs() <= t_tol, "guess {}: {} vs {}", guess, warm, cold);
                for (l, wi) in lens.iter().zip(&w) {
                    let (a, b) = (ea * l / (ea + wi * warm), ea * l / (ea + wi * cold));
                    prop_assert!((a - b).abs() <= 1e-12 * b, "guess {}: rest {} vs {}", guess, a, b);
                }
            }
        }

        /// The lazily computed cones equal the bound from the angle, and
        /// the floor's shortcut decides a joint as the bound would.
        #[test]
        fn lazy_cones_equal_fresh_ones(
            bend in proptest::collection::vec(-1.5f64..1.5, 4),
            mu_s in 0.0f64..0.5,
            mu_k in 0.0f64..0.5,
            hi in 0.0f64..2000.0,
            ratio in 0.2f64..1.0,
        ) {
            let dirs: Vec<Vector3<f64>> = bend
                .iter()
                .enumerate()
                .map(|(i, b)| Vector3::new(b.cos(), b.sin(), 0.1 * i as f64).normalize())
                .collect();
            let f = JointFriction::with_kinetic(
                crate::model::friction::FrictionCoefficient::Constant(mu_s),
                crate::model::friction::FrictionCoefficient::Constant(mu_k),
                crate::model::friction::AngleConvention::Wrap,
            ).unwrap();
            let mut cones = JointCones::new(&dirs, &f);
            let lo = ratio * hi;
            for j in 1..dirs.len() {
                let theta = interior_angle(&dirs[j - 1], &dirs[j]);
                for sliding in [false, true] {
                    let b = f.ratio_bound(theta, sliding);
                    let tol = 1e-3;
                    let by_bound = hi - b * lo >= -tol;
                    prop_assert_eq!(cones.reaches_edge(j, sliding, hi, lo, tol), by_bound);
                    prop_assert_eq!(cones.bound(j, sliding), b);
                }
            }
        }
    }

    /// A four-segment cable bent at every joint: segment directions,
    /// lengths (m) and EA (N).
    fn bent_cable() -> (Vec<Vector3<f64>>, [f64; 4], f64) {
        let dirs = [
            Vector3::new(1.0, 0.2, 0.0),
            Vector3::new(1.0, -0.3, 0.1),
            Vector3::new(0.8, 0.4, -0.2),
            Vector3::new(1.0, 0.0, 0.3),
        ]
        .iter()
        .map(|d| d.normalize())
        .collect();
        (dirs, [0.6, 0.7, 0.65, 0.5], 7e5)
    }

    #[test]
    fn a_warm_guess_does_not_change_the_distribution() {
        // Joint 1 slides towards the motor, joint 2 towards the end, joint
        // 3 sticks: one cluster of three segments and one stuck segment.
        let (dirs, lengths, ea) = bent_cable();
        let start: Vec<f64> = lengths
            .iter()
            .zip([700.0, 500.0, 650.0, 300.0])
            .map(|(l, n)| l / (1.0 + n / ea))
            .collect();
        let slip = [
            JointSlip::Stuck,
            JointSlip::TowardsMotor,
            JointSlip::TowardsEnd,
            JointSlip::Stuck,
        ];
        let begin = IncrementStart {
            rest_m: &start,
            slip: &[JointSlip::Stuck; 4],
        };
        let f = JointFriction::constant(0.2).unwrap();
        // Cold: a slack first segment in the guess starts Newton at T = 0.
        let mut cold = lengths.to_vec();
        cold[0] = 2.0 * lengths[0];
        map_cable_with_slip(ea, &lengths, &dirs, &mut cold, &slip, begin, &f);
        assert!(segment_tension(ea, lengths[0], cold[0]) > 100.0);
        for guess in [cold.clone(), start.clone(), vec![0.5; 4]] {
            let mut warm = guess;
            map_cable_with_slip(ea, &lengths, &dirs, &mut warm, &slip, begin, &f);
            for i in 0..4 {
                assert!(
                    (warm[i] - cold[i]).abs() <= 1e-12 * cold[i],
                    "{warm:?} vs {cold:?}"
                );
            }
        }
        // Material is conserved within the cluster; the stuck segment keeps its own.
        let sum = |r: &[f64]| r[..3].iter().sum::<f64>();
        assert!((sum(&cold) - sum(&start)).abs() < 1e-14);
        assert_eq!(cold[3], start[3]);
    }

    #[test]
    fn mapping_with_the_mappings_own_slip_states_reproduces_it() {
        let (dirs, lengths, ea) = bent_cable();
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
