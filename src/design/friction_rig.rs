//! The seed's friction rig: a cable over one joint seat between two nearly
//! frictionless pulleys 400 mm apart, the seat raised to set the interior
//! angle θ; baskets of weights load both ends.
//!
//! Modelled as a continuous cable of two segments `P1 → J → P2` with all
//! three nodes held, so that only the sliding over `J` can move: the pulleys
//! fix the tensions on each side, which is what the rig does.

use nalgebra::Vector3;

use crate::model::{
    ContinuousCable, ForwardModel, JointFriction, Node, RelaxReport, RelaxSettings, Structure,
    Workspace,
};

/// Centre distance of the rig's pulleys, m (seed: 400 mm).
pub const PULLEY_SPACING_M: f64 = 0.4;
/// Axial stiffness of the rig's 4 mm braided steel cable, N (as the bridge).
pub const RIG_CABLE_EA_N: f64 = 7.0e5;

/// The rig with interior angle θ and the cable pre-loaded to `tension_p1_n`
/// on the first side and `tension_p2_n` on the second.
pub fn friction_rig(interior_angle_rad: f64, tension_p1_n: f64, tension_p2_n: f64) -> Structure {
    let half = 0.5 * PULLEY_SPACING_M;
    let height = half / (0.5 * interior_angle_rad).tan();
    let node = |id: &str, x: f64, z: f64| Node {
        id: id.into(),
        position_m: Vector3::new(x, 0.0, z),
        mass_kg: 0.0,
        fixed: [true; 3],
        load_n: Vector3::zeros(),
    };
    let nodes = vec![
        node("P1", -half, 0.0),
        node("J", 0.0, height),
        node("P2", half, 0.0),
    ];
    let length = (half * half + height * height).sqrt();
    let rest = |t: f64| length * RIG_CABLE_EA_N / (RIG_CABLE_EA_N + t);
    let cable = ContinuousCable {
        id: "rig".into(),
        path: vec![0, 1, 2],
        ea_n: RIG_CABLE_EA_N,
        segment_rest_lengths_m: vec![rest(tension_p1_n), rest(tension_p2_n)],
    };
    Structure::new(
        "friction rig",
        nodes,
        vec![],
        vec![cable],
        Vector3::zeros(),
        vec![],
    )
    .expect("the rig is a valid structure for any angle in (0, π)")
}

/// What one loading of the rig did.
#[derive(Debug, Clone, PartialEq)]
pub struct RigOutcome {
    /// The solve.
    pub report: RelaxReport,
    /// Material that slid over the joint, m (positive towards P1).
    pub slide_m: f64,
    /// Tension on each side after the solve, N.
    pub tensions_n: [f64; 2],
}

/// Loads the rig to the given tensions and lets the joint stick or slide.
pub fn load_rig(
    friction: &JointFriction,
    interior_angle_rad: f64,
    tension_p1_n: f64,
    tension_p2_n: f64,
) -> RigOutcome {
    let structure = friction_rig(interior_angle_rad, tension_p1_n, tension_p2_n);
    let settings = RelaxSettings {
        tol_force_rel: 1e-12,
        ..RelaxSettings::default()
    };
    let model = ForwardModel::new(structure, friction.clone(), settings)
        .expect("the rig's constant settings are valid");
    let mut state = model.reference_state();
    let before = state.segment_rest_lengths_m[0];
    let report = model.relax(&mut state, &mut Workspace::default());
    let forces = model.member_forces(&state);
    RigOutcome {
        report,
        slide_m: state.segment_rest_lengths_m[0] - before,
        tensions_n: [forces.segment_n[0], forces.segment_n[1]],
    }
}

/// Smallest load ratio `T_high/T_low` at which the modelled joint slides,
/// found by bisection on the model itself (not on the formula), to a
/// relative precision of 1e-10.
pub fn modelled_slip_ratio(
    friction: &JointFriction,
    interior_angle_rad: f64,
    tension_low_n: f64,
) -> f64 {
    let slides = |ratio: f64| {
        load_rig(
            friction,
            interior_angle_rad,
            tension_low_n,
            ratio * tension_low_n,
        )
        .slide_m
            != 0.0
    };
    let (mut lo, mut hi) = (1.0, 2.0);
    while !slides(hi) {
        lo = hi;
        hi *= 2.0;
    }
    while (hi - lo) > 1e-10 * lo {
        let mid = 0.5 * (lo + hi);
        if slides(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}
