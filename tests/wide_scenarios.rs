//! Issue 22's wide truths from the command line: a thermal truth needs a
//! temperature and acts at it; a truth file's local faults reach the
//! deployment and its records; `scenarios/wide.toml` draws the same
//! scenarios, byte for byte, at 1 and 2 threads.

mod common;

use std::path::Path;

use common::cli::{failed_with, stderr, tdeploy, tdeploy_with, RunOptions};
use common::files::{column, read_csv};
use common::fixtures::dir_with;
use common::repo_arg;

const THERMAL: &str = "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n[effects.thermal]\nexpansion_per_k = 1.2e-5\nreference_temperature_c = 20\n";

/// Ran to its end (connected or not: this file tests the truths, not the
/// controller).
fn ran(out: &std::process::Output) {
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "exit {:?}: {}",
        out.status.code(),
        stderr(out)
    );
}

fn read(dir: &Path, file: &str) -> String {
    std::fs::read_to_string(dir.join(file)).unwrap()
}

/// Without `--temperature` a thermal truth is refused (exit 2, one line
/// naming the flag), in `deploy` and `cycles` alike; at 40 °C it acts:
/// the truth's members are longer than at its 20 °C reference, so the
/// true gaps differ from a deployment at 20 °C.
#[test]
fn a_thermal_truth_needs_a_temperature_and_acts_at_it() {
    let dir = dir_with(&[("thermal.toml", THERMAL)]);
    for command in ["deploy", "cycles"] {
        let e = failed_with(
            &tdeploy(
                &[command, "--truth", "thermal.toml", "-o", "out"],
                dir.path(),
            ),
            2,
        );
        assert!(
            e.contains("thermal effect") && e.contains("--temperature"),
            "{e}"
        );
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    }
    let e = failed_with(
        &tdeploy(
            &[
                "deploy",
                "--truth",
                "thermal.toml",
                "--temperature",
                "500",
                "-o",
                "out",
            ],
            dir.path(),
        ),
        2,
    );
    assert!(e.contains("--temperature"), "{e}");
    let deploy = |out: &str, t: &str| {
        ran(&tdeploy(
            &[
                "deploy",
                "--truth",
                "thermal.toml",
                "--temperature",
                t,
                "-o",
                out,
            ],
            dir.path(),
        ));
        read(&dir.path().join(out), "deployment.csv")
    };
    let (reference, warm) = (deploy("at20", "20"), deploy("at40", "40"));
    assert_ne!(reference, warm, "a 20 K swing changed nothing");
}

/// A truth file's `[faults.*]` tables act in `deploy` and are written
/// back, by part id, in the deployment's `truth.toml`.
#[test]
fn a_truth_files_faults_reach_the_deployment_and_its_record() {
    let faulty = "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n[faults.drum_zero_error]\nmotor = \"A_cc1\"\noffset_m = 0.015\n";
    let plain = "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n";
    let dir = dir_with(&[("faulty.toml", faulty), ("plain.toml", plain)]);
    let deploy = |truth: &str, out: &str| {
        ran(&tdeploy(
            &["deploy", "--truth", truth, "-o", out],
            dir.path(),
        ));
        dir.path().join(out)
    };
    let (with, without) = (deploy("faulty.toml", "f"), deploy("plain.toml", "p"));
    let record = read(&with, "truth.toml");
    assert!(
        record.contains("[faults.drum_zero_error]") && record.contains("\"A_cc1\""),
        "{record}"
    );
    assert_ne!(
        read(&with, "deployment.csv"),
        read(&without, "deployment.csv"),
        "a 15 mm drum zero error changed nothing"
    );
    let e = failed_with(
        &tdeploy(
            &["deploy", "--truth", "bad.toml", "-o", "b"],
            dir_with(&[("bad.toml", &faulty.replace("A_cc1", "Z"))]).path(),
        ),
        2,
    );
    assert!(
        e.contains("bad.toml: line 4, field `faults.drum_zero_error.motor`: no motor \"Z\""),
        "{e}"
    );
}

/// Two scenarios of the wide distribution give the same files at 1 and 2
/// threads, and runs.csv names every fault's draw.
#[test]
fn the_wide_distribution_gives_the_same_bytes_at_1_and_2_threads() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |name: &str, threads: usize| {
        let out = tmp.path().join(name);
        let args = [
            "evaluate",
            "--distribution",
            &repo_arg("scenarios/wide.toml"),
            "--scenarios",
            "2",
            "--seed",
            "7",
            "--threads",
            &threads.to_string(),
            "-o",
            out.to_str().unwrap(),
        ];
        ran(&tdeploy_with(&args, tmp.path(), RunOptions::default()));
        out
    };
    let (one, two) = (run("one", 1), run("two", 2));
    for f in ["evaluation.toml", "runs.csv", "summary.csv"] {
        assert!(read(&one, f) == read(&two, f), "{f} differs");
    }
    let (header, rows) = read_csv(&one.join("runs.csv"));
    for name in [
        "thermal.expansion_per_k",
        "temperature_c",
        "faults.drum_zero_error.present",
        "faults.member_error.part_position",
        "faults.half_difference.cable_scale",
        "fold_b_m",
        "binds",
    ] {
        column(&header, name);
    }
    assert_eq!(rows.len(), 2);
}
