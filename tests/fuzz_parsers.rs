//! File-mutation fuzzing of every file parser in `tensegrity_deploy::io`
//! (cargo-fuzz needs a nightly compiler; CI has stable only, so proptest
//! drives the mutations).
//!
//! Each target starts from valid example files (the shipped experiments,
//! policies and lab models, the reference bridge written out, small
//! hand-made files) and applies one to three mutations: a byte flipped,
//! the file truncated, random bytes inserted, a line deleted or
//! duplicated, or a numeric field replaced by NaN, ±inf, ±1e308, -0, a
//! subnormal, or an integer too large for any type. Every parse must
//! return: no panic (proptest reports one as a failure, with the input),
//! no hang (each parse must finish within the hang guard
//! [`PARSE_DEADLINE`]), and an error must be one line naming the file.
//!
//! Two targets mutate *contents* rather than bytes: `memory_contents`
//! edits one value of a stored case (a number made hostile, a list grown
//! or shortened, the status replaced) and writes the case back with a
//! valid checksum, so that only the semantic checks stand between it and
//! the controller; `shard_contents` does the same to one cell of a real
//! evaluation shard's `runs.csv`. Each must be refused in one line naming
//! the file, or load with every value inside its documented range.
//!
//! `cargo test --release --test fuzz_parsers` runs a smoke run of
//! [`SMOKE_CASES`] inputs per target from a fixed seed (a few seconds in
//! all). A longer run: `FUZZ_CASES=100000 cargo test --release --test
//! fuzz_parsers` (and `FUZZ_SEED=N` for other inputs); see docs/hardening.md.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

use common::fixtures::reference_structure;
use common::repo_text;
use tensegrity_deploy::io::bridge_params::parse_bridge_parameters;
use tensegrity_deploy::io::commands::parse_commands;
use tensegrity_deploy::io::evaluation_files::{
    fingerprint, parse_distribution, read_evaluation_record, read_runs,
};
use tensegrity_deploy::io::experiment_file::parse_experiment;
use tensegrity_deploy::io::friction_table::parse_friction_table;
use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::memory_file::{
    append_case, parse_memory, read_memory_or_empty, MEMORY_FORMAT,
};
use tensegrity_deploy::io::model_file::parse_model;
use tensegrity_deploy::io::policy_file::parse_policy;
use tensegrity_deploy::io::problem_file::parse_problem;
use tensegrity_deploy::io::structure_file::{parse_structure, structure_to_json};
use tensegrity_deploy::io::FileError;
use tensegrity_deploy::learn::{
    Case, CaseConditions, CaseLearning, CaseModel, CaseOutcome, LearntEffect,
};

/// Inputs per target in the smoke run.
const SMOKE_CASES: u32 = 48;
/// Hang guard: a parse that takes longer than this counts as a hang (an
/// infinite loop on some input). Not a speed check: a parse of the largest
/// example takes about a millisecond, so the guard is thousands of times
/// the normal time and stays quiet on any loaded machine.
const PARSE_DEADLINE: Duration = Duration::from_secs(5);

/// Inputs per target: `FUZZ_CASES`, else the smoke run's.
fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(SMOKE_CASES)
}

/// A runner with a fixed seed (`FUZZ_SEED`, default 13) and no failure
/// files written.
fn runner() -> TestRunner {
    let seed: u64 = std::env::var("FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(13);
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases: cases(),
        failure_persistence: None,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

/// Numbers a hostile file puts where a number belongs.
const HOSTILE_NUMBERS: [&str; 14] = [
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "-0",
    "0",
    "4.9e-324",
    "-1",
    "1e-9",
    "99999999999999999999999",
    "18446744073709551616",
    "",
];

/// One mutation of a file's bytes.
#[derive(Debug, Clone)]
enum Mutation {
    /// XOR the byte at (index mod length) with a non-zero mask.
    FlipByte(usize, u8),
    /// Keep only the first (index mod length) bytes.
    Truncate(usize),
    /// Insert bytes at (index mod length).
    Insert(usize, Vec<u8>),
    /// Replace the (k mod count)-th number with a hostile one.
    ReplaceNumber(usize, usize),
    /// Delete the (k mod lines)-th line.
    DeleteLine(usize),
    /// Repeat the (k mod lines)-th line.
    DuplicateLine(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1u8..=255).prop_map(|(i, m)| Mutation::FlipByte(i, m)),
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), prop::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
        (any::<usize>(), 0..HOSTILE_NUMBERS.len()).prop_map(|(k, h)| Mutation::ReplaceNumber(k, h)),
        (any::<usize>(), 0..HOSTILE_NUMBERS.len()).prop_map(|(k, h)| Mutation::ReplaceNumber(k, h)),
        any::<usize>().prop_map(Mutation::DeleteLine),
        any::<usize>().prop_map(Mutation::DuplicateLine),
    ]
}

/// Byte spans of the numbers in `bytes` (a digit run with its sign,
/// point and exponent).
fn number_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i].is_ascii_digit() {
            let mut start = i;
            if start > 0 && bytes[start - 1] == b'-' {
                start -= 1;
            }
            let mut end = i;
            while end < bytes.len()
                && (bytes[end].is_ascii_digit()
                    || matches!(bytes[end], b'.' | b'e' | b'E')
                    || (matches!(bytes[end], b'-' | b'+') && matches!(bytes[end - 1], b'e' | b'E')))
            {
                end += 1;
            }
            spans.push((start, end));
            i = end;
        } else {
            i += 1;
        }
    }
    spans
}

/// Line spans (with their newline) of `bytes`.
fn line_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = 0;
    for (i, b) in bytes.iter().enumerate() {
        if *b == b'\n' {
            spans.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < bytes.len() {
        spans.push((start, bytes.len()));
    }
    spans
}

fn apply(mut bytes: Vec<u8>, m: &Mutation) -> Vec<u8> {
    let n = bytes.len().max(1);
    match m {
        Mutation::FlipByte(i, mask) => {
            if !bytes.is_empty() {
                bytes[i % n] ^= mask;
            }
        }
        Mutation::Truncate(i) => bytes.truncate(i % n),
        Mutation::Insert(i, b) => {
            let at = i % (bytes.len() + 1);
            bytes.splice(at..at, b.iter().copied());
        }
        Mutation::ReplaceNumber(k, h) => {
            let spans = number_spans(&bytes);
            if !spans.is_empty() {
                let (s, e) = spans[k % spans.len()];
                bytes.splice(s..e, HOSTILE_NUMBERS[*h].bytes());
            }
        }
        Mutation::DeleteLine(k) => {
            let spans = line_spans(&bytes);
            if !spans.is_empty() {
                let (s, e) = spans[k % spans.len()];
                bytes.drain(s..e);
            }
        }
        Mutation::DuplicateLine(k) => {
            let spans = line_spans(&bytes);
            if !spans.is_empty() {
                let (s, e) = spans[k % spans.len()];
                let line = bytes[s..e].to_vec();
                bytes.splice(e..e, line);
            }
        }
    }
    bytes
}

/// One fuzz input: which seed file, and the mutations.
fn input(seeds: usize) -> impl Strategy<Value = (usize, Vec<Mutation>)> {
    (0..seeds, prop::collection::vec(mutation(), 1..=3))
}

/// Checks how a parse of `path` ended: within the hang guard, and an
/// error is one line naming a file of the input (`names`).
fn check_outcome<T>(
    result: Result<T, FileError>,
    elapsed: Duration,
    names: &[&Path],
) -> Result<(), TestCaseError> {
    prop_assert!(elapsed < PARSE_DEADLINE, "parse took {elapsed:?}: a hang");
    if let Err(e) = result {
        let text = e.to_string();
        prop_assert!(!text.contains('\n'), "error on several lines: {text}");
        prop_assert!(
            names
                .iter()
                .any(|n| text.starts_with(&n.display().to_string())),
            "error does not start with the file: {text}"
        );
    }
    Ok(())
}

/// Fuzzes a text parser: `parse(text, path)` on mutations of `seeds`.
/// Bytes that are not UTF-8 go through the library's file reader (shared by
/// every reader, here through the structure reader), which must name the
/// file, and then, decoded lossily, through the parser.
fn fuzz_text<T>(name: &str, seeds: &[String], parse: impl Fn(&str, &Path) -> Result<T, FileError>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    let mut runner = runner();
    runner
        .run(&input(seeds.len()), |(seed, mutations)| {
            let bytes = mutations
                .iter()
                .fold(seeds[seed].as_bytes().to_vec(), apply);
            if std::str::from_utf8(&bytes).is_err() {
                std::fs::write(&path, &bytes).unwrap();
                let start = Instant::now();
                let read = tensegrity_deploy::io::structure_file::read_structure(&path);
                prop_assert!(read.is_err(), "bytes that are not UTF-8 were read");
                check_outcome(read, start.elapsed(), &[&path])?;
            }
            let text = String::from_utf8_lossy(&bytes);
            let start = Instant::now();
            let result = parse(&text, &path);
            check_outcome(result, start.elapsed(), &[&path])
        })
        .unwrap_or_else(|e| panic!("{name}: {e}"));
}

const SMALL: &str = r#"{
  "format": "tensegrity-deploy/structure/1",
  "name": "two cables",
  "gravity_m_per_s2": [0, 0, -9.81],
  "nodes": [
    {"id": "a", "position_m": [0, 0, 0], "mass_kg": 0, "fixed": [true, true, true]},
    {"id": "b", "position_m": [1, 0, 0], "mass_kg": 1, "load_n": [0, 0, -5]},
    {"id": "c", "position_m": [2, 0, 0], "mass_kg": 0, "fixed": [true, true, true]}
  ],
  "struts": [{"id": "s0", "nodes": ["a", "c"], "ea_n": 2.6e7, "ei_nm2": 2.3e3, "rest_length_m": 2.0}],
  "cables": [
    {"id": "c0", "nodes": ["a", "b"], "ea_n": 1e5, "rest_length_m": 0.99},
    {"id": "c1", "nodes": ["b", "c"], "ea_n": 1e5, "rest_length_m": 0.99}
  ],
  "springs": [{"id": "k0", "nodes": ["a", "b"], "stiffness_n_per_m": 4e3, "rest_length_m": 0.5}],
  "continuous_cables": [
    {"id": "cc", "path": ["a", "b", "c"], "ea_n": 1e5, "segment_rest_lengths_m": [0.99, 0.99]}
  ],
  "midspan_pairs": [["b", "b"]]
}"#;

#[test]
fn structure_files() {
    fuzz_text(
        "structure.json",
        &[SMALL.to_string(), structure_to_json(&reference_structure())],
        parse_structure,
    );
}

#[test]
fn command_files() {
    let s = reference_structure();
    let (a, b) = (&s.continuous_cables[0].id, &s.continuous_cables[9].id);
    let seeds = [format!(
        "step,cable,payout_change_m\n1,{a},-0.01\n1,{b},0.02\n2,{a},0.005\n7,{b},-1e-3\n"
    )];
    fuzz_text("commands.csv", &seeds, |text, path| {
        parse_commands(text, path, &s)
    });
}

#[test]
fn friction_tables() {
    let seeds = ["interior_angle_deg,mu\n117,0.14\n146,0.10\n170,0.05\n".to_string()];
    fuzz_text("friction.csv", &seeds, parse_friction_table);
}

#[test]
fn bridge_parameter_files() {
    let seeds = [
        "module_length_m = 1.2\nring_radius_m = 0.6\ncontinuous_cable_tension_n = 600\nmodules_per_half = 2\nmin_stiffness_n_per_m = -inf\n\n[topology]\nring_twist_deg = 54\nsprings = \"interior_rings\"\naxial_offset = 2\n".to_string(),
    ];
    fuzz_text("params.toml", &seeds, parse_bridge_parameters);
}

#[test]
fn model_files() {
    let seeds = [
        repo_text("experiments/lab/truth-friction.toml"),
        repo_text("experiments/lab/baseline.toml"),
        "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n[effects.thermal]\nexpansion_per_k = 1.2e-5\nreference_temperature_c = 20\n[effects.motor]\nslip_fraction = 0.01\nbacklash_m = 0.002\n[effects.support_flexibility]\ncompliance_m_per_n = 1e-6\n".to_string(),
    ];
    fuzz_text("model.toml", &seeds, parse_model);
}

#[test]
fn experiment_files() {
    let seeds = [
        repo_text("experiments/friction-rig.toml"),
        repo_text("experiments/friction-effect.toml"),
        repo_text("experiments/friction-vs-measurement.toml"),
        repo_text("experiments/deployment.toml"),
    ];
    fuzz_text("experiment.toml", &seeds, parse_experiment);
}

#[test]
fn policy_files() {
    let seeds = [
        repo_text("policies/qp.toml"),
        repo_text("policies/nominal.toml"),
        repo_text("policies/greedy-tree.toml"),
    ];
    fuzz_text("policy.toml", &seeds, parse_policy);
}

#[test]
fn scenario_distribution_files() {
    let seeds = [repo_text("scenarios/default.toml")];
    fuzz_text("scenarios.toml", &seeds, parse_distribution);
}

#[test]
fn memory_files() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("memory.tdm");
    for k in 0..2 {
        let case = Case {
            conditions: CaseConditions {
                temperature_c: Some(10.0 + k as f64),
                fold_m: vec![0.4; 10],
                start_gap_m: Some(0.142),
                payout_scale: vec![-0.03, 0.04],
            },
            commands_m: vec![vec![-0.05; 10]],
            take_up_commands: None,
            measured_gaps_m: vec![vec![Some(0.1), None, Some(0.3), Some(0.4), Some(0.5)]],
            final_gap_vectors_m: vec![Some([0.01, 0.0, 0.0])],
            prediction_error_m: vec![Some(1e-3)],
            outcome: CaseOutcome {
                status: "connected".into(),
                commands: 1,
                corrective_commands: Some(0),
                final_gap_m: Some(0.008),
                approach_commands: None,
            },
            learning: None,
            model: None,
        };
        append_case(&path, &case).unwrap();
    }
    let seeds = [std::fs::read_to_string(&path).unwrap()];
    fuzz_text("memory.tdm", &seeds, parse_memory);
}

#[test]
fn problem_files() {
    let seeds = ["format = \"tensegrity-deploy/problem/1\"\nstart_payout_m = 0.40\nconnection_tolerance_m = 0.030\nmin_tension_n = 5.0\nmax_tension_n = 3000.0\nmax_strut_buckling_utilisation = 0.5\nmin_payout_m = -0.10\nmax_payout_m = 0.50\nmax_step_m = [0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05]\nmin_strut_clearance_m = 0.0\n".to_string()];
    fuzz_text("problem.toml", &seeds, parse_problem);
}

/// A log of the small structure: four files, one of which each input
/// mutates.
fn small_log() -> [(&'static str, String); 4] {
    [
        (
            "log.toml",
            "format = \"tensegrity-deploy/log/1\"\nstructure = \"two cables\"\n".into(),
        ),
        (
            "sensors.csv",
            "sensor,kind,target,noise_sd\nt0,tension,cc:0,0.5\nt1,tension,c1,0.5\nz,position_z,b,1e-4\nT,temperature,-,0.1\n".into(),
        ),
        (
            "commands.csv",
            "cycle,step,cable,payout_change_m\n0,1,cc,0.01\n0,2,cc,-0.01\n1,1,cc,0.005\n".into(),
        ),
        (
            "measurements.csv",
            "cycle,step,sensor,value\n0,0,t0,100.5\n0,0,z,-0.001\n0,1,t0,90\n0,1,T,20.5\n0,2,t1,\n1,0,z,0\n1,1,t0,95.25\n".into(),
        ),
    ]
}

#[test]
fn log_folders() {
    let structure = parse_structure(SMALL, Path::new("small.json")).unwrap();
    let files = small_log();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("log");
    std::fs::create_dir(&log).unwrap();
    for (name, text) in &files {
        std::fs::write(log.join(name), text).unwrap();
    }
    read_log(&log, &structure).expect("the unmutated log reads");
    let names: Vec<PathBuf> = files.iter().map(|(n, _)| log.join(n)).collect();
    let name_refs: Vec<&Path> = names.iter().map(PathBuf::as_path).collect();
    let mut runner = runner();
    runner
        .run(&input(files.len()), |(which, mutations)| {
            let bytes = mutations
                .iter()
                .fold(files[which].1.as_bytes().to_vec(), apply);
            std::fs::write(&names[which], &bytes).unwrap();
            let start = Instant::now();
            let result = read_log(&log, &structure);
            let elapsed = start.elapsed();
            std::fs::write(&names[which], &files[which].1).unwrap();
            check_outcome(result, elapsed, &name_refs)
        })
        .unwrap_or_else(|e| panic!("log folder: {e}"));
}

#[test]
fn mutations_change_what_they_say() {
    // The mutator itself: a number replaced, a line dropped, a truncation.
    let text = b"a = 1.5e-3\nb = -2\n".to_vec();
    assert_eq!(number_spans(&text), vec![(4, 10), (15, 17)]);
    assert_eq!(
        apply(text.clone(), &Mutation::ReplaceNumber(1, 4)),
        b"a = 1.5e-3\nb = 1e308\n"
    );
    assert_eq!(apply(text.clone(), &Mutation::DeleteLine(0)), b"b = -2\n");
    assert_eq!(apply(text.clone(), &Mutation::Truncate(3)), b"a =");
    assert_eq!(
        apply(text, &Mutation::DuplicateLine(1)),
        b"a = 1.5e-3\nb = -2\nb = -2\n"
    );
}

/// One semantic edit of a JSON value or a CSV cell.
#[derive(Debug, Clone)]
enum ContentEdit {
    /// The (k mod count)-th number replaced by a hostile one.
    Number(usize, usize),
    /// The (k mod count)-th list grown by a copy of its last element.
    Grow(usize),
    /// The (k mod count)-th list shortened by one.
    Shrink(usize),
    /// The (k mod count)-th string replaced.
    Text(usize, usize),
}

/// Strings a hostile file puts where a status or name belongs.
const HOSTILE_TEXTS: [&str; 5] = [
    "bogus",
    "",
    "connected\nconnected",
    "CONNECTED",
    "not_started ",
];

fn content_edit() -> impl Strategy<Value = ContentEdit> {
    prop_oneof![
        (any::<usize>(), 0..HOSTILE_NUMBERS.len()).prop_map(|(k, h)| ContentEdit::Number(k, h)),
        (any::<usize>(), 0..HOSTILE_NUMBERS.len()).prop_map(|(k, h)| ContentEdit::Number(k, h)),
        any::<usize>().prop_map(ContentEdit::Grow),
        any::<usize>().prop_map(ContentEdit::Shrink),
        (any::<usize>(), 0..HOSTILE_TEXTS.len()).prop_map(|(k, t)| ContentEdit::Text(k, t)),
    ]
}

/// Applies `edit` to a JSON value: numbers, lists and strings counted in
/// document order. A hostile number JSON cannot hold (NaN, inf) becomes
/// the largest finite one of its sign; an integer too large stays a float.
fn edit_json(value: &mut serde_json::Value, edit: &ContentEdit) {
    // Leaves and lists, in document order, by path.
    fn paths(
        v: &serde_json::Value,
        at: &mut Vec<String>,
        leaves: &mut Vec<String>,
        lists: &mut Vec<String>,
    ) {
        match v {
            serde_json::Value::Array(items) => {
                lists.push(at.join("/"));
                for (i, item) in items.iter().enumerate() {
                    at.push(i.to_string());
                    paths(item, at, leaves, lists);
                    at.pop();
                }
            }
            serde_json::Value::Object(map) => {
                for (k, item) in map {
                    at.push(k.clone());
                    paths(item, at, leaves, lists);
                    at.pop();
                }
            }
            _ => leaves.push(at.join("/")),
        }
    }
    let (mut leaves, mut lists) = (Vec::new(), Vec::new());
    paths(value, &mut Vec::new(), &mut leaves, &mut lists);
    let pointer = |p: &str| {
        if p.is_empty() {
            String::new()
        } else {
            format!("/{p}")
        }
    };
    match edit {
        ContentEdit::Number(k, h) => {
            let numbers: Vec<&String> = leaves
                .iter()
                .filter(|p| value.pointer(&pointer(p)).is_some_and(|v| v.is_number()))
                .collect();
            if numbers.is_empty() {
                return;
            }
            let at = pointer(numbers[k % numbers.len()]);
            let x: f64 = match HOSTILE_NUMBERS[*h] {
                "NaN" | "nan" | "inf" | "" => f64::MAX,
                "-inf" => f64::MIN,
                text => text.parse().unwrap_or(f64::MAX),
            };
            *value.pointer_mut(&at).unwrap() = serde_json::json!(x);
        }
        ContentEdit::Grow(k) | ContentEdit::Shrink(k) => {
            if lists.is_empty() {
                return;
            }
            let at = pointer(&lists[k % lists.len()]);
            if let Some(serde_json::Value::Array(items)) = value.pointer_mut(&at) {
                if matches!(edit, ContentEdit::Grow(_)) {
                    if let Some(last) = items.last().cloned() {
                        items.push(last);
                    }
                } else {
                    items.pop();
                }
            }
        }
        ContentEdit::Text(k, t) => {
            let texts: Vec<&String> = leaves
                .iter()
                .filter(|p| value.pointer(&pointer(p)).is_some_and(|v| v.is_string()))
                .collect();
            if texts.is_empty() {
                return;
            }
            let at = pointer(texts[k % texts.len()]);
            *value.pointer_mut(&at).unwrap() = serde_json::json!(HOSTILE_TEXTS[*t]);
        }
    }
}

/// A memory of cases as the tools write them for the reference bridge
/// (10 motors, 5 midspan pairs).
fn consistent_memory_lines() -> Vec<serde_json::Value> {
    (0..2)
        .map(|k| {
            let case = Case {
                conditions: CaseConditions {
                    temperature_c: Some(10.0 + k as f64),
                    fold_m: vec![0.4; 10],
                    start_gap_m: Some(0.142),
                    payout_scale: vec![1.01, 0.99],
                },
                commands_m: vec![vec![-0.05; 10], vec![-0.01; 10]],
                take_up_commands: None,
                measured_gaps_m: vec![
                    vec![Some(0.1); 5],
                    vec![Some(0.01), None, Some(0.02), Some(0.0), Some(0.01)],
                ],
                final_gap_vectors_m: vec![Some([0.01, 0.0, 0.0]), None, None, None, None],
                prediction_error_m: vec![Some(1e-3), None],
                outcome: CaseOutcome {
                    status: "connected".into(),
                    commands: 2,
                    corrective_commands: Some(1),
                    final_gap_m: Some(0.008),
                    approach_commands: Some(2),
                },
                // The second case learnt from the first: its record's
                // fields are mutated too.
                learning: (k == 1).then(|| CaseLearning {
                    from_case: 0,
                    from_gap_m: 0.02,
                    predicted_gaps_m: vec![Some(0.002), None, Some(0.001), Some(0.0), Some(0.003)],
                    learnt_commands: 2,
                    approach_completed: true,
                }),
                // Each case carries a learnt model: its fields are
                // mutated too.
                model: Some(CaseModel {
                    effects: vec![
                        LearntEffect {
                            effect: "joint_friction".into(),
                            values: vec![0.19],
                            std_errors: vec![Some(0.006)],
                            rival: None,
                        },
                        LearntEffect {
                            effect: "motor".into(),
                            values: vec![0.001, 0.003],
                            std_errors: vec![None, Some(2e-4)],
                            rival: None,
                        },
                    ],
                    base: "reference {}".into(),
                    accepted: k == 0,
                    held_out: true,
                    planned_rms: 1.9,
                    fitted_rms: 1.1,
                    held_out_readings: 300,
                }),
            };
            serde_json::to_value(case).unwrap()
        })
        .collect()
}

/// Issue 25: memory cases with a valid checksum but impossible contents
/// loaded and were used. Each semantically mutated case, written back with
/// its checksum, is refused naming the file, or loads with every number
/// finite and every list of the bridge's length.
#[test]
fn memory_contents() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("memory.tdm");
    let cases = consistent_memory_lines();
    let mut runner = runner();
    runner
        .run(
            &(0..cases.len(), prop::collection::vec(content_edit(), 1..=2)),
            |(which, edits)| {
                let mut text = format!("{MEMORY_FORMAT}\n");
                for (k, case) in cases.iter().enumerate() {
                    let mut case = case.clone();
                    if k == which {
                        for e in &edits {
                            edit_json(&mut case, e);
                        }
                    }
                    let json = serde_json::to_string(&case).unwrap();
                    text.push_str(&format!("fnv1a:{} {json}\n", fingerprint(json.as_bytes())));
                }
                std::fs::write(&path, &text).unwrap();
                let start = Instant::now();
                let result = read_memory_or_empty(&path, 10, 5);
                if let Ok(memory) = &result {
                    for case in &memory.cases {
                        prop_assert_eq!(case.conditions.fold_m.len(), 10);
                        prop_assert!(case.commands_m.iter().all(|r| r.len() == 10));
                        prop_assert!(case.commands_m.iter().flatten().all(|x| x.is_finite()));
                        prop_assert!(case
                            .outcome
                            .final_gap_m
                            .is_none_or(|g| (0.0..=10.0).contains(&g)));
                        prop_assert!(case
                            .outcome
                            .approach_commands
                            .is_none_or(|k| k <= case.commands_m.len()));
                        if let Some(l) = &case.learning {
                            prop_assert_eq!(l.predicted_gaps_m.len(), 5);
                            prop_assert!((0.0..=10.0).contains(&l.from_gap_m));
                            prop_assert!(l
                                .predicted_gaps_m
                                .iter()
                                .flatten()
                                .all(|g| (0.0..=10.0).contains(g)));
                        }
                    }
                    for (k, case) in memory.cases.iter().enumerate() {
                        prop_assert!(case.learning.as_ref().is_none_or(|l| l.from_case < k));
                        // A learnt model the next cycle would plan on:
                        // effects of the library, each value inside its
                        // admissible range.
                        if let Some(m) = &case.model {
                            for e in &m.effects {
                                let kind = e.kind();
                                prop_assert!(kind.is_some(), "{}", e.effect);
                                let specs = kind.unwrap().parameters();
                                prop_assert_eq!(e.values.len(), specs.len());
                                for (x, p) in e.values.iter().zip(specs) {
                                    prop_assert!(*x >= p.admissible.0 && *x <= p.admissible.1);
                                }
                            }
                            prop_assert!(m.planned_rms.is_finite() && m.fitted_rms.is_finite());
                        }
                    }
                }
                check_outcome(result, start.elapsed(), &[&path])?;
                prop_assert_eq!(
                    std::fs::read_to_string(&path).unwrap(),
                    text,
                    "file changed"
                );
                Ok(())
            },
        )
        .unwrap_or_else(|e| panic!("memory contents: {e}"));
}

/// Issue 25: shard rows were merged unchecked. One cell of a real shard's
/// `runs.csv` (from `tdeploy evaluate`, 2 scenarios) replaced by a hostile
/// number or text: `read_runs` refuses it naming the file, or reads values
/// that are finite and non-negative where the column is.
#[test]
fn shard_contents() {
    let dir = tempfile::tempdir().unwrap();
    let shard = dir.path().join("shard");
    let out = common::cli::tdeploy(
        &[
            "evaluate",
            "--scenarios",
            "2",
            "--seed",
            "3",
            "--threads",
            "1",
            "-o",
            shard.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(out.status.success(), "{}", common::cli::stderr(&out));
    let record = read_evaluation_record(&shard.join("evaluation.toml")).unwrap();
    let runs_path = shard.join("runs.csv");
    let original = std::fs::read_to_string(&runs_path).unwrap();
    read_runs(&shard, &record).unwrap();
    let rows: Vec<Vec<String>> = original
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let cells = (rows.len() - 1) * rows[0].len();
    let mut runner = runner();
    runner
        .run(
            &(0..cells, 0..HOSTILE_NUMBERS.len() + HOSTILE_TEXTS.len()),
            |(cell, hostile)| {
                let mut rows = rows.clone();
                let width = rows[0].len();
                let value = if hostile < HOSTILE_NUMBERS.len() {
                    HOSTILE_NUMBERS[hostile].to_string()
                } else {
                    HOSTILE_TEXTS[hostile - HOSTILE_NUMBERS.len()].replace('\n', " ")
                };
                rows[1 + cell / width][cell % width] = value;
                let text: String = rows.iter().map(|r| r.join(",") + "\n").collect();
                std::fs::write(&runs_path, &text).unwrap();
                let start = Instant::now();
                let result = read_runs(&shard, &record);
                if let Ok(runs) = &result {
                    for r in &runs.results {
                        prop_assert!(r.cable_travel_m.is_finite() && r.cable_travel_m >= 0.0);
                        prop_assert!(r.worst_utilisation.is_finite() && r.worst_utilisation >= 0.0);
                        prop_assert!(r.corrective_commands.is_none_or(|k| k <= r.commands));
                        prop_assert!(r.status != "connected" || r.binds.is_empty());
                        for name in &r.binds {
                            let chars = name.chars().count();
                            prop_assert!(chars > 0 && chars <= 80 && name.trim() == name);
                            prop_assert!(
                                !name.contains(';') && !name.chars().any(char::is_control)
                            );
                        }
                        for g in [r.final_measured_gap_m, r.final_true_gap_m, r.approach_gap_m]
                            .into_iter()
                            .flatten()
                        {
                            prop_assert!(g.is_finite() && g >= 0.0, "gap {g}");
                        }
                        if let Some(b) = r.largest_force_breach_n {
                            prop_assert!(b.is_finite() && b >= 0.0 && r.truth_violations > 0);
                        }
                    }
                }
                check_outcome(result, start.elapsed(), &[&runs_path])
            },
        )
        .unwrap_or_else(|e| panic!("shard contents: {e}"));
}
