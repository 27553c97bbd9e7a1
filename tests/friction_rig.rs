//! The seed's friction rig (a cable over one joint between two pulleys):
//! the modelled joint must stick below, and slip at, a load ratio of
//! e^(μφ), to 1e-6 relative. The truth is the capstan formula, evaluated
//! independently of the solver; the model's threshold is found by loading
//! the rig through the full DR solve.

use std::f64::consts::PI;
use tensegrity_deploy::design::friction_rig::{load_rig, modelled_slip_ratio};
use tensegrity_deploy::model::{AngleConvention, FrictionCoefficient, JointFriction};

const ANGLES_DEG: [f64; 3] = [117.0, 146.0, 170.0];
const TENSIONS_N: [f64; 5] = [1000.0, 1500.0, 2000.0, 2500.0, 3000.0];

#[test]
fn joint_sticks_below_and_slips_at_the_capstan_ratio() {
    let mu = 0.2;
    let friction = JointFriction::constant(mu).unwrap();
    for theta_deg in ANGLES_DEG {
        let theta = theta_deg.to_radians();
        let bound = (mu * (PI - theta)).exp();
        for t in TENSIONS_N {
            let below = load_rig(&friction, theta, t, t * bound * (1.0 - 1e-6)).unwrap();
            assert!(below.report.status.is_converged());
            assert_eq!(
                below.slide_m, 0.0,
                "θ={theta_deg}°, T={t}: slid below the bound"
            );
            let above = load_rig(&friction, theta, t, t * bound * 1.05).unwrap();
            assert!(above.report.status.is_converged());
            assert!(
                above.slide_m < 0.0,
                "θ={theta_deg}°, T={t}: did not slide above the bound"
            );
            // Sliding puts the ratio back on the bound.
            let ratio = above.tensions_n[1] / above.tensions_n[0];
            assert!(
                (ratio / bound - 1.0).abs() < 1e-6,
                "ratio after slip {ratio}, bound {bound}"
            );
            // The threshold found by loading the model agrees with the formula.
            let slip = modelled_slip_ratio(&friction, theta, t).unwrap();
            assert!(
                (slip / bound - 1.0).abs() < 1e-6,
                "θ={theta_deg}°: model {slip}, formula {bound}"
            );
        }
    }
}

#[test]
fn interior_convention_uses_the_interior_angle() {
    let friction = JointFriction::new(
        FrictionCoefficient::Constant(0.1),
        AngleConvention::Interior,
    )
    .unwrap();
    let theta = 146f64.to_radians();
    let slip = modelled_slip_ratio(&friction, theta, 2000.0).unwrap();
    assert!((slip / (0.1 * theta).exp() - 1.0).abs() < 1e-6);
}

#[test]
fn frictionless_joint_slides_to_equal_tension() {
    let out = load_rig(
        &JointFriction::frictionless(),
        146f64.to_radians(),
        1000.0,
        1300.0,
    )
    .unwrap();
    assert!(out.report.status.is_converged());
    let [a, b] = out.tensions_n;
    assert!((a - b).abs() < 1e-6 * a, "{a} vs {b}");
    // Material conservation: equal-tension split of the same total length.
    assert!(
        (a - 1150.0).abs() < 1.0,
        "equal tension {a} should be near the mean load"
    );
}
