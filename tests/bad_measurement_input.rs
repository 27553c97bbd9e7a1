//! Malformed logs and model files given to the measurement commands
//! (`compare`, `diagnose`, `calibrate`): one clear error line naming file,
//! line and field, exit status 2 (bad input), never a panic, nothing written.

mod common;

use std::path::{Path, PathBuf};

use common::cli::{failed_with, stderr, succeeded, tdeploy};
use common::fixtures::{lab_log_folder, REFERENCE_MODEL};

/// A tiny good log (one 1 cm cycle, one step each way) and a baseline model.
fn fixture() -> (tempfile::TempDir, PathBuf) {
    let dir = lab_log_folder("0.01");
    let log = dir.path().join("log");
    (dir, log)
}

/// Runs `compare` after `edit` of `file` in the log; returns its stderr
/// after checking it failed cleanly.
fn compare_fails(dir: &Path, model: &str) -> String {
    let out = tdeploy(&["compare", model, "log", "-o", "report"], dir);
    let e = failed_with(&out, 2);
    assert!(!dir.join("report").exists(), "nothing written on bad input");
    e
}

fn edit_log(log: &Path, file: &str, from: &str, to: &str) -> String {
    let p = log.join(file);
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.contains(from), "{file} has no {from:?}");
    std::fs::write(&p, text.replacen(from, to, 1)).unwrap();
    text
}

#[test]
fn the_fixture_log_compares_cleanly() {
    let (dir, _) = fixture();
    succeeded(&tdeploy(
        &["compare", "model.toml", "log", "-o", "report"],
        dir.path(),
    ));
}

#[test]
fn wrong_columns_are_named() {
    let (dir, log) = fixture();
    edit_log(
        &log,
        "measurements.csv",
        "cycle,step,sensor,value",
        "cycle,step,value,sensor",
    );
    let e = compare_fails(dir.path(), "model.toml");
    assert!(
        e.contains("measurements.csv: line 1, field `header`"),
        "{e}"
    );
}

#[test]
fn an_unknown_sensor_is_named_with_its_line() {
    let (dir, log) = fixture();
    let text = std::fs::read_to_string(log.join("measurements.csv")).unwrap();
    let second = text.lines().nth(1).unwrap();
    let sensor = second.split(',').nth(2).unwrap();
    edit_log(
        &log,
        "measurements.csv",
        second,
        &second.replacen(sensor, "ghost", 1),
    );
    let e = compare_fails(dir.path(), "model.toml");
    assert!(
        e.contains("measurements.csv: line 2, field `sensor`: no sensor \"ghost\""),
        "{e}"
    );
}

#[test]
fn a_non_numeric_value_is_named_with_its_line() {
    let (dir, log) = fixture();
    let text = std::fs::read_to_string(log.join("measurements.csv")).unwrap();
    let third = text.lines().nth(2).unwrap();
    let value = third.rsplit(',').next().unwrap();
    let bad = format!("{}twelve", &third[..third.len() - value.len()]);
    edit_log(&log, "measurements.csv", third, &bad);
    let e = compare_fails(dir.path(), "model.toml");
    assert!(
        e.contains("measurements.csv: line 3, field `value`: \"twelve\" is not a finite number"),
        "{e}"
    );
}

#[test]
fn a_sensor_on_a_member_the_structure_lacks_is_rejected() {
    let (dir, log) = fixture();
    edit_log(&log, "sensors.csv", "A_cc0:3", "A_cc0:7");
    let e = compare_fails(dir.path(), "model.toml");
    assert!(e.contains("sensors.csv: line 2, field `target`"), "{e}");
}

#[test]
fn a_log_made_for_another_structure_is_rejected() {
    let (dir, log) = fixture();
    let text = std::fs::read_to_string(log.join("log.toml")).unwrap();
    let line = text.lines().find(|l| l.starts_with("structure")).unwrap();
    edit_log(&log, "log.toml", line, "structure = \"a cable net\"");
    let e = compare_fails(dir.path(), "model.toml");
    assert!(
        e.contains("log.toml: structure: the log was made on"),
        "{e}"
    );
}

#[test]
fn bad_model_files_are_named_with_line_and_field() {
    let (dir, _) = fixture();
    let cases = [
        (
            "[effects.joint_friction]\nmu = -0.1\n",
            "line 4, field `effects.joint_friction.mu`: must be ≥ 0, got -0.1",
        ),
        ("[effects.joint_friction]\nmu = \"high\"\n", "bad.toml:4:"),
        ("[effects.warp_drive]\nfactor = 9\n", "warp_drive"),
        ("[effects.motor]\nbacklash = 0.002\n", "backlash"),
        (
            "[effects.support_flexibility]\ncompliance_m_per_n = 1.0\n",
            "must lie in [0, 0.01], got 1",
        ),
    ];
    for (tail, want) in cases {
        std::fs::write(
            dir.path().join("bad.toml"),
            format!("{REFERENCE_MODEL}{tail}"),
        )
        .unwrap();
        let e = compare_fails(dir.path(), "bad.toml");
        assert!(e.contains("bad.toml") && e.contains(want), "{tail}: {e}");
    }
    std::fs::write(
        dir.path().join("bad.toml"),
        REFERENCE_MODEL.replace("model/1", "model/9"),
    )
    .unwrap();
    let e = compare_fails(dir.path(), "bad.toml");
    assert!(e.contains("bad.toml") && e.contains("format"), "{e}");
}

#[test]
fn calibrate_never_overwrites_a_model_file() {
    let (dir, _) = fixture();
    std::fs::write(dir.path().join("taken.toml"), "# mine\n").unwrap();
    for out_name in ["model.toml", "taken.toml"] {
        let out = tdeploy(
            &[
                "calibrate",
                "model.toml",
                "log",
                "--add",
                "load_cell_bias",
                "-o",
                out_name,
            ],
            dir.path(),
        );
        let stderr = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    assert_eq!(
        std::fs::read_to_string(dir.path().join("taken.toml")).unwrap(),
        "# mine\n"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("model.toml")).unwrap(),
        REFERENCE_MODEL
    );
    let out = tdeploy(
        &[
            "calibrate",
            "model.toml",
            "log",
            "--add",
            "flux",
            "-o",
            "new.toml",
        ],
        dir.path(),
    );
    let stderr = stderr(&out);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr.contains("unknown effect \"flux\""), "{stderr}");
}
