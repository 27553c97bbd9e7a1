//! Deployment-problem files (TOML): start, connection and limits.
//!
//! ```toml
//! format = "tensegrity-deploy/problem/1"
//! start_payout_m = 0.40           # or one value per motor: [0.4, 0.4, …]
//! connection_tolerance_m = 0.030
//! min_tension_n = 5.0
//! max_tension_n = 3000.0
//! max_strut_buckling_utilisation = 0.5
//! min_payout_m = -0.10
//! max_payout_m = 0.50
//! max_step_m = 0.05
//! min_strut_clearance_m = 0.0
//! ```
//! Every field may be left out (its documented default in
//! [`crate::plan::DeploymentProblem`] applies); unknown keys are errors.
//! Errors name the file, the line and the field.

use std::path::Path;

use serde::de::DeserializeOwned;

use super::toml_text::syntax_error;
use super::FileError;
use crate::plan::DeploymentProblem;

/// The `format` a problem file must declare.
pub const PROBLEM_FORMAT: &str = "tensegrity-deploy/problem/1";

/// Reads and validates a problem file. The per-motor lists are checked
/// against a structure by [`read_problem_for`].
pub fn read_problem(path: &Path) -> Result<DeploymentProblem, FileError> {
    let text = super::read_text(path)?;
    parse_problem(&text, path)
}

/// [`read_problem`] for a structure with `motors` motors: the per-motor
/// lists are also checked against each other and the motor count
/// ([`DeploymentProblem::motor_limits`]: one value or one per motor, each
/// minimum below its maximum, each start inside its stroke), the error
/// naming the file, the line and the field.
pub fn read_problem_for(path: &Path, motors: usize) -> Result<DeploymentProblem, FileError> {
    let text = super::read_text(path)?;
    let problem = parse_problem(&text, path)?;
    problem
        .motor_limits(motors)
        .map_err(|e| FileError::field(path, field_line(&text, e.field), e.field, e.reason))?;
    Ok(problem)
}

/// The text of a problem file for `problem`: every field written out, so
/// that a run's output records the problem it solved whatever its source
/// (a file or the built-in default). [`parse_problem`] reads it back.
pub fn problem_to_toml(problem: &DeploymentProblem) -> String {
    // A problem is plain numbers and lists: serialising cannot fail.
    let body = toml::to_string(problem).expect("a deployment problem serialises to TOML");
    format!("format = \"{PROBLEM_FORMAT}\"\n{body}")
}

/// Parses a problem file; `path` names it in errors.
pub fn parse_problem(text: &str, path: &Path) -> Result<DeploymentProblem, FileError> {
    let problem: DeploymentProblem = parse_versioned(text, path, PROBLEM_FORMAT)?;
    problem
        .validate()
        .map_err(|e| FileError::field(path, field_line(text, e.field), e.field, e.reason))?;
    Ok(problem)
}

/// Parses TOML into `T` after checking and removing a `format = "…"` key;
/// syntax and type errors name their line, column and message.
pub(crate) fn parse_versioned<T: DeserializeOwned>(
    text: &str,
    path: &Path,
    format: &str,
) -> Result<T, FileError> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| syntax_error(text, path, &e))?;
    match table.remove("format") {
        Some(toml::Value::String(f)) if f == format => {}
        Some(other) => {
            return Err(FileError::field(
                path,
                field_line(text, "format"),
                "format",
                format!("expected \"{format}\", found {other}"),
            ))
        }
        None => {
            return Err(FileError::field(
                path,
                1,
                "format",
                format!("missing; the file must start with format = \"{format}\""),
            ))
        }
    }
    // Deserialise from the text again (not the table) so that errors keep
    // their spans; the `format` key is blanked, not removed, to keep lines.
    let without_format: String = text
        .lines()
        .map(|l| {
            if key_of(l) == Some("format") && !in_table(text, l) {
                ""
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    toml::from_str(&without_format).map_err(|e| syntax_error(&without_format, path, &e))
}

/// `true` if line `l` (a slice of `text`) comes after a `[table]` header.
fn in_table(text: &str, l: &str) -> bool {
    let offset = l.as_ptr() as usize - text.as_ptr() as usize;
    text[..offset]
        .lines()
        .any(|x| x.trim_start().starts_with('['))
}

/// The key a `key = value` line sets.
fn key_of(line: &str) -> Option<&str> {
    let code = line.split('#').next().unwrap_or("");
    let (key, _) = code.split_once('=')?;
    let key = key.trim();
    (!key.is_empty() && !key.starts_with('[')).then_some(key)
}

/// 1-based line where `field` (`key` or `table.key`) is set; 1 when the
/// file leaves it to its default.
pub(crate) fn field_line(text: &str, field: &str) -> usize {
    let (table, key) = match field.split_once('.') {
        Some((t, k)) => (Some(t), k),
        None => (None, field),
    };
    let mut current: Option<String> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.starts_with('[') {
            current = Some(t.trim_matches(|c| c == '[' || c == ']').trim().to_string());
            if table.is_some() && current.as_deref() == table && key.is_empty() {
                return i + 1;
            }
            continue;
        }
        if key_of(line) == Some(key) && current.as_deref() == table {
            return i + 1;
        }
    }
    1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_full_file_and_names_line_and_field_of_a_bad_value() {
        let good = "format = \"tensegrity-deploy/problem/1\"\nstart_payout_m = 0.3\nmax_step_m = [0.05, 0.05]\n";
        let p = parse_problem(good, Path::new("p.toml")).unwrap();
        assert_eq!(p.start_payout_m, crate::plan::PerMotor::All(0.3));
        let bad =
            "format = \"tensegrity-deploy/problem/1\"\n# comment\nconnection_tolerance_m = -0.03\n";
        match parse_problem(bad, Path::new("p.toml")).unwrap_err() {
            FileError::Field { line, field, .. } => {
                assert_eq!((line, field.as_str()), (3, "connection_tolerance_m"))
            }
            e => panic!("{e}"),
        }
    }

    #[test]
    fn a_written_problem_reads_back_equal() {
        let problem = DeploymentProblem {
            max_step_m: crate::plan::PerMotor::Each(vec![0.05, 0.04, 0.03]),
            connection_tolerance_m: 0.025,
            ..Default::default()
        };
        let text = problem_to_toml(&problem);
        assert_eq!(parse_problem(&text, Path::new("p.toml")).unwrap(), problem);
        let default = DeploymentProblem::default();
        let text = problem_to_toml(&default);
        assert_eq!(parse_problem(&text, Path::new("p.toml")).unwrap(), default);
    }

    #[test]
    fn finds_keys_inside_tables() {
        let text = "a = 1\n[t]\nb = 2\n[u]\nb = 3\n";
        assert_eq!(field_line(text, "t.b"), 3);
        assert_eq!(field_line(text, "u.b"), 5);
        assert_eq!(field_line(text, "a"), 1);
    }

    /// Issue 25: the per-motor checks (start outside the stroke, minimum
    /// not below maximum, wrong list length) named neither the file nor
    /// the line.
    #[test]
    fn per_motor_checks_name_file_line_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        let head = "format = \"tensegrity-deploy/problem/1\"\n# limits\n";
        for (body, line, field, says) in [
            (
                "start_payout_m = 0.6\n",
                3,
                "start_payout_m",
                "motor 0: start 0.6 m is outside the stroke",
            ),
            (
                "min_payout_m = 0.5\nmax_payout_m = 0.5\n",
                3,
                "min_payout_m",
                "is not below maximum",
            ),
            (
                "max_step_m = [0.05, 0.05]\n",
                3,
                "max_step_m",
                "give one value or 10 (one per motor)",
            ),
        ] {
            std::fs::write(&path, format!("{head}{body}")).unwrap();
            read_problem(&path).unwrap_or_else(|e| panic!("valid alone: {e}"));
            let e = read_problem_for(&path, 10).unwrap_err();
            let FileError::Field {
                line: l, field: f, ..
            } = &e
            else {
                panic!("{e}")
            };
            assert_eq!((*l, f.as_str()), (line, field), "{e}");
            let text = e.to_string();
            assert!(text.contains("p.toml") && text.contains(says), "{text}");
        }
    }
}
