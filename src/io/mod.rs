//! Files: the only part of the library that touches the file system.
//!
//! Every reader validates what it reads and names the file, and the line
//! and field or the entry, in its error. Every writer writes atomically
//! (a temporary file in the same folder, then a rename), so a crash or a
//! failed run never leaves a half-written file in place of a good one.
//!
//! Every file a command writes has its writer here, its format documented
//! in the writer's module: the inputs that are also outputs
//! ([`structure_file`], [`commands`], [`model_file`], [`problem_file`],
//! [`log`], [`memory_file`]) and the command's results:
//! [`simulation_files`] (`simulate`), [`plan_files`] (`plan`),
//! [`deployment_files`] (`deploy`), [`replay_files`] (`replay`),
//! [`cycles_files`] (`cycles`), [`evaluation_files`] and
//! [`evaluation_summary`] (`evaluate`, `merge`, the deployment
//! experiment), [`experiment_tables`] (the other experiments),
//! [`comparison_files`] (`compare`, and the JSON reports of `compare` and
//! `diagnose`). Results folders are written whole ([`output`]). The SVG
//! figures are drawn in [`crate::report`] and written with
//! [`write_atomically`].

pub mod bridge_params;
pub mod commands;
pub mod comparison_files;
pub mod csv_table;
pub mod cycles_files;
pub mod deployment_files;
pub mod evaluation_files;
pub mod evaluation_summary;
pub mod experiment_file;
pub mod experiment_tables;
pub mod friction_table;
pub mod journal;
pub mod log;
pub mod memory_file;
pub mod model_file;
pub mod output;
pub mod plan_files;
pub mod policy_file;
pub mod problem_file;
pub mod replay_files;
pub mod session_files;
pub mod session_protocol;
pub mod simulation_files;
pub mod structure_file;
mod toml_text;

pub use csv_table::CsvTable;

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::model::StructureError;

/// An error reading or writing a file, naming the file and the place in it.
///
/// Each variant's message holds its cause, and no variant chains it as an
/// error `source` too: a chain printer (`anyhow`'s `{:#}`) would print the
/// cause twice.
#[derive(Debug, Error)]
pub enum FileError {
    /// The file could not be read.
    #[error("{}: cannot read: {cause}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Cause.
        cause: std::io::Error,
    },
    /// The folder could not be created.
    #[error("{}: cannot create: {cause}", path.display())]
    Create {
        /// The folder.
        path: PathBuf,
        /// Cause.
        cause: std::io::Error,
    },
    /// The file could not be written.
    #[error("{}: cannot write: {cause}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Cause.
        cause: std::io::Error,
    },
    /// Malformed syntax (JSON or TOML).
    #[error("{}:{line}:{column}: {}", path.display(), fold_line_breaks(message))]
    Syntax {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// A value that parses but makes no sense, in a CSV file.
    #[error("{}: line {line}, field `{}`: {}", path.display(), fold_line_breaks(field), fold_line_breaks(message))]
    Field {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// Column name.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// An entry of a JSON document that makes no sense.
    #[error("{}: {}: {}", path.display(), fold_line_breaks(entry), fold_line_breaks(message))]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Which entry, e.g. `cables[3] ("c3")`.
        entry: String,
        /// What is wrong.
        message: String,
    },
    /// The structure failed validation.
    #[error("{}: {}", path.display(), fold_line_breaks(&cause.to_string()))]
    Structure {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        cause: StructureError,
    },
}

impl FileError {
    /// A [`FileError::Field`].
    pub(crate) fn field(path: &Path, line: usize, field: &str, message: String) -> Self {
        FileError::Field {
            path: path.to_path_buf(),
            line,
            field: field.to_string(),
            message,
        }
    }

    pub(crate) fn read(path: &Path, cause: std::io::Error) -> Self {
        FileError::Read {
            path: path.to_path_buf(),
            cause,
        }
    }

    pub(crate) fn write(path: &Path, cause: std::io::Error) -> Self {
        FileError::Write {
            path: path.to_path_buf(),
            cause,
        }
    }
}

/// `text` with its line breaks written as `\n` and `\r`: a quoted CSV
/// field or a JSON id can hold them, and an error stays one line.
fn fold_line_breaks(text: &str) -> String {
    text.replace('\r', "\\r").replace('\n', "\\n")
}

/// Largest input file any reader accepts, bytes (64 MiB: a structure of
/// [`structure_file::MAX_NODES`] nodes is a few MiB, a long log a few tens);
/// a larger file is refused before it is read into memory.
pub const MAX_INPUT_BYTES: u64 = 64 << 20;

/// The text of the input file `path`: an unreadable file, one over
/// [`MAX_INPUT_BYTES`] or one that is not UTF-8 is an error naming the file
/// (and, for bad UTF-8, the line and column of the first bad byte).
pub(crate) fn read_text(path: &Path) -> Result<String, FileError> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| FileError::read(path, e))?;
    let mut bytes = Vec::new();
    // One byte more than the limit tells "at the limit" from "over it".
    file.take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| FileError::read(path, e))?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(FileError::Invalid {
            path: path.to_path_buf(),
            entry: "file".into(),
            message: format!("larger than the input limit of {MAX_INPUT_BYTES} bytes"),
        });
    }
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let (line, column) = toml_text::line_column_bytes(e.as_bytes(), valid);
        FileError::Syntax {
            path: path.to_path_buf(),
            line,
            column,
            message: "invalid UTF-8 (files must be UTF-8 text)".into(),
        }
    })
}

/// A CSV reader over `text` (fields trimmed) whose header has been checked
/// to be exactly `expected`; the error names `path`, line 1 and `header`.
pub(crate) fn csv_with_header<'a>(
    text: &'a str,
    path: &Path,
    expected: &[&str],
) -> Result<csv::Reader<&'a [u8]>, FileError> {
    let header_error = |message: String| FileError::field(path, 1, "header", message);
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header = reader
        .headers()
        .map_err(|e| header_error(e.to_string()))?
        .clone();
    if header.iter().collect::<Vec<_>>() != expected {
        return Err(header_error(format!(
            "expected columns `{}`, found `{}`",
            expected.join(","),
            header.iter().collect::<Vec<_>>().join(",")
        )));
    }
    Ok(reader)
}

/// The records of a CSV reader with their 1-based line numbers; a row the
/// CSV parser rejects becomes a `row` field error on its line.
pub(crate) fn csv_records<'a>(
    reader: &'a mut csv::Reader<&'a [u8]>,
    path: &'a Path,
) -> impl Iterator<Item = Result<(usize, csv::StringRecord), FileError>> + 'a {
    reader.records().map(move |record| match record {
        Ok(r) => Ok((r.position().map(|p| p.line() as usize).unwrap_or(0), r)),
        Err(e) => {
            let line = e.position().map(|p| p.line() as usize).unwrap_or(0);
            Err(FileError::field(path, line, "row", e.to_string()))
        }
    })
}

/// Writes `value` as pretty-printed JSON to `path`, atomically. Non-finite
/// numbers (a standard error that could not be estimated) become `null`.
pub fn write_json<T: serde::Serialize + ?Sized>(path: &Path, value: &T) -> Result<(), FileError> {
    write_atomically(path, &json_bytes(path, value)?)
}

/// Writes `value` as [`write_json`] does, but only where no file is, where
/// the file already holds exactly these bytes, or with `force`
/// ([`output::check_new_file`]): a report file the user named must not
/// replace a file of theirs.
pub fn write_new_json<T: serde::Serialize + ?Sized>(
    path: &Path,
    value: &T,
    force: bool,
) -> Result<(), FileError> {
    let bytes = json_bytes(path, value)?;
    output::check_new_file(path, &bytes, force)?;
    write_atomically(path, &bytes)
}

/// `value` as pretty-printed JSON text with a final newline; `path` names
/// the file in errors.
fn json_bytes<T: serde::Serialize + ?Sized>(path: &Path, value: &T) -> Result<Vec<u8>, FileError> {
    json_text(value)
        .map(String::into_bytes)
        .map_err(|e| FileError::write(path, e.into()))
}

/// `value` as the JSON text [`write_json`] writes: pretty-printed, with a
/// final newline (a command that prints a file it wrote prints this).
pub fn json_text<T: serde::Serialize + ?Sized>(value: &T) -> Result<String, serde_json::Error> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    Ok(text)
}

/// Flushes the folder holding `path` to disk, so that a rename or a new
/// file in it survives a power loss (a rename is durable only once its
/// folder is). Used where a file is a record, not a view rebuilt from one:
/// a journal's creation and repair, a new session folder.
pub fn sync_parent_folder(path: &Path) -> Result<(), FileError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::File::open(&dir)
        .and_then(|f| f.sync_all())
        .map_err(|e| FileError::write(&dir, e))
}

/// Writes `bytes` to `path` atomically: a temporary sibling, flushed, then
/// renamed over the target.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    use std::io::Write;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        FileError::write(path, e)
    })
}
