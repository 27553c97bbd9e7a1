//! The report of a policy evaluation, shared by `evaluate`, `merge` and
//! the deployment experiment: a table per policy, the paired comparisons,
//! and the files of [`tensegrity_deploy::io::evaluation_files`] plus
//! `summary.csv`, `paired.csv` and `evaluation.svg`.

use std::path::Path;

use anyhow::Result;

use tensegrity_deploy::io::evaluation_files::{EvaluationRecord, EvaluationRuns};
use tensegrity_deploy::io::{write_atomically, CsvTable};
use tensegrity_deploy::report::figures::grouped_bars_svg;
use tensegrity_deploy::studies::evaluation::{paired_outcomes, summarise_results};
use tensegrity_deploy::studies::statistics::mcnemar_exact_p;

/// Milliseconds of an optional duration in seconds, for tables.
fn ms(v: Option<f64>) -> String {
    v.map_or("-".into(), |s| format!("{:.1}", 1e3 * s))
}

/// An optional number with `digits` decimals, for tables.
fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.digits$}"))
}

/// Prints the summary of `runs` and writes every file of the set into
/// `folder` (which must exist). Returns how many runs broke a truth limit.
pub fn report(record: &EvaluationRecord, runs: &EvaluationRuns, folder: &Path) -> Result<usize> {
    // One decimal on the rates: 1000 of 1000 has a Wilson interval of
    // 99.6–100 %, which whole percent would print as "100–100".
    say!(
        "{:<14} {:>9} {:>15} {:>9} {:>9} {:>11} {:>10} {:>10} {:>10} {:>9} {:>9} {:>6} {:>9}",
        "policy",
        "success",
        "Wilson 95 %",
        "cmds med",
        "cmds p95",
        "corrective",
        "approach",
        "gap med",
        "gap p95",
        "travel",
        "worst use",
        "viol.",
        "ms/cmd"
    );
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
    ]);
    let mut bars: Vec<(&str, Vec<f64>)> = Vec::new();
    let mut violations = 0;
    for (p, name) in runs.policy_names.iter().enumerate() {
        let s = summarise_results(&runs.results, p);
        violations += s.violations;
        let rate = s.successes as f64 / s.runs.max(1) as f64;
        say!(
            "{:<14} {:>8.1}% {:>7.1}–{:>5.1} % {:>9} {:>9} {:>11} {:>7} mm {:>7} mm {:>7} mm {:>7} m {:>9.2} {:>6} {:>9}",
            name,
            100.0 * rate,
            100.0 * s.success_interval.0,
            100.0 * s.success_interval.1,
            num(s.commands_median, 1),
            num(s.commands_p95, 1),
            num(s.corrective_median, 1),
            num(s.approach_gap_median_m.map(|g| 1e3 * g), 1),
            num(s.final_gap_median_m.map(|g| 1e3 * g), 1),
            num(s.final_gap_p95_m.map(|g| 1e3 * g), 1),
            num(s.travel_median_m, 2),
            s.worst_utilisation,
            s.violations,
            ms(s.planning_time_median_s)
        );
        let opt = |v: Option<f64>| v.map_or(String::new(), |x| x.to_string());
        summary.row([
            name.clone(),
            s.runs.to_string(),
            s.successes.to_string(),
            rate.to_string(),
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
        ]);
        bars.push((
            name.as_str(),
            vec![
                100.0 * rate,
                s.commands_median.unwrap_or(0.0),
                s.corrective_median.unwrap_or(0.0),
                s.final_gap_median_m.map_or(0.0, |g| 1e3 * g),
            ],
        ));
    }
    // The first policy against each other one on the same scenarios.
    let mut paired = CsvTable::new(&[
        "policy_a",
        "policy_b",
        "both",
        "only_a",
        "only_b",
        "neither",
        "mcnemar_exact_p",
    ]);
    let names = &runs.policy_names;
    for b in 1..names.len() {
        let (both, only_a, only_b, neither) = paired_outcomes(&runs.results, 0, b);
        let p = mcnemar_exact_p(only_a, only_b);
        say!(
            "{} vs {} on the same {} scenarios: both succeed {both}, only {} {only_a}, only {} {only_b}, neither {neither}; exact McNemar p = {p:.2e}",
            names[0],
            names[b],
            both + only_a + only_b + neither,
            names[0],
            names[b],
        );
        paired.row([
            names[0].clone(),
            names[b].clone(),
            both.to_string(),
            only_a.to_string(),
            only_b.to_string(),
            neither.to_string(),
            p.to_string(),
        ]);
    }
    let svg = grouped_bars_svg(
        &format!(
            "{} policies on {} scenarios (median over successes; gap over all runs)",
            names.len(),
            runs.scenarios.len()
        ),
        "value",
        &[
            "success rate, %".to_string(),
            "commands to connection".into(),
            "corrective commands".into(),
            "final largest gap, mm".into(),
        ],
        &bars,
    )?;
    write_atomically(
        &folder.join("evaluation.toml"),
        record.to_toml()?.as_bytes(),
    )?;
    runs.runs_table().write(&folder.join("runs.csv"))?;
    summary.write(&folder.join("summary.csv"))?;
    paired.write(&folder.join("paired.csv"))?;
    runs.timing_table().write(&folder.join("timing.csv"))?;
    write_atomically(&folder.join("evaluation.svg"), svg.as_bytes())?;
    Ok(violations)
}
