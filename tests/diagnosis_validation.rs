//! Logs that cannot be compared, given to `compare` and `diagnose`: a sensor
//! with zero noise SD, a log whose every comparable reading is missing, a
//! cycle without any. Each is refused with exit status 2 and one error line
//! naming the file, never "nothing missing", never a panic.

mod common;

use std::path::Path;

use common::cli::{failed_with, stdout, tdeploy};
use common::fixtures::lab_log_folder;

/// A tiny good log: two 1 cm cycles, one step each way.
fn fixture() -> tempfile::TempDir {
    lab_log_folder("0.01,0.01")
}

/// Both commands refuse the log: exit 2, one line, naming `file`; returns
/// compare's line.
fn both_refuse(dir: &Path, file: &str) -> String {
    let mut first = String::new();
    for args in [
        &["compare", "model.toml", "log", "-o", "report"][..],
        &["diagnose", "model.toml", "log", "--rounds", "1"][..],
    ] {
        let out = tdeploy(args, dir);
        let stderr = failed_with(&out, 2);
        let stdout = stdout(&out);
        assert!(stderr.contains(file), "{args:?}: {stderr}");
        assert!(!stdout.contains("nothing is missing"), "{stdout}");
        if first.is_empty() {
            first = stderr;
        }
    }
    assert!(!dir.join("report").exists(), "nothing written on bad input");
    first
}

/// Rewrites `measurements.csv`, blanking the values of the rows `blank`
/// picks (by cycle and sensor).
fn blank_readings(dir: &Path, blank: impl Fn(&str, &str) -> bool) {
    let p = dir.join("log").join("measurements.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut out = String::new();
    for (i, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        if i > 0 && blank(f[0], f[2]) {
            out.push_str(&format!("{},{},{},\n", f[0], f[1], f[2]));
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    std::fs::write(&p, out).unwrap();
}

#[test]
fn a_sensor_with_zero_noise_is_refused() {
    let dir = fixture();
    let p = dir.path().join("log").join("sensors.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let second = text.lines().nth(1).unwrap();
    let noise = second.rsplit(',').next().unwrap();
    let zeroed = second.replacen(&format!(",{noise}"), ",0", 1);
    std::fs::write(&p, text.replacen(second, &zeroed, 1)).unwrap();
    let e = both_refuse(dir.path(), "sensors.csv");
    assert!(
        e.contains("line 2, field `noise_sd`: must be a finite number in (0, 10000], got 0"),
        "{e}"
    );
}

#[test]
fn a_log_with_every_reading_missing_is_refused() {
    let dir = fixture();
    blank_readings(dir.path(), |_, _| true);
    let e = both_refuse(dir.path(), "measurements.csv");
    assert!(e.contains("no comparable reading in the log"), "{e}");
}

#[test]
fn a_cycle_with_only_temperatures_is_refused() {
    let dir = fixture();
    blank_readings(dir.path(), |cycle, sensor| {
        cycle == "2" && sensor != "temperature"
    });
    let e = both_refuse(dir.path(), "measurements.csv");
    assert!(e.contains("cycle 2 has no comparable reading"), "{e}");
}
