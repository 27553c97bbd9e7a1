//! The folder of an online deployment session (`tdeploy session`, see
//! [`crate::control::session`]).
//!
//! ```text
//! SESSION/
//!   session.toml   format, structure, approval_required, created_by,
//!                  inputs_fingerprint, [interlocks]
//!   session.lock   the lock a writing command holds (empty)
//!   model.toml     the controller's model (a model file)
//!   problem.toml   the problem, every field written out
//!   policy.toml    the policy, every field written out
//!   sensors.csv    the sensor layout (the log's format)
//!   folded_start.json  the controller model's folded start (a state,
//!                  computed once: no command folds the model again)
//!   guidance.json  the case memory's guidance (with `start --memory`):
//!                  the learnt approach and payout-scale prior, fixed
//!   events.tdj     the journal: every event, checksummed (the record)
//!   log/           the measurement log so far (derived)
//!   pending.json   the pending command, when there is one (derived)
//!   pending.csv    the same as a command file (derived)
//!   status.json    where the session stands (derived)
//! ```
//!
//! - **The record** is `events.tdj`, a journal ([`super::journal`]): the
//!   format line `tensegrity-deploy/session-events/1`, then one
//!   [`SessionEvent`] per line as compact JSON behind its FNV-1a checksum.
//!   Events are only ever appended, in one write, flushed before the
//!   command reports them. The inputs beside it are written once, when
//!   the session is created (the folder appears whole or not at all).
//! - **The views** (`log/`, `pending.*`, `status.json`) are rewritten
//!   from the record after every change, each file atomically; a crash
//!   between the append and the views leaves them one change behind, and
//!   the next command rewrites them. Nothing reads them back.
//! - **The log** (`log/`, [`super::log`]) is in the layout `tdeploy
//!   deploy` writes: cycle 1, step 1 the fold from the designed state to
//!   the folded start (measured: the session's step 0), step `k + 1` the
//!   session's command `k` and its readings. Issued commands not yet
//!   measured, and rejected ones, are not in it: it holds what the bridge
//!   did. `tdeploy compare`, `diagnose` and `replay` read it.
//! - **Readings files** (`session record --measurements F`): either CSV
//!   with the header `step,sensor,value` (one row per sensor read; every
//!   row the same step; an empty value or a missing row is a reading not
//!   taken), or one JSON measurements message of the protocol
//!   ([`super::session_protocol`]).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::commands::{write_commands, CommandSequence};
use super::evaluation_files::fingerprint;
use super::journal::{self, JournalKind, Tail};
use super::log::{read_sensors, sensors_table, write_log, READING_RANGE};
use super::model_file::ModelFile;
use super::policy_file::policy_to_toml;
use super::problem_file::problem_to_toml;
use super::session_protocol::{parse_in_message, InMessage, ProtocolError, SessionStatus};
use super::toml_text::parse_toml;
use super::{
    csv_records, csv_with_header, read_text, sync_parent_folder, write_atomically, write_json,
    FileError,
};
use crate::control::{
    CaseTakeUp, Guidance, Interlocks, Session, SessionEvent, SessionPhase, StepReadings,
    MAX_FEEDFORWARD_SPLITS, OWN_COMMAND_TOLERANCE_M,
};
use crate::measure::log::{Cycle, MeasurementLog};
use crate::model::{DeploymentState, Structure};
use crate::plan::{DeploymentProblem, Policy};
use crate::sim::Sensor;

/// The `format` of `session.toml`.
pub const SESSION_FORMAT: &str = "tensegrity-deploy/session/1";
/// The first line of `events.tdj`.
pub const EVENTS_FORMAT: &str = "tensegrity-deploy/session-events/1";
/// Header of a readings CSV file.
pub const READINGS_HEADER: [&str; 3] = ["step", "sensor", "value"];

/// `session.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionMeta {
    /// [`SESSION_FORMAT`].
    pub format: String,
    /// The structure's name (the model's).
    pub structure: String,
    /// Whether every command needs an operator's approval.
    pub approval_required: bool,
    /// The program that created it, with its version.
    pub created_by: String,
    /// The FNV-1a fingerprint of the inputs beside it (`model.toml`,
    /// `problem.toml`, `policy.toml`, `sensors.csv`, `folded_start.json`,
    /// `guidance.json`) and of this file's other fields: a session runs on
    /// the inputs it started with, and one whose inputs were edited since
    /// is refused.
    pub inputs_fingerprint: String,
    /// The interlocks' thresholds it runs with.
    pub interlocks: Interlocks,
}

/// The input files of a session, in the order they are fingerprinted.
const INPUT_FILES: [&str; 6] = [
    "model.toml",
    "problem.toml",
    "policy.toml",
    "sensors.csv",
    "folded_start.json",
    "guidance.json",
];

/// The fingerprint of the session's inputs in `dir` (a missing optional
/// file counts as empty) and of `meta`'s other fields (approval, the
/// interlocks' thresholds: loosening one is an edit too).
fn inputs_fingerprint(dir: &Path, meta: &SessionMeta) -> Result<String, FileError> {
    let settings = SessionMeta {
        inputs_fingerprint: String::new(),
        ..meta.clone()
    };
    let mut bytes = toml::to_string(&settings)
        .map_err(|e| FileError::Invalid {
            path: dir.join("session.toml"),
            entry: "session".into(),
            message: e.to_string(),
        })?
        .into_bytes();
    for name in INPUT_FILES {
        let path = dir.join(name);
        match std::fs::read(&path) {
            Ok(b) => bytes.extend_from_slice(&b),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && name == "guidance.json" => {}
            Err(e) => return Err(FileError::read(&path, e)),
        }
        bytes.push(0);
    }
    Ok(fingerprint(&bytes))
}

/// The journal's kind, for messages.
fn events_kind(repair: &str) -> JournalKind<'_> {
    JournalKind {
        format: EVENTS_FORMAT,
        older_formats: &[],
        record: "event",
        repair,
    }
}

/// The journal of the session in `dir`.
pub fn events_path(dir: &Path) -> PathBuf {
    dir.join("events.tdj")
}

/// What a new session is created with.
pub struct NewSession<'a> {
    /// `session.toml` (its inputs' fingerprint is filled in).
    pub meta: SessionMeta,
    /// The controller's model file (its structure source absolute or
    /// the reference).
    pub model_file: &'a ModelFile,
    /// The problem.
    pub problem: &'a DeploymentProblem,
    /// The policy.
    pub policy: &'a Policy,
    /// The sensor layout.
    pub sensors: &'a [Sensor],
    /// The structure (for the sensor layout's targets).
    pub structure: &'a Structure,
    /// The model's folded start, kept so that no command folds the model
    /// again ([`crate::control::SessionSetup::folded_start`]).
    pub folded_start: &'a DeploymentState,
    /// Guidance from the case memory, fixed when the session is created
    /// (`None`: none).
    pub guidance: Option<&'a Guidance>,
}

/// Creates the session folder `dir` with its inputs and an empty journal.
/// An existing `dir` is refused, whatever it holds: a session is never
/// overwritten. The folder is written beside `dir` and renamed into
/// place, so it appears whole or not at all.
pub fn create_session(dir: &Path, new: &NewSession) -> Result<(), FileError> {
    if dir.exists() {
        return Err(FileError::Invalid {
            path: dir.to_path_buf(),
            entry: "-o".into(),
            message: "already exists; a session folder is never overwritten (choose a new one)"
                .into(),
        });
    }
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).map_err(|e| FileError::Create {
        path: parent.clone(),
        cause: e,
    })?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "session".into());
    let tmp = parent.join(format!(".{name}.tmp{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let result = (|| {
        std::fs::create_dir(&tmp).map_err(|e| FileError::Create {
            path: tmp.clone(),
            cause: e,
        })?;
        // The structure file stays where it is (its path absolute).
        write_atomically(
            &tmp.join("model.toml"),
            new.model_file.to_toml(dir).as_bytes(),
        )?;
        write_atomically(
            &tmp.join("problem.toml"),
            problem_to_toml(new.problem).as_bytes(),
        )?;
        write_atomically(
            &tmp.join("policy.toml"),
            policy_to_toml(new.policy).as_bytes(),
        )?;
        sensors_table(new.sensors, new.structure).write(&tmp.join("sensors.csv"))?;
        write_json(&tmp.join("folded_start.json"), new.folded_start)?;
        if let Some(g) = new.guidance {
            write_json(&tmp.join("guidance.json"), g)?;
        }
        let meta = SessionMeta {
            inputs_fingerprint: inputs_fingerprint(&tmp, &new.meta)?,
            ..new.meta.clone()
        };
        let meta = toml::to_string(&meta).map_err(|e| FileError::Invalid {
            path: tmp.join("session.toml"),
            entry: "session".into(),
            message: e.to_string(),
        })?;
        write_atomically(&tmp.join("session.toml"), meta.as_bytes())?;
        write_atomically(&tmp.join("session.lock"), b"")?;
        journal::append_records::<SessionEvent>(&events_path(&tmp), events_kind(""), &[])?;
        std::fs::rename(&tmp, dir).map_err(|e| FileError::write(dir, e))?;
        sync_parent_folder(dir)
    })();
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

/// Reads `session.toml` of the session in `dir`.
pub fn read_meta(dir: &Path) -> Result<SessionMeta, FileError> {
    let path = dir.join("session.toml");
    let meta: SessionMeta = parse_toml(&read_text(&path)?, &path)?;
    if meta.format != SESSION_FORMAT {
        return Err(FileError::Invalid {
            path,
            entry: "format".into(),
            message: format!("expected \"{SESSION_FORMAT}\", found \"{}\"", meta.format),
        });
    }
    if let Err((field, message)) = meta.interlocks.validate() {
        return Err(FileError::Invalid {
            path,
            entry: format!("interlocks.{field}"),
            message,
        });
    }
    if inputs_fingerprint(dir, &meta)? != meta.inputs_fingerprint {
        return Err(FileError::Invalid {
            path,
            entry: "inputs_fingerprint".into(),
            message: format!(
                "the session's inputs ({} or this file's settings) changed since it started; a session runs on the inputs it started with (start a new one)",
                INPUT_FILES.join(", ")
            ),
        });
    }
    Ok(meta)
}

/// Reads the model's folded start the session keeps
/// (`folded_start.json`), checked against `structure`, the problem's
/// `start_payout_m` and whether the model runs over cable seats
/// (`seated`: the state then holds the arcs of every segment, else none);
/// `None` when the file is missing (the controller then folds the model
/// itself, to the same state).
pub fn read_folded_start(
    dir: &Path,
    structure: &Structure,
    start_payout_m: &[f64],
    seated: bool,
) -> Result<Option<DeploymentState>, FileError> {
    let path = dir.join("folded_start.json");
    if !path.exists() {
        return Ok(None);
    }
    let text = read_text(&path)?;
    let state: DeploymentState = serde_json::from_str(&text).map_err(|e| FileError::Syntax {
        path: path.clone(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    let invalid = |entry: &str, message: String| FileError::Invalid {
        path: path.clone(),
        entry: entry.into(),
        message,
    };
    if state.positions_m.len() != structure.nodes.len()
        || state.segment_rest_lengths_m.len() != structure.segment_count()
        || state.joint_slip.len() != structure.segment_count()
        || state.segment_offsets.len() != structure.continuous_cables.len() + 1
    {
        return Err(invalid(
            "positions_m",
            "not a state of the session's structure (node or segment counts differ)".into(),
        ));
    }
    // The fold reaches its payout in increments: to rounding.
    let same = state.payout_m.len() == start_payout_m.len()
        && state
            .payout_m
            .iter()
            .zip(start_payout_m)
            .all(|(a, b)| (a - b).abs() <= OWN_COMMAND_TOLERANCE_M);
    if !same {
        return Err(invalid(
            "payout_m",
            format!(
                "{:?} m, but the problem starts at {start_payout_m:?} m",
                state.payout_m
            ),
        ));
    }
    if state
        .positions_m
        .iter()
        .any(|p| !p.iter().all(|v| v.is_finite()))
        || state
            .segment_rest_lengths_m
            .iter()
            .any(|l| !(l.is_finite() && *l > 0.0))
    {
        return Err(invalid(
            "positions_m",
            "a position or rest length that is not a finite (positive) number".into(),
        ));
    }
    let arcs = if seated { structure.segment_count() } else { 0 };
    if state.seat_material_m.len() != arcs
        || state
            .seat_material_m
            .iter()
            .any(|m| !(m.is_finite() && *m >= 0.0))
    {
        return Err(invalid(
            "seat_material_m",
            if seated {
                format!(
                    "the model runs over cable seats: the kept start must hold the arcs of its {arcs} segments as finite lengths ≥ 0 m (a start kept by a build before the seats were the model's has none: start a new session)"
                )
            } else {
                "the model has no cable seats, but the kept start holds arcs".into()
            },
        ));
    }
    Ok(Some(state))
}

/// Reads the guidance the session was created with (`guidance.json`;
/// the default, no guidance, when there is none), checked for `motors`
/// motors.
pub fn read_guidance(dir: &Path, motors: usize) -> Result<Guidance, FileError> {
    let path = dir.join("guidance.json");
    if !path.exists() {
        return Ok(Guidance::default());
    }
    let text = read_text(&path)?;
    let g: Guidance = serde_json::from_str(&text).map_err(|e| FileError::Syntax {
        path: path.clone(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    // Each row one finite payout change per motor.
    let bad_row = |rows: &[Vec<f64>], field: &str| {
        rows.iter()
            .position(|u| u.len() != motors || u.iter().any(|v| !v.is_finite()))
            .map(|k| FileError::Invalid {
                path: path.clone(),
                entry: format!("{field}[{k}]"),
                message: format!("needs {motors} finite payout changes, m"),
            })
    };
    if let Some(e) = bad_row(&g.feedforward_m, "feedforward_m") {
        return Err(e);
    }
    if let CaseTakeUp::InFront(added) = &g.case_take_up {
        if added.len() > g.feedforward_m.len() {
            return Err(FileError::Invalid {
                path,
                entry: "case_take_up.in_front".into(),
                message: format!(
                    "{} rows for {} feedforward commands",
                    added.len(),
                    g.feedforward_m.len()
                ),
            });
        }
        if let Some(e) = bad_row(added, "case_take_up.in_front") {
            return Err(e);
        }
    }
    if g.feedforward_splits > MAX_FEEDFORWARD_SPLITS {
        return Err(FileError::Invalid {
            path,
            entry: "feedforward_splits".into(),
            message: format!(
                "{} halvings; at most {MAX_FEEDFORWARD_SPLITS}",
                g.feedforward_splits
            ),
        });
    }
    let prior_ok = g
        .payout_scale_prior
        .iter()
        .flatten()
        .chain(&g.payout_scale_prior_sd)
        .all(|v| v.is_finite());
    if !prior_ok {
        return Err(FileError::Invalid {
            path,
            entry: "payout_scale_prior".into(),
            message: "not finite".into(),
        });
    }
    Ok(g)
}

/// Reads the session's sensor layout.
pub fn read_session_sensors(dir: &Path, structure: &Structure) -> Result<Vec<Sensor>, FileError> {
    read_sensors(&dir.join("sensors.csv"), structure)
}

/// The journal's events, validated (the file unchanged; a torn last line
/// is an error, see [`repair_events`]).
pub fn read_events(dir: &Path) -> Result<Vec<SessionEvent>, FileError> {
    let path = events_path(dir);
    let repair = format!("tdeploy session repair {}", dir.display());
    let text = read_text(&path)?;
    Ok(journal::parse_journal(&text, &path, events_kind(&repair))?
        .into_iter()
        .map(|(_, e)| e)
        .collect())
}

/// The journal's events as a repair would leave them, the file
/// unchanged: a torn last line (the append a crash interrupted: it was
/// never reported, so it never happened) left out, a complete last event
/// without its `\n` read; with what the tail was.
pub fn read_events_tolerant(dir: &Path) -> Result<(Vec<SessionEvent>, Tail), FileError> {
    let path = events_path(dir);
    let repair = format!("tdeploy session repair {}", dir.display());
    let bytes = std::fs::read(&path).map_err(|e| FileError::read(&path, e))?;
    let (records, tail) = journal::parse_journal_tolerant(&bytes, &path, events_kind(&repair))?;
    Ok((records.into_iter().map(|(_, e)| e).collect(), tail))
}

/// Repairs the journal's tail ([`journal::repair_torn_tail`]) and returns
/// what it was, with the events.
pub fn repair_events(dir: &Path) -> Result<(Tail, Vec<SessionEvent>), FileError> {
    let path = events_path(dir);
    let repair = format!("tdeploy session repair {}", dir.display());
    let (tail, records) = journal::repair_torn_tail(&path, events_kind(&repair))?;
    Ok((tail, records.into_iter().map(|(_, e)| e).collect()))
}

/// Appends `events` to the journal in one write (nothing when empty).
pub fn append_events(dir: &Path, events: &[SessionEvent]) -> Result<(), FileError> {
    if events.is_empty() {
        return Ok(());
    }
    let repair = format!("tdeploy session repair {}", dir.display());
    journal::append_records(&events_path(dir), events_kind(&repair), events)
}

/// The pending command as `pending.json` writes it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PendingCommand<'a> {
    /// The command's number.
    pub step: usize,
    /// Payout change per motor, m, in the motors' order.
    pub payout_change_m: &'a [f64],
    /// The motors (continuous cables) in order.
    pub motors: Vec<&'a str>,
    /// Whether it may be executed now.
    pub cleared: bool,
    /// Gap per pair the controller predicts for it, m.
    pub predicted_gaps_m: Option<&'a [f64]>,
}

/// Rewrites the session's views from `session` (see the module notes):
/// `log/`, `pending.json` and `pending.csv` (removed without a pending
/// command), `status.json`.
pub fn write_views(
    dir: &Path,
    session: &Session,
    status: &SessionStatus,
    start_payout_m: &[f64],
) -> Result<(), FileError> {
    let setup = session.setup();
    let structure = setup.model.structure();
    remove_stale_temporaries(dir)?;
    remove_stale_temporaries(&dir.join("log"))?;
    if !session.readings().is_empty() {
        let mut commands = vec![start_payout_m.to_vec()];
        commands.extend(session.executed_commands_m().iter().cloned());
        let mut readings = vec![vec![None; setup.sensors.len()]];
        readings.extend(session.readings().iter().cloned());
        let log = MeasurementLog {
            structure: structure.name.clone(),
            sensors: setup.sensors.to_vec(),
            cycles: vec![Cycle {
                label: 1,
                step_labels: (1..=commands.len() as u64).collect(),
                commands,
                readings,
            }],
        };
        write_log(&dir.join("log"), &log, structure)?;
    }
    let (json, csv) = (dir.join("pending.json"), dir.join("pending.csv"));
    match (&status.pending_step, &status.pending_command_m) {
        (Some(step), Some(command)) => {
            let pending = PendingCommand {
                step: *step,
                payout_change_m: command,
                motors: structure
                    .continuous_cables
                    .iter()
                    .map(|c| c.id.as_str())
                    .collect(),
                cleared: status.pending_cleared.unwrap_or(false),
                predicted_gaps_m: status.pending_predicted_gaps_m.as_deref(),
            };
            write_json(&json, &pending)?;
            let sequence = CommandSequence {
                step_labels: vec![*step as u64],
                payout_change_m: vec![command.clone()],
            };
            write_commands(&csv, &sequence, structure)?;
        }
        _ => {
            for p in [&json, &csv] {
                match std::fs::remove_file(p) {
                    Ok(()) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                    Err(e) => return Err(FileError::write(p, e)),
                }
            }
        }
    }
    write_json(&dir.join("status.json"), status)
}

/// Removes the temporary files (`.NAME.tmpPID`) of atomic writes that a
/// killed process left in `dir` (a missing folder has none).
fn remove_stale_temporaries(dir: &Path) -> Result<(), FileError> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') && name.contains(".tmp") && entry.path().is_file() {
            std::fs::remove_file(entry.path()).map_err(|e| FileError::write(&entry.path(), e))?;
        }
    }
    Ok(())
}

/// Reads a readings file (CSV or one JSON measurements message, see the
/// module notes) for the layout `sensors`.
pub fn read_readings(path: &Path, sensors: &[Sensor]) -> Result<StepReadings, FileError> {
    let text = read_text(path)?;
    if text.trim_start().starts_with('{') {
        let invalid = |e: ProtocolError| match e.position {
            Some((line, column)) => FileError::Syntax {
                path: path.to_path_buf(),
                line,
                column,
                message: e.message,
            },
            None => FileError::Invalid {
                path: path.to_path_buf(),
                entry: e.field,
                message: e.message,
            },
        };
        return match parse_in_message(&text, sensors) {
            Ok(InMessage::Measurements(r)) => Ok(r),
            Ok(other) => Err(invalid(ProtocolError::field(
                "type",
                format!("a \"{}\" message is not readings", other.type_name()),
            ))),
            Err(e) => Err(invalid(e)),
        };
    }
    let mut reader = csv_with_header(&text, path, &READINGS_HEADER)?;
    let mut values = vec![None; sensors.len()];
    let mut seen = vec![false; sensors.len()];
    let mut step: Option<usize> = None;
    for record in csv_records(&mut reader, path) {
        let (line, r) = record?;
        let err = |field: &str, message: String| FileError::field(path, line, field, message);
        let k: usize = r[0].parse().map_err(|_| {
            err(
                "step",
                format!("\"{}\" is not a non-negative integer", &r[0]),
            )
        })?;
        match step {
            Some(s) if s != k => {
                return Err(err(
                    "step",
                    format!("step {k}, but the rows above are step {s}: one step per file"),
                ))
            }
            _ => step = Some(k),
        }
        let s = sensors.iter().position(|s| s.id == r[1]).ok_or_else(|| {
            err(
                "sensor",
                format!("no sensor \"{}\" in the session's layout", &r[1]),
            )
        })?;
        if seen[s] {
            return Err(err("sensor", format!("\"{}\" read twice", &r[1])));
        }
        seen[s] = true;
        if !r[2].is_empty() {
            let v: f64 = r[2]
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| err("value", format!("\"{}\" is not a finite number", &r[2])))?;
            READING_RANGE.check(v).map_err(|m| err("value", m))?;
            values[s] = Some(v);
        }
    }
    let step = step.ok_or_else(|| FileError::field(path, 1, "step", "no readings".into()))?;
    Ok(StepReadings { step, values })
}

/// The status line of a phase, in words.
pub fn phase_words(phase: &SessionPhase) -> String {
    match phase {
        SessionPhase::AwaitingStart => "awaiting the folded start's readings (step 0)".into(),
        SessionPhase::Remeasure { step } => format!(
            "step {step}'s readings were discarded: read the sensors again (no command is repeated) and record step {step}"
        ),
        SessionPhase::Ready { step } => {
            format!("step {step} measured; `next` plans command {}", step + 1)
        }
        SessionPhase::Pending { step, cleared, .. } => {
            if *cleared {
                format!("command {step} issued; awaiting its readings")
            } else {
                format!("command {step} awaits an operator's approval")
            }
        }
        SessionPhase::Stopped { step, reason } => {
            format!(
                "stopped after step {step} by an interlock: {reason}; `session resume` continues"
            )
        }
        SessionPhase::Ended { words, .. } => format!("ended: {words}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};

    /// The second guard behind the inputs' fingerprint: a folded start
    /// that is not the problem's, or not of the structure, is refused
    /// naming the file and field.
    #[test]
    fn a_folded_start_that_is_not_the_problems_is_refused_naming_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let mut state = DeploymentState::reference(&s);
        let n = state.payout_m.len();
        state.payout_m = vec![0.4; n];
        write_json(&dir.path().join("folded_start.json"), &state).unwrap();
        let start = vec![0.4; n];
        assert_eq!(
            read_folded_start(dir.path(), &s, &start, false).unwrap(),
            Some(state.clone())
        );
        // A model over cable seats keeps the arcs with its start: a start
        // without them (kept before the seats were the model's) is refused.
        let e = read_folded_start(dir.path(), &s, &start, true)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("folded_start.json") && e.contains("seat_material_m"),
            "{e}"
        );
        let mut seated = state.clone();
        seated.seat_material_m = vec![0.001; s.segment_count()];
        write_json(&dir.path().join("folded_start.json"), &seated).unwrap();
        assert_eq!(
            read_folded_start(dir.path(), &s, &start, true).unwrap(),
            Some(seated)
        );
        assert!(read_folded_start(dir.path(), &s, &start, false).is_err());
        write_json(&dir.path().join("folded_start.json"), &state).unwrap();
        let other = vec![0.3; n];
        let e = read_folded_start(dir.path(), &s, &other, false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("folded_start.json") && e.contains("payout_m"),
            "{e}"
        );
        state.positions_m.pop();
        write_json(&dir.path().join("folded_start.json"), &state).unwrap();
        let e = read_folded_start(dir.path(), &s, &start, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("node or segment counts"), "{e}");
        std::fs::remove_file(dir.path().join("folded_start.json")).unwrap();
        assert_eq!(
            read_folded_start(dir.path(), &s, &start, false).unwrap(),
            None
        );
    }

    /// A session's `guidance.json` written before the feedforward halves
    /// reads as no halving; a hand-edited count beyond the controller's
    /// bound is refused naming the field (each halving is one more model
    /// trial per decision).
    #[test]
    fn a_guidance_file_reads_its_halvings_within_their_bound() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("guidance.json");
        let old = r#"{"feedforward_m":[[-0.05,-0.05]],"payout_scale_prior":null,"payout_scale_prior_sd":null}"#;
        std::fs::write(&path, old).unwrap();
        assert_eq!(read_guidance(dir.path(), 2).unwrap().feedforward_splits, 0);
        let many = old.replace("}", r#","feedforward_splits":1000}"#);
        std::fs::write(&path, many).unwrap();
        let e = read_guidance(dir.path(), 2).unwrap_err().to_string();
        assert!(
            e.contains("guidance.json") && e.contains("feedforward_splits"),
            "{e}"
        );
    }

    /// A `guidance.json` written before the case's take-up was recorded
    /// reads as a take-up inside the learnt commands (the controller then
    /// takes its own out in proportion, as it did); one held in front
    /// reads back, and rows that do not fit the feedforward or the motors
    /// are refused naming the field.
    #[test]
    fn a_guidance_file_reads_where_it_holds_the_cases_take_up() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("guidance.json");
        let old = r#"{"feedforward_m":[[-0.05,-0.05]],"payout_scale_prior":null,"payout_scale_prior_sd":null}"#;
        std::fs::write(&path, old).unwrap();
        assert_eq!(
            read_guidance(dir.path(), 2).unwrap().case_take_up,
            CaseTakeUp::Inside
        );
        let with =
            |case_take_up: &str| old.replace("}", &format!(r#","case_take_up":{case_take_up}}}"#));
        std::fs::write(&path, with(r#"{"in_front":[[-0.004,0.0]]}"#)).unwrap();
        assert_eq!(
            read_guidance(dir.path(), 2).unwrap().case_take_up,
            CaseTakeUp::InFront(vec![vec![-0.004, 0.0]])
        );
        std::fs::write(&path, with(r#""none""#)).unwrap();
        assert_eq!(
            read_guidance(dir.path(), 2).unwrap().case_take_up,
            CaseTakeUp::None
        );
        for (bad, field) in [
            (
                r#"{"in_front":[[-0.004,0.0],[0.0,0.0]]}"#,
                "case_take_up.in_front",
            ),
            (r#"{"in_front":[[-0.004]]}"#, "case_take_up.in_front[0]"),
        ] {
            std::fs::write(&path, with(bad)).unwrap();
            let e = read_guidance(dir.path(), 2).unwrap_err().to_string();
            assert!(e.contains("guidance.json") && e.contains(field), "{e}");
        }
    }
}
