//! The summary tables of a policy evaluation, and the writer of its whole
//! set ([`write_evaluation`]: `tdeploy evaluate`, `tdeploy merge`, the
//! deployment experiment). `evaluation.toml`, `runs.csv` and `timing.csv`
//! are documented in [`super::evaluation_files`]; numbers are written as
//! the shortest text that reads back to the same value; empty: no value
//! (a median over no successful run).
//!
//! - `summary.csv`: one row per policy, in the order given. Columns:
//!   `policy`, `runs`, `successes`, `success_rate` (0–1), `wilson_low`,
//!   `wilson_high` (Wilson 95 % interval of the rate), `commands_median`,
//!   `commands_p95`, `corrective_median` (over successful runs),
//!   `approach_gap_median_m` (largest measured gap after the first
//!   approach), `final_gap_median_m`, `final_gap_p95_m` (largest true gap
//!   at the end), `cable_travel_median_m` (over started runs),
//!   `worst_utilisation` and `violations` (of the truth, over all runs),
//!   `runs_breaking_limits` (runs whose truth broke a limit) and
//!   `runs_breaking_limits_as_built` (of those, the runs whose truth
//!   breaks a limit in its own as-built state; both since the seventeenth
//!   session).
//! - `paired.csv`: the first policy against each other one on the same
//!   scenarios. Columns: `policy_a`, `policy_b`, `both`, `only_a`,
//!   `only_b`, `neither` (scenarios each succeeded on),
//!   `mcnemar_exact_p` (exact McNemar p-value of the discordant pairs),
//!   then on the `both` scenarios, pair by pair (since the eighteenth
//!   session): `gap_b_smaller` and `gap_b_larger` (scenarios where
//!   `policy_b`'s final true gap is below or above `policy_a`'s; ties in
//!   neither), `gap_sign_test_p` (their exact two-sided sign test),
//!   `gap_mean_difference_m` (mean of b − a, m, ties included; empty
//!   with no such scenario), and the same for the commands sent:
//!   `commands_b_fewer`, `commands_b_more`, `commands_sign_test_p`,
//!   `commands_mean_difference`. Only the header with one policy.
//! - `by_fold.csv` (since the twentieth session): each policy's runs in
//!   10 cm bands of the fold ([`crate::studies::fold_bands`]): by half
//!   A's fold and then by half B's where the distribution folds the halves
//!   differently (`fold_difference_m`), else by the one fold; per policy
//!   and half, one row per band that holds a run, shallowest first.
//!   Columns: `policy`, `half` (`A`, `B`, or `both` where the halves fold
//!   alike), `fold_from_m` (excluded, but for the first band, which starts
//!   at 0) and `fold_to_m` (included), both to the millimetre, `runs`,
//!   `succeeded`, `broke_limits` (runs whose truth broke a limit) and
//!   `other_failures` (the rest: stopped short, never started, a limit
//!   the fold broke not restored, or called connected with the true gap
//!   out of tolerance); the last three sum to `runs`, and each half's
//!   rows count every run once.
//!
//! The set's figure, `evaluation.svg`, is drawn by
//! `report::evaluation_figure`.

use std::path::Path;

use super::evaluation_files::{EvaluationRecord, EvaluationRuns};
use super::{write_atomically, CsvTable, FileError};
use crate::studies::evaluation::{PairedComparison, PolicySummary};
use crate::studies::fold_bands::FoldBand;

/// Writes `evaluation.toml`, `runs.csv`, `summary.csv`, `paired.csv`,
/// `by_fold.csv` and `timing.csv` of `runs` into `dir` (which must
/// exist); `summaries` are the policies' in `runs.policy_names` order.
pub fn write_evaluation(
    dir: &Path,
    record: &EvaluationRecord,
    runs: &EvaluationRuns,
    summaries: &[PolicySummary],
    pairs: &[PairedComparison],
    bands: &[FoldBand],
) -> Result<(), FileError> {
    write_atomically(&dir.join("evaluation.toml"), record.to_toml()?.as_bytes())?;
    runs.runs_table().write(&dir.join("runs.csv"))?;
    summary_table(&runs.policy_names, summaries).write(&dir.join("summary.csv"))?;
    paired_table(&runs.policy_names, pairs).write(&dir.join("paired.csv"))?;
    fold_table(&runs.policy_names, bands).write(&dir.join("by_fold.csv"))?;
    runs.timing_table().write(&dir.join("timing.csv"))
}

/// `summary.csv`.
fn summary_table(names: &[String], summaries: &[PolicySummary]) -> CsvTable {
    let mut summary = CsvTable::new(&[
        "policy",
        "runs",
        "successes",
        "success_rate",
        "wilson_low",
        "wilson_high",
        "commands_median",
        "commands_p95",
        "corrective_median",
        "approach_gap_median_m",
        "final_gap_median_m",
        "final_gap_p95_m",
        "cable_travel_median_m",
        "worst_utilisation",
        "violations",
        "runs_breaking_limits",
        "runs_breaking_limits_as_built",
    ]);
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| x.to_string());
    for (name, s) in names.iter().zip(summaries) {
        summary.row([
            name.clone(),
            s.runs.to_string(),
            s.successes.to_string(),
            s.success_rate().to_string(),
            s.success_interval.0.to_string(),
            s.success_interval.1.to_string(),
            opt(s.commands_median),
            opt(s.commands_p95),
            opt(s.corrective_median),
            opt(s.approach_gap_median_m),
            opt(s.final_gap_median_m),
            opt(s.final_gap_p95_m),
            opt(s.travel_median_m),
            s.worst_utilisation.to_string(),
            s.violations.to_string(),
            s.runs_breaking_limits.to_string(),
            s.runs_breaking_limits_as_built.to_string(),
        ]);
    }
    summary
}

/// `paired.csv`.
fn paired_table(names: &[String], pairs: &[PairedComparison]) -> CsvTable {
    let mut paired = CsvTable::new(&[
        "policy_a",
        "policy_b",
        "both",
        "only_a",
        "only_b",
        "neither",
        "mcnemar_exact_p",
        "gap_b_smaller",
        "gap_b_larger",
        "gap_sign_test_p",
        "gap_mean_difference_m",
        "commands_b_fewer",
        "commands_b_more",
        "commands_sign_test_p",
        "commands_mean_difference",
    ]);
    let mean = |d: Option<f64>| d.map_or(String::new(), |d| d.to_string());
    for p in pairs {
        let (g, c) = (&p.final_true_gap, &p.commands);
        paired.row([
            names[p.a].clone(),
            names[p.b].clone(),
            p.both.to_string(),
            p.only_a.to_string(),
            p.only_b.to_string(),
            p.neither.to_string(),
            p.mcnemar_p.to_string(),
            g.b_below.to_string(),
            g.b_above.to_string(),
            g.sign_test_p.to_string(),
            mean(g.mean_difference),
            c.b_below.to_string(),
            c.b_above.to_string(),
            c.sign_test_p.to_string(),
            mean(c.mean_difference),
        ]);
    }
    paired
}

/// `by_fold.csv`.
fn fold_table(names: &[String], bands: &[FoldBand]) -> CsvTable {
    let mut t = CsvTable::new(&[
        "policy",
        "half",
        "fold_from_m",
        "fold_to_m",
        "runs",
        "succeeded",
        "broke_limits",
        "other_failures",
    ]);
    for b in bands {
        t.row([
            names[b.policy].clone(),
            b.fold_of.label().to_string(),
            fold_text(b.from_m),
            fold_text(b.to_m),
            b.runs.to_string(),
            b.succeeded.to_string(),
            b.broke_limits.to_string(),
            b.other_failures().to_string(),
        ]);
    }
    t
}

/// A band's end, m, as written: to the millimetre (`0.3`, not
/// `0.30000000000000004`).
fn fold_text(m: f64) -> String {
    ((1e3 * m).round() / 1e3).to_string()
}
