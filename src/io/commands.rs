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
//! negative reels it in (deploying), within [`PAYOUT_CHANGE_RANGE_M`]. A
//! step may list a cable once.
//!
//! Work is bounded: a step is applied in increments no larger than the
//! simulation's increment, at most
//! [`MAX_INCREMENTS_PER_COMMAND`]
//! per step and [`MAX_INCREMENTS_PER_RUN`] over the file
//! ([`check_increments`]).

use std::path::Path;

use super::{CsvTable, FileError};
use crate::model::solver::command::{increments_needed, MAX_INCREMENTS_PER_COMMAND};
use crate::model::Structure;
use crate::numerics::NumberRange;

/// The header a command file must have.
pub const COMMAND_HEADER: [&str; 3] = ["step", "cable", "payout_change_m"];

/// Range of one step's payout change of one cable, m: ±10 m, five times
/// the length of a reference-bridge cable; more is a unit slip (mm for m).
pub const PAYOUT_CHANGE_RANGE_M: NumberRange = NumberRange::closed(-10.0, 10.0);

/// Most increments a whole command sequence may take: 100 steps at the
/// per-step limit, or a thousand 1 m steps at 1 cm. It bounds a run's work.
pub const MAX_INCREMENTS_PER_RUN: usize = 1_000_000;

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
    let text = super::read_text(path)?;
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
        let change: f64 = record[2].parse().map_err(|_| {
            field_error(
                line,
                "payout_change_m",
                format!("\"{}\" is not a finite number", &record[2]),
            )
        })?;
        PAYOUT_CHANGE_RANGE_M
            .check(change)
            .map_err(|m| field_error(line, "payout_change_m", m))?;
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
        if std::mem::replace(&mut seen_in_step[cable], true) {
            return Err(field_error(
                line,
                "cable",
                format!("cable \"{}\" appears twice in step {step}", &record[1]),
            ));
        }
        // A step was pushed above whenever the list was empty.
        if let Some(row) = out.payout_change_m.last_mut() {
            row[cable] = change;
        }
    }
    if out.step_labels.is_empty() {
        return Err(field_error(1, "row", "the file has no commands".into()));
    }
    Ok(out)
}

/// The number of increments `seq` takes at a largest increment of
/// `max_increment_m`, checked against the limits per step
/// ([`MAX_INCREMENTS_PER_COMMAND`]) and per run ([`MAX_INCREMENTS_PER_RUN`]);
/// the error names `path` (the command file, or what stands for it), the
/// step, and the limit hit.
pub fn check_increments(
    seq: &CommandSequence,
    max_increment_m: f64,
    path: &Path,
) -> Result<usize, FileError> {
    let invalid = |entry: String, message: String| FileError::Invalid {
        path: path.to_path_buf(),
        entry,
        message,
    };
    let mut total = 0.0;
    for (label, row) in seq.step_labels.iter().zip(&seq.payout_change_m) {
        let largest = row.iter().fold(0.0f64, |a, d| a.max(d.abs()));
        let needed = increments_needed(largest, max_increment_m);
        if !(needed <= MAX_INCREMENTS_PER_COMMAND as f64) {
            return Err(invalid(
                format!("step {label}"),
                format!(
                    "a payout change of {} m in increments of at most {} m needs {} increments, over the limit of {MAX_INCREMENTS_PER_COMMAND} per step (use a larger increment or split the step)",
                    crate::numerics::range::compact(largest),
                    crate::numerics::range::compact(max_increment_m),
                    crate::numerics::range::compact(needed)
                ),
            ));
        }
        total += needed;
    }
    if !(total <= MAX_INCREMENTS_PER_RUN as f64) {
        return Err(invalid(
            "steps".into(),
            format!(
                "the commands need {total} increments in all, over the limit of {MAX_INCREMENTS_PER_RUN} per run (use a larger increment or fewer steps)"
            ),
        ));
    }
    Ok(total as usize)
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

/// Writes `commands` as a command file whose step 0 is the fold from the
/// designed state to `start_payout_m` (where `tdeploy simulate` starts),
/// so that `tdeploy simulate -c FILE` replays the whole deployment; steps
/// 1… are the commands (`tdeploy plan`'s and `tdeploy deploy`'s
/// `commands.csv`).
pub fn write_fold_and_commands(
    path: &Path,
    structure: &Structure,
    start_payout_m: Vec<f64>,
    commands: Vec<Vec<f64>>,
) -> Result<(), FileError> {
    let mut payout_change_m = vec![start_payout_m];
    payout_change_m.extend(commands);
    let sequence = CommandSequence {
        step_labels: (0..payout_change_m.len() as u64).collect(),
        payout_change_m,
    };
    write_commands(path, &sequence, structure)
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
