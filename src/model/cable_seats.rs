//! Joint eccentricity: a continuous cable does not pass through the centre
//! of a joint but over a cable seat of radius `r` around it, so it wraps an
//! arc of length `r·φ` there, with `φ` the wrap angle (the angle the cable
//! turns through, π minus the interior angle).
//!
//! # How it is modelled
//! The seats sit around the node centres, so the straight runs between two
//! seats are parallel to the line between the centres and as long as it
//! (exactly, for a bend in one plane; to `O((r/d)²)` ≈ 1e-3 relative at
//! r = 30 mm and d = 1 m otherwise), and the forces on the joints keep
//! their directions. What changes is the material: the arc on each seat
//! holds `r·φ` of cable that the straight runs no longer have. Each
//! segment lends half the arc at each of its ends, so the material that
//! stretches over the centre-to-centre length of segment `j` is its own
//! minus [`seat_material_m`]`[j]`.
//!
//! The as-built state has its arcs already wrapped (the cable was cut to
//! the design prestress on the real joints), so only *changes* of the wrap
//! angles move material: a model with seats subtracts the change of
//! [`seat_material_m`] since the last solve from each segment at the end
//! of every command and solves again until the arcs stop changing (see
//! [`crate::model::solver::seats`]).

use nalgebra::Vector3;

use super::structure::Structure;

/// The cable held on the seats at each end of every continuous-cable
/// segment, m, flat in segment order (cable by cable, motor first): half of
/// `seat_radius_m·φ` from each end joint. Cable ends (drum and anchor) have
/// no seat.
pub fn seat_material_m(
    structure: &Structure,
    positions_m: &[Vector3<f64>],
    seat_radius_m: f64,
) -> Vec<f64> {
    let mut out = Vec::with_capacity(structure.segment_count());
    for c in &structure.continuous_cables {
        let start = out.len();
        out.resize(start + c.segment_count(), 0.0);
        for (k, w) in c.path.windows(3).enumerate() {
            let into = (positions_m[w[1]] - positions_m[w[0]]).normalize();
            let out_of = (positions_m[w[2]] - positions_m[w[1]]).normalize();
            let wrap_rad = into.dot(&out_of).clamp(-1.0, 1.0).acos();
            let half_arc_m = 0.5 * seat_radius_m * wrap_rad;
            // Joint k+1 of the path lies between segments k and k+1.
            out[start + k] += half_arc_m;
            out[start + k + 1] += half_arc_m;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use std::f64::consts::PI;

    #[test]
    fn a_right_angle_bend_holds_a_quarter_circle_split_between_its_segments() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let c = &s.continuous_cables[0];
        // Put the first three path nodes on a right angle.
        let mut x = s.reference_positions();
        x[c.path[0]] = Vector3::new(0.0, 0.0, 0.0);
        x[c.path[1]] = Vector3::new(1.0, 0.0, 0.0);
        x[c.path[2]] = Vector3::new(1.0, 2.0, 0.0);
        let r = 0.02;
        let m = seat_material_m(&s, &x, r);
        assert_eq!(m.len(), s.segment_count());
        assert!((m[0] - 0.5 * r * PI / 2.0).abs() < 1e-15);
        // The second segment also lends to the next joint.
        let next = (x[c.path[2]] - x[c.path[1]])
            .normalize()
            .dot(&(x[c.path[3]] - x[c.path[2]]).normalize())
            .acos();
        assert!((m[1] - 0.5 * r * (PI / 2.0 + next)).abs() < 1e-15);
    }

    #[test]
    fn the_total_is_the_radius_times_the_sum_of_wrap_angles() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let x = s.reference_positions();
        let r = 0.015;
        let m = seat_material_m(&s, &x, r);
        let mut offset = 0;
        for c in &s.continuous_cables {
            let total: f64 = m[offset..offset + c.segment_count()].iter().sum();
            let wraps: f64 = c
                .path
                .windows(3)
                .map(|w| {
                    let a = x[w[1]] - x[w[0]];
                    let b = x[w[2]] - x[w[1]];
                    a.angle(&b)
                })
                .sum();
            assert!((total - r * wraps).abs() < 1e-14);
            // The cable ends lend to one joint only.
            assert!(m[offset] > 0.0 && m[offset + c.segment_count() - 1] > 0.0);
            offset += c.segment_count();
        }
        assert_eq!(seat_material_m(&s, &x, 0.0), vec![0.0; s.segment_count()]);
    }
}
