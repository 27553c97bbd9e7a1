//! `tdeploy diagnose MODEL LOG`: which effect the model lacks, found by
//! fitting every candidate and scoring it on held-out cycles.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::ArgMatches;

use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::measure::diagnose::{diagnose as run, Candidate, DiagnoseSettings, Verdict};

fn params(c: &Candidate) -> String {
    c.kind
        .parameters()
        .iter()
        .zip(c.values.iter().zip(&c.std_errors))
        .map(|(p, (v, se))| super::fitted_parameter(p, *v, *se))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Runs `tdeploy diagnose`.
pub fn diagnose(a: &ArgMatches) -> Result<()> {
    let model_path = a.get_one::<PathBuf>("model").unwrap();
    let log_dir = a.get_one::<PathBuf>("log").unwrap();
    let model_file = read_model(model_path)?;
    let model = super::effect_model(&model_file)?;
    let log = read_log(log_dir, &model.structure)?;
    let settings = DiagnoseSettings {
        max_rounds: *a.get_one::<usize>("rounds").unwrap(),
    };
    let start = std::time::Instant::now();
    let d = run(&model, &log, &settings)
        .with_context(|| format!("diagnosing {}", log_dir.display()))?;
    for (i, round) in d.rounds.iter().enumerate() {
        say!(
            "round {}: model held-out RMS {:.2} σ, BIC {:.1}",
            i + 1,
            round.base_held_out_rms,
            round.base_bic
        );
        say!(
            "  {:<20} {:>10} {:>10} {:>10} {:>10}  parameters",
            "candidate",
            "held-out σ",
            "explained",
            "BIC",
            "cond"
        );
        for c in &round.ranking {
            say!(
                "  {:<20} {:>10.2} {:>9.0}% {:>10.1} {:>10.1e}  {}{}",
                c.kind.name(),
                c.held_out_rms,
                100.0 * c.explained,
                c.bic,
                c.condition,
                params(c),
                if c.converged { "" } else { " (not converged)" }
            );
        }
        let unfitted: Vec<String> = round
            .screened
            .iter()
            .filter(|s| !s.passed())
            .map(|s| {
                format!(
                    "{} (predicted χ² gain {:.1} < {:.1})",
                    s.kind.name(),
                    s.predicted_gain,
                    s.threshold
                )
            })
            .collect();
        if !unfitted.is_empty() {
            say!("  not worth fitting: {}", unfitted.join(", "));
        }
    }
    match &d.verdict {
        Verdict::NothingMissing => {
            say!("verdict: residuals are consistent with sensor noise: nothing is missing")
        }
        Verdict::Missing(found) => {
            for c in found {
                say!(
                    "verdict: effect {} is missing ({}; explains {:.0}% of the held-out residual above noise)",
                    c.kind.name(),
                    params(c),
                    100.0 * c.explained
                );
            }
        }
        Verdict::Unexplained {
            found,
            held_out_rms,
        } => {
            let names: Vec<_> = found.iter().map(|c| c.kind.name()).collect();
            let after = if names.is_empty() {
                String::new()
            } else {
                format!(" after adding [{}]", names.join(", "))
            };
            say!(
                "verdict: a structured residual remains that no candidate explains: held-out RMS {held_out_rms:.2} σ{after}; {}",
                super::compare::where_it_fails(&log, &d.final_comparison)
            );
        }
    }
    say!(
        "({:.1} s on {} threads)",
        start.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    Ok(())
}
