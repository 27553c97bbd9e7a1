//! The files of an open-loop plan (`tdeploy plan`), written into a folder
//! ([`write_plan`]). Units are SI (m, N, s).
//!
//! - `commands.csv`: a command file ([`super::commands`]) whose step 0 is
//!   the fold from the designed state to the problem's start payout and
//!   steps 1… the planned commands (`tdeploy simulate -c` replays it).
//! - `plan.csv`: one row per planned command. Columns: `step` (1 for the
//!   first command); `gap_{p}_m` for every midspan pair `p` (the model's
//!   gap after the command); `predicted_gap_{p}_m` (what the planner's
//!   linearisation predicted; empty for a planner that predicts nothing);
//!   `worst_utilisation`, `min_tension_n`, `min_clearance_m` (empty where
//!   no clearance is checked), `qp_status`, `trust_region_m` (empty for a
//!   planner without a QP or trust region), `rejected_trials`,
//!   `planning_time_s` (wall clock, four decimals: the one column that
//!   changes from run to run), `active_constraints` (`; ` separated).

use std::path::Path;

use super::commands::write_fold_and_commands;
use super::output::create_folder;
use super::{CsvTable, FileError};
use crate::model::Structure;
use crate::plan::Plan;

/// Writes `commands.csv` (the fold to `start_payout_m`, then the plan's
/// commands for `structure`) and `plan.csv` into `dir`, created if
/// missing.
pub fn write_plan(
    dir: &Path,
    structure: &Structure,
    start_payout_m: Vec<f64>,
    plan: &Plan,
) -> Result<(), FileError> {
    create_folder(dir)?;
    write_fold_and_commands(
        &dir.join("commands.csv"),
        structure,
        start_payout_m,
        plan.commands(),
    )?;
    plan_table(plan).write(&dir.join("plan.csv"))
}

/// `plan.csv`: one row per command.
fn plan_table(plan: &Plan) -> CsvTable {
    let pairs = plan.start_gaps_m.len();
    let mut header = vec!["step".to_string()];
    header.extend((0..pairs).map(|p| format!("gap_{p}_m")));
    header.extend((0..pairs).map(|p| format!("predicted_gap_{p}_m")));
    header.extend(
        [
            "worst_utilisation",
            "min_tension_n",
            "min_clearance_m",
            "qp_status",
            "trust_region_m",
            "rejected_trials",
            "planning_time_s",
            "active_constraints",
        ]
        .map(String::from),
    );
    let mut table = CsvTable::new(&header.iter().map(String::as_str).collect::<Vec<_>>());
    for (k, r) in plan.records.iter().enumerate() {
        let mut row = vec![(k + 1).to_string()];
        row.extend(r.gaps_m.iter().map(|g| g.to_string()));
        match &r.predicted_gaps_m {
            Some(p) => row.extend(p.iter().map(|g| g.to_string())),
            None => row.extend((0..pairs).map(|_| String::new())),
        }
        row.push(r.worst_utilisation.to_string());
        row.push(r.min_tension_n.to_string());
        row.push(if r.min_clearance_m.is_finite() {
            r.min_clearance_m.to_string()
        } else {
            String::new()
        });
        row.push(
            r.qp_status
                .map(|s| s.as_str().to_string())
                .unwrap_or_default(),
        );
        row.push(r.trust_region_m.map(|t| t.to_string()).unwrap_or_default());
        row.push(r.rejected_trials.to_string());
        row.push(format!("{:.4}", r.planning_time_s));
        row.push(r.active_constraints.join("; "));
        table.row(row);
    }
    table
}
