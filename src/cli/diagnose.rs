//! `tdeploy diagnose MODEL LOG`: which effect the model lacks, found by
//! fitting every candidate and scoring it on held-out cycles.
//!
//! `--json FILE` writes the diagnosis as one JSON object (its fields in
//! [`tensegrity_deploy::io::comparison_files`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::comparison_files::{
    sensor_ids, write_diagnosis_report, DiagnosisReport,
};
use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::measure::comparison_verdict::where_it_fails;
use tensegrity_deploy::measure::diagnose::{
    diagnose, Candidate, DiagnoseError, DiagnoseSettings, ParameterFlag, Screened, Verdict,
};
use tensegrity_deploy::measure::evidence::{Statistic, Subject};
use tensegrity_deploy::measure::local::Term;
use tensegrity_deploy::model::EffectKind;

use super::words::{
    fitted_parameter, number, outliers_in_words, signed_number, where_it_fails_in_words,
};
use super::{plant_stopped, value, Outcome};

/// The `diagnose` subcommand's arguments.
pub fn command() -> Command {
    Command::new("diagnose")
        .about("Fit every effect the model lacks to a log, score each on held-out cycles, and say which is missing")
        .arg(Arg::new("model").required(true).value_parser(value_parser!(PathBuf)).help("Model file (TOML)"))
        .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder"))
        .arg(Arg::new("rounds").long("rounds").default_value("2").value_parser(value_parser!(usize)).help("Effects to look for at most, one per round (1 to the number of effects)"))
        .arg(Arg::new("json").long("json").value_parser(value_parser!(PathBuf)).help("Also write the diagnosis as JSON to this file (an existing file with other contents needs --force)"))
        .arg(Arg::new("force").long("force").action(clap::ArgAction::SetTrue).help("Overwrite the --json file if it exists with other contents"))
}

/// Options of `tdeploy diagnose`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Model file.
    pub model: PathBuf,
    /// Log folder.
    pub log: PathBuf,
    /// Search settings.
    pub settings: DiagnoseSettings,
    /// JSON report file, if asked for.
    pub json: Option<PathBuf>,
    /// Overwrite an existing JSON file.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let max_rounds: usize = value(m, "rounds")?;
        let most = EffectKind::ALL.len();
        if !(1..=most).contains(&max_rounds) {
            anyhow::bail!("--rounds: must be 1 to {most}, got {max_rounds}");
        }
        Ok(Options {
            model: value(m, "model")?,
            log: value(m, "log")?,
            settings: DiagnoseSettings {
                max_rounds,
                ..DiagnoseSettings::default()
            },
            json: m.get_one::<PathBuf>("json").cloned(),
            force: m.get_flag("force"),
        })
    }
}

fn params(c: &Candidate) -> String {
    c.term
        .parameters()
        .iter()
        .zip(c.values.iter().zip(&c.std_errors))
        .map(|(p, (v, se))| fitted_parameter(p, *v, *se))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Runs `tdeploy diagnose`.
pub fn run(o: &Options) -> Result<Outcome> {
    let model = read_model(&o.model)?.measurement_model()?;
    let log = read_log(&o.log, &model.structure)?;
    let start = std::time::Instant::now();
    let d = match diagnose(&model, &log, &o.settings) {
        Ok(d) => d,
        Err(DiagnoseError::Replay(e)) => {
            return plant_stopped(e, format!("diagnosing {}", o.log.display()))
        }
        Err(DiagnoseError::Log(e)) => anyhow::bail!("{}: {e}", o.log.display()),
        Err(DiagnoseError::Settings(e)) => anyhow::bail!("{e}"),
    };
    if let Some(words) = outliers_in_words(&log, &d.outliers, &o.settings.outliers) {
        say!("{words}; removed before the search");
    }
    for (i, round) in d.rounds.iter().enumerate() {
        say!(
            "round {}: model held-out RMS {:.2} σ, BIC {:.1}",
            i + 1,
            round.base_held_out_rms,
            round.base_bic
        );
        say!(
            "  {:<34} {:>10} {:>10} {:>10} {:>10}  parameters",
            "candidate",
            "held-out σ",
            "explained",
            "BIC",
            "cond"
        );
        for c in &round.ranking {
            say!(
                "  {:<34} {:>10.2} {:>9.0}% {:>10.1} {:>10.1e}  {}{}",
                c.name,
                c.held_out_rms,
                100.0 * c.explained,
                c.bic,
                c.condition,
                params(c),
                if c.converged { "" } else { " (not converged)" }
            );
            for f in &c.flags {
                say!("    {}: {f}", flag_word(f));
            }
        }
        let describe = |s: &Screened| {
            format!(
                "{} (predicted χ² gain {:.1} < {:.1})",
                s.name, s.predicted_gain, s.threshold
            )
        };
        let unfitted: Vec<String> = round
            .screened
            .iter()
            .filter(|s| !s.passed() && matches!(s.term, Term::Global(_)))
            .map(describe)
            .collect();
        if !unfitted.is_empty() {
            say!("  not worth fitting: {}", unfitted.join(", "));
        }
        // The local tier is long: its count and the closest to passing.
        let local: Vec<&Screened> = round
            .screened
            .iter()
            .filter(|s| !s.passed() && matches!(s.term, Term::Local(_)))
            .collect();
        if let Some(first) = local.first() {
            say!(
                "  local candidates screened: {} of {} in the tier; {} not worth fitting, closest: {}",
                round
                    .screened
                    .iter()
                    .filter(|s| matches!(s.term, Term::Local(_)))
                    .count(),
                round.local_tier,
                local.len(),
                describe(first)
            );
        }
    }
    let fails = match &d.verdict {
        Verdict::Unexplained { .. } => where_it_fails(&d.final_comparison, &d.evidence),
        _ => None,
    };
    let significant: Vec<String> = d
        .evidence
        .significant()
        .map(|t| {
            let name = match t.subject {
                Subject::Sensor(s) => log.sensors.get(s).map(|s| s.id.clone()).unwrap_or_default(),
                Subject::Group(g) => format!("group {}", g.name()),
            };
            match t.statistic {
                Statistic::Mean => format!("{name} mean {} SE", signed_number(t.value, 1)),
                Statistic::Spread => format!("{name} spread {} σ", number(t.value, 2)),
            }
        })
        .collect();
    if significant.is_empty() {
        say!(
            "per-sensor tests (final model): none of {} rejects noise (Holm, family-wise error {})",
            d.evidence.tests.len(),
            d.evidence.family_alpha
        );
    } else {
        say!(
            "per-sensor tests (final model): {} of {} reject noise (Holm, family-wise error {}): {}",
            significant.len(),
            d.evidence.tests.len(),
            d.evidence.family_alpha,
            significant.join(", ")
        );
    }
    match &d.verdict {
        Verdict::NothingMissing => {
            say!("verdict: residuals are consistent with sensor noise: nothing is missing")
        }
        Verdict::Missing { found, confident } => {
            for c in found {
                say!(
                    "verdict: {} {} is missing ({}; explains {:.0}% of the held-out residual above noise)",
                    if matches!(c.term, Term::Local(_)) { "local effect" } else { "effect" },
                    c.name,
                    params(c),
                    100.0 * c.explained
                );
                for f in &c.flags {
                    say!("  {}: {f}", flag_word(f));
                }
                if !c.converged {
                    say!("  warning: the fit did not converge");
                }
            }
            if !confident {
                say!("  not confident: a fitted value is flagged above; the effect may stand in for another");
            }
        }
        Verdict::Unexplained {
            found,
            held_out_rms,
        } => {
            let names: Vec<_> = found.iter().map(|c| c.name.as_str()).collect();
            let after = if names.is_empty() {
                String::new()
            } else {
                format!(" after adding [{}]", names.join(", "))
            };
            let place = match &fails {
                Some(w) => where_it_fails_in_words(&log, w),
                None => "no reading could be compared".into(),
            };
            say!(
                "verdict: a structured residual remains that no candidate explains: held-out RMS {held_out_rms:.2} σ{after}; {place}"
            );
        }
    }
    say!(
        "({:.1} s on {} threads)",
        start.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    if let Some(json) = &o.json {
        let report = DiagnosisReport {
            model: &o.model,
            log: &o.log,
            sensors: sensor_ids(&log),
            diagnosis: &d,
            where_it_fails: fails,
        };
        write_diagnosis_report(json, &report, o.force)?;
        say!("JSON report in {}", json.display());
    }
    Ok(Outcome::GoalReached)
}

/// How a parameter flag is introduced: a neutral limit is information
/// (the effect lacks that part), every other flag a warning.
fn flag_word(flag: &ParameterFlag) -> &'static str {
    match flag {
        ParameterFlag::AtNeutralLimit { .. } => "note",
        _ => "warning",
    }
}
