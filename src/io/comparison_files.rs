//! The files of a model-versus-log comparison (`tdeploy compare`) and the
//! JSON reports of `compare --json` and `diagnose --json`. Numbers are
//! written as the shortest text that reads back to the same value;
//! residuals are in the sensor's unit (m for a position, N for a load
//! cell), `z` is the residual in noise SDs.
//!
//! **Report folder** ([`write_comparison`]):
//! - `residuals.csv`: one row per compared reading. Columns: `cycle` and
//!   `step` (labels as logged; step 0 the cycle's first reading),
//!   `sensor` (id), `direction` (`start` for step 0, else the command
//!   before the reading `folding` or `deploying`), `measured`,
//!   `predicted`, `residual` (measured − predicted), `z`, `payout_m` (the
//!   model's mean motor payout since the as-built state), `command_m`
//!   (sum of the step's commanded payout changes: positive folding),
//!   `joint_angle_deg` (mean interior angle of the continuous cables'
//!   joints), `temperature_c` (empty: not known).
//! - `sensors.csv`: one row per sensor with readings. Columns: `sensor`,
//!   `count`, `mean`, `sd`, `rms`, `worst` (of the residual, its unit),
//!   `rms_z`, `mean_z`; then the per-sensor noise tests: `mean_se` (mean z
//!   in standard errors), `mean_p`, `mean_significant`, `spread_z` (SD of z
//!   about its mean), `spread_p`, `spread_significant` (Holm-corrected
//!   rejection of noise). Empty test columns: the test was not made.
//!
//! The folder's figures (`measured_vs_predicted.svg`,
//! `residuals_over_steps.svg`, `residuals_vs_features.svg`) are drawn by
//! `report::comparison_figures`.
//!
//! **`compare --json FILE`** ([`ComparisonReport`]): `model` and `log`
//! (the paths), `sensors` (sensor ids in log order: the `sensor` index of
//! every residual and the order of `per_sensor`), `comparison`
//! ([`Comparison`]: `residuals`, `per_sensor` as `[stats of the residual
//! in its unit, stats of z]`, `per_direction`, `overall`; `overall.rms` is
//! the overall RMS in noise SDs), `outliers` (readings left out of the
//! tests), `evidence` (the noise tests) and `verdict`
//! ([`ComparisonVerdict`], tagged by its `verdict` field).
//!
//! **`diagnose --json FILE`** ([`DiagnosisReport`]): `model`, `log`,
//! `sensors` (ids in log order), `diagnosis` ([`Diagnosis`]: `rounds`,
//! `verdict`, and `final_comparison`, whose `overall.rms` is the overall
//! RMS in noise SDs with the effects found) and `where_it_fails` (for a
//! structured residual, else `null`). Standard errors that could not be
//! estimated are `null`.
//!
//! Both JSON files are written only where no file is, where the file holds
//! exactly these bytes, or with `--force` ([`super::write_new_json`]).

use std::path::Path;

use serde::Serialize;

use super::{write_new_json, CsvTable, FileError};
use crate::measure::compare::Comparison;
use crate::measure::comparison_verdict::{ComparisonVerdict, WhereItFails};
use crate::measure::diagnose::Diagnosis;
use crate::measure::evidence::{Evidence, Statistic, Subject};
use crate::measure::log::MeasurementLog;
use crate::measure::outliers::Outlier;

/// The `compare --json` report (see the module notes).
#[derive(Debug, Serialize)]
pub struct ComparisonReport<'a> {
    /// The model file.
    pub model: &'a Path,
    /// The log folder.
    pub log: &'a Path,
    /// Sensor ids in log order.
    pub sensors: Vec<&'a str>,
    /// The comparison.
    pub comparison: &'a Comparison,
    /// Readings left out of the tests.
    pub outliers: &'a [Outlier],
    /// The noise tests.
    pub evidence: &'a Evidence,
    /// What the comparison says.
    pub verdict: &'a ComparisonVerdict,
}

/// The `diagnose --json` report (see the module notes).
#[derive(Debug, Serialize)]
pub struct DiagnosisReport<'a> {
    /// The model file.
    pub model: &'a Path,
    /// The log folder.
    pub log: &'a Path,
    /// Sensor ids in log order.
    pub sensors: Vec<&'a str>,
    /// The diagnosis.
    pub diagnosis: &'a Diagnosis,
    /// Where the model fails worst, for a structured residual.
    pub where_it_fails: Option<WhereItFails>,
}

/// Sensor ids of `log`, in order.
pub fn sensor_ids(log: &MeasurementLog) -> Vec<&str> {
    log.sensors.iter().map(|s| s.id.as_str()).collect()
}

/// Writes the `compare --json` report to `path` (an existing file with
/// other contents needs `force`).
pub fn write_comparison_report(
    path: &Path,
    report: &ComparisonReport,
    force: bool,
) -> Result<(), FileError> {
    write_new_json(path, report, force)
}

/// Writes the `diagnose --json` report to `path` (an existing file with
/// other contents needs `force`).
pub fn write_diagnosis_report(
    path: &Path,
    report: &DiagnosisReport,
    force: bool,
) -> Result<(), FileError> {
    write_new_json(path, report, force)
}

/// Writes `residuals.csv` and `sensors.csv` of comparison `c` of `log`,
/// with the noise tests `e`, into `dir`.
pub fn write_comparison(
    dir: &Path,
    log: &MeasurementLog,
    c: &Comparison,
    e: &Evidence,
) -> Result<(), FileError> {
    residuals_table(log, c).write(&dir.join("residuals.csv"))?;
    sensors_table(log, c, e).write(&dir.join("sensors.csv"))
}

fn residuals_table(log: &MeasurementLog, c: &Comparison) -> CsvTable {
    let mut t = CsvTable::new(&[
        "cycle",
        "step",
        "sensor",
        "direction",
        "measured",
        "predicted",
        "residual",
        "z",
        "payout_m",
        "command_m",
        "joint_angle_deg",
        "temperature_c",
    ]);
    for r in &c.residuals {
        let cycle = &log.cycles[r.cycle];
        let step = if r.step == 0 {
            0
        } else {
            cycle.step_labels[r.step - 1]
        };
        t.row([
            cycle.label.to_string(),
            step.to_string(),
            log.sensors[r.sensor].id.clone(),
            r.direction.as_str().to_string(),
            r.measured.to_string(),
            r.predicted.to_string(),
            r.residual.to_string(),
            r.z.to_string(),
            r.features.payout_m.to_string(),
            r.features.command_m.to_string(),
            r.features.joint_angle_rad.to_degrees().to_string(),
            r.features
                .temperature_c
                .map(|t| t.to_string())
                .unwrap_or_default(),
        ]);
    }
    t
}

fn sensors_table(log: &MeasurementLog, c: &Comparison, e: &Evidence) -> CsvTable {
    let mut t = CsvTable::new(&[
        "sensor",
        "count",
        "mean",
        "sd",
        "rms",
        "worst",
        "rms_z",
        "mean_z",
        "mean_se",
        "mean_p",
        "mean_significant",
        "spread_z",
        "spread_p",
        "spread_significant",
    ]);
    for (i, (sensor, (st, z))) in log.sensors.iter().zip(&c.per_sensor).enumerate() {
        if st.count > 0 {
            let cells = |statistic| match e.test_of(Subject::Sensor(i), statistic) {
                Some(t) => [
                    t.value.to_string(),
                    t.p_value.to_string(),
                    t.significant.to_string(),
                ],
                None => Default::default(),
            };
            let [mean_se, mean_p, mean_sig] = cells(Statistic::Mean);
            let [spread, spread_p, spread_sig] = cells(Statistic::Spread);
            t.row([
                sensor.id.clone(),
                st.count.to_string(),
                st.mean.to_string(),
                st.sd.to_string(),
                st.rms.to_string(),
                st.worst.to_string(),
                z.rms.to_string(),
                z.mean.to_string(),
                mean_se,
                mean_p,
                mean_sig,
                spread,
                spread_p,
                spread_sig,
            ]);
        }
    }
    t
}
