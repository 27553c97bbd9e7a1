//! Measurement logs: what was commanded and what the sensors read, cycle by
//! cycle and step by step.
//!
//! A log is a folder of four files:
//!
//! - `log.toml`: `format = "tensegrity-deploy/log/1"` and `structure`, the
//!   name of the structure the log was made on (checked against the model's
//!   structure, so that a log is never replayed on another bridge).
//! - `commands.csv`: `cycle,step,cable,payout_change_m`: the payout change
//!   sent to each motor (within
//!   [`PAYOUT_CHANGE_RANGE_M`](super::commands::PAYOUT_CHANGE_RANGE_M)),
//!   one row per cycle, step and cable (cables a step
//!   does not list are not moved). Cycles and steps are non-negative
//!   integers, in increasing order.
//! - `sensors.csv`: `sensor,kind,target,noise_sd`: the sensor layout.
//!   `kind` is `tension` (target: a continuous-cable segment
//!   `CABLE_ID:SEGMENT`, or a member id; N), `position_x`, `position_y`,
//!   `position_z` (target: a node id; m) or `temperature` (target `-`; °C).
//!   `noise_sd` is the sensor's noise standard deviation in its unit,
//!   positive (residuals are divided by it) and no larger than the kind's
//!   bound ([`SensorTarget::noise_sd_range`]: 0.1 m, 10 kN, 10 °C).
//! - `measurements.csv`: `cycle,step,sensor,value`: one row per cycle, step
//!   and sensor, in SI units (°C for temperature), within [`READING_RANGE`];
//!   step 0 of a cycle is the
//!   state before its first command. An empty `value`, or a missing row, is
//!   a missing reading.
//!
//! Loading validates every file against the structure and names the file,
//! line and field of the first problem. A log must be comparable: every
//! cycle needs at least one reading of a sensor other than the thermometer
//! ([`MeasurementLog::check_comparable`]).

use std::collections::HashMap;
use std::path::Path;

use super::toml_text::parse_toml;
use super::{csv_records, csv_with_header, write_atomically, CsvTable, FileError};
use crate::measure::log::{Cycle, MeasurementLog};
use crate::model::Structure;
use crate::numerics::NumberRange;
use crate::sim::{Axis, Sensor, SensorTarget};

/// The `format` a log must declare.
pub const LOG_FORMAT: &str = "tensegrity-deploy/log/1";
/// Header of `commands.csv`.
pub const LOG_COMMANDS_HEADER: [&str; 4] = ["cycle", "step", "cable", "payout_change_m"];
/// Header of `sensors.csv`.
pub const SENSORS_HEADER: [&str; 4] = ["sensor", "kind", "target", "noise_sd"];
/// Range of any reading (N, m or °C): ±1e9, far beyond any sensor of the
/// bridge; a larger number is a corrupt file, and would overflow the
/// squared residuals of a comparison.
pub const READING_RANGE: NumberRange = NumberRange::closed(-1e9, 1e9);
/// Header of `measurements.csv`.
pub const MEASUREMENTS_HEADER: [&str; 4] = ["cycle", "step", "sensor", "value"];

#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct LogMeta {
    format: String,
    structure: String,
}

fn parse_u64(text: &str, path: &Path, line: usize, field: &str) -> Result<u64, FileError> {
    text.parse().map_err(|_| {
        FileError::field(
            path,
            line,
            field,
            format!("\"{text}\" is not a non-negative integer"),
        )
    })
}

fn parse_finite(text: &str, path: &Path, line: usize, field: &str) -> Result<f64, FileError> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            FileError::field(
                path,
                line,
                field,
                format!("\"{text}\" is not a finite number"),
            )
        })
}

fn read_text(path: &Path) -> Result<String, FileError> {
    super::read_text(path)
}

/// Reads and validates the log in folder `dir` against `structure`.
pub fn read_log(dir: &Path, structure: &Structure) -> Result<MeasurementLog, FileError> {
    let meta_path = dir.join("log.toml");
    let meta: LogMeta = parse_toml(&read_text(&meta_path)?, &meta_path)?;
    let invalid = |entry: &str, message: String| FileError::Invalid {
        path: meta_path.clone(),
        entry: entry.into(),
        message,
    };
    if meta.format != LOG_FORMAT {
        return Err(invalid(
            "format",
            format!("expected \"{LOG_FORMAT}\", found \"{}\"", meta.format),
        ));
    }
    if meta.structure != structure.name {
        return Err(invalid(
            "structure",
            format!(
                "the log was made on \"{}\", the model's structure is \"{}\"",
                meta.structure, structure.name
            ),
        ));
    }
    let sensors = read_sensors(&dir.join("sensors.csv"), structure)?;
    let mut cycles = read_commands(&dir.join("commands.csv"), structure)?;
    let measurements = dir.join("measurements.csv");
    read_measurements(&measurements, &sensors, &mut cycles)?;
    let log = MeasurementLog {
        structure: meta.structure,
        sensors,
        cycles,
    };
    log.check_comparable().map_err(|e| FileError::Invalid {
        path: measurements,
        entry: "readings".into(),
        message: e.to_string(),
    })?;
    Ok(log)
}

/// Reads and validates a sensor layout (`sensors.csv`) against
/// `structure`.
pub fn read_sensors(path: &Path, structure: &Structure) -> Result<Vec<Sensor>, FileError> {
    let text = read_text(path)?;
    let mut reader = csv_with_header(&text, path, &SENSORS_HEADER)?;
    let mut sensors: Vec<Sensor> = Vec::new();
    for record in csv_records(&mut reader, path) {
        let (line, r) = record?;
        let err = |field: &str, message: String| FileError::field(path, line, field, message);
        let id = r[0].to_string();
        if id.is_empty() || sensors.iter().any(|s| s.id == id) {
            return Err(err("sensor", format!("\"{id}\" is empty or repeated")));
        }
        let sensor = sensor_row(path, line, &r, structure).map_err(|e| naming_sensor(e, &id))?;
        sensors.push(sensor);
    }
    if sensors.is_empty() {
        return Err(FileError::field(path, 1, "row", "no sensors".into()));
    }
    Ok(sensors)
}

/// `error` on a row of `sensors.csv` with the row's sensor named, so that
/// a layout of many sensors says which one is wrong.
fn naming_sensor(error: FileError, id: &str) -> FileError {
    match error {
        FileError::Field {
            path,
            line,
            field,
            message,
        } => FileError::Field {
            path,
            line,
            field,
            message: format!("{message} (sensor \"{id}\")"),
        },
        other => other,
    }
}

/// One row of `sensors.csv` (its id checked by the caller).
fn sensor_row(
    path: &Path,
    line: usize,
    r: &csv::StringRecord,
    structure: &Structure,
) -> Result<Sensor, FileError> {
    let err = |field: &str, message: String| FileError::field(path, line, field, message);
    let id = r[0].to_string();
    let target_text = &r[2];
    let target = match &r[1] {
        "tension" => {
            if let Some((cable_id, segment)) = target_text.split_once(':') {
                let cable = structure
                    .continuous_cables
                    .iter()
                    .position(|c| c.id == cable_id)
                    .ok_or_else(|| err("target", format!("no continuous cable \"{cable_id}\"")))?;
                let segment: usize = segment
                    .parse()
                    .ok()
                    .filter(|s| *s < structure.continuous_cables[cable].segment_count())
                    .ok_or_else(|| err("target", format!("\"{target_text}\": no such segment")))?;
                SensorTarget::SegmentTension { cable, segment }
            } else {
                let member = structure
                    .members
                    .iter()
                    .position(|m| m.id == target_text)
                    .ok_or_else(|| err("target", format!("no member \"{target_text}\"")))?;
                SensorTarget::MemberForce { member }
            }
        }
        kind @ ("position_x" | "position_y" | "position_z") => {
            let node = structure
                .node_index(target_text)
                .ok_or_else(|| err("target", format!("no node \"{target_text}\"")))?;
            let axis = match kind {
                "position_x" => Axis::X,
                "position_y" => Axis::Y,
                _ => Axis::Z,
            };
            SensorTarget::Position { node, axis }
        }
        "temperature" => SensorTarget::Temperature,
        other => {
            return Err(err(
                "kind",
                format!("unknown kind \"{other}\" (tension, position_x, position_y, position_z, temperature)"),
            ))
        }
    };
    let noise_sd = parse_finite(&r[3], path, line, "noise_sd")?;
    target.noise_sd_range().check(noise_sd).map_err(|reason| {
        err(
            "noise_sd",
            format!("{reason} (the sensor's noise SD in its unit)"),
        )
    })?;
    Ok(Sensor {
        id,
        target,
        noise_sd,
    })
}

fn read_commands(path: &Path, structure: &Structure) -> Result<Vec<Cycle>, FileError> {
    let text = read_text(path)?;
    let mut reader = csv_with_header(&text, path, &LOG_COMMANDS_HEADER)?;
    let n = structure.continuous_cables.len();
    let mut cycles: Vec<Cycle> = Vec::new();
    for record in csv_records(&mut reader, path) {
        let (line, r) = record?;
        let err = |field: &str, message: String| FileError::field(path, line, field, message);
        let cycle = parse_u64(&r[0], path, line, "cycle")?;
        let step = parse_u64(&r[1], path, line, "step")?;
        if step == 0 {
            return Err(err(
                "step",
                "step 0 is the state before the first command; commands start at step 1".into(),
            ));
        }
        let cable = structure
            .continuous_cables
            .iter()
            .position(|c| c.id == r[2])
            .ok_or_else(|| err("cable", format!("no continuous cable \"{}\"", &r[2])))?;
        let change = parse_finite(&r[3], path, line, "payout_change_m")?;
        super::commands::PAYOUT_CHANGE_RANGE_M
            .check(change)
            .map_err(|m| err("payout_change_m", m))?;
        match cycles.last() {
            Some(c) if c.label == cycle => {}
            Some(c) if c.label > cycle => {
                return Err(err(
                    "cycle",
                    format!("cycle {cycle} comes after cycle {}", c.label),
                ))
            }
            _ => cycles.push(Cycle {
                label: cycle,
                step_labels: vec![],
                commands: vec![],
                readings: vec![],
            }),
        }
        // A cycle was pushed above whenever the list was empty.
        let Some(c) = cycles.last_mut() else { continue };
        match c.step_labels.last() {
            Some(&s) if s == step => {}
            Some(&s) if s > step => {
                return Err(err("step", format!("step {step} comes after step {s}")))
            }
            _ => {
                c.step_labels.push(step);
                c.commands.push(vec![0.0; n]);
            }
        }
        // A step was pushed above whenever the cycle had none.
        let Some(row) = c.commands.last_mut() else {
            continue;
        };
        if row[cable] != 0.0 {
            return Err(err("cable", format!("\"{}\" twice in one step", &r[2])));
        }
        row[cable] = change;
    }
    if cycles.is_empty() {
        return Err(FileError::field(path, 1, "row", "no commands".into()));
    }
    Ok(cycles)
}

fn read_measurements(
    path: &Path,
    sensors: &[Sensor],
    cycles: &mut [Cycle],
) -> Result<(), FileError> {
    let text = read_text(path)?;
    let mut reader = csv_with_header(&text, path, &MEASUREMENTS_HEADER)?;
    let sensor_index: HashMap<&str, usize> = sensors
        .iter()
        .enumerate()
        .map(|(i, s)| (s.id.as_str(), i))
        .collect();
    for c in cycles.iter_mut() {
        c.readings = vec![vec![None; sensors.len()]; c.step_labels.len() + 1];
    }
    for record in csv_records(&mut reader, path) {
        let (line, r) = record?;
        let err = |field: &str, message: String| FileError::field(path, line, field, message);
        let cycle = parse_u64(&r[0], path, line, "cycle")?;
        let step = parse_u64(&r[1], path, line, "step")?;
        let c = cycles
            .iter_mut()
            .find(|c| c.label == cycle)
            .ok_or_else(|| err("cycle", format!("cycle {cycle} has no commands")))?;
        let k = if step == 0 {
            0
        } else {
            1 + c
                .step_labels
                .iter()
                .position(|&s| s == step)
                .ok_or_else(|| err("step", format!("cycle {cycle} has no step {step}")))?
        };
        let s = *sensor_index
            .get(&r[2])
            .ok_or_else(|| err("sensor", format!("no sensor \"{}\" in sensors.csv", &r[2])))?;
        if c.readings[k][s].is_some() {
            return Err(err(
                "sensor",
                format!("\"{}\" read twice in one step", &r[2]),
            ));
        }
        if !r[3].is_empty() {
            let value = parse_finite(&r[3], path, line, "value")?;
            READING_RANGE.check(value).map_err(|m| err("value", m))?;
            c.readings[k][s] = Some(value);
        }
    }
    Ok(())
}

/// A sensor layout as `sensors.csv`.
pub fn sensors_table(sensors: &[Sensor], structure: &Structure) -> CsvTable {
    let mut table = CsvTable::new(&SENSORS_HEADER);
    for s in sensors {
        let (kind, target) = s.kind_and_target(structure);
        table.row([
            s.id.clone(),
            kind.to_string(),
            target,
            s.noise_sd.to_string(),
        ]);
    }
    table
}

/// Writes `log` into folder `dir` (created if missing), every file
/// atomically.
pub fn write_log(dir: &Path, log: &MeasurementLog, structure: &Structure) -> Result<(), FileError> {
    std::fs::create_dir_all(dir).map_err(|e| FileError::write(dir, e))?;
    let meta = toml::to_string(&LogMeta {
        format: LOG_FORMAT.into(),
        structure: log.structure.clone(),
    })
    .expect("log metadata serialises");
    write_atomically(&dir.join("log.toml"), meta.as_bytes())?;
    sensors_table(&log.sensors, structure).write(&dir.join("sensors.csv"))?;
    let mut commands = CsvTable::new(&LOG_COMMANDS_HEADER);
    let mut measurements = CsvTable::new(&MEASUREMENTS_HEADER);
    for c in &log.cycles {
        for (step, row) in c.step_labels.iter().zip(&c.commands) {
            for (cable, v) in row.iter().enumerate() {
                if *v != 0.0 {
                    commands.row([
                        c.label.to_string(),
                        step.to_string(),
                        structure.continuous_cables[cable].id.clone(),
                        v.to_string(),
                    ]);
                }
            }
        }
        let steps = std::iter::once(0).chain(c.step_labels.iter().copied());
        for (step, readings) in steps.zip(&c.readings) {
            for (s, v) in log.sensors.iter().zip(readings) {
                let value = v.map(|v| v.to_string()).unwrap_or_default();
                measurements.row([c.label.to_string(), step.to_string(), s.id.clone(), value]);
            }
        }
    }
    commands.write(&dir.join("commands.csv"))?;
    measurements.write(&dir.join("measurements.csv"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};

    fn sample(structure: &Structure) -> MeasurementLog {
        let n = structure.continuous_cables.len();
        let mut cmd = vec![0.0; n];
        cmd[0] = 0.01;
        cmd[1] = -0.01;
        MeasurementLog {
            structure: structure.name.clone(),
            sensors: vec![
                Sensor {
                    id: "lc0".into(),
                    target: SensorTarget::SegmentTension {
                        cable: 0,
                        segment: 3,
                    },
                    noise_sd: 7.0,
                },
                Sensor {
                    id: "z4".into(),
                    target: SensorTarget::Position {
                        node: 24,
                        axis: Axis::Z,
                    },
                    noise_sd: 0.001,
                },
                Sensor {
                    id: "temp".into(),
                    target: SensorTarget::Temperature,
                    noise_sd: 0.1,
                },
            ],
            cycles: vec![Cycle {
                label: 1,
                step_labels: vec![1, 2],
                commands: vec![cmd.clone(), cmd],
                readings: vec![
                    vec![Some(550.0), Some(0.1), Some(20.0)],
                    vec![Some(540.5), None, Some(20.1)],
                    vec![Some(530.25), Some(0.12), None],
                ],
            }],
        }
    }

    #[test]
    fn a_log_round_trips_through_its_folder() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let log = sample(&s);
        write_log(dir.path(), &log, &s).unwrap();
        assert_eq!(read_log(dir.path(), &s).unwrap(), log);
    }

    #[test]
    fn bad_logs_are_rejected_naming_file_line_and_field() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        write_log(dir.path(), &sample(&s), &s).unwrap();
        let edit = |file: &str, from: &str, to: &str| {
            let p = dir.path().join(file);
            let text = std::fs::read_to_string(&p).unwrap();
            std::fs::write(&p, text.replacen(from, to, 1)).unwrap();
            let e = read_log(dir.path(), &s).unwrap_err().to_string();
            std::fs::write(&p, text).unwrap();
            e
        };
        let e = edit(
            "measurements.csv",
            "cycle,step,sensor,value",
            "cycle,step,sensor,val",
        );
        assert!(
            e.contains("measurements.csv: line 1, field `header`"),
            "{e}"
        );
        let e = edit("measurements.csv", "1,1,lc0,540.5", "1,1,lc9,540.5");
        assert!(
            e.contains("measurements.csv: line 5, field `sensor`: no sensor \"lc9\""),
            "{e}"
        );
        let e = edit("measurements.csv", "540.5", "abc");
        assert!(
            e.contains("line 5, field `value`: \"abc\" is not a finite number"),
            "{e}"
        );
        let e = edit("sensors.csv", "A_cc0:3", "A_cc0:9");
        assert!(e.contains("sensors.csv: line 2, field `target`"), "{e}");
        // Issue 24: every error on a sensor row names the sensor.
        assert!(e.ends_with("(sensor \"lc0\")"), "{e}");
        let e = edit("commands.csv", "A_cc1", "A_cc7");
        assert!(e.contains("commands.csv: line 3, field `cable`"), "{e}");
        let e = edit("log.toml", "hollow-rope", "another");
        assert!(
            e.contains("log.toml: structure: the log was made on"),
            "{e}"
        );
    }

    #[test]
    fn zero_noise_and_logs_without_comparable_readings_are_refused() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        write_log(dir.path(), &sample(&s), &s).unwrap();
        let sensors = dir.path().join("sensors.csv");
        let text = std::fs::read_to_string(&sensors).unwrap();
        std::fs::write(&sensors, text.replacen(",7\n", ",0\n", 1)).unwrap();
        let e = read_log(dir.path(), &s).unwrap_err().to_string();
        assert!(
            e.contains("sensors.csv: line 2, field `noise_sd`: must be a finite number in (0, 10000], got 0"),
            "{e}"
        );
        assert!(e.contains("(sensor \"lc0\")"), "{e}");
        std::fs::write(&sensors, text).unwrap();
        // Every reading but the thermometer's blanked: nothing to compare.
        let mut log = sample(&s);
        for step in &mut log.cycles[0].readings {
            step[0] = None;
            step[1] = None;
        }
        write_log(dir.path(), &log, &s).unwrap();
        let e = read_log(dir.path(), &s).unwrap_err().to_string();
        assert!(
            e.contains("measurements.csv: readings: no comparable reading in the log"),
            "{e}"
        );
        assert_eq!(e.lines().count(), 1, "{e}");
    }

    /// Issue 25: `noise_sd = 1e297` on the position sensors made
    /// `replay --fit` run past 60 s; a temperature noise of 1e299 was
    /// accepted too. Each kind has its upper bound, and the error names it.
    #[test]
    fn huge_sensor_noise_is_refused_naming_the_bound() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        write_log(dir.path(), &sample(&s), &s).unwrap();
        let sensors = dir.path().join("sensors.csv");
        let text = std::fs::read_to_string(&sensors).unwrap();
        for (from, to, line, bound) in [
            (",7\n", ",1e297\n", 2, "(0, 10000]"),
            (",0.001\n", ",1e297\n", 3, "(0, 0.1]"),
            (",0.1\n", ",1e299\n", 4, "(0, 10]"),
        ] {
            std::fs::write(&sensors, text.replacen(from, to, 1)).unwrap();
            let e = read_log(dir.path(), &s).unwrap_err().to_string();
            assert!(
                e.contains(&format!("sensors.csv: line {line}, field `noise_sd`: must be a finite number in {bound}")),
                "{e}"
            );
        }
        // The bounds themselves are accepted.
        let at_bounds = text
            .replacen(",7\n", ",10000\n", 1)
            .replacen(",0.1\n", ",10\n", 1)
            .replacen(",0.001\n", ",0.1\n", 1);
        std::fs::write(&sensors, at_bounds).unwrap();
        let log = read_log(dir.path(), &s).unwrap();
        let noise: Vec<f64> = log.sensors.iter().map(|x| x.noise_sd).collect();
        assert_eq!(noise, [1e4, 0.1, 10.0]);
    }

    #[test]
    fn a_log_toml_syntax_error_keeps_its_line_and_column() {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        write_log(dir.path(), &sample(&s), &s).unwrap();
        let meta = dir.path().join("log.toml");
        let text = std::fs::read_to_string(&meta).unwrap();
        std::fs::write(&meta, text.replacen("structure = ", "structure = = ", 1)).unwrap();
        let e = read_log(dir.path(), &s).unwrap_err().to_string();
        let line = 1 + text
            .lines()
            .position(|l| l.starts_with("structure"))
            .unwrap();
        assert!(
            e.starts_with(&format!("{}:{line}:13: ", meta.display())),
            "{e}"
        );
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}
