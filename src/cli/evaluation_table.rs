//! The printed table of a policy evaluation, shared by `evaluate`, `merge`
//! and the deployment experiment: a row per policy, a line per paired
//! comparison, and each policy's outcomes by fold (when the runs span
//! more than one 10 cm band); the set of files is written through
//! [`tensegrity_deploy::io::evaluation_summary`] and its figure drawn by
//! [`tensegrity_deploy::report::evaluation_figure`].

use std::path::Path;

use anyhow::Result;

use tensegrity_deploy::io::evaluation_files::{EvaluationRecord, EvaluationRuns};
use tensegrity_deploy::io::evaluation_summary::write_evaluation;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::plan::verdict::AS_BUILT_PREFIX;
use tensegrity_deploy::plan::RunOutcome;
use tensegrity_deploy::report::evaluation_figure::evaluation_svg;
use tensegrity_deploy::studies::evaluation::{
    binding_counts, first_against_others, summarise_results, PolicySummary,
};
use tensegrity_deploy::studies::fold_bands::{fold_bands, FoldOf};
use tensegrity_deploy::studies::statistics::median;

/// How many of the names that bind most often the table prints.
const BINDS_NAMED: usize = 5;

/// Milliseconds of an optional duration in seconds, for tables.
fn ms(v: Option<f64>) -> String {
    v.map_or("-".into(), |s| format!("{:.1}", 1e3 * s))
}

/// An optional number with `digits` decimals, for tables.
fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.digits$}"))
}

/// What the truth's limits came to over one policy's runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TruthLimits {
    /// Truth limit violations (increments that broke a limit), over the runs.
    pub violations: usize,
    /// Runs that ended with a limit the fold had broken still broken
    /// (`limits_not_restored`): no increment broke it, but the run left it.
    pub not_restored: usize,
}

impl TruthLimits {
    /// Why the runs fail the evaluation's standard (every truth limit kept
    /// and every start-broken one restored), or `None`.
    pub fn failure(&self) -> Option<String> {
        (self.violations > 0 || self.not_restored > 0).then(|| {
            format!(
                "{} truth limit violations over the runs, {} runs left a limit the fold broke unrestored (both must be 0)",
                self.violations, self.not_restored
            )
        })
    }
}

/// The [`TruthLimits`] of every policy together.
pub fn all_policies(limits: &[TruthLimits]) -> TruthLimits {
    TruthLimits {
        violations: limits.iter().map(|l| l.violations).sum(),
        not_restored: limits.iter().map(|l| l.not_restored).sum(),
    }
}

/// Prints the summary of `runs` and writes every file of the set into
/// `folder` (which must exist). Returns what the truth's limits came to,
/// per policy.
pub fn print_and_write(
    record: &EvaluationRecord,
    runs: &EvaluationRuns,
    folder: &Path,
) -> Result<Vec<TruthLimits>> {
    let names = &runs.policy_names;
    let summaries: Vec<PolicySummary> = (0..names.len())
        .map(|p| summarise_results(&runs.results, p))
        .collect();
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
    for (name, s) in names.iter().zip(&summaries) {
        say!(
            "{:<14} {:>8.1}% {:>7.1}–{:>5.1} % {:>9} {:>9} {:>11} {:>7} mm {:>7} mm {:>7} mm {:>7} m {:>9.2} {:>6} {:>9}",
            name,
            100.0 * s.success_rate(),
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
    }
    for (p, (name, s)) in names.iter().zip(&summaries).enumerate() {
        let failed = s.runs - s.successes;
        if failed == 0 {
            continue;
        }
        let (counts, unnamed) = binding_counts(&runs.results, p);
        let mut named: Vec<String> = counts
            .iter()
            .take(BINDS_NAMED)
            .map(|(limit, n)| format!("{limit} ({n})"))
            .collect();
        if counts.len() > BINDS_NAMED {
            named.push(format!("{} more", counts.len() - BINDS_NAMED));
        }
        let unnamed = (unnamed > 0).then(|| format!("{unnamed} name nothing"));
        let words: Vec<String> = [(!named.is_empty()).then(|| named.join(", ")), unnamed]
            .into_iter()
            .flatten()
            .collect();
        say!(
            "{name}: what binds in the {failed} runs that did not connect (runs naming it; runs.csv's binds): {}",
            words.join("; ")
        );
        let (broke, out_as_built) = (s.runs_breaking_limits, s.runs_breaking_limits_as_built);
        if broke > 0 {
            say!(
                "{name}: {out_as_built} of the {broke} runs that broke limits are on truths that break limits in their own as-built state, before any fold (binds `{}…`)",
                AS_BUILT_PREFIX
            );
            let mut breaches: Vec<f64> = runs
                .results
                .iter()
                .filter(|r| r.policy == p)
                .filter_map(|r| r.largest_force_breach_n)
                .collect();
            breaches.sort_by(f64::total_cmp);
            let runs_breaching = breaches.len();
            if let (Some(&least), Some(&most), Some(middle)) =
                (breaches.first(), breaches.last(), median(breaches.clone()))
            {
                say!(
                    "{name}: how far a truth force went beyond its bound in each run that broke a force limit (runs.csv's largest_force_breach_n): {runs_breaching} runs, from {least:.2} N to {most:.2} N, median {middle:.2} N"
                );
            }
        }
    }
    // The first policy against each other one on the same scenarios.
    let pairs = first_against_others(&runs.results, names.len());
    for p in &pairs {
        let (a, b) = (&names[p.a], &names[p.b]);
        say!(
            "{a} vs {b} on the same {} scenarios: both succeed {}, only {a} {}, only {b} {}, neither {}; exact McNemar p = {:.2e}",
            p.scenarios(),
            p.both,
            p.only_a,
            p.only_b,
            p.neither,
            p.mcnemar_p,
        );
        if p.both > 0 {
            let (g, c) = (&p.final_true_gap, &p.commands);
            let signed = |d: Option<f64>, scale: f64| {
                d.map_or("–".into(), |d| format!("{:+.2}", scale * d))
            };
            say!(
                "  on the {} both succeed on: {b}'s final true gap below {a}'s in {}, above in {} (exact sign test p = {:.2e}; mean {b} − {a} {} mm); {b}'s commands fewer in {}, more in {} (p = {:.2e}; mean {b} − {a} {})",
                p.both,
                g.b_below,
                g.b_above,
                g.sign_test_p,
                signed(g.mean_difference, 1e3),
                c.b_below,
                c.b_above,
                c.sign_test_p,
                signed(c.mean_difference, 1.0),
            );
        }
    }
    let bands = fold_bands(&runs.results, names.len(), |s| runs.half_folds_m(s));
    for (p, name) in names.iter().enumerate() {
        for fold_of in [FoldOf::BothHalves, FoldOf::HalfA, FoldOf::HalfB] {
            let mine: Vec<String> = bands
                .iter()
                .filter(|b| b.policy == p && b.fold_of == fold_of)
                .map(|b| {
                    format!(
                        "{:.0}–{:.0} cm {}/{}/{} of {}",
                        1e2 * b.from_m,
                        1e2 * b.to_m,
                        b.succeeded,
                        b.broke_limits,
                        b.other_failures(),
                        b.runs
                    )
                })
                .collect();
            let whose = match fold_of {
                FoldOf::BothHalves => "the fold",
                FoldOf::HalfA => "half A's fold",
                FoldOf::HalfB => "half B's fold",
            };
            if mine.len() > 1 {
                say!(
                    "{name} by {whose} (succeeded/broke limits/failed otherwise of runs; by_fold.csv): {}",
                    mine.join("; ")
                );
            }
        }
    }
    let svg = evaluation_svg(names, &summaries, runs.scenarios.len())?;
    write_evaluation(folder, record, runs, &summaries, &pairs, &bands)?;
    write_atomically(&folder.join("evaluation.svg"), svg.as_bytes())?;
    Ok(summaries
        .iter()
        .enumerate()
        .map(|(p, s)| TruthLimits {
            violations: s.violations,
            not_restored: runs
                .results
                .iter()
                .filter(|r| {
                    r.policy == p
                        && RunOutcome::LimitsNotRestored.label() == Some(r.status.as_str())
                })
                .count(),
        })
        .collect())
}
