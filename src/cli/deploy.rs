//! `tdeploy deploy [--truth F] [--model F] [--policy P] [--problem F]
//! [--temperature °C] [--seed S] [--threads N] [-o DIR] [--force] [--json]`: a closed-loop deployment
//! of a simulated bridge (the truth) by the controller planning on its
//! model, corrected by a noisy measurement after every command (see
//! [`tensegrity_deploy::control::closed_loop`]).
//!
//! Defaults: the truth is the reference bridge with
//! [`tensegrity_deploy::sim::default_truth()`]'s effects (μ = 0.2, 3 mm motor
//! backlash); the controller plans on the same bridge without friction;
//! the policy is `policies/qp.toml`'s (built in); the problem is the
//! default 40 cm fold; seed 1. A truth with a thermal effect needs
//! `--temperature` (the air temperature, held throughout); without one it
//! is refused (exit 2) rather than deployed at its reference temperature.
//!
//! Prints one line per command (command per motor in mm, the largest
//! measured gap, the truth's worst utilisation, the QP status, the
//! planning time) and a verdict; exit 0 when connected, 1 when not, 2 on
//! bad input. With `--json`, prints `summary.json` instead.
//!
//! Writes in DIR, as a whole (a crash leaves the old set or the new one;
//! a folder holding files tdeploy did not write needs `--force`):
//! `commands.csv`, `log/`, `truth.toml`, `model.toml`, `problem.toml`,
//! `deployment.csv`, `summary.json` and `timing.csv` (formats in
//! [`tensegrity_deploy::io::deployment_files`]) and `deployment.svg`
//! ([`tensegrity_deploy::report::deployment_figure`]). `timing.csv` is the
//! only file that changes from run to run: every other one is the same,
//! byte for byte, for the same inputs and seed at any thread count.

use std::path::PathBuf;

use anyhow::Result;
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};

use tensegrity_deploy::control::{deploy_closed_loop, ClosedLoopSetup, DeployError, Deployment};
use tensegrity_deploy::io::deployment_files::{
    write_deployment, DeploymentSet, DeploymentSources, DeploymentSummary,
};
use tensegrity_deploy::io::json_text;
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::model::JointFriction;
use tensegrity_deploy::plan::RunVerdict;
use tensegrity_deploy::report::deployment_figure::deployment_svg;
use tensegrity_deploy::sim::{standard_sensors, PlantError};

use super::inputs::{
    absolute, controller_model_file, deployment_temperature, planning_model, policy_or_default,
    problem_or_default, truth_or_default,
};
use super::progress::{Progress, Unit};
use super::words::{commands_count, mm};
use super::{value, with_threads, Outcome};

/// The `deploy` subcommand's arguments.
pub fn command() -> Command {
    Command::new("deploy")
        .about("Deploy a simulated bridge (the truth) in closed loop: plan on the model, command the truth, measure, correct; exit code 1 if it does not connect")
        .arg(Arg::new("truth").long("truth").value_parser(value_parser!(PathBuf)).help("Truth model file (TOML: structure and effects) standing in for the real bridge. Default: the reference bridge with joint friction μ = 0.2 (wrap angle) and 3 mm motor backlash"))
        .arg(Arg::new("model").long("model").value_parser(value_parser!(PathBuf)).help("Model file the controller plans on (its structure, stiffness and friction). Default: the reference bridge without friction"))
        .arg(Arg::new("policy").long("policy").value_parser(value_parser!(PathBuf)).help("Policy file (default: policies/qp.toml's settings, built in)"))
        .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file (default: fold 0.40 m, 30 mm connection, documented limits)"))
        .arg(Arg::new("temperature").long("temperature").value_parser(value_parser!(f64)).help("Air temperature during the deployment, °C (held throughout); needed by a truth with a thermal effect, which expands its members from their reference temperature"))
        .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the sensor noise"))
        .arg(super::truth_substeps_arg())
        .arg(super::threads_arg())
        .arg(Arg::new("out").long("out").short('o').default_value("out/deploy").value_parser(value_parser!(PathBuf)).help("Folder for commands.csv, log/, deployment.csv, summary.json, deployment.svg, timing.csv, truth.toml and model.toml"))
        .arg(super::force_arg())
        .arg(Arg::new("json").long("json").action(ArgAction::SetTrue).help("Print summary.json on stdout instead of the per-command lines and verdict (no progress bar)"))
}

/// Options of `tdeploy deploy`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Truth model file; `None`: the default truth.
    pub truth: Option<PathBuf>,
    /// Controller's model file; `None`: the frictionless reference bridge.
    pub model: Option<PathBuf>,
    /// Policy file; `None`: the built-in default.
    pub policy: Option<PathBuf>,
    /// Problem file; `None`: the default problem.
    pub problem: Option<PathBuf>,
    /// Air temperature, °C (`--temperature`); `None`: not given (refused
    /// with a thermal truth).
    pub temperature_c: Option<f64>,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// The truth splits its increments at slip events.
    pub truth_slip_event_substeps: bool,
    /// Worker threads; `None`: rayon's default.
    pub threads: Option<usize>,
    /// Results folder.
    pub out: PathBuf,
    /// Print the summary as JSON instead of lines.
    pub json: bool,
    /// Replace a folder of other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let threads = super::threads_option(m)?;
        Ok(Options {
            truth: m.get_one::<PathBuf>("truth").cloned(),
            model: m.get_one::<PathBuf>("model").cloned(),
            policy: m.get_one::<PathBuf>("policy").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            temperature_c: m.get_one::<f64>("temperature").copied(),
            seed: value(m, "seed")?,
            truth_slip_event_substeps: m.get_flag("slip-event-substeps"),
            threads,
            out: value(m, "out")?,
            json: m.get_flag("json"),
            force: m.get_flag("force"),
        })
    }
}

/// The verdict line.
fn verdict(v: &RunVerdict, d: &Deployment) -> String {
    format!(
        "{} (after {}; largest measured gap {} mm, true {} mm)",
        v.describe(),
        commands_count(d.records.len()),
        mm(d.final_measured_gap_m()),
        mm(d.final_true_gap_m())
    )
}

/// Runs `tdeploy deploy`.
pub fn run(o: &Options) -> Result<Outcome> {
    // Claimed before the work, so that a refusal costs nothing; the set
    // is written whole (old or new, never a mix).
    let folder = ResultsFolder::claim(&o.out, "deploy", o.force)?;
    let (truth_file, truth, truth_words) = truth_or_default(
        o.truth.as_deref(),
        o.model.as_deref(),
        o.truth_slip_event_substeps,
    )?;
    let temperature_c = deployment_temperature(o.temperature_c, &truth.effects, &truth_words)?;
    let (model_file, model_words) = controller_model_file(o.model.as_deref())?;
    let model_file = absolute(model_file)?;
    let model = planning_model(o.model.as_deref(), JointFriction::frictionless())?;
    let policy = policy_or_default(o.policy.as_deref())?;
    let problem = problem_or_default(
        o.problem.as_deref(),
        model.structure().continuous_cables.len(),
    )?;
    let sensors = standard_sensors(&truth.structure);
    let setup = ClosedLoopSetup {
        model: &model,
        problem: &problem,
        policy: &policy,
        truth: &truth,
        sensors: &sensors,
        temperature_c,
        seed: o.seed,
    };
    let quiet = o.json;
    if !quiet {
        say!(
            "deploy: policy {} ({}), truth {truth_words}, controller's model {model_words}, seed {}{}",
            policy.name,
            policy.planner.as_str(),
            o.seed,
            temperature_c.map_or(String::new(), |t| format!(", {t} °C"))
        );
    }
    let mut progress = Progress::new(Unit::Commands, policy.max_commands as u64, quiet);
    let result = with_threads(o.threads, || deploy_closed_loop(&setup, &mut progress))?;
    progress.finish();
    let d = match result {
        Ok(d) => d,
        // The truth failing to fold is a solve that did not converge
        // (exit 1); everything else is input the deployment cannot use.
        Err(DeployError::TruthStart(
            e @ (PlantError::Solver { .. }
            | PlantError::AsBuilt { .. }
            | PlantError::SeatsUnsettled { .. }),
        )) => {
            return Ok(Outcome::GoalMissed(format!(
                "the truth plant could not reach the folded start: {e}"
            )))
        }
        Err(e) => return Err(e.into()),
    };

    let run_verdict = d.verdict(problem.connection_tolerance_m);
    let verdict = verdict(&run_verdict, &d);
    let sources = DeploymentSources {
        truth: truth_words,
        model: model_words,
        problem: o.problem.as_ref().map_or_else(
            || "the default problem".to_string(),
            |p| p.display().to_string(),
        ),
        seed: o.seed,
    };
    let summary = DeploymentSummary::new(
        &d,
        &run_verdict,
        &policy,
        &problem,
        sources,
        verdict.clone(),
    );
    let out = folder.path();
    write_deployment(
        out,
        &DeploymentSet {
            deployment: &d,
            structure: model.structure(),
            truth: &truth,
            sensors: &sensors,
            truth_file: &truth_file,
            model_file: &model_file,
            problem: &problem,
            summary: &summary,
            // Paths in the model files are relative to where the set
            // will be.
            target: &o.out,
        },
    )?;
    let svg = deployment_svg(
        &truth.forward_model()?,
        &d,
        problem.connection_tolerance_m,
        &format!("Closed-loop deployment, seed {}", o.seed),
    )?;
    write_atomically(&out.join("deployment.svg"), svg.as_bytes())?;
    folder.commit()?;

    if o.json {
        say!("{}", json_text(&summary)?.trim_end());
    } else {
        say!("{verdict}");
        match (d.first_below_corrective_gap, d.corrective_commands) {
            (Some(k), Some(n)) => say!(
                "largest measured gap below 60 mm after command {k}; {} after it (corrective)",
                commands_count(n)
            ),
            _ => say!("the largest measured gap never came below 60 mm"),
        }
        if let Some(line) = estimates_line(&d) {
            say!("{line}");
        }
        if d.truth_limit_violations == 0 {
            say!(
                "the truth kept every limit at every increment ({} increments checked)",
                summary.truth_increments_checked
            );
        } else {
            say!(
                "the truth broke {} limits along the way (see deployment.csv)",
                d.truth_limit_violations
            );
        }
        say!(
            "results in {} (commands.csv, log/, problem.toml, deployment.csv, summary.json, deployment.svg, timing.csv)",
            o.out.display()
        );
    }
    Ok(if run_verdict.is_connected() {
        Outcome::GoalReached
    } else {
        Outcome::GoalMissed(verdict)
    })
}

/// What the controller estimated by the end, in words: the payout scale of
/// each bridge half and the load cells' common bias (`None` with neither).
fn estimates_line(d: &Deployment) -> Option<String> {
    let mut parts = Vec::new();
    if !d.final_payout_scale.is_empty() {
        let scales: Vec<String> = d
            .final_payout_scale
            .iter()
            .map(|s| format!("{:+.1} %", 100.0 * s))
            .collect();
        parts.push(format!("payout scale per half {}", scales.join(", ")));
    }
    if let Some((mean, sd)) = d.final_load_cell_bias_n {
        parts.push(format!("load cells' common bias {mean:.1} ± {sd:.1} N"));
    }
    (!parts.is_empty()).then(|| format!("estimated: {}", parts.join("; ")))
}
