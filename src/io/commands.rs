//! Command files: motor payout changes per step, as tidy CSV.
//!
//! ```csv
//! step,cable,payout_change_m
//! 1,A_cc0,-0.01
//! 1,B_cc0,-0.01
//! 2,A_cc1,0.005
//! ```
//! One row per step and cable. `step` is a non-negative integer; rows of one
//! step are applied together, steps in increasing order (a step may not
//! reappear after a later one). `cable` is a continuous-cable id of the
//! structure; cables a step does not list keep their payout. `payout_change_m`
//! is the change of payout in metres: positive pays cable out (folding),
//! negative reels it in (deploying). A step may list a cable once.

use std::path::Path;

use super::{CsvTable, FileError};
use crate::model::Structure;

/// The header a command file must have.
pub const COMMAND_HEADER: [&str; 3] = ["step", "cable", "payout_change_m"];

/// A validated sequence of payout commands.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandSequence {
    /// Step numbers as written in the file.
    pub step_labels: Vec<u64>,
    /// Payout change per step and continuous cable (structure order), m.
    pub payout_change_m: Vec<Vec<f64>>,
}

/// Reads a command file for `structure`.
pub fn read_commands(path: &Path, structure: &Structure) -> Result<CommandSequence, FileError> {
    let text = std::fs::read_to_string(path).map_err(|e| FileError::read(path, e))?;
    parse_commands(&text, path, structure)
}

/// Parses command CSV; `path` names the source in errors.
pub fn parse_commands(
    text: &str,
    path: &Path,
    structure: &Structure,
) -> Result<CommandSequence, FileError> {
    let field_error =
        |line: usize, field: &str, message: String| FileError::field(path, line, field, message);
    let mut reader = super::csv_with_header(text, path, &COMMAND_HEADER)?;
    let n_cables = structure.continuous_cables.len();
    let mut out = CommandSequence {
        step_labels: vec![],
        payout_change_m: vec![],
    };
    let mut seen_in_step = vec![false; n_cables];
    for record in super::csv_records(&mut reader, path) {
        let (line, record) = record?;
        let step: u64 = record[0].parse().map_err(|_| {
            field_error(
                line,
                "step",
                format!("\"{}\" is not a non-negative integer", &record[0]),
            )
        })?;
        let cable = structure
            .continuous_cables
            .iter()
            .position(|c| c.id == record[1])
            .ok_or_else(|| {
                field_error(
                    line,
                    "cable",
                    format!("no continuous cable \"{}\" in the structure", &record[1]),
                )
            })?;
        let change: f64 = record[2]
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
                field_error(
                    line,
                    "payout_change_m",
                    format!("\"{}\" is not a finite number", &record[2]),
                )
            })?;
        match out.step_labels.last() {
            Some(&last) if last == step => {}
            Some(&last) if last > step => {
                return Err(field_error(
                    line,
                    "step",
                    format!("step {step} comes after step {last}; steps must increase"),
                ))
            }
            _ => {
                out.step_labels.push(step);
                out.payout_change_m.push(vec![0.0; n_cables]);
                seen_in_step.fill(false);
            }
        }
        let row = out
            .payout_change_m
            .last_mut()
            .expect("a step was just pushed");
        if std::mem::replace(&mut seen_in_step[cable], true) {
            return Err(field_error(
                line,
                "cable",
                format!("cable \"{}\" appears twice in step {step}", &record[1]),
            ));
        }
        row[cable] = change;
    }
    if out.step_labels.is_empty() {
        return Err(field_error(1, "row", "the file has no commands".into()));
    }
    Ok(out)
}

/// A command sequence in the same format (zero changes omitted).
pub fn commands_to_csv(seq: &CommandSequence, structure: &Structure) -> String {
    commands_table(seq, structure).as_str().to_string()
}

/// Writes a command file atomically.
pub fn write_commands(
    path: &Path,
    seq: &CommandSequence,
    structure: &Structure,
) -> Result<(), FileError> {
    commands_table(seq, structure).write(path)
}

fn commands_table(seq: &CommandSequence, structure: &Structure) -> CsvTable {
    let mut table = CsvTable::new(&COMMAND_HEADER);
    for (label, row) in seq.step_labels.iter().zip(&seq.payout_change_m) {
        for (c, v) in row.iter().enumerate() {
            if *v != 0.0 {
                table.row([
                    label.to_string(),
                    structure.continuous_cables[c].id.clone(),
                    v.to_string(),
                ]);
            }
        }
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};

    #[test]
    fn a_command_sequence_round_trips_through_its_file() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let n = s.continuous_cables.len();
        let mut first = vec![0.0; n];
        first[0] = -0.01;
        first[n - 1] = 0.1 + 0.2; // a value with no short decimal form
        let mut second = vec![0.0; n];
        second[3] = 0.005;
        let seq = CommandSequence {
            step_labels: vec![1, 4],
            payout_change_m: vec![first, second],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.csv");
        write_commands(&path, &seq, &s).unwrap();
        assert_eq!(read_commands(&path, &s).unwrap(), seq);
        assert_eq!(
            commands_to_csv(&seq, &s),
            std::fs::read_to_string(&path).unwrap()
        );
    }
}
