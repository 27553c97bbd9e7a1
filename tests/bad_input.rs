//! Bad files are rejected with errors that name the file and the line and
//! field (CSV) or the entry (JSON); the CLI exits 2 (bad input) without a
//! panic.

mod common;

use std::path::Path;

use common::cli::{stderr, tdeploy};
use common::fixtures::{reference_structure, TWO_CABLES};
use tensegrity_deploy::io::commands::parse_commands;
use tensegrity_deploy::io::structure_file::{parse_structure, structure_to_json};

fn structure_error(text: &str) -> String {
    parse_structure(text, Path::new("bridge.json"))
        .unwrap_err()
        .to_string()
}

#[test]
fn good_structure_parses() {
    parse_structure(TWO_CABLES, Path::new("bridge.json")).unwrap();
}

#[test]
fn unknown_node_id_names_file_entry_and_id() {
    let e = structure_error(&TWO_CABLES.replace(r#"["b", "c"], "ea_n""#, r#"["b", "zz"], "ea_n""#));
    assert_eq!(e, "bridge.json: cables[1] (\"c1\"): unknown node id \"zz\"");
}

#[test]
fn zero_length_member_is_rejected() {
    let e = structure_error(&TWO_CABLES.replace(r#"["a", "b"], "ea_n""#, r#"["b", "b"], "ea_n""#));
    assert!(
        e.starts_with("bridge.json: cables[0] (\"c0\"): zero-length"),
        "{e}"
    );
}

#[test]
fn repeated_path_node_is_rejected() {
    let e = structure_error(&TWO_CABLES.replace(r#"["a", "b", "c"]"#, r#"["a", "b", "a"]"#));
    assert!(
        e.contains("continuous_cables[0] (\"cc\"): path repeats node \"a\""),
        "{e}"
    );
}

#[test]
fn non_positive_stiffness_is_rejected() {
    let e = structure_error(&TWO_CABLES.replace(
        r#""ea_n": 1e5, "rest_length_m": 0.99}"#,
        r#""ea_n": 0, "rest_length_m": 0.99}"#,
    ));
    assert!(
        e.contains("cables[0] (\"c0\"): field `ea_n` must be a finite number in [1, 1e12], got 0"),
        "{e}"
    );
}

#[test]
fn nan_is_a_syntax_error_with_line_and_column() {
    let e = structure_error(&TWO_CABLES.replace(r#""mass_kg": 1}"#, r#""mass_kg": NaN}"#));
    assert!(e.starts_with("bridge.json:7:"), "{e}");
}

#[test]
fn unconnected_free_node_is_rejected() {
    let text = TWO_CABLES.replace(
        r#"{"id": "c", "position_m": [2, 0, 0], "mass_kg": 0, "fixed": [true, true, true]}"#,
        r#"{"id": "c", "position_m": [2, 0, 0], "mass_kg": 0, "fixed": [true, true, true]},
    {"id": "d", "position_m": [3, 0, 0], "mass_kg": 1}"#,
    );
    let e = structure_error(&text);
    assert!(
        e.contains("nodes[3] (\"d\"): free node is not reached by any member"),
        "{e}"
    );
}

#[test]
fn misspelt_field_is_rejected_not_ignored() {
    let e = structure_error(&TWO_CABLES.replace(
        r#""mass_kg": 1}"#,
        r#""mass_kg": 1, "fixd": [true, true, true]}"#,
    ));
    assert!(e.contains("unknown field `fixd`"), "{e}");
}

#[test]
fn reference_bridge_round_trips_through_its_file() {
    let s = reference_structure();
    let back = parse_structure(&structure_to_json(&s), Path::new("rb.json")).unwrap();
    assert_eq!(s, back);
}

fn command_error(text: &str) -> String {
    let s = parse_structure(TWO_CABLES, Path::new("bridge.json")).unwrap();
    parse_commands(text, Path::new("cmd.csv"), &s)
        .unwrap_err()
        .to_string()
}

#[test]
fn command_errors_name_line_and_field() {
    assert_eq!(
        command_error("step,cable,payout\n1,cc,0.1\n"),
        "cmd.csv: line 1, field `header`: expected columns `step,cable,payout_change_m`, found `step,cable,payout`"
    );
    assert_eq!(
        command_error("step,cable,payout_change_m\n1,cc,0.1\n2,nope,0.1\n"),
        "cmd.csv: line 3, field `cable`: no continuous cable \"nope\" in the structure"
    );
    assert_eq!(
        command_error("step,cable,payout_change_m\n1,cc,abc\n"),
        "cmd.csv: line 2, field `payout_change_m`: \"abc\" is not a finite number"
    );
    assert!(
        command_error("step,cable,payout_change_m\n2,cc,0.1\n1,cc,0.1\n")
            .contains("line 3, field `step`")
    );
    assert!(
        command_error("step,cable,payout_change_m\n1,cc,0\n1,cc,0.1\n").contains("appears twice")
    );
    assert!(command_error("step,cable,payout_change_m\n-1,cc,0.1\n").contains("field `step`"));
}

#[test]
fn cli_exits_non_zero_with_one_clear_line_on_a_bad_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        TWO_CABLES.replace(r#"["b", "c"], "ea_n""#, r#"["b", "zz"], "ea_n""#),
    )
    .unwrap();
    let out_dir = dir.path().join("out");
    let out = tdeploy(
        &[
            "simulate",
            "-q",
            "--structure",
            bad.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    let stderr = stderr(&out);
    assert!(
        stderr.contains("bad.json: cables[1] (\"c1\"): unknown node id \"zz\""),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        !dir.path().join("out").exists(),
        "nothing is written for a rejected input"
    );
}
