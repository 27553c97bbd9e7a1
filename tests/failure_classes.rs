//! One regression test per failure class of issue 22 that a single truth
//! shows (the uneven fold, the 48–50 cm folds and a run that broke limits
//! are in `tests/deploy.rs`; the thermal truth's temperature in
//! `tests/wide_scenarios.rs`). Each truth is a model file as a user would
//! write it, deployed by the default controller (frictionless model,
//! `policies/qp.toml`'s settings) on seeds 1 and 2. A run must connect
//! with no truth limit broken, or stop "not reachable safely" naming what
//! binds, again with none broken; where it does neither today, the test
//! checks that the verdict says so and names it (never "connected").

mod common;

use std::path::Path;

use common::fixtures::deploy_frictionless_controller;
use tensegrity_deploy::control::Deployment;
use tensegrity_deploy::io::model_file::parse_model;
use tensegrity_deploy::plan::{DeploymentProblem, Policy, RunVerdict};
use tensegrity_deploy::sim::standard_sensors;

/// Deploys the truth of model-file `text` at `temperature_c` on `seed`.
fn deploy(text: &str, temperature_c: Option<f64>, seed: u64) -> (Deployment, RunVerdict) {
    let truth = parse_model(text, Path::new("truth.toml"))
        .unwrap()
        .measurement_model()
        .unwrap();
    let sensors = standard_sensors(&truth.structure);
    let problem = DeploymentProblem::default();
    let d = deploy_frictionless_controller(
        &truth,
        &sensors,
        &problem,
        &Policy::default(),
        temperature_c,
        seed,
        &mut (),
    );
    let v = d.verdict(problem.connection_tolerance_m);
    (d, v)
}

/// Connects on seeds 1 and 2 with no truth limit broken.
fn connects_within_limits(text: &str, temperature_c: Option<f64>) {
    for seed in [1, 2] {
        let (_, v) = deploy(text, temperature_c, seed);
        let words = format!("seed {seed}: {}", v.describe());
        assert!(v.is_connected(), "{words}");
        assert_eq!(v.violations, 0, "{words}");
    }
}

const HEADER: &str = "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n";

/// Support compliance at the top of its plausible range (5e-5 m/N) with
/// the default truth's friction: the abutment-ring cables go slack on
/// the way (20 violations when they had a minimum, see `plan::limits`);
/// every other member keeps its limits and the bridge connects.
#[test]
fn flexible_supports_at_the_top_of_their_range_connect_within_limits() {
    let text = format!(
        "{HEADER}[effects.joint_friction]\nmu = 0.2\n\n\
         [effects.support_flexibility]\ncompliance_m_per_n = 5e-5\n"
    );
    connects_within_limits(&text, None);
}

/// One strut 5 mm long (`A_strut_m0_a1`) at μ = 0.2: it once ended "not
/// reachable" after breaking 13 limits; it connects (7.7 and 7.5 mm).
#[test]
fn a_strut_5_mm_long_connects_within_limits() {
    let text = format!(
        "{HEADER}[effects.joint_friction]\nmu = 0.2\n\n\
         [faults.member_error]\nmember = \"A_strut_m0_a1\"\n\
         rest_length_error_m = 0.005\nstiffness_scale = 1.0\n"
    );
    connects_within_limits(&text, None);
}

/// A thermal truth deployed at 40 °C, 20 K above its reference: its
/// members are longer than the controller's model, and it connects.
#[test]
fn a_thermal_truth_at_40_c_connects_within_limits() {
    let text = format!(
        "{HEADER}[effects.joint_friction]\nmu = 0.2\n\n\
         [effects.thermal]\nexpansion_per_k = 1.2e-5\nreference_temperature_c = 20.0\n"
    );
    connects_within_limits(&text, Some(40.0));
}

/// Friction with the interior-angle convention at μ = 0.25 drained every
/// module-1 axial cable to 0 N (11–16 violations). The controller now
/// stops before: "not reachable safely", naming the `cc` segment whose
/// minimum binds, with no truth limit broken (measured: after 4 and 7
/// commands, 110 and 107 mm from connection). Connecting is open.
#[test]
fn interior_angle_friction_stops_safely_naming_what_binds() {
    let text = format!("{HEADER}[effects.joint_friction]\nmu = 0.25\nconvention = \"interior\"\n");
    for seed in [1, 2] {
        let (_, v) = deploy(&text, None, seed);
        let words = v.describe();
        assert_eq!(v.violations, 0, "seed {seed}: {words}");
        if !v.is_connected() {
            assert!(
                words.contains("not reachable safely: segment"),
                "seed {seed}: {words}"
            );
        }
    }
}

/// One drum zeroed 15 mm off (`A_cc1` holds 15 mm more material than its
/// drum says): the whole cable is slack at the start. Open: on seed 1 the
/// controller connects but `A_cc1`'s segments fall back below 5 N near
/// the design (47 violations); on seed 2 it ends within the gap with the
/// slack never restored. The verdict says so either way: never
/// "connected", always naming `A_cc1`.
#[test]
fn one_drum_zero_error_is_never_called_connected_and_names_the_cable() {
    let text = format!(
        "{HEADER}[effects.joint_friction]\nmu = 0.2\n\n\
         [faults.drum_zero_error]\nmotor = \"A_cc1\"\noffset_m = 0.015\n"
    );
    for seed in [1, 2] {
        let (d, v) = deploy(&text, None, seed);
        let words = v.describe();
        assert!(!v.is_connected(), "seed {seed}: {words}");
        assert!(words.contains("A_cc1"), "seed {seed}: {words}");
        assert!(
            d.truth_start_broken
                .iter()
                .any(|l| l.member.starts_with("segment A_cc1")),
            "seed {seed}: {words}"
        );
    }
}

/// Load cells zeroed 40 N low (the effect `load_cell_bias`) at μ = 0.2:
/// read as the model's error, a folded segment's 10 N reads as −30 N and
/// the controller stopped "not reachable" after 3 commands, 136 mm from
/// connection. With the common bias estimated apart (the default
/// `control.load_cell_bias_prior_sd_n`) it connects within every limit
/// on seeds 1 and 2. The estimate at the end of seed 1 is −31.6 ± 4.3 N:
/// the model's own force errors (it has no friction) share the offsets,
/// so the bias is checked to within 15 N, not 3 standard deviations.
#[test]
fn a_load_cell_bias_is_not_read_as_slack_cables() {
    let text = format!(
        "{HEADER}[effects.joint_friction]\nmu = 0.2\n\n[effects.load_cell_bias]\nbias_n = -40.0\n"
    );
    connects_within_limits(&text, None);
    let (d, _) = deploy(&text, None, 1);
    let (bias, sd) = d.final_load_cell_bias_n.unwrap();
    assert!((bias + 40.0).abs() < 15.0, "{bias} ± {sd} N");
    assert!(sd < 10.0, "{bias} ± {sd} N");
}

/// Known limitation 20 (a model file with flexible supports was refused as
/// "another bridge": its bearings and ground nodes are appended to the
/// bridge's). Planned on the truth's own support compliance (5e-5 m/N,
/// the top of its plausible range, μ = 0.2 hidden), the controller's start
/// gaps match the bridge's and it no longer reads the supports' give as a
/// payout scale: on seed 1 the frictionless reference model estimated
/// −48.8 % and −46.8 % per half and sent a corrective command; the
/// supports model −1.5 % and −3.2 %, none.
#[test]
fn a_model_with_the_truths_flexible_supports_is_planned_on() {
    use common::fixtures::{deploy_planning_on, reference_structure};
    let supports = "[effects.support_flexibility]\ncompliance_m_per_n = 5e-5\n";
    let truth_text = format!("{HEADER}[effects.joint_friction]\nmu = 0.2\n\n{supports}");
    let truth = parse_model(&truth_text, Path::new("truth.toml"))
        .unwrap()
        .measurement_model()
        .unwrap();
    let model = parse_model(&format!("{HEADER}{supports}"), Path::new("model.toml"))
        .unwrap()
        .measurement_model()
        .unwrap()
        .forward_model()
        .unwrap();
    assert!(model.structure().nodes.len() > reference_structure().nodes.len());
    let sensors = standard_sensors(&truth.structure);
    let (problem, policy) = (DeploymentProblem::default(), Policy::default());
    let d = deploy_planning_on(
        &model,
        &truth,
        &sensors,
        &problem,
        &policy,
        None,
        1,
        &mut (),
    );
    let v = d.verdict(problem.connection_tolerance_m);
    assert!(v.is_connected(), "{}", v.describe());
    assert_eq!(v.violations, 0, "{}", v.describe());
    for s in &d.final_payout_scale {
        assert!(s.abs() < 0.1, "payout scale {:?}", d.final_payout_scale);
    }
    assert_eq!(d.corrective_commands, Some(0));
    // The same truth on the frictionless reference model: the supports'
    // give is read as cables moving half as far as commanded.
    let (nominal, _) = deploy(&truth_text, None, 1);
    assert!(
        nominal.final_payout_scale.iter().all(|s| *s < -0.3),
        "{:?}",
        nominal.final_payout_scale
    );
}

/// A member cut off its length can put the truth outside its limits in
/// its own as-built state (wide seed 7072: 9 of the 13 runs that broke
/// limits were on such truths, `docs/controller.md`). One ring cable of
/// half B cut 4.6 mm short (scenario 158's fault alone, with μ = 0.2):
/// `B_ring0_1` carries 5 826 N against its 3 000 N maximum as built, and
/// the fold does not relieve it. The verdict names that as well as the
/// unrestored start, in words and in `binds`; a truth within its limits
/// as built (the default truth) has nothing to name.
#[test]
fn a_ring_cable_cut_short_is_named_as_out_of_its_limits_as_built() {
    use tensegrity_deploy::control::as_built_breaches;
    let text = format!(
        "{HEADER}[effects.joint_friction]\nmu = 0.2\n\n\
         [faults.member_error]\nmember = \"B_ring0_1\"\n\
         rest_length_error_m = -0.0046\nstiffness_scale = 1.0\n"
    );
    let problem = DeploymentProblem::default();
    for seed in [1, 2] {
        let (d, v) = deploy(&text, None, seed);
        let words = format!("seed {seed}: {}", v.describe());
        assert!(!v.is_connected(), "{words}");
        let checked = d.truth_as_built_broken.as_deref().unwrap_or_default();
        assert_eq!(checked.len(), 1, "{words}");
        let b = &checked[0];
        assert_eq!(b.limit(), "cable B_ring0_1 max", "{words}");
        assert_eq!(b.limit_n, problem.max_tension_n, "{words}");
        assert!(b.force_n > b.limit_n, "{words}");
        assert!(words.contains("in its own as-built state"), "{words}");
        assert!(
            v.binds()
                .contains(&"truth as built: cable B_ring0_1 max".to_string()),
            "{words}"
        );
    }
    let default_truth =
        tensegrity_deploy::sim::default_truth(common::fixtures::reference_structure());
    let built = tensegrity_deploy::sim::Plant::new(&default_truth, None, None).unwrap();
    assert_eq!(as_built_breaches(&built, &problem), Vec::new());
}
