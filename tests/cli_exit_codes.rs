//! The CLI's exit codes (0 done, 1 ran but did not reach its goal, 2 bad
//! input or I/O error), its one-line errors naming file, line and column or
//! field, and its JSON reports, which must agree with what it prints and
//! with their own residuals.

mod common;

use common::cli::{failed_with, stderr, stdout, succeeded, tdeploy};
use common::files::read_json;
use common::fixtures::{dir_with, lab_log_folder, TWO_CABLES, TWO_STEP_COMMANDS};

const FRICTION_EFFECT: &str = "kind = \"friction-effect\"\nmu = 0.2\nfold_m = 0.05\ndeploy_m = 0.05\nincrement_m = 0.005\nforce_floor_n = 50\nout = \"out\"\n";

#[test]
fn a_simulation_that_converges_exits_0_and_one_that_does_not_exits_1() {
    let dir = dir_with(&[("s.json", TWO_CABLES), ("c.csv", TWO_STEP_COMMANDS)]);
    let base = ["simulate", "-q", "-s", "s.json", "-c", "c.csv", "-o", "run"];
    let out = tdeploy(&base, dir.path());
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let steps = std::fs::read_to_string(dir.path().join("run/steps.csv")).unwrap();
    assert_eq!(steps.lines().count(), 4, "header, step 0 and two steps");
    assert!(steps.lines().skip(1).all(|l| l.contains(",converged,")));
    // The reference bridge with ten iterations allowed per solve and a
    // tolerance no solve reaches in ten: the first solve stops.
    let out = tdeploy(
        &[
            "simulate",
            "-q",
            "--tol",
            "1e-15",
            "--max-iter",
            "10",
            "-o",
            "stuck",
        ],
        dir.path(),
    );
    let e = failed_with(&out, 1);
    assert!(
        e.starts_with("goal not reached: simulation stopped at step 0: iteration limit"),
        "{e}"
    );
    let steps = std::fs::read_to_string(dir.path().join("stuck/steps.csv")).unwrap();
    assert!(steps.contains("0,iteration_limit,"), "{steps}");
}

#[test]
fn bad_files_and_flags_exit_2_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let e = failed_with(&tdeploy(&["experiment", "missing.toml"], dir.path()), 2);
    assert!(e.contains("missing.toml: cannot read"), "{e}");
    let e = failed_with(&tdeploy(&["simulate", "--increment", "0"], dir.path()), 2);
    assert_eq!(
        e.trim_end(),
        "error: --increment: must be a finite number in (0, 0.1], got 0"
    );
    let e = failed_with(&tdeploy(&["lab", "m.toml", "--steps", "0"], dir.path()), 2);
    assert!(e.contains("--steps: must be at least 1"), "{e}");
    // clap's own usage errors exit 2 as well (several lines of usage).
    let out = tdeploy(&["simulate", "--no-such-flag"], dir.path());
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn a_toml_syntax_error_names_file_line_and_column_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    // Line 3, column 15: the second number after `fold_m = 0.05 `.
    std::fs::write(
        dir.path().join("exp.toml"),
        FRICTION_EFFECT.replace("fold_m = 0.05", "fold_m = 0.05 0.06"),
    )
    .unwrap();
    let e = failed_with(&tdeploy(&["experiment", "exp.toml"], dir.path()), 2);
    assert!(e.starts_with("error: exp.toml:3:15: "), "{e}");
    std::fs::write(
        dir.path().join("params.toml"),
        "ring_radius_m = 0.5\n[topology]\nring_twist_deg = = 54\n",
    )
    .unwrap();
    let e = failed_with(
        &tdeploy(&["structure", "--params", "params.toml"], dir.path()),
        2,
    );
    assert!(e.starts_with("error: params.toml:3:18: "), "{e}");
    assert!(!dir.path().join("reference-bridge.json").exists());
}

#[test]
fn a_bad_experiment_or_parameter_value_names_its_field() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("exp.toml"),
        FRICTION_EFFECT.replace("deploy_m = 0.05", "deploy_m = -0.05"),
    )
    .unwrap();
    let e = failed_with(&tdeploy(&["experiment", "exp.toml"], dir.path()), 2);
    assert_eq!(
        e.trim_end(),
        "error: exp.toml: line 4, field `deploy_m`: must be a finite number in [0, 1], got -0.05"
    );
    assert!(!dir.path().join("out").exists(), "nothing written");
    std::fs::write(
        dir.path().join("params.toml"),
        "[topology]\nmiddle_ring_radius_ratio = inf\n",
    )
    .unwrap();
    let e = failed_with(
        &tdeploy(&["structure", "--params", "params.toml"], dir.path()),
        2,
    );
    assert!(
        e.contains("params.toml: line 2, field `topology.middle_ring_radius_ratio`"),
        "{e}"
    );
}

/// RMS of every residual's `z` in a JSON comparison.
fn rms_of_residuals(comparison: &serde_json::Value) -> (f64, usize) {
    let z: Vec<f64> = comparison["residuals"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["z"].as_f64().unwrap())
        .collect();
    let n = z.len();
    ((z.iter().map(|z| z * z).sum::<f64>() / n as f64).sqrt(), n)
}

#[test]
fn json_reports_parse_back_with_the_overall_rms() {
    let dir = lab_log_folder("0.01,0.01");
    let out = tdeploy(
        &[
            "compare",
            "model.toml",
            "log",
            "-o",
            "report",
            "--json",
            "report.json",
        ],
        dir.path(),
    );
    succeeded(&out);
    let v = read_json(&dir.path().join("report.json"));
    let comparison: tensegrity_deploy::measure::compare::Comparison =
        serde_json::from_value(v["comparison"].clone()).unwrap();
    // The overall RMS is that of the residuals it summarises (the same
    // sum in another order: 1e-12 relative), and what the table printed.
    let (rms, n) = rms_of_residuals(&v["comparison"]);
    assert_eq!(comparison.overall.count, n);
    assert!((comparison.overall.rms - rms).abs() < 1e-12 * rms);
    let printed = stdout(&out);
    assert!(
        printed.contains(&format!("overall: rms {:.2} noise SDs", rms)),
        "{printed}"
    );
    assert_eq!(
        v["sensors"].as_array().unwrap().len(),
        comparison.per_sensor.len()
    );
    // The baseline explains its own log: the verdict is noise.
    assert_eq!(v["verdict"]["verdict"], "noise");

    let out = tdeploy(
        &["diagnose", "model.toml", "log", "--json", "diagnosis.json"],
        dir.path(),
    );
    succeeded(&out);
    let v = read_json(&dir.path().join("diagnosis.json"));
    let final_comparison = &v["diagnosis"]["final_comparison"];
    let (rms, _) = rms_of_residuals(final_comparison);
    let overall = final_comparison["overall"]["rms"].as_f64().unwrap();
    assert!((overall - rms).abs() < 1e-12 * rms);
    assert_eq!(v["diagnosis"]["verdict"], "nothing_missing");
    assert!(!v["diagnosis"]["rounds"].as_array().unwrap().is_empty());
}
