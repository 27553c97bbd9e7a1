//! The tables of repeated deployment-fold cycles (`tdeploy cycles`),
//! written into its results folder ([`write_cycles`]). Gaps in m; numbers
//! as the shortest text that reads back to the same value.
//!
//! - `cycles.csv`: one row per cycle. Columns: `cycle` (1 for the first),
//!   `status` (the deployment's verdict label,
//!   [`crate::plan::RunVerdict::label`]: `connected`, `limits_broken`, …),
//!   `commands`,
//!   `corrective_commands` (commands after the one that brought the
//!   largest measured gap below 60 mm), `approach_commands` (commands of
//!   the first approach), `approach_gap_m` (largest measured gap after
//!   it), `final_gap_m`, `final_true_gap_m` (largest measured and true gap
//!   at the end), `truth_limit_violations`, `learnt_from_case` (index in
//!   the memory of the case the cycle learnt from), `learnt_commands`
//!   (commands the ILC update learnt; the model may take one in halves,
//!   and a feedforward that ended early, a learnt command the model found
//!   beyond a limit even halved, leaves the rest to the planner),
//!   `ilc_predicted_gap_m` (largest end gap the ILC update predicted for
//!   the whole learnt approach), `ilc_error_m` (the ILC update's largest
//!   |predicted − measured| gap over the pairs at the end of its learnt
//!   approach, m; empty where the approach was cut short), `planning_model_rms`
//!   (RMS of the cycle's readings against the controller's model file,
//!   replayed open-loop from the design through the cycle's fold and
//!   commands, in noise SDs: near 1 where the model explains the cycle;
//!   empty where the replay failed; with a policy that learns its model,
//!   against the model file and every effect learnt beyond it, of which
//!   the planner takes the structural part: the readings of the cycle
//!   were held out of everything it learnt), then the self-diagnosis
//!   after the cycle (`[memory] model_learning_enable`; empty without):
//!   `model_update` (`accepted`: the next cycle plans on the model fitted
//!   on this cycle's log; `not_better`: the fit did not predict the
//!   held-out readings better, the model before is carried on;
//!   `nothing_learnt`: nothing trusted was found beyond that model;
//!   `not_run`: the self-diagnosis failed), `model_planned_rms` and `model_fitted_rms`
//!   (held-out RMS residual of the self-diagnosis's log against the model
//!   the cycle was planned on and against the fitted one, noise SDs),
//!   `learnt_model` (the effects the next cycle carries beyond the model
//!   file, with their standard errors, in words), `adaptation_error` (why
//!   the memory could not give guidance although it held cases: a case
//!   its model cannot follow, in words), `memory_declined` (why it would
//!   not: no case connected, or the newest learnt cycle refuted the ILC
//!   update, `crate::learn::acceptance`; the cycle ran as the memoryless
//!   controller would, in words). Empty: no value (no such command, no
//!   case learnt from, no error).
//!   `approach_commands` and `approach_gap_m` are empty in a cycle that
//!   connected without a first approach: without a feedforward, the
//!   approach ends at the first command the controller's model *predicted*
//!   to connect; when the halves were found connected only on measurement
//!   (the correction from the readings, not a prediction, closed the last
//!   millimetres) no command was that one.
//! - `timing.csv`: `cycle,planning_time_s,self_diagnosis_time_s`,
//!   wall-clock planning time of each cycle (adaptation and every command)
//!   and of the self-diagnosis after it (empty without): the one file that
//!   changes from run to run.
//!
//! The cases themselves go to the memory file ([`super::memory_file`]),
//! the learning curve `cycles.svg` is drawn by `report::cycles_figure`.

use std::path::Path;

use super::{CsvTable, FileError};
use crate::studies::cycles::CycleResult;

/// Writes `cycles.csv` and `timing.csv` of `results` into `dir`.
pub fn write_cycles(dir: &Path, results: &[CycleResult]) -> Result<(), FileError> {
    cycles_table(results).write(&dir.join("cycles.csv"))?;
    let mut timing = CsvTable::new(&["cycle", "planning_time_s", "self_diagnosis_time_s"]);
    for r in results {
        timing.row([
            r.cycle.to_string(),
            r.planning_time_s.to_string(),
            field(r.model_update.as_ref().map(|u| u.time_s)),
        ]);
    }
    timing.write(&dir.join("timing.csv"))
}

/// A CSV field: the value or empty.
fn field<T: ToString>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

/// `x` where it is a number (a self-diagnosis that did not run has none).
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// `cycles.csv`.
fn cycles_table(results: &[CycleResult]) -> CsvTable {
    let mut t = CsvTable::new(&[
        "cycle",
        "status",
        "commands",
        "corrective_commands",
        "approach_commands",
        "approach_gap_m",
        "final_gap_m",
        "final_true_gap_m",
        "truth_limit_violations",
        "learnt_from_case",
        "learnt_commands",
        "ilc_predicted_gap_m",
        "ilc_error_m",
        "planning_model_rms",
        "model_update",
        "model_planned_rms",
        "model_fitted_rms",
        "learnt_model",
        "adaptation_error",
        "memory_declined",
    ]);
    for r in results {
        t.row([
            r.cycle.to_string(),
            r.status.clone(),
            r.commands.to_string(),
            field(r.corrective_commands),
            field(r.approach_commands),
            field(r.approach_gap_m),
            field(r.final_gap_m),
            field(r.final_true_gap_m),
            r.truth_limit_violations.to_string(),
            field(r.learnt_from_case),
            field(r.learnt_commands),
            field(r.ilc_predicted_gap_m),
            field(r.ilc_error_m),
            field(r.planning_model_rms),
            field(r.model_update.as_ref().map(|u| u.outcome())),
            field(r.model_update.as_ref().and_then(|u| finite(u.planned_rms))),
            // Where nothing was fitted beyond the model planned on there is
            // no fitted model to score: empty, not the planned figure again.
            field(
                r.model_update
                    .as_ref()
                    .filter(|u| u.changed)
                    .and_then(|u| finite(u.fitted_rms)),
            ),
            field(r.model_update.as_ref().map(|u| u.carried.clone())),
            field(r.adaptation_error.as_ref()),
            field(r.memory_declined.as_ref()),
        ]);
    }
    t
}
