//! The seed's friction rig: a cable over one joint seat between two nearly
//! frictionless pulleys 400 mm apart, the seat raised to set the interior
//! angle θ; baskets of weights load both ends.
//!
//! Modelled as a continuous cable of two segments `P1 → J → P2` with all
//! three nodes held, so that only the sliding over `J` can move: the pulleys
//! fix the tensions on each side, which is what the rig does.

use nalgebra::Vector3;
use thiserror::Error;

use crate::model::{
    ContinuousCable, ForwardModel, JointFriction, Node, RelaxReport, RelaxSettings, RelaxStatus,
    SettingsError, Structure, StructureError, Workspace,
};

/// Centre distance of the rig's pulleys, m (seed: 400 mm).
pub const PULLEY_SPACING_M: f64 = 0.4;
/// Axial stiffness of the rig's 4 mm braided steel cable, N (as the bridge).
pub const RIG_CABLE_EA_N: f64 = 7.0e5;

/// Smallest interior angle the rig is built for, rad (1°): the seat then
/// stands 11 m above the pulleys; below it the geometry degenerates.
pub const MIN_RIG_ANGLE_RAD: f64 = std::f64::consts::PI / 180.0;
/// Largest interior angle, rad (179°): a nearly straight cable, 1.7 mm of
/// seat height.
pub const MAX_RIG_ANGLE_RAD: f64 = 179.0 * std::f64::consts::PI / 180.0;
/// Largest tension on either side of the rig, N (10 MN, fifty times the
/// breaking load of a 4 mm cable): a larger one is an input slip.
pub const MAX_RIG_TENSION_N: f64 = 1e7;
/// Doublings of the load ratio [`modelled_slip_ratio`] tries before it
/// gives up (a ratio of 2⁶⁰ exceeds any capstan bound with μ ≤ 2 … by far).
pub const MAX_RATIO_DOUBLINGS: usize = 60;

/// A rig that cannot be built or loaded.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RigError {
    /// The interior angle is not a finite number in
    /// [[`MIN_RIG_ANGLE_RAD`], [`MAX_RIG_ANGLE_RAD`]].
    #[error("interior angle {angle_deg}° is outside the rig's range [1°, 179°]")]
    Angle {
        /// The angle, degrees.
        angle_deg: f64,
    },
    /// A tension is not a finite number in (0, [`MAX_RIG_TENSION_N`]].
    #[error("rig tension {tension_n} N is outside (0, 1e7] N")]
    Tension {
        /// The tension, N.
        tension_n: f64,
    },
    /// The rig's structure failed validation.
    #[error("the rig is not a valid structure: {0}")]
    Structure(#[from] StructureError),
    /// The rig's solver settings were rejected.
    #[error("the rig's solver settings: {0}")]
    Settings(#[from] SettingsError),
    /// A loading of the rig did not reach equilibrium.
    #[error("loading the rig at a ratio of {ratio}: {}", .status.describe())]
    NotConverged {
        /// Load ratio `T_high/T_low` tried.
        ratio: f64,
        /// How the solve ended.
        status: RelaxStatus,
    },
    /// The joint still held at a ratio of 2^[`MAX_RATIO_DOUBLINGS`].
    #[error("the joint never slipped up to a load ratio of 2^{MAX_RATIO_DOUBLINGS}")]
    NeverSlips,
}

/// The rig with interior angle θ and the cable pre-loaded to `tension_p1_n`
/// on the first side and `tension_p2_n` on the second.
pub fn friction_rig(
    interior_angle_rad: f64,
    tension_p1_n: f64,
    tension_p2_n: f64,
) -> Result<Structure, RigError> {
    // `!(…)` so that NaN fails too.
    if !(MIN_RIG_ANGLE_RAD..=MAX_RIG_ANGLE_RAD).contains(&interior_angle_rad) {
        return Err(RigError::Angle {
            angle_deg: interior_angle_rad.to_degrees(),
        });
    }
    for t in [tension_p1_n, tension_p2_n] {
        if !(t > 0.0 && t <= MAX_RIG_TENSION_N) {
            return Err(RigError::Tension { tension_n: t });
        }
    }
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
    Ok(Structure::new(
        "friction rig",
        nodes,
        vec![],
        vec![cable],
        Vector3::zeros(),
        vec![],
    )?)
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
) -> Result<RigOutcome, RigError> {
    let structure = friction_rig(interior_angle_rad, tension_p1_n, tension_p2_n)?;
    let settings = RelaxSettings {
        tol_force_rel: 1e-12,
        ..RelaxSettings::default()
    };
    let model = ForwardModel::new(structure, friction.clone(), settings)?;
    let mut state = model.reference_state();
    let before = state.segment_rest_lengths_m[0];
    let report = model.relax(&mut state, &mut Workspace::default());
    let forces = model.member_forces(&state);
    Ok(RigOutcome {
        report,
        slide_m: state.segment_rest_lengths_m[0] - before,
        tensions_n: [forces.segment_n[0], forces.segment_n[1]],
    })
}

/// Smallest load ratio `T_high/T_low` at which the modelled joint slides,
/// found by bisection on the model itself (not on the formula), to a
/// relative precision of 1e-10. The search is bounded: at most
/// [`MAX_RATIO_DOUBLINGS`] doublings, then about 35 bisections; a solve
/// that does not converge, or a high tension beyond [`MAX_RIG_TENSION_N`],
/// ends it with an error.
pub fn modelled_slip_ratio(
    friction: &JointFriction,
    interior_angle_rad: f64,
    tension_low_n: f64,
) -> Result<f64, RigError> {
    let slides = |ratio: f64| -> Result<bool, RigError> {
        let out = load_rig(
            friction,
            interior_angle_rad,
            tension_low_n,
            ratio * tension_low_n,
        )?;
        if !out.report.status.is_converged() {
            return Err(RigError::NotConverged {
                ratio,
                status: out.report.status,
            });
        }
        Ok(out.slide_m != 0.0)
    };
    let (mut lo, mut hi) = (1.0, 2.0);
    let mut doublings = 0;
    while !slides(hi)? {
        doublings += 1;
        if doublings > MAX_RATIO_DOUBLINGS {
            return Err(RigError::NeverSlips);
        }
        lo = hi;
        hi *= 2.0;
    }
    while (hi - lo) > 1e-10 * lo {
        let mid = 0.5 * (lo + hi);
        if slides(mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(hi)
}

/// One slip of the rig, and the friction coefficient the seed's
/// back-calculation makes of it with either angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigSlip {
    /// Interior angle θ at the seat, degrees.
    pub interior_angle_deg: f64,
    /// Tension on the low side, kN.
    pub tension_kn: f64,
    /// Load ratio `T_high/T_low` at which the modelled joint slides
    /// ([`modelled_slip_ratio`]).
    pub modelled_ratio: f64,
    /// The capstan formula's ratio `e^(μα)` with the model's convention.
    pub formula_ratio: f64,
    /// Extra load on the high side at the slip, N.
    pub slip_load_n: f64,
    /// μ back-calculated with the interior angle θ (the seed's way).
    pub mu_interior: f64,
    /// μ back-calculated with the wrap angle π − θ.
    pub mu_wrap: f64,
}

/// The rig at interior angle `interior_angle_deg` with `tension_kn` on the
/// low side, loaded until it slips ([`modelled_slip_ratio`]), and the μ
/// either angle convention back-calculates from that slip.
pub fn rig_slip(
    friction: &JointFriction,
    interior_angle_deg: f64,
    tension_kn: f64,
) -> Result<RigSlip, RigError> {
    let theta = interior_angle_deg.to_radians();
    let tension_n = 1e3 * tension_kn;
    let ratio = modelled_slip_ratio(friction, theta, tension_n)?;
    Ok(RigSlip {
        interior_angle_deg,
        tension_kn,
        modelled_ratio: ratio,
        formula_ratio: friction.ratio_bound(theta, false),
        slip_load_n: tension_n * (ratio - 1.0),
        mu_interior: ratio.ln() / theta,
        mu_wrap: ratio.ln() / (std::f64::consts::PI - theta),
    })
}
