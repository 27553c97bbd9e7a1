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
use tensegrity_deploy::io::evaluation_files::parse_distribution;
use tensegrity_deploy::io::experiment_file::parse_experiment;
use tensegrity_deploy::io::friction_table::parse_friction_table;
use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::memory_file::{append_case, parse_memory};
use tensegrity_deploy::io::model_file::parse_model;
use tensegrity_deploy::io::policy_file::parse_policy;
use tensegrity_deploy::io::problem_file::parse_problem;
use tensegrity_deploy::io::structure_file::{parse_structure, structure_to_json};
use tensegrity_deploy::io::FileError;
use tensegrity_deploy::learn::{Case, CaseConditions, CaseOutcome};

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
            measured_gaps_m: vec![vec![Some(0.1), None, Some(0.3), Some(0.4), Some(0.5)]],
            final_gap_vectors_m: vec![Some([0.01, 0.0, 0.0])],
            prediction_error_m: vec![Some(1e-3)],
            outcome: CaseOutcome {
                status: "connected".into(),
                commands: 1,
                corrective_commands: Some(0),
                final_gap_m: Some(0.008),
            },
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
