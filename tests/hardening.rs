//! Issue 13: every panic, hang and NaN-passed-off-as-a-result a hostile
//! user found, one test each, named after it. Each drives the `tdeploy`
//! binary (under the hang guard [`common::cli::HANG_GUARD`], so that a
//! hang fails instead of stalling the suite; not a speed check) or the
//! library, and checks the clear one-line error or the plain
//! non-converged status with its exit code.

mod common;

use std::path::Path;
use std::process::Output;

use common::cli::{failed_with, tdeploy_with, RunOptions};
use common::fixtures::{dir_with, lab_log_folder, TWO_CABLES, TWO_STEP_COMMANDS};
use common::repo_arg;

use nalgebra::Vector3;
use tensegrity_deploy::design::friction_rig::{friction_rig, modelled_slip_ratio, RigError};
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::solver::PLAUSIBLE_STRAIN;
use tensegrity_deploy::model::{
    ForwardModel, JointFriction, Member, MemberKind, Node, RelaxSettings, RelaxStatus, Structure,
    Workspace,
};

/// Runs `tdeploy args` in `dir` under the hang guard.
fn guarded(args: &[&str], dir: &Path) -> Output {
    tdeploy_with(args, dir, RunOptions::hang_guarded())
}

// ---- the panic ----------------------------------------------------------

#[test]
fn a_friction_rig_with_a_non_finite_or_extreme_tension_or_angle_is_an_error_not_a_panic() {
    let rig = "kind = \"friction-rig\"\nmu = 0.2\ninterior_angles_deg = [146]\ntensions_kn = [[1]]\nout = \"o\"\n";
    for (from, to, field) in [
        ("[[1]]", "[[nan]]", "tensions_kn[0][0]"),
        ("[[1]]", "[[inf]]", "tensions_kn[0][0]"),
        ("[[1]]", "[[1e308]]", "tensions_kn[0][0]"),
        ("[[1]]", "[[1e-300]]", "tensions_kn[0][0]"),
        ("[146]", "[0]", "interior_angles_deg[0]"),
        ("[146]", "[180]", "interior_angles_deg[0]"),
        ("[146]", "[1e-300]", "interior_angles_deg[0]"),
        ("[146]", "[-5]", "interior_angles_deg[0]"),
    ] {
        let dir = dir_with(&[("e.toml", &rig.replace(from, to))]);
        let e = failed_with(&guarded(&["experiment", "e.toml"], dir.path()), 2);
        assert!(
            e.starts_with("error: e.toml: line ") && e.contains(&format!("`{field}`")),
            "{to}: {e}"
        );
    }
    // The library refuses the same numbers with an error, never a panic.
    let friction = JointFriction::constant(0.2).unwrap();
    for (angle, t) in [
        (f64::NAN, 1e3),
        (0.0, 1e3),
        (std::f64::consts::PI, 1e3),
        (1e-300, 1e3),
        (2.0, f64::INFINITY),
        (2.0, -1.0),
        (2.0, 1e308),
    ] {
        assert!(friction_rig(angle, t, t).is_err(), "θ={angle}, T={t}");
        assert!(modelled_slip_ratio(&friction, angle, t).is_err());
    }
    // A search that would stretch the rig's cable past the plausible strain
    // ends with an error, not a loop: μ = 2 at 1° needs a load ratio of
    // e^(2·179π/180) ≈ 517; from 100 kN on a 7e5 N cable (14 % strain)
    // the first doubling already strains it 29 %.
    let sticky = JointFriction::constant(2.0).unwrap();
    let e = modelled_slip_ratio(&sticky, 1f64.to_radians(), 1e5).unwrap_err();
    assert!(
        matches!(
            e,
            RigError::NotConverged {
                status: RelaxStatus::ImplausibleStrain,
                ..
            }
        ),
        "{e}"
    );
}

// ---- the hangs ----------------------------------------------------------

#[test]
fn a_payout_of_1e3_m_is_refused_not_a_hang() {
    let dir = dir_with(&[
        ("s.json", TWO_CABLES),
        ("c.csv", "step,cable,payout_change_m\n1,cc,1000\n"),
    ]);
    let e = failed_with(
        &guarded(
            &["simulate", "-q", "-s", "s.json", "-c", "c.csv"],
            dir.path(),
        ),
        2,
    );
    assert_eq!(
        e,
        "error: c.csv: line 2, field `payout_change_m`: must be a finite number in [-10, 10], got 1000"
    );
    assert!(!dir.path().join("out").exists(), "nothing written");
}

#[test]
fn an_increment_of_1e_9_m_is_refused_not_a_hang() {
    let dir = dir_with(&[("s.json", TWO_CABLES), ("c.csv", TWO_STEP_COMMANDS)]);
    let e = failed_with(
        &guarded(
            &[
                "simulate",
                "-q",
                "-s",
                "s.json",
                "-c",
                "c.csv",
                "--increment",
                "1e-9",
            ],
            dir.path(),
        ),
        2,
    );
    assert!(
        e.starts_with("error: c.csv: step 1: a payout change of 0.001 m in increments of at most 1e-9 m needs 1e6 increments, over the limit of 10000 per step"),
        "{e}"
    );
    // Through an experiment file the solver's own limit stops it.
    let effect = "kind = \"friction-effect\"\nmu = 0.2\nfold_m = 1\ndeploy_m = 1\nincrement_m = 1e-9\nforce_floor_n = 50\nout = \"o\"\n";
    let dir = dir_with(&[("e.toml", effect)]);
    let e = failed_with(&guarded(&["experiment", "e.toml"], dir.path()), 2);
    assert!(e.contains("the limit per command"), "{e}");
}

#[test]
fn a_fixed_node_near_1e308_is_refused_not_a_hang() {
    for coordinate in ["1e308", "1e300", "-1.7e308"] {
        let dir = dir_with(&[
            (
                "s.json",
                &TWO_CABLES.replace("[2, 0, 0]", &format!("[{coordinate}, 0, 0]")),
            ),
            ("c.csv", TWO_STEP_COMMANDS),
        ]);
        let e = failed_with(
            &guarded(
                &["simulate", "-q", "-s", "s.json", "-c", "c.csv"],
                dir.path(),
            ),
            2,
        );
        assert!(
            e.starts_with("error: s.json: nodes[2] (\"c\"): field `position_m[0]` must be a finite number in [-10000, 10000]"),
            "{e}"
        );
    }
}

#[test]
fn modules_per_half_64_is_refused_before_any_work() {
    let dir = dir_with(&[("p.toml", "modules_per_half = 64\n")]);
    let e = failed_with(
        &guarded(&["structure", "--params", "p.toml"], dir.path()),
        2,
    );
    assert_eq!(
        e,
        "error: p.toml: line 1, field `modules_per_half`: must be 1 to 16 (the limit on the bridge's size), got 64"
    );
    // The library holds the same limit.
    let p = BridgeParameters {
        modules_per_half: 64,
        ..BridgeParameters::default()
    };
    assert!(reference_bridge(&p).is_err());
}

#[test]
fn a_measurement_of_1e308_is_refused_with_its_file_and_line() {
    let dir = lab_log_folder("0.01");
    let path = dir.path().join("log/measurements.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    // The second line's value becomes 1e308.
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let (head, _) = lines[1].rsplit_once(',').unwrap();
    lines[1] = format!("{head},1e308");
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let e = failed_with(
        &guarded(
            &["compare", "model.toml", "log", "-o", "report"],
            dir.path(),
        ),
        2,
    );
    assert!(
        e.contains("measurements.csv: line 2, field `value`: must be a finite number in [-1e9, 1e9], got 1e308"),
        "{e}"
    );
    assert!(!dir.path().join("report").exists(), "nothing written");
}

// ---- NaN or inf as a result ---------------------------------------------

/// Nodes `a` (held) at the origin and `b` at 1 m on x; `b` held too when
/// `hold_b`.
fn nodes(b_x: f64, hold_b: bool) -> Vec<Node> {
    let node = |id: &str, x: f64, fixed: bool| Node {
        id: id.into(),
        position_m: Vector3::new(x, 0.0, 0.0),
        mass_kg: 1.0,
        fixed: [fixed; 3],
        load_n: Vector3::zeros(),
    };
    vec![node("a", 0.0, true), node("b", b_x, hold_b)]
}

fn member(kind: MemberKind, rest_length_m: f64) -> Member {
    Member {
        id: "m".into(),
        kind,
        nodes: [0, 1],
        rest_length_m,
    }
}

/// The status of relaxing `structure` from its reference state.
fn relax(structure: Structure, settings: RelaxSettings) -> RelaxStatus {
    let model = ForwardModel::new(structure, JointFriction::frictionless(), settings).unwrap();
    let mut state = model.reference_state();
    model.relax(&mut state, &mut Workspace::default()).status
}

#[test]
fn a_fixed_node_at_1e300_is_never_converged_with_infinite_forces() {
    // Past the file's range check (the library takes any finite number):
    // a cable from the origin to a held node at 1e300 m, and a free node
    // hanging on it. Its force overflows; the solve must say so.
    let mut n = nodes(1e300, true);
    n.push(Node {
        id: "free".into(),
        position_m: Vector3::new(0.5, 0.0, 0.0),
        mass_kg: 1.0,
        fixed: [false; 3],
        load_n: Vector3::zeros(),
    });
    let members = vec![
        Member {
            id: "c0".into(),
            kind: MemberKind::Cable { ea_n: 7e5 },
            nodes: [0, 2],
            rest_length_m: 0.49,
        },
        Member {
            id: "c1".into(),
            kind: MemberKind::Cable { ea_n: 7e5 },
            nodes: [2, 1],
            rest_length_m: 0.49,
        },
    ];
    let s = Structure::new("far", n, members, vec![], Vector3::zeros(), vec![]).unwrap();
    let status = relax(s, RelaxSettings::default());
    assert!(!status.is_converged(), "{status:?}");
}

#[test]
fn a_strut_with_a_tiny_ei_or_rest_length_is_refused() {
    let strut = r#"{"format": "tensegrity-deploy/structure/1", "name": "s", "gravity_m_per_s2": [0, 0, 0],
      "nodes": [{"id": "a", "position_m": [0, 0, 0], "mass_kg": 0, "fixed": [true, true, true]},
                {"id": "b", "position_m": [1, 0, 0], "mass_kg": 0, "fixed": [true, true, true]}],
      "struts": [{"id": "s0", "nodes": ["a", "b"], "ea_n": 2.6e7, "ei_nm2": EI, "rest_length_m": REST}]}"#;
    for (ei, rest, field) in [
        ("1e-300", "1", "ei_nm2"),
        ("2.3e3", "1e-9", "rest_length_m"),
    ] {
        let dir = dir_with(&[("s.json", &strut.replace("EI", ei).replace("REST", rest))]);
        let e = failed_with(&guarded(&["simulate", "-q", "-s", "s.json"], dir.path()), 2);
        assert!(
            e.starts_with(&format!(
                "error: s.json: struts[0] (\"s0\"): field `{field}` must be a finite number in"
            )),
            "{e}"
        );
    }
}

#[test]
fn tol_1e300_is_refused_not_converged_in_0_iterations() {
    let dir = tempfile::tempdir().unwrap();
    let e = failed_with(&guarded(&["simulate", "--tol", "1e300"], dir.path()), 2);
    assert_eq!(
        e,
        "error: --tol: must be a finite number in (0, 0.01], got 1e300"
    );
    // The library's settings check agrees.
    let settings = RelaxSettings {
        tol_force_rel: 1e300,
        ..RelaxSettings::default()
    };
    assert!(settings.validate().is_err());
}

#[test]
fn a_member_strained_beyond_the_plausible_limit_is_not_converged() {
    // A member between two held nodes 1 m apart: its strain is exactly
    // 1/L0 − 1, set on either side of the documented limit (±1 % of it).
    let strained = |kind: MemberKind, strain: f64| {
        let s = Structure::new(
            "one member",
            nodes(1.0, true),
            vec![member(kind, 1.0 / (1.0 + strain))],
            vec![],
            Vector3::zeros(),
            vec![],
        )
        .unwrap();
        relax(s, RelaxSettings::default())
    };
    let strut = MemberKind::Strut {
        ea_n: 2.6e7,
        ei_nm2: 2.3e3,
    };
    let cable = MemberKind::Cable { ea_n: 7e5 };
    let spring = MemberKind::Spring {
        stiffness_n_per_m: 4e3,
    };
    let (below, above) = (0.99 * PLAUSIBLE_STRAIN, 1.01 * PLAUSIBLE_STRAIN);
    for (kind, strain, expected) in [
        (strut, below, RelaxStatus::Converged),
        (strut, -below, RelaxStatus::Converged),
        (strut, above, RelaxStatus::ImplausibleStrain),
        (strut, -above, RelaxStatus::ImplausibleStrain),
        (cable, below, RelaxStatus::Converged),
        (cable, above, RelaxStatus::ImplausibleStrain),
        // A slack cable carries nothing: no limit on shortening.
        (cable, -0.5, RelaxStatus::Converged),
        // Springs stretch by design (the reference bridge's up to 120 %).
        (spring, 2.0, RelaxStatus::Converged),
    ] {
        assert_eq!(strained(kind, strain), expected, "{kind:?} at {strain}");
    }
    // Through the CLI: a strut crushed to half its rest length ends the run
    // with the status named, exit 1, and the step written.
    let file = r#"{"format": "tensegrity-deploy/structure/1", "name": "s", "gravity_m_per_s2": [0, 0, 0],
      "nodes": [{"id": "a", "position_m": [0, 0, 0], "mass_kg": 0, "fixed": [true, true, true]},
                {"id": "b", "position_m": [1, 0, 0], "mass_kg": 0, "fixed": [true, true, true]}],
      "struts": [{"id": "s0", "nodes": ["a", "b"], "ea_n": 2.6e7, "ei_nm2": 2.3e3, "rest_length_m": 2}]}"#;
    let dir = dir_with(&[("s.json", file)]);
    let e = failed_with(
        &guarded(&["simulate", "-q", "-s", "s.json", "-o", "r"], dir.path()),
        1,
    );
    assert!(
        e.starts_with("goal not reached: simulation stopped at step 0: implausible strain"),
        "{e}"
    );
    let steps = std::fs::read_to_string(dir.path().join("r/steps.csv")).unwrap();
    assert!(steps.contains("\n0,implausible_strain,"), "{steps}");
}

#[test]
fn reference_temperature_nan_is_refused() {
    let model = "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n[effects.thermal]\nexpansion_per_k = 1.2e-5\nreference_temperature_c = nan\n";
    let dir = dir_with(&[("m.toml", model)]);
    let e = failed_with(&guarded(&["lab", "m.toml", "-o", "log"], dir.path()), 2);
    assert_eq!(
        e,
        "error: m.toml: line 5, field `effects.thermal.reference_temperature_c`: must be a finite number in [-100, 100], got NaN"
    );
}

#[test]
fn nan_bridge_parameters_are_refused_before_form_finding() {
    for field in [
        "cable_min_tension_n",
        "spring_target_tension_n",
        "strut_min_compression_n",
        "topology.middle_ring_radius_ratio",
        "topology.ring_twist_deg",
    ] {
        let mut p = BridgeParameters::default();
        match field {
            "cable_min_tension_n" => p.cable_min_tension_n = f64::NAN,
            "spring_target_tension_n" => p.spring_target_tension_n = f64::NAN,
            "strut_min_compression_n" => p.strut_min_compression_n = f64::NAN,
            "topology.middle_ring_radius_ratio" => p.topology.middle_ring_radius_ratio = f64::NAN,
            _ => p.topology.ring_twist_deg = f64::NAN,
        }
        let e = reference_bridge(&p).unwrap_err().to_string();
        assert!(
            e.contains(field) && !e.contains("prestress"),
            "{field}: {e}"
        );
    }
}

// ---- messages -----------------------------------------------------------

#[test]
fn structure_validation_and_os_errors_print_once() {
    let dir = dir_with(&[(
        "s.json",
        &TWO_CABLES
            .replace(
                "\"mass_kg\": 1}",
                "\"mass_kg\": 1, \"fixed\": [false, false, false]}",
            )
            .replace("[\"a\", \"b\", \"c\"]", "[\"a\", \"b\", \"a\"]"),
    )]);
    let e = failed_with(&guarded(&["simulate", "-q", "-s", "s.json"], dir.path()), 2);
    assert_eq!(e.matches("repeats node").count(), 1, "{e}");
    let e = failed_with(&guarded(&["simulate", "-s", "missing.json"], dir.path()), 2);
    assert_eq!(e.matches("No such file").count(), 1, "{e}");
}

#[test]
fn invalid_utf8_names_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = TWO_CABLES.as_bytes().to_vec();
    // Line 3 is `  "name": "two cables",`; its 12th byte becomes 0xff.
    let line3 = TWO_CABLES
        .lines()
        .take(2)
        .map(|l| l.len() + 1)
        .sum::<usize>();
    bytes[line3 + 11] = 0xff;
    std::fs::write(dir.path().join("s.json"), bytes).unwrap();
    let e = failed_with(&guarded(&["simulate", "-q", "-s", "s.json"], dir.path()), 2);
    assert_eq!(
        e,
        "error: s.json:3:12: invalid UTF-8 (files must be UTF-8 text)"
    );
}

// ---- outputs ------------------------------------------------------------

#[test]
fn outputs_refuse_to_overwrite_a_users_files_without_force() {
    let dir = dir_with(&[("s.json", TWO_CABLES), ("c.csv", TWO_STEP_COMMANDS)]);
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), "my notes").unwrap();
    std::fs::write(dir.path().join("bridge.json"), "my bridge").unwrap();
    let simulate = [
        "simulate", "-q", "-s", "s.json", "-c", "c.csv", "-o", "mine",
    ];
    let e = failed_with(&guarded(&simulate, dir.path()), 2);
    assert!(
        e.contains("mine: output folder: holds files tdeploy did not write")
            && e.contains("--force"),
        "{e}"
    );
    let e = failed_with(&guarded(&["structure", "-o", "bridge.json"], dir.path()), 2);
    assert!(
        e.contains("bridge.json: file: already exists") && e.contains("--force"),
        "{e}"
    );
    let e = failed_with(&guarded(&["lab", "m.toml", "-o", "mine"], dir.path()), 2);
    assert!(e.contains("m.toml: cannot read"), "bad input first: {e}");
    std::fs::write(
        dir.path().join("m.toml"),
        "format = \"tensegrity-deploy/model/1\"\nstructure = \"s.json\"\n",
    )
    .unwrap();
    let e = failed_with(&guarded(&["lab", "m.toml", "-o", "mine"], dir.path()), 2);
    assert!(e.contains("holds files tdeploy did not write"), "{e}");
    let e = failed_with(
        &guarded(&["compare", "m.toml", "mine", "-o", "mine"], dir.path()),
        2,
    );
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(
        std::fs::read_to_string(mine.join("notes.txt")).unwrap(),
        "my notes"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("bridge.json")).unwrap(),
        "my bridge"
    );
    // --force replaces a user's folder whole; a re-run into tdeploy's own
    // output is refused too (issue 25: an earlier result is never lost by
    // accident), naming the command that wrote it, and --force replaces it.
    let mut forced = simulate.to_vec();
    forced.push("--force");
    assert!(guarded(&forced, dir.path()).status.success());
    assert!(!mine.join("notes.txt").exists() && mine.join("steps.csv").is_file());
    let e = failed_with(&guarded(&simulate, dir.path()), 2);
    assert!(
        e.contains("earlier run of `tdeploy simulate`") && e.contains("--force"),
        "{e}"
    );
    assert!(guarded(&forced, dir.path()).status.success());
    let out = guarded(&["structure", "-o", "bridge.json", "--force"], dir.path());
    assert!(out.status.success());
    // The same bytes again need no --force.
    assert!(guarded(&["structure", "-o", "bridge.json"], dir.path())
        .status
        .success());
    // No temporary folder or file is left beside the outputs.
    for entry in std::fs::read_dir(dir.path()).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with('.'), "stray {name}");
    }
}

#[test]
fn simulate_writes_the_steps_that_converged_before_a_failing_step() {
    let dir = dir_with(&[
        ("s.json", TWO_CABLES),
        (
            "c.csv",
            "step,cable,payout_change_m\n1,cc,0.001\n2,cc,0.001\n3,cc,-5\n4,cc,0.001\n",
        ),
    ]);
    let e = failed_with(
        &guarded(
            &["simulate", "-q", "-s", "s.json", "-c", "c.csv", "-o", "r"],
            dir.path(),
        ),
        2,
    );
    assert!(
        e.starts_with(
            "error: step 3 cannot be applied: continuous cable \"cc\": reeling in would leave"
        ) && e.ends_with("(results up to step 2 in r)"),
        "{e}"
    );
    let steps = std::fs::read_to_string(dir.path().join("r/steps.csv")).unwrap();
    let labels: Vec<&str> = steps
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(labels, ["0", "1", "2"], "{steps}");
}

#[test]
fn compare_and_diagnose_json_reports_do_not_overwrite_a_users_file() {
    let dir = tempfile::tempdir().unwrap();
    let truth = repo_arg("experiments/lab/truth-friction.toml");
    let baseline = repo_arg("experiments/lab/baseline.toml");
    let lab = guarded(
        &[
            "lab",
            &truth,
            "-o",
            "log",
            "--amplitudes",
            "0.01,0.05",
            "--steps",
            "2",
        ],
        dir.path(),
    );
    assert_eq!(lab.status.code(), Some(0));
    std::fs::write(dir.path().join("mine.json"), "keep").unwrap();
    for args in [
        vec![
            "compare",
            &baseline,
            "log",
            "-o",
            "cmp",
            "--json",
            "mine.json",
        ],
        vec![
            "diagnose",
            &baseline,
            "log",
            "--rounds",
            "1",
            "--json",
            "mine.json",
        ],
    ] {
        let e = failed_with(&guarded(&args, dir.path()), 2);
        assert!(e.contains("mine.json") && e.contains("--force"), "{e}");
        assert_eq!(
            std::fs::read_to_string(dir.path().join("mine.json")).unwrap(),
            "keep"
        );
    }
    // With --force it is replaced; the same report again needs no --force.
    let mut forced = vec![
        "diagnose",
        &baseline,
        "log",
        "--rounds",
        "1",
        "--json",
        "mine.json",
    ];
    forced.push("--force");
    assert_eq!(guarded(&forced, dir.path()).status.code(), Some(0));
    assert!(std::fs::read_to_string(dir.path().join("mine.json"))
        .unwrap()
        .starts_with('{'));
    let again = guarded(
        &[
            "diagnose",
            &baseline,
            "log",
            "--rounds",
            "1",
            "--json",
            "mine.json",
        ],
        dir.path(),
    );
    assert_eq!(again.status.code(), Some(0));
}
