//! The case-memory file: one case per line, each with its own checksum,
//! appended atomically (a journal, [`super::journal`]).
//!
//! ```text
//! tensegrity-deploy/memory/4
//! fnv1a:3f0c2b5e9a1d4c77 {"conditions":{…},"commands_m":[…],…}
//! fnv1a:…
//! ```
//!
//! Line 1 is the format and its version. Every further line is one
//! [`Case`] as compact JSON, preceded by the FNV-1a (64 bit) checksum of
//! exactly those JSON bytes and a space; every line ends in `\n`.
//!
//! - **Validated on load**: a wrong header, a checksum that does not match
//!   its line, JSON that is not a case, or a last line without its `\n`
//!   is an error naming the file and line; the file is never changed by a
//!   load, and a corrupted case is never used.
//! - **Appends are atomic**: a new file is written whole (temporary file,
//!   then rename); a case is appended as one `write` of a whole line,
//!   flushed to disk before the call returns. A crash during an append
//!   can leave only a last line without its `\n`: every case before it is
//!   intact, the load names the torn line, and [`repair_torn_tail`]
//!   (`tdeploy memory repair FILE`) removes it atomically. Appending to a
//!   file with a torn tail is refused.

use std::path::Path;

use super::journal::{self, JournalKind};
use super::{read_text, FileError};
use crate::learn::{Case, CaseMemory};

/// The first line of a memory file. Version 2 added each case's
/// optional learning record ([`crate::learn::CaseLearning`]), version 3
/// the model learnt after the case ([`crate::learn::CaseModel`]), version
/// 4 which commands took up slack cables
/// ([`crate::learn::Case::take_up_commands`]).
pub const MEMORY_FORMAT: &str = "tensegrity-deploy/memory/4";

/// Earlier memory formats still read: a version-1 case is a version-2
/// case without a learning record or an approach count (read as a cycle
/// that ran without guidance); a version-2 case is a version-3 case
/// without a learnt model (its cycle learnt none); a version-3 case is a
/// version-4 case with no take-up recorded (a learnt approach paces its
/// every command).
const OLDER_MEMORY_FORMATS: &[&str] = &[
    "tensegrity-deploy/memory/1",
    "tensegrity-deploy/memory/2",
    "tensegrity-deploy/memory/3",
];

/// The memory as a journal ([`super::journal`]).
fn kind(repair: &str) -> JournalKind<'_> {
    JournalKind {
        format: MEMORY_FORMAT,
        older_formats: OLDER_MEMORY_FORMATS,
        record: "case",
        repair,
    }
}

/// The repair command for `path`.
fn repair_command(path: &Path) -> String {
    format!("tdeploy memory repair {}", path.display())
}

/// Reads and validates a memory file (see the module documentation).
pub fn read_memory(path: &Path) -> Result<CaseMemory, FileError> {
    let text = read_text(path)?;
    parse_memory(&text, path)
}

/// Reads the memory file `path` if there is one, else an empty memory
/// (a memory that [`append_case`] will create); every case is checked for
/// a bridge of `motors` motors and `pairs` midspan pairs
/// ([`Case::validate`]), the error naming the file, the case's line and
/// the field. The file is not changed.
pub fn read_memory_or_empty(
    path: &Path,
    motors: usize,
    pairs: usize,
) -> Result<CaseMemory, FileError> {
    if !path.exists() {
        return Ok(CaseMemory::default());
    }
    let memory = read_memory(path)?;
    for (k, case) in memory.cases.iter().enumerate() {
        check_case(path, case, k, motors, pairs, "the case is not used")?;
    }
    Ok(memory)
}

/// Checks `case`, the memory's case `index`, for a bridge of `motors`
/// motors and `pairs` midspan pairs ([`Case::validate`],
/// [`Case::validate_learnt_from`]); the error names the file, the case's
/// line, the field and `consequence`.
fn check_case(
    path: &Path,
    case: &Case,
    index: usize,
    motors: usize,
    pairs: usize,
    consequence: &str,
) -> Result<(), FileError> {
    case.validate(motors, pairs)
        .and_then(|()| case.validate_learnt_from(index))
        .map_err(|e| {
            // Line 1 is the format; case k is on line k + 2.
            FileError::field(
                path,
                index + 2,
                &format!("case.{}", e.field),
                format!("{}: {consequence}", e.reason),
            )
        })
}

/// [`append_case`] of the memory's case `index`, checked first as
/// [`read_memory_or_empty`] will check it when the file is next read: a
/// case the tools would refuse to read is not written, and the file is
/// left as it was. (Until the twenty-first session cases were appended
/// unchecked, so a value the reader's range refused, a drum paying out
/// short in the twentieth, was found only when the memory was next read,
/// and every case after it was lost to that run.)
pub fn append_checked_case(
    path: &Path,
    case: &Case,
    index: usize,
    motors: usize,
    pairs: usize,
) -> Result<(), FileError> {
    check_case(
        path,
        case,
        index,
        motors,
        pairs,
        "the case is not written (the memory would refuse it when read)",
    )?;
    append_case(path, case)
}

/// Parses a memory file's text; `path` names it in errors.
pub fn parse_memory(text: &str, path: &Path) -> Result<CaseMemory, FileError> {
    let repair = repair_command(path);
    let cases = journal::parse_journal::<Case>(text, path, kind(&repair))?;
    Ok(CaseMemory {
        cases: cases.into_iter().map(|(_, c)| c).collect(),
    })
}

/// Appends `case` to the memory file at `path`, creating it if missing
/// (see [`super::journal`] for what a crash can leave).
pub fn append_case(path: &Path, case: &Case) -> Result<(), FileError> {
    let repair = repair_command(path);
    journal::append_records(path, kind(&repair), std::slice::from_ref(case))
}

/// What [`repair_torn_tail`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct Repair {
    /// Bytes of the torn last line removed (0: the file was whole and is
    /// unchanged).
    pub dropped_bytes: usize,
    /// The cases the file holds after the repair, every one validated.
    pub memory: CaseMemory,
}

/// Removes a last line without its `\n` (a torn append), rewriting the
/// file atomically, and loads what is left ([`journal::repair_torn_tail`]).
pub fn repair_torn_tail(path: &Path) -> Result<Repair, FileError> {
    let repair = repair_command(path);
    let (tail, cases) = journal::repair_torn_tail::<Case>(path, kind(&repair))?;
    Ok(Repair {
        dropped_bytes: match tail {
            journal::Tail::Torn(n) => n,
            _ => 0,
        },
        memory: CaseMemory {
            cases: cases.into_iter().map(|(_, c)| c).collect(),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::{CaseConditions, CaseOutcome};

    fn case(k: usize) -> Case {
        Case {
            conditions: CaseConditions {
                temperature_c: Some(10.0 + k as f64),
                fold_m: vec![0.4; 10],
                start_gap_m: Some(0.1415926),
                payout_scale: vec![-0.031, 0.0427],
            },
            commands_m: vec![vec![-0.05; 10], vec![-0.0123456789; 10]],
            take_up_commands: None,
            measured_gaps_m: vec![vec![Some(0.1), None, Some(0.3), Some(0.4), Some(0.5)]],
            final_gap_vectors_m: vec![Some([0.01, -0.002, 0.0]), None],
            prediction_error_m: vec![Some(1e-3), None],
            outcome: CaseOutcome {
                status: "connected".into(),
                commands: 2,
                corrective_commands: None,
                final_gap_m: Some(0.0081),
                approach_commands: None,
            },
            learning: None,
            model: None,
        }
    }

    fn stored(dir: &Path, n: usize) -> std::path::PathBuf {
        let path = dir.join("memory.tdm");
        for k in 0..n {
            append_case(&path, &case(k)).unwrap();
        }
        path
    }

    #[test]
    fn the_memory_round_trips_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = stored(dir.path(), 3);
        let memory = read_memory(&path).unwrap();
        assert_eq!(memory.cases, (0..3).map(case).collect::<Vec<_>>());
    }

    /// A learnt case's record (version 2) and its take-ups (version 4)
    /// round-trip; a case without them is written without the fields, as
    /// version 1 wrote it.
    #[test]
    fn a_learnt_cases_record_round_trips_and_a_plain_case_is_written_as_before() {
        use crate::learn::CaseLearning;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("memory.tdm");
        let mut learnt = case(1);
        learnt.outcome.approach_commands = Some(2);
        learnt.learning = Some(CaseLearning {
            from_case: 0,
            from_gap_m: 0.02,
            predicted_gaps_m: vec![Some(0.002), None, Some(0.001), Some(0.0), Some(0.003)],
            learnt_commands: 2,
            approach_completed: true,
        });
        learnt.take_up_commands = Some(vec![0]);
        append_case(&path, &case(0)).unwrap();
        append_case(&path, &learnt).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], MEMORY_FORMAT);
        assert!(!lines[1].contains("learning") && !lines[1].contains("approach_commands"));
        assert!(!lines[1].contains("take_up_commands"));
        assert!(lines[2].contains("\"learning\"") && lines[2].contains("\"take_up_commands\":[0]"));
        assert_eq!(read_memory(&path).unwrap().cases, vec![case(0), learnt]);
    }

    /// A version-1 file (cases without learning records), version-2 file
    /// (without learnt models) or version-3 file (without take-ups) loads; the first append rewrites it under
    /// the current header, its cases byte for byte, so that no file holds
    /// current cases under an older header (an older reader refuses the
    /// file by its header, not by a field it does not know).
    #[test]
    fn an_older_memory_loads_and_its_first_append_upgrades_it_whole() {
        for older in OLDER_MEMORY_FORMATS {
            let dir = tempfile::tempdir().unwrap();
            let path = stored(dir.path(), 2);
            let text = std::fs::read_to_string(&path).unwrap();
            let old = text.replacen(MEMORY_FORMAT, older, 1);
            assert_ne!(old, text);
            std::fs::write(&path, &old).unwrap();
            assert_eq!(read_memory(&path).unwrap().cases, vec![case(0), case(1)]);
            append_case(&path, &case(2)).unwrap();
            let upgraded = std::fs::read_to_string(&path).unwrap();
            assert!(upgraded.starts_with(&format!("{MEMORY_FORMAT}\n")));
            let (_, old_cases) = old.split_once('\n').unwrap();
            assert!(upgraded.contains(old_cases));
            assert_eq!(
                read_memory(&path).unwrap().cases,
                (0..3).map(case).collect::<Vec<_>>()
            );
            // A header of no known version is refused, naming the one it
            // must be.
            std::fs::write(&path, old.replacen(older, "tensegrity-deploy/memory/9", 1)).unwrap();
            let e = read_memory(&path).unwrap_err().to_string();
            assert!(e.contains("line 1") && e.contains(MEMORY_FORMAT), "{e}");
        }
    }

    /// A case with the model learnt after it (format 3) reads back as
    /// written (its checks: `learn::case`'s tests).
    #[test]
    fn a_case_with_its_learnt_model_reads_back_as_written() {
        use crate::learn::{CaseModel, LearntEffect};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.tdm");
        let mut learnt = case(1);
        learnt.model = Some(CaseModel {
            effects: vec![
                LearntEffect {
                    effect: "joint_friction".into(),
                    values: vec![0.19],
                    std_errors: vec![Some(0.006)],
                    rival: None,
                },
                LearntEffect {
                    effect: "joint_mass_error".into(),
                    values: vec![1.1],
                    std_errors: vec![Some(0.02)],
                    rival: Some("stiffness_error".into()),
                },
            ],
            base: "reference {}".into(),
            accepted: true,
            held_out: true,
            planned_rms: 1.9,
            fitted_rms: 1.1,
            held_out_readings: 420,
        });
        append_case(&path, &case(0)).unwrap();
        append_case(&path, &learnt).unwrap();
        assert_eq!(read_memory(&path).unwrap().cases, vec![case(0), learnt]);
    }

    /// One changed byte inside a case: refused at its line, the file left
    /// as it was.
    #[test]
    fn a_corrupted_case_is_rejected_naming_its_line_and_the_file_is_left_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let path = stored(dir.path(), 3);
        let mut bytes = std::fs::read(&path).unwrap();
        let third_line = bytes
            .iter()
            .enumerate()
            .filter(|(_, &b)| b == b'\n')
            .nth(1)
            .unwrap()
            .0
            + 1;
        let at = third_line + 60;
        bytes[at] = if bytes[at] == b'1' { b'2' } else { b'1' };
        std::fs::write(&path, &bytes).unwrap();
        let e = read_memory(&path).unwrap_err().to_string();
        assert!(
            e.contains("memory.tdm") && e.contains("line 3") && e.contains("checksum"),
            "{e}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
    }

    /// A crash mid-append leaves a line without its `\n`: the load names
    /// it, appending is refused, nothing earlier is lost, and dropping
    /// the torn tail gives back every earlier case.
    #[test]
    fn an_interrupted_append_loses_nothing_stored_before_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = stored(dir.path(), 2);
        let line = journal::record_line(&path, &case(2)).unwrap();
        let mut file = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .unwrap();
        std::io::Write::write_all(&mut file, &line.as_bytes()[..line.len() / 2]).unwrap();
        drop(file);
        let torn = std::fs::read(&path).unwrap();
        let e = read_memory(&path).unwrap_err().to_string();
        assert!(e.contains("line 4") && e.contains("interrupted"), "{e}");
        assert!(append_case(&path, &case(3)).is_err());
        assert_eq!(std::fs::read(&path).unwrap(), torn);
        assert!(e.contains("tdeploy memory repair"), "{e}");
        let repair = repair_torn_tail(&path).unwrap();
        assert_eq!(repair.dropped_bytes, line.len() / 2);
        assert_eq!(repair.memory.cases, vec![case(0), case(1)]);
        assert_eq!(read_memory(&path).unwrap().cases, vec![case(0), case(1)]);
        assert_eq!(repair_torn_tail(&path).unwrap().dropped_bytes, 0);
        // A corrupted case is not what a crash leaves: not repaired.
        let whole = std::fs::read_to_string(&path).unwrap();
        let bad = whole
            .replacen("fnv1a:", "fnv1a:0", 2)
            .replacen("fnv1a:0", "fnv1a:", 1);
        std::fs::write(&path, format!("{bad}torn")).unwrap();
        let e = repair_torn_tail(&path).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("checksum"), "{e}");
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            format!("{bad}torn")
        );
    }

    #[test]
    fn a_file_that_is_not_a_memory_is_refused_and_not_appended_to() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notes.txt");
        std::fs::write(&path, "my notes\n").unwrap();
        assert!(read_memory(&path)
            .unwrap_err()
            .to_string()
            .contains("line 1"));
        assert!(append_case(&path, &case(0)).is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "my notes\n");
    }

    /// A case the reader would refuse is not appended: the error names
    /// the file, the line it would have taken and the field, and the file
    /// is left as it was.
    #[test]
    fn a_case_the_reader_would_refuse_is_not_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("checked.tdm");
        let good = consistent_case();
        append_checked_case(&path, &good, 0, 10, 5).unwrap();
        let before = std::fs::read(&path).unwrap();
        let mut bad = consistent_case();
        bad.conditions.payout_scale[0] = -1.5;
        let e = append_checked_case(&path, &bad, 1, 10, 5)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("checked.tdm") && e.contains("line 3") && e.contains("payout_scale"),
            "{e}"
        );
        assert!(e.contains("not written"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), before);
        // Wrong counts for the bridge: refused too, nothing created.
        let fresh = dir.path().join("fresh.tdm");
        assert!(append_checked_case(&fresh, &good, 0, 9, 5).is_err());
        assert!(!fresh.exists());
        assert_eq!(read_memory_or_empty(&path, 10, 5).unwrap().cases, [good]);
    }

    /// The payout scale a case stores is the estimator's `ŝ` (a half's
    /// cable moves `(1 + ŝ)` times its drum command), negative for drums
    /// that pay out short: the range `(0, 10]` refused such a case when
    /// the memory was next read (`tdeploy cycles --memory` run twice on a
    /// bridge whose drums slip). Read back as written; `1 + ŝ ≤ 0` is
    /// refused.
    #[test]
    fn a_case_whose_drums_paid_out_short_is_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("short.tdm");
        let mut short = consistent_case();
        short.conditions.payout_scale = vec![-0.0054, -0.05];
        append_case(&path, &short).unwrap();
        let memory = read_memory_or_empty(&path, 10, 5).unwrap();
        assert_eq!(memory.cases, [short.clone()]);
        short.conditions.payout_scale[1] = -1.0;
        assert!(short.validate(10, 5).is_err());
    }

    /// A case as the tools write it for the reference bridge (10 motors,
    /// 5 midspan pairs).
    fn consistent_case() -> Case {
        Case {
            conditions: CaseConditions {
                temperature_c: Some(12.0),
                fold_m: vec![0.4; 10],
                start_gap_m: Some(0.14),
                payout_scale: vec![0.01, -0.01],
            },
            commands_m: vec![vec![-0.05; 10], vec![-0.01; 10]],
            take_up_commands: None,
            measured_gaps_m: vec![
                vec![Some(0.1); 5],
                vec![Some(0.01), None, Some(0.01), Some(0.02), Some(0.0)],
            ],
            final_gap_vectors_m: vec![Some([0.01, -0.002, 0.0]), None, None, None, None],
            prediction_error_m: vec![Some(1e-3), None],
            outcome: CaseOutcome {
                status: "connected".into(),
                commands: 2,
                corrective_commands: Some(1),
                final_gap_m: Some(0.02),
                approach_commands: None,
            },
            learning: None,
            model: None,
        }
    }

    /// Issue 25: cases with a 1 000-motor fold, an 11-motor command row,
    /// the wrong number of gap pairs, values of 1e308 or subnormal,
    /// negative gaps or folds and a garbage status all loaded and were
    /// used (a final gap of 1e308 made `cycles` write an infinite ILC
    /// prediction). Each is refused naming the file, the case's line and
    /// the field; the file is left as it was.
    #[test]
    fn memory_contents_out_of_range_are_refused_naming_line_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let good = consistent_case();
        good.validate(10, 5).unwrap();
        /// A field path and the edit that breaks it.
        type Edit = (&'static str, fn(&mut Case));
        let edits: Vec<Edit> = vec![
            ("case.conditions.fold_m", |c| {
                c.conditions.fold_m = vec![0.4; 1000]
            }),
            ("case.conditions.fold_m[3]", |c| {
                c.conditions.fold_m[3] = -0.1
            }),
            ("case.commands_m[1]", |c| c.commands_m[1].push(0.0)),
            ("case.commands_m[0][2]", |c| c.commands_m[0][2] = 1e308),
            ("case.measured_gaps_m[0][4]", |c| {
                c.measured_gaps_m[0][4] = Some(-0.01)
            }),
            ("case.final_gap_vectors_m", |c| {
                c.final_gap_vectors_m.pop().map(drop).unwrap_or(())
            }),
            ("case.final_gap_vectors_m[0][1]", |c| {
                c.final_gap_vectors_m[0] = Some([0.0, 1e308, 0.0])
            }),
            ("case.prediction_error_m[0]", |c| {
                c.prediction_error_m[0] = Some(1e-310)
            }),
            ("case.conditions.payout_scale[0]", |c| {
                c.conditions.payout_scale[0] = -1.0
            }),
            ("case.outcome.status", |c| c.outcome.status = "bogus".into()),
            ("case.outcome.status", |c| c.outcome.status = String::new()),
            ("case.outcome.commands", |c| c.outcome.commands = 7),
            ("case.outcome.corrective_commands", |c| {
                c.outcome.corrective_commands = Some(usize::MAX)
            }),
            ("case.outcome.final_gap_m", |c| {
                c.outcome.final_gap_m = Some(1e308)
            }),
            ("case.take_up_commands[0]", |c| {
                c.take_up_commands = Some(vec![2])
            }),
            ("case.take_up_commands[1]", |c| {
                c.take_up_commands = Some(vec![1, 0])
            }),
            ("case.take_up_commands[1]", |c| {
                c.take_up_commands = Some(vec![0, 0])
            }),
        ];
        for (k, (field, edit)) in edits.into_iter().enumerate() {
            let path = dir.path().join(format!("m{k}.tdm"));
            append_case(&path, &good).unwrap();
            let mut bad = good.clone();
            edit(&mut bad);
            append_case(&path, &bad).unwrap();
            let bytes = std::fs::read(&path).unwrap();
            let e = read_memory_or_empty(&path, 10, 5).unwrap_err();
            let FileError::Field { line, field: f, .. } = &e else {
                panic!("{e}")
            };
            assert_eq!((*line, f.as_str()), (3, field), "{e}");
            assert!(e.to_string().contains(&format!("m{k}.tdm")), "{e}");
            assert_eq!(std::fs::read(&path).unwrap(), bytes);
        }
    }
}
