//! Checksummed journals: files that only grow, one record per line, each
//! line checked on load. The case memory ([`super::memory_file`]) and a
//! session's events ([`super::session_files`]) are journals.
//!
//! ```text
//! tensegrity-deploy/memory/3
//! fnv1a:3f0c2b5e9a1d4c77 {"conditions":{…},"commands_m":[…],…}
//! fnv1a:…
//! ```
//!
//! Line 1 is the format and its version. Every further line is one record
//! as compact JSON, preceded by the FNV-1a (64 bit) checksum of exactly
//! those JSON bytes and a space; every line ends in `\n`.
//!
//! - **Validated on load**: a wrong header, a checksum that does not match
//!   its line, JSON that is not a record, or a last line without its `\n`
//!   is an error naming the file and line; the file is never changed by a
//!   load, and a corrupted record is never used.
//! - **Appends are atomic**: a new file is written whole (temporary file,
//!   then rename, the folder flushed); records are appended as one `write` of whole lines,
//!   flushed to disk before the call returns. A crash during an append can
//!   leave only a last line without its `\n`: every record before it is
//!   intact, the load names the torn line, and [`repair_torn_tail`] removes
//!   it atomically. Appending to a file with a torn tail is refused.

use std::io::Write;
use std::path::Path;

use serde::de::DeserializeOwned;
use serde::Serialize;

use super::evaluation_files::fingerprint;
use super::{sync_parent_folder, write_atomically, FileError};

/// The checksum prefix of a record line.
const CHECKSUM_PREFIX: &str = "fnv1a:";

/// What a journal holds, for its messages.
#[derive(Debug, Clone, Copy)]
pub struct JournalKind<'a> {
    /// The first line.
    pub format: &'a str,
    /// Earlier first lines whose records read as this version's (fields
    /// added since are optional): such a file loads, and the first append
    /// rewrites it whole, atomically, under [`Self::format`] (its records
    /// byte for byte), so that no file mixes versions under an old header.
    pub older_formats: &'a [&'a str],
    /// What one record is, as error messages name it ("case", "event").
    pub record: &'a str,
    /// The command that repairs a torn tail, for the message (e.g.
    /// `tdeploy memory repair FILE`).
    pub repair: &'a str,
}

/// One record as its line (with the `\n`).
pub fn record_line<T: Serialize>(path: &Path, record: &T) -> Result<String, FileError> {
    let json = serde_json::to_string(record).map_err(|e| FileError::write(path, e.into()))?;
    Ok(format!(
        "{CHECKSUM_PREFIX}{} {json}\n",
        fingerprint(json.as_bytes())
    ))
}

/// The record of one line's content (without its `\n`), if its checksum
/// matches and its JSON is a record.
fn parse_record<T: DeserializeOwned>(content: &str) -> Option<T> {
    let (sum, json) = content.split_once(' ')?;
    let sum = sum.strip_prefix(CHECKSUM_PREFIX)?;
    (sum == fingerprint(json.as_bytes()))
        .then(|| serde_json::from_str(json).ok())
        .flatten()
}

impl JournalKind<'_> {
    /// Whether `first_line` (without its `\n`) is this journal's header, of
    /// this version or an older one it reads.
    fn reads_header(&self, first_line: &[u8]) -> bool {
        first_line == self.format.as_bytes()
            || self
                .older_formats
                .iter()
                .any(|f| first_line == f.as_bytes())
    }
}

/// What ends a journal's bytes after its last `\n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tail {
    /// Nothing: the journal is whole.
    Whole,
    /// A complete record, checksum and all, without its `\n` (an editor
    /// can leave this): kept, the `\n` added by a repair.
    MissingNewline,
    /// A torn line of this many bytes (an interrupted append): dropped
    /// by a repair.
    Torn(usize),
}

/// Where the journal's complete lines end, and what follows them.
fn tail_of<T: DeserializeOwned>(bytes: &[u8], kind: &JournalKind) -> (usize, Tail) {
    match bytes.last() {
        None | Some(b'\n') => (bytes.len(), Tail::Whole),
        Some(_) => {
            let keep = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
            let last = &bytes[keep..];
            // The header alone, or a whole record, lacking only its `\n`.
            let whole = if keep == 0 {
                kind.reads_header(last)
            } else {
                std::str::from_utf8(last)
                    .ok()
                    .and_then(parse_record::<T>)
                    .is_some()
            };
            if whole {
                (bytes.len(), Tail::MissingNewline)
            } else {
                (keep, Tail::Torn(bytes.len() - keep))
            }
        }
    }
}

/// Parses a journal's bytes as a repair would leave them, without
/// changing the file: a complete last record without its `\n` is read, a
/// torn last line is left out; returns what the tail was.
pub fn parse_journal_tolerant<T: DeserializeOwned>(
    bytes: &[u8],
    path: &Path,
    kind: JournalKind,
) -> Result<(Vec<(usize, T)>, Tail), FileError> {
    let (keep, tail) = tail_of::<T>(bytes, &kind);
    let mut text = std::str::from_utf8(&bytes[..keep])
        .map_err(|e| FileError::field(path, 1, kind.record, format!("not text (UTF-8): {e}")))?
        .to_string();
    if tail == Tail::MissingNewline {
        text.push('\n');
    }
    Ok((parse_journal(&text, path, kind)?, tail))
}

/// Parses a journal's text; `path` names it in errors. Records are
/// returned with their line numbers.
pub fn parse_journal<T: DeserializeOwned>(
    text: &str,
    path: &Path,
    kind: JournalKind,
) -> Result<Vec<(usize, T)>, FileError> {
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    match lines.first() {
        Some(l) if kind.reads_header(l.trim_end_matches('\n').as_bytes()) => {}
        _ => {
            return Err(FileError::field(
                path,
                1,
                "format",
                format!("the first line must be `{}`", kind.format),
            ))
        }
    }
    let mut records = Vec::new();
    for (i, raw) in lines.iter().enumerate().skip(1) {
        let line = i + 1;
        let Some(content) = raw.strip_suffix('\n') else {
            let message = if parse_record::<T>(raw).is_some() {
                format!(
                    "complete but for its line break; `{}` adds it and keeps every {}",
                    kind.repair, kind.record
                )
            } else {
                format!(
                    "incomplete (an append was interrupted); the {}s before it are intact: `{}` removes this line and keeps them",
                    kind.record, kind.repair
                )
            };
            return Err(FileError::field(path, line, kind.record, message));
        };
        let corrupted = |why: &str| {
            FileError::field(
                path,
                line,
                "checksum",
                format!(
                    "{why}: the file is corrupted and this {} is not used",
                    kind.record
                ),
            )
        };
        let (sum, json) = content
            .split_once(' ')
            .ok_or_else(|| corrupted("no checksum"))?;
        let sum = sum
            .strip_prefix(CHECKSUM_PREFIX)
            .ok_or_else(|| corrupted("no checksum"))?;
        if sum != fingerprint(json.as_bytes()) {
            return Err(corrupted(&format!(
                "the checksum does not match the {}",
                kind.record
            )));
        }
        let record: T = serde_json::from_str(json).map_err(|e| {
            FileError::field(
                path,
                line,
                kind.record,
                format!("not a {}: {e}", kind.record),
            )
        })?;
        records.push((line, record));
    }
    Ok(records)
}

/// Appends `records` to the journal at `path` in one write, creating the
/// file if missing (see the module documentation for what a crash can
/// leave).
pub fn append_records<T: Serialize>(
    path: &Path,
    kind: JournalKind,
    records: &[T],
) -> Result<(), FileError> {
    let mut lines = String::new();
    for r in records {
        lines.push_str(&record_line(path, r)?);
    }
    let existing = match std::fs::read(path) {
        Ok(bytes) => Some(bytes),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(FileError::read(path, e)),
    };
    match existing {
        None => {
            write_atomically(path, format!("{}\n{lines}", kind.format).as_bytes())?;
            sync_parent_folder(path)
        }
        Some(bytes) => {
            let first = bytes.split(|&b| b == b'\n').next().unwrap_or(&[]);
            if !kind.reads_header(first) {
                return Err(FileError::field(
                    path,
                    1,
                    "format",
                    format!(
                        "not a {} file (the first line must be `{}`); nothing appended",
                        kind.record, kind.format
                    ),
                ));
            }
            if bytes.last() != Some(&b'\n') {
                let line = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
                return Err(FileError::field(
                    path,
                    line,
                    kind.record,
                    format!(
                        "incomplete (an earlier append was interrupted); nothing appended: `{}` removes this line and keeps every {} before it",
                        kind.repair, kind.record
                    ),
                ));
            }
            if lines.is_empty() {
                return Ok(());
            }
            if first != kind.format.as_bytes() {
                // An older version: rewritten whole under this version's
                // header, its records as they were, then the new ones.
                let mut upgraded = format!("{}\n", kind.format).into_bytes();
                upgraded.extend_from_slice(&bytes[first.len() + 1..]);
                upgraded.extend_from_slice(lines.as_bytes());
                write_atomically(path, &upgraded)?;
                return sync_parent_folder(path);
            }
            let mut file = std::fs::OpenOptions::new()
                .append(true)
                .open(path)
                .map_err(|e| FileError::write(path, e))?;
            file.write_all(lines.as_bytes())
                .and_then(|()| file.sync_all())
                .map_err(|e| FileError::write(path, e))
        }
    }
}

/// Repairs the journal's tail, rewriting the file atomically: a torn
/// last line (an interrupted append) is removed, a complete last record
/// without its `\n` gets it; then loads it. Returns the tail found and
/// the records. A file whose other lines do not load (a wrong header, a
/// corrupted record) is an error and is left unchanged: only what a crash
/// (or an editor's missing final newline) can leave is repaired.
pub fn repair_torn_tail<T: DeserializeOwned>(
    path: &Path,
    kind: JournalKind,
) -> Result<(Tail, Vec<(usize, T)>), FileError> {
    let bytes = std::fs::read(path).map_err(|e| FileError::read(path, e))?;
    let (records, tail) = parse_journal_tolerant(&bytes, path, kind)?;
    match tail {
        Tail::Whole => {}
        Tail::MissingNewline => {
            let mut fixed = bytes.clone();
            fixed.push(b'\n');
            write_atomically(path, &fixed)?;
            sync_parent_folder(path)?;
        }
        Tail::Torn(n) => {
            write_atomically(path, &bytes[..bytes.len() - n])?;
            sync_parent_folder(path)?;
        }
    }
    Ok((tail, records))
}
