//! Payout sensitivities against one-sided finite differences of full
//! re-solves, on the reference bridge after every cable has paid out 5 cm,
//! without friction and with μ = 0.2.
//!
//! Reference: from a copy of the state, apply a payout of `+h` or `−h` on
//! one motor in one increment of `h` (as a command would), relax to
//! `tol_force_rel` = 1e-9, and difference. `h` = 1e-5 m.
//!
//! Tolerance, per quantity, relative to its largest entry: 1e-3.
//! - Truncation: a one-sided difference is off by `h/2·|x''|`. The
//!   differences shrink in proportion to `h` (worst position error 1.3e-3,
//!   1.3e-4, 1.3e-5 m/m at h = 1e-4, 1e-5, 1e-6 m against derivatives of
//!   1.5–2.5 m/m), so `|x''| ≈ 25/m·|x'|max` and the truncation is about
//!   1.5e-4 of the largest entry at h = 1e-5 m; forces and tensions
//!   likewise (at most 2.2e-4).
//! - Solver noise: a residual of 1e-9 of the largest force (~1e-6 N) moves
//!   positions by far less than the truncation (the error still halves
//!   with `h` at 1e-6 m), so it is below 1e-5 of the largest entry.
//! - Sensitivity rounding: central differences over 1 µm, ~1e-10 relative.
//!
//! So 1e-3 is 4.5× the worst expected error. A joint put in the wrong state
//! changes responses by far more: paying out and reeling in differ by tens
//! of percent at μ = 0.2 (checked below), and each is compared with its own
//! one-sided difference.
//!
//! Floors for entries that are zero (fixed nodes, slack members): 1e-9 m/m
//! and 1e-6 N/m.

mod common;

use common::fixtures::reference_structure;
use tensegrity_deploy::model::{
    DeploymentState, ForwardModel, JointFriction, MotorDirection, MotorResponse,
    PayoutSensitivities, RelaxSettings, SensitivityError, SlipOnset, Workspace,
};

const H_M: f64 = 1e-5;
const REL_TOL: f64 = 1e-3;

fn model(mu: f64) -> ForwardModel {
    let settings = RelaxSettings {
        tol_force_rel: 1e-9,
        ..RelaxSettings::default()
    };
    ForwardModel::new(
        reference_structure(),
        JointFriction::constant(mu).unwrap(),
        settings,
    )
    .unwrap()
}

/// The bridge after every cable has paid out 5 cm in 1 cm increments.
fn moved_state(model: &ForwardModel, ws: &mut Workspace) -> DeploymentState {
    let mut state = model.reference_state();
    let n = model.structure().continuous_cables.len();
    let r = model
        .apply_payout(&mut state, ws, &vec![0.05; n], 0.01, &mut ())
        .unwrap();
    assert!(r.status.is_converged(), "{r:?}");
    state
}

/// The flat entries of a response: positions (x, y, z per node), member
/// forces, segment tensions.
fn parts(r: &MotorResponse) -> [Vec<f64>; 3] {
    [
        r.positions_m_per_m
            .iter()
            .flat_map(|v| v.iter().copied())
            .collect(),
        r.member_force_n_per_m.clone(),
        r.segment_tension_n_per_m.clone(),
    ]
}

/// One-sided finite difference of a full re-solve: `motor` moved `h` in
/// `direction`, as d/dp.
fn finite_difference(
    model: &ForwardModel,
    state: &DeploymentState,
    ws: &mut Workspace,
    motor: usize,
    direction: MotorDirection,
) -> [Vec<f64>; 3] {
    let dp = direction.sign() * H_M;
    let mut cmd = vec![0.0; model.structure().continuous_cables.len()];
    cmd[motor] = dp;
    let mut moved = state.clone();
    let r = model
        .apply_payout(&mut moved, ws, &cmd, H_M, &mut ())
        .unwrap();
    assert!(r.status.is_converged(), "{r:?}");
    let (f0, f1) = (model.member_forces(state), model.member_forces(&moved));
    let diff =
        |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(a, b)| (b - a) / dp).collect() };
    let flat = |s: &DeploymentState| -> Vec<f64> {
        s.positions_m
            .iter()
            .flat_map(|v| v.iter().copied())
            .collect()
    };
    [
        diff(&flat(state), &flat(&moved)),
        diff(&f0.member_n, &f1.member_n),
        diff(&f0.segment_n, &f1.segment_n),
    ]
}

const NAMES: [&str; 3] = ["positions", "member forces", "segment tensions"];
const FLOORS: [f64; 3] = [1e-9, 1e-6, 1e-6];

/// Largest entry-wise difference over the allowance `REL_TOL·max|ours| +
/// floor`, per part.
fn error_ratio(ours: &[Vec<f64>; 3], reference: &[Vec<f64>; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for p in 0..3 {
        let largest = ours[p].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = ours[p]
            .iter()
            .zip(&reference[p])
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        out[p] = worst / (REL_TOL * largest + FLOORS[p]);
    }
    out
}

fn check_against_finite_differences(mu: f64) -> PayoutSensitivities {
    let model = model(mu);
    let mut ws = Workspace::default();
    let state = moved_state(&model, &mut ws);
    let sens = model.payout_sensitivities(&state, &mut ws).unwrap();
    let n = model.structure().continuous_cables.len();
    assert_eq!(sens.pay_out.len(), n);
    assert_eq!(sens.reel_in.len(), n);
    for motor in 0..n {
        for direction in MotorDirection::BOTH {
            let ours = parts(sens.response(motor, direction).unwrap());
            let fd = finite_difference(&model, &state, &mut ws, motor, direction);
            let ratio = error_ratio(&ours, &fd);
            for p in 0..3 {
                assert!(
                    ratio[p] <= 1.0,
                    "μ = {mu}, motor {motor} {direction:?}, {}: error {:.2} of the allowance",
                    NAMES[p],
                    ratio[p]
                );
            }
        }
    }
    sens
}

#[test]
fn frictionless_sensitivities_match_finite_differences_and_both_directions_agree() {
    let sens = check_against_finite_differences(0.0);
    // Without friction every joint slides either way: the one-sided
    // derivatives are one derivative (here even computed alike; the finite
    // differences above checked each side on its own).
    for (out, inn) in sens.pay_out.iter().zip(&sens.reel_in) {
        let ratio = error_ratio(&parts(out), &parts(inn));
        assert!(ratio.iter().all(|r| *r <= 1.0), "{ratio:?}");
        assert_eq!(out.sliding_joints, inn.sliding_joints);
        // One half's 5 cables × 3 interior joints, all sliding.
        assert_eq!(out.sliding_joints, 15);
    }
}

#[test]
fn sensitivities_with_friction_match_finite_differences_and_directions_differ() {
    let sens = check_against_finite_differences(0.2);
    // Paying out and reeling in are different derivatives with friction:
    // different joints slide, and the responses differ by far more than
    // the finite-difference tolerance (so each direction's check above
    // would fail against the other's derivative).
    let mut differing = 0;
    for (out, inn) in sens.pay_out.iter().zip(&sens.reel_in) {
        let ratio = error_ratio(&parts(out), &parts(inn));
        if ratio.iter().any(|r| *r > 20.0) && out.sliding_joints != inn.sliding_joints {
            differing += 1;
        }
    }
    assert!(differing >= 1, "no motor responds differently by direction");
}

#[test]
fn midspan_gap_response_is_the_difference_of_the_pair_responses() {
    let model = model(0.2);
    let mut ws = Workspace::default();
    let state = moved_state(&model, &mut ws);
    let sens = model.payout_sensitivities(&state, &mut ws).unwrap();
    let s = model.structure();
    for direction in MotorDirection::BOTH {
        for motor in 0..s.continuous_cables.len() {
            let gaps = sens.midspan_gap_response(s, motor, direction);
            let dx = &sens.response(motor, direction).unwrap().positions_m_per_m;
            assert_eq!(gaps.len(), s.midspan_pairs.len());
            for (g, [a, b]) in gaps.iter().zip(&s.midspan_pairs) {
                assert_eq!(*g, dx[*a] - dx[*b]);
            }
        }
    }
    assert!(sens
        .midspan_gap_response(s, s.continuous_cables.len(), MotorDirection::PayOut)
        .is_empty());
}

#[test]
fn a_state_out_of_equilibrium_is_rejected() {
    let model = model(0.2);
    let mut ws = Workspace::default();
    // The as-built geometry with one cable reeled in 1 cm and not relaxed.
    let mut state = model.reference_state();
    state.segment_rest_lengths_m[state.segment_offsets[0]] -= 0.01;
    match model.payout_sensitivities(&state, &mut ws) {
        Err(SensitivityError::NotConverged {
            residual_n,
            tolerance_n,
        }) => assert!(residual_n > tolerance_n),
        other => panic!("expected NotConverged, got {other:?}"),
    }
}

/// The planner's finite differences probe one motor of each bridge half in
/// the same solve (the halves share no member or cable before connection)
/// and credit each half's change to its own motor; with the reference's
/// `h` and tolerance they must match the tangent motor by motor, to the
/// same allowance as the single-motor differences above. A crediting
/// error (a half's motion given to the other half's motor) would show as
/// a response of the size of the derivatives themselves.
#[test]
fn grouped_probes_credit_each_half_to_its_own_motor() {
    use tensegrity_deploy::plan::response::IndependentParts;
    use tensegrity_deploy::plan::PayoutResponse;
    for mu in [0.0, 0.2] {
        let model = model(mu);
        let mut ws = Workspace::default();
        let state = moved_state(&model, &mut ws);
        let parts = IndependentParts::of(&model);
        let n = model.structure().continuous_cables.len();
        let groups = parts.probe_groups(n);
        assert_eq!(groups.len(), n / 2, "{groups:?}");
        assert!(groups.iter().all(|g| g.len() == 2), "{groups:?}");
        let tangent = PayoutResponse::tangent(&model, &state).unwrap();
        let grouped = PayoutResponse::finite_difference(&model, &state, H_M, H_M).unwrap();
        let split = |e: &tensegrity_deploy::plan::response::MotorEffect| {
            let members = model.structure().members.len();
            [
                e.positions_m_per_m
                    .iter()
                    .flat_map(|v| v.iter().copied())
                    .collect::<Vec<_>>(),
                e.force_n_per_m[..members].to_vec(),
                e.force_n_per_m[members..].to_vec(),
            ]
        };
        for (ours, fd) in tangent
            .pay_out
            .iter()
            .zip(&grouped.pay_out)
            .chain(tangent.reel_in.iter().zip(&grouped.reel_in))
        {
            let ratio = error_ratio(&split(ours), &split(fd));
            assert!(ratio.iter().all(|r| *r <= 1.0), "μ = {mu}: {ratio:?}");
        }
    }
}

/// Without friction every joint slides either way, so the slip-onset
/// tangent has no joint to add: it is the exact tangent, entry for entry
/// (same factorisation, same clustered cables; allowance as above).
#[test]
fn slip_onset_tangent_is_the_exact_tangent_without_friction() {
    let model = model(0.0);
    let mut ws = Workspace::default();
    let state = moved_state(&model, &mut ws);
    let exact = model.payout_sensitivities(&state, &mut ws).unwrap();
    let onset = model
        .payout_sensitivities_with(&state, &mut ws, SlipOnset::Loaded)
        .unwrap();
    for direction in MotorDirection::BOTH {
        for motor in 0..model.structure().continuous_cables.len() {
            let a = parts(exact.response(motor, direction).unwrap());
            let b = parts(onset.response(motor, direction).unwrap());
            let ratio = error_ratio(&a, &b);
            assert!(
                ratio.iter().all(|r| *r <= 1.0),
                "{motor} {direction:?}: {ratio:?}"
            );
        }
    }
}

/// At the 40 cm fold with μ = 0.2 every joint sticks: the exact one-sided
/// derivative lets nothing slide and misjudges a 5 cm reel-in of every
/// motor by several times its size, while the slip-onset tangent, whose
/// loaded joints slide, predicts its gap change linearly within 60 %.
/// Measured (`cargo run --release --example friction_responses`): 52 %
/// for the slip-onset tangent, 455 % for the exact one; the bound is what
/// a trust region that grows back needs (a prediction error e gives a
/// reduction ratio of roughly 1 ± e, and ρ ≥ 0.4 of the default trust
/// region is met).
#[test]
fn slip_onset_tangent_predicts_a_5_cm_reel_in_from_a_fold_where_every_joint_sticks() {
    use tensegrity_deploy::plan::{folded_start, DeploymentProblem, PayoutResponse, Policy};
    let model = ForwardModel::new(
        reference_structure(),
        JointFriction::constant(0.2).unwrap(),
        RelaxSettings::default(),
    )
    .unwrap();
    let policy = Policy::default();
    let start = folded_start(&model, &DeploymentProblem::default(), policy.increment_m).unwrap();
    let n = start.payout_m.len();
    let u = vec![-0.05; n];
    let mut moved = start.clone();
    let r = model
        .apply_payout(
            &mut moved,
            &mut Workspace::default(),
            &u,
            policy.increment_m,
            &mut (),
        )
        .unwrap();
    assert!(r.status.is_converged(), "{r:?}");
    let pairs = &model.structure().midspan_pairs;
    let error = |response: &PayoutResponse| {
        let (dx, _) = response.predicted_change(&u);
        let (mut num, mut den) = (0.0, 0.0);
        for [a, b] in pairs {
            let actual = (moved.positions_m[*a] - moved.positions_m[*b])
                - (start.positions_m[*a] - start.positions_m[*b]);
            num += (dx[*a] - dx[*b] - actual).norm_squared();
            den += actual.norm_squared();
        }
        (num / den).sqrt()
    };
    let exact = error(&PayoutResponse::tangent(&model, &start).unwrap());
    let onset = error(&PayoutResponse::tangent_with(&model, &start, SlipOnset::Loaded).unwrap());
    assert!(
        onset < 0.6,
        "slip-onset tangent off by {:.0} %",
        100.0 * onset
    );
    assert!(
        exact > 1.0,
        "exact tangent off by only {:.0} %",
        100.0 * exact
    );
}
