//! The tables the experiments write (`tdeploy experiment FILE`, each into
//! the `out` folder its experiment file names, created if missing).
//! Numbers are written as the shortest text that reads back to the same
//! value. The deployment experiment writes an evaluation's set
//! ([`super::evaluation_summary`]); the figures (`overlay.svg`,
//! `average_tension.svg`) are drawn by `report::experiment_figures`.
//!
//! - **friction-rig**, `friction-rig.csv`: one row per angle and tension
//!   ([`crate::design::friction_rig::RigSlip`]). Columns:
//!   `interior_angle_deg`, `tension_kn` (low side), `slip_ratio_model`
//!   (`T_high/T_low` at which the modelled joint slides),
//!   `slip_ratio_formula` (the capstan bound `e^(μα)`), `slip_load_n`
//!   (extra load at the slip, N), `mu_backcalc_interior` and
//!   `mu_backcalc_wrap` (μ back-calculated with the interior angle θ and
//!   with the wrap angle π − θ).
//! - **friction-effect**: `midspan_shift.csv` (`node,shift_m,
//!   percent_of_30mm`: how far each midspan node ends up from where it
//!   ends without friction, and that as a share of the 30 mm connector),
//!   `force_change_by_type.csv` (`kind,members,mean_relative_change,
//!   max_relative_change`: relative member-force change per member kind,
//!   over members above the force floor; 0.1 = 10 %),
//!   `force_change_by_member.csv` (`member,relative_change`; continuous
//!   cable segments as `segment_{k}`, `k` counting all segments).
//! - **friction-vs-measurement**, `tensions.csv`: `sensor,step,
//!   measured_n,no_friction_n,friction_n`: each load cell's reading after
//!   each step (1 for the first), and the simulations' without and with
//!   friction, N.

use std::path::Path;

use super::output::create_folder;
use super::{CsvTable, FileError};
use crate::design::friction_rig::RigSlip;
use crate::model::Structure;
use crate::studies::friction_vs_measurement::FrictionVsMeasurement;
use crate::studies::FrictionEffect;

/// Writes `friction-rig.csv` of `slips` into `dir`.
pub fn write_friction_rig(dir: &Path, slips: &[RigSlip]) -> Result<(), FileError> {
    let mut csv = CsvTable::new(&[
        "interior_angle_deg",
        "tension_kn",
        "slip_ratio_model",
        "slip_ratio_formula",
        "slip_load_n",
        "mu_backcalc_interior",
        "mu_backcalc_wrap",
    ]);
    for s in slips {
        csv.row(
            [
                s.interior_angle_deg,
                s.tension_kn,
                s.modelled_ratio,
                s.formula_ratio,
                s.slip_load_n,
                s.mu_interior,
                s.mu_wrap,
            ]
            .map(|v| v.to_string()),
        );
    }
    create_folder(dir)?;
    csv.write(&dir.join("friction-rig.csv"))
}

/// The percentage of the 30 mm connector a midspan shift is.
fn percent_of_connector(shift_m: f64) -> f64 {
    100.0 * shift_m / 0.03
}

/// Writes the three tables of the friction-effect study `r` on
/// `structure` into `dir`.
pub fn write_friction_effect(
    dir: &Path,
    structure: &Structure,
    r: &FrictionEffect,
) -> Result<(), FileError> {
    let mut shifts = CsvTable::new(&["node", "shift_m", "percent_of_30mm"]);
    for (node, shift) in &r.midspan_shift_m {
        shifts.row([
            structure.nodes[*node].id.clone(),
            shift.to_string(),
            percent_of_connector(*shift).to_string(),
        ]);
    }
    let mut kinds = CsvTable::new(&[
        "kind",
        "members",
        "mean_relative_change",
        "max_relative_change",
    ]);
    for c in &r.force_change {
        kinds.row([
            c.kind.to_string(),
            c.counted.to_string(),
            c.mean_relative.to_string(),
            c.max_relative.to_string(),
        ]);
    }
    let mut members = CsvTable::new(&["member", "relative_change"]);
    let n_members = structure.members.len();
    for (i, rel) in &r.member_change {
        let name = match structure.members.get(*i) {
            Some(m) => m.id.clone(),
            None => format!("segment_{}", i - n_members),
        };
        members.row([name, rel.to_string()]);
    }
    create_folder(dir)?;
    shifts.write(&dir.join("midspan_shift.csv"))?;
    kinds.write(&dir.join("force_change_by_type.csv"))?;
    members.write(&dir.join("force_change_by_member.csv"))
}

/// Writes `tensions.csv` of the friction-vs-measurement study into `dir`.
pub fn write_friction_vs_measurement(
    dir: &Path,
    study: &FrictionVsMeasurement,
) -> Result<(), FileError> {
    let mut csv = CsvTable::new(&[
        "sensor",
        "step",
        "measured_n",
        "no_friction_n",
        "friction_n",
    ]);
    for c in &study.cells {
        for k in 0..c.measured_n.len() {
            csv.row([
                c.sensor.clone(),
                (k + 1).to_string(),
                c.measured_n[k].to_string(),
                c.no_friction_n[k].to_string(),
                c.friction_n[k].to_string(),
            ]);
        }
    }
    create_folder(dir)?;
    csv.write(&dir.join("tensions.csv"))
}
