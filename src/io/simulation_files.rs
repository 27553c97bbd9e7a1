//! The tables of a simulation (`tdeploy simulate`): tidy CSV, one file per
//! table, written atomically ([`write_simulation`]). The figure of the
//! run, `state.svg`, is drawn by `report::drawing`.
//!
//! - `steps.csv`: `step,status,increments,iterations,max_residual_n,max_friction_residual_n,max_midspan_gap_m`
//! - `positions.csv`: `step,node,x_m,y_m,z_m`
//! - `member_forces.csv`: `step,member,kind,force_n,length_m,buckling_utilisation`
//!   (force positive in tension; utilisation = compression / Euler load, struts only)
//! - `segments.csv`: `step,cable,segment,rest_length_m,length_m,tension_n,payout_m`
//!
//! Step 0 is the initial state, relaxed. Empty: no value (no midspan gap
//! for a structure without midspan pairs; no buckling utilisation for a
//! member that is not a strut). Residuals in `steps.csv` are written in
//! scientific notation, every other number as the shortest text that
//! reads back to the same value.

use std::path::Path;

use super::{CsvTable, FileError};
use crate::model::{CommandReport, DeploymentState, ForwardModel, MemberKind};

/// One row of results: the state after a step and how the step went.
#[derive(Debug, Clone)]
pub struct StepRecord {
    /// Step label.
    pub step: u64,
    /// How the command went.
    pub report: CommandReport,
    /// The state after it.
    pub state: DeploymentState,
}

/// Writes the four result tables into `dir` (created if missing).
pub fn write_simulation(
    dir: &Path,
    model: &ForwardModel,
    records: &[StepRecord],
) -> Result<(), FileError> {
    std::fs::create_dir_all(dir).map_err(|e| FileError::write(dir, e))?;
    let s = &model.structure();
    let mut steps = CsvTable::new(&[
        "step",
        "status",
        "increments",
        "iterations",
        "max_residual_n",
        "max_friction_residual_n",
        "max_midspan_gap_m",
    ]);
    for r in records {
        let gap = r.state.max_midspan_gap_m(s);
        steps.row([
            r.step.to_string(),
            r.report.status.as_str().to_string(),
            r.report.increments.to_string(),
            r.report.iterations.to_string(),
            format!("{:e}", r.report.max_residual_n),
            format!("{:e}", r.report.max_friction_residual_n),
            gap.map(|g| g.to_string()).unwrap_or_default(),
        ]);
    }
    steps.write(&dir.join("steps.csv"))?;
    let mut positions = CsvTable::new(&["step", "node", "x_m", "y_m", "z_m"]);
    for r in records {
        for (n, x) in s.nodes.iter().zip(&r.state.positions_m) {
            positions.row([
                r.step.to_string(),
                n.id.clone(),
                x.x.to_string(),
                x.y.to_string(),
                x.z.to_string(),
            ]);
        }
    }
    positions.write(&dir.join("positions.csv"))?;
    let forces: Vec<_> = records
        .iter()
        .map(|r| model.member_forces(&r.state))
        .collect();
    let mut members = CsvTable::new(&[
        "step",
        "member",
        "kind",
        "force_n",
        "length_m",
        "buckling_utilisation",
    ]);
    for (r, f) in records.iter().zip(&forces) {
        for (k, m) in s.members.iter().enumerate() {
            let util = match m.kind {
                MemberKind::Strut { ei_nm2, .. } => {
                    let euler =
                        std::f64::consts::PI.powi(2) * ei_nm2 / (m.rest_length_m * m.rest_length_m);
                    ((-f.member_n[k]).max(0.0) / euler).to_string()
                }
                _ => String::new(),
            };
            members.row([
                r.step.to_string(),
                m.id.clone(),
                m.kind.name().to_string(),
                f.member_n[k].to_string(),
                f.member_length_m[k].to_string(),
                util,
            ]);
        }
    }
    members.write(&dir.join("member_forces.csv"))?;
    let mut segments = CsvTable::new(&[
        "step",
        "cable",
        "segment",
        "rest_length_m",
        "length_m",
        "tension_n",
        "payout_m",
    ]);
    for (r, f) in records.iter().zip(&forces) {
        for (c, cable) in s.continuous_cables.iter().enumerate() {
            let o = r.state.segment_offsets[c];
            for j in 0..cable.segment_count() {
                segments.row([
                    r.step.to_string(),
                    cable.id.clone(),
                    j.to_string(),
                    r.state.segment_rest_lengths_m[o + j].to_string(),
                    f.segment_length_m[o + j].to_string(),
                    f.segment_n[o + j].to_string(),
                    r.state.payout_m[c].to_string(),
                ]);
            }
        }
    }
    segments.write(&dir.join("segments.csv"))
}
