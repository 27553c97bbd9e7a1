//! `tdeploy experiment FILE`: the experiments in `experiments/`, each a TOML
//! file ([`tensegrity_deploy::io::experiment_file`]) whose `kind` picks the
//! study; results as CSV ([`tensegrity_deploy::io::experiment_tables`],
//! the deployment experiment an evaluation's set) and SVG
//! ([`tensegrity_deploy::report::experiment_figures`]), and a table beside
//! the seed's values.

use std::path::PathBuf;

use anyhow::Result;
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::design::friction_rig::{rig_slip, RigError};
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::{EvaluationRecord, EvaluationRuns};
use tensegrity_deploy::io::experiment_file::{
    read_experiment, DeploymentExperiment, Experiment, FrictionEffectExperiment,
    FrictionRigExperiment, FrictionVsMeasurementExperiment,
};
use tensegrity_deploy::io::experiment_tables::{
    write_friction_effect, write_friction_rig, write_friction_vs_measurement,
};
use tensegrity_deploy::io::output::create_folder;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::model::ForwardModel;
use tensegrity_deploy::model::{FrictionCoefficient, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::report::experiment_figures::{average_tension_svg, friction_effect_svg};
use tensegrity_deploy::studies::evaluation::{
    evaluate, EvaluationSetup, ScenarioDistribution, Shard,
};
use tensegrity_deploy::studies::friction_vs_measurement::{
    friction_vs_measurement, CellComparison, FrictionVsMeasurementSettings,
};
use tensegrity_deploy::studies::{friction_effect, FrictionEffectSettings};

use super::evaluation_table::print_and_write;
use super::progress::{Progress, Unit};
use super::{plant_stopped, value, Outcome};

/// The `experiment` subcommand's arguments.
pub fn command() -> Command {
    Command::new("experiment")
        .about("Run an experiment file from experiments/")
        .arg(
            Arg::new("file")
                .required(true)
                .value_parser(value_parser!(PathBuf)),
        )
}

/// Options of `tdeploy experiment`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Experiment file.
    pub file: PathBuf,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(Options {
            file: value(m, "file")?,
        })
    }
}

/// Runs `tdeploy experiment`.
pub fn run(o: &Options) -> Result<Outcome> {
    match read_experiment(&o.file)? {
        Experiment::FrictionRig(e) => friction_rig(&e),
        Experiment::FrictionEffect(e) => friction_effect_experiment(&e),
        Experiment::FrictionVsMeasurement(e) => friction_vs_measurement_experiment(&e),
        Experiment::Deployment(e) => deployment_experiment(&e),
    }
}

fn friction_rig(e: &FrictionRigExperiment) -> Result<Outcome> {
    let friction = JointFriction::new(FrictionCoefficient::Constant(e.mu), e.convention)?;
    say!(
        "friction rig, true μ = {} ({:?} convention)",
        e.mu,
        e.convention
    );
    say!(
        "{:>6} {:>6} {:>12} {:>12} {:>12} {:>10} {:>10}",
        "θ deg",
        "T kN",
        "ratio model",
        "ratio e^μα",
        "slip load N",
        "μ(θ)",
        "μ(π−θ)"
    );
    let mut slips = Vec::new();
    for (theta_deg, tensions) in e.interior_angles_deg.iter().zip(&e.tensions_kn) {
        for t_kn in tensions {
            let s = match rig_slip(&friction, *theta_deg, *t_kn) {
                Ok(s) => s,
                Err(e @ (RigError::NotConverged { .. } | RigError::NeverSlips)) => {
                    return Ok(Outcome::GoalMissed(format!(
                        "friction rig at {theta_deg}°, {t_kn} kN: {e}"
                    )))
                }
                Err(e) => {
                    return Err(anyhow::Error::new(e)
                        .context(format!("friction rig at {theta_deg}°, {t_kn} kN")))
                }
            };
            say!(
                "{theta_deg:>6.0} {t_kn:>6.1} {:>12.6} {:>12.6} {:>12.1} {:>10.4} {:>10.4}",
                s.modelled_ratio,
                s.formula_ratio,
                s.slip_load_n,
                s.mu_interior,
                s.mu_wrap
            );
            slips.push(s);
        }
    }
    write_friction_rig(&e.out, &slips)?;
    say!("The seed back-calculates μ with the interior angle θ; with the wrap angle π−θ the same slips give the μ(π−θ) column.");
    say!("results in {}", e.out.join("friction-rig.csv").display());
    Ok(Outcome::GoalReached)
}

/// The seed's Table 2: midspan node shift with friction, mm (nodes 1–5).
const SEED_TABLE_2_MM: [f64; 5] = [2.0, 2.3, 3.5, 3.6, 3.0];

fn friction_effect_experiment(e: &FrictionEffectExperiment) -> Result<Outcome> {
    let structure = reference_bridge(&BridgeParameters::default())?;
    let settings = FrictionEffectSettings {
        friction: JointFriction::new(FrictionCoefficient::Constant(e.mu), e.convention)?,
        fold_m: e.fold_m,
        deploy_m: e.deploy_m,
        increment_m: e.increment_m,
        force_floor_n: e.force_floor_n,
        relax: RelaxSettings::default(),
    };
    let r = friction_effect(&structure, &settings)?;
    for (name, run) in [
        ("frictionless", &r.frictionless),
        ("with friction", &r.with_friction),
    ] {
        for (what, rep) in [("fold", &run.fold), ("deploy", &run.deploy)] {
            if !rep.status.is_converged() {
                return Ok(Outcome::GoalMissed(format!(
                    "{name} run, {what} command: {}",
                    rep.status.describe()
                )));
            }
        }
    }
    say!(
        "friction effect: every cable paid out {} cm then reeled in {} cm in {} cm increments; μ = {} ({:?} angle) vs μ = 0",
        100.0 * e.fold_m, 100.0 * e.deploy_m, 100.0 * e.increment_m, e.mu, e.convention
    );
    say!("midspan node shift, half A (the seed reports one half):");
    say!(
        "{:>6} {:>10} {:>10} {:>12} {:>12}",
        "node",
        "ΔL mm",
        "% of 30",
        "seed ΔL mm",
        "seed %"
    );
    let half_a: Vec<_> = r.midspan_shift_m.iter().step_by(2).collect();
    for (k, (node, shift)) in half_a.iter().enumerate() {
        let seed = SEED_TABLE_2_MM.get(k).copied().unwrap_or(f64::NAN);
        say!(
            "{:>6} {:>10.2} {:>10.1} {:>12.1} {:>12.1}",
            structure.nodes[*node].id,
            1e3 * shift,
            100.0 * shift / 0.03,
            seed,
            100.0 * seed / 30.0
        );
    }
    say!(
        "relative member-force change (members above {} N without friction):",
        e.force_floor_n
    );
    say!(
        "{:>18} {:>8} {:>10} {:>10}",
        "type",
        "members",
        "mean %",
        "max %"
    );
    for c in &r.force_change {
        say!(
            "{:>18} {:>8} {:>10.2} {:>10.2}",
            c.kind,
            c.counted,
            100.0 * c.mean_relative,
            100.0 * c.max_relative
        );
    }
    say!("seed (Fig. 12): continuous cables change least, discontinuous cables moderately, struts most.");
    write_friction_effect(&e.out, &structure, &r)?;
    let svg = friction_effect_svg(&structure, &r)?;
    write_atomically(&e.out.join("overlay.svg"), svg.as_bytes())?;
    say!("results in {}", e.out.display());
    Ok(Outcome::GoalReached)
}

/// The seed's finding: friction cut the mean difference by 50 % and the
/// standard deviation by 40 %.
const SEED_CUTS_PERCENT: (f64, f64) = (50.0, 40.0);

fn friction_vs_measurement_experiment(e: &FrictionVsMeasurementExperiment) -> Result<Outcome> {
    let structure = reference_bridge(&BridgeParameters::default())?;
    let study = match friction_vs_measurement(
        &structure,
        &FrictionVsMeasurementSettings {
            truth_effects: e.truth.clone(),
            model_mu: e.model_mu,
            actuation_m: e.actuation_m,
            steps: e.steps,
            seed: e.seed,
            increment_m: e.increment_m,
        },
    ) {
        Ok(study) => study,
        Err(err) => return plant_stopped(err, "friction-vs-measurement study".into()),
    };
    say!(
        "friction vs measurement: {} cm deployment in {} steps, truth {:?}, simulation with μ = {}",
        100.0 * e.actuation_m,
        e.steps,
        e.truth
            .enabled()
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>(),
        e.model_mu
    );
    say!(
        "{:<14} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "load cell",
        "meas. avg N",
        "no-fr avg N",
        "fric. avg N",
        "|d| no-fr",
        "|d| fric.",
        "sd no-fr",
        "sd fric."
    );
    for c in &study.cells {
        let (a, b) = (c.no_friction(), c.friction());
        say!(
            "{:<14} {:>12.1} {:>12.1} {:>12.1} {:>12.1} {:>12.1} {:>12.1} {:>12.1}",
            c.sensor,
            CellComparison::average(&c.measured_n),
            CellComparison::average(&c.no_friction_n),
            CellComparison::average(&c.friction_n),
            a.mean_abs_n,
            b.mean_abs_n,
            a.sd_n,
            b.sd_n
        );
    }
    let (without, with) = study.differences();
    let cut = |a: f64, b: f64| 100.0 * (1.0 - b / a);
    say!(
        "mean |difference|: {:.1} N without friction, {:.1} N with: {:.0} % less (seed: {:.0} % less)",
        without.mean_abs_n,
        with.mean_abs_n,
        cut(without.mean_abs_n, with.mean_abs_n),
        SEED_CUTS_PERCENT.0
    );
    say!(
        "SD of difference: {:.1} N without friction, {:.1} N with: {:.0} % less (seed: {:.0} % less)",
        without.sd_n,
        with.sd_n,
        cut(without.sd_n, with.sd_n),
        SEED_CUTS_PERCENT.1
    );
    let svg = average_tension_svg(&study, e.actuation_m)?;
    write_friction_vs_measurement(&e.out, &study)?;
    write_atomically(&e.out.join("average_tension.svg"), svg.as_bytes())?;
    say!("results in {}", e.out.display());
    Ok(Outcome::GoalReached)
}

fn deployment_experiment(e: &DeploymentExperiment) -> Result<Outcome> {
    let policies = e
        .policies
        .iter()
        .map(|p| read_policy(p).map_err(anyhow::Error::from))
        .collect::<Result<Vec<_>>>()?;
    let structure = reference_bridge(&BridgeParameters::default())?;
    let model = ForwardModel::new(
        structure.clone(),
        JointFriction::constant(e.model_mu)?,
        RelaxSettings::default(),
    )?;
    let distribution = ScenarioDistribution::plausible(&e.hidden_effects);
    let problem = DeploymentProblem::default();
    say!(
        "deployment: {} policies × {} scenarios (seed {}), hidden effects {:?}, controller model μ = {}",
        policies.len(),
        e.scenarios,
        e.seed,
        e.hidden_effects.iter().map(|k| k.name()).collect::<Vec<_>>(),
        e.model_mu
    );
    let progress = Progress::new(
        Unit::Deployments,
        (e.scenarios * policies.len()) as u64,
        false,
    );
    let setup = EvaluationSetup {
        bridge: &structure,
        model: &model,
        policies: &policies,
        distribution: &distribution,
        problem: &problem,
        seed: e.seed,
        cycles: 1,
        truth_slip_event_substeps: false,
    };
    let indices: Vec<usize> = (0..e.scenarios).collect();
    let (scenarios, results) = evaluate(&setup, &indices, &|| progress.tick());
    progress.finish();
    let names: Vec<String> = policies.iter().map(|p| p.name.clone()).collect();
    let record = EvaluationRecord::new(
        e.seed,
        e.scenarios,
        Shard::ALL,
        &policies,
        format!("reference, joint friction mu = {}", e.model_mu),
        None,
        1,
        false,
        distribution.clone(),
    )?;
    let runs = EvaluationRuns::new(&distribution, names, &scenarios, results);
    create_folder(&e.out)?;
    let limits = print_and_write(&record, &runs, &e.out)?;
    say!(
        "seed lab practice: predetermined 5 cm commands of every cable, no feedback (the nominal policy); connection judged by eye, success rate not reported"
    );
    say!(
        "results in {} (evaluation.toml, runs.csv, summary.csv, paired.csv, by_fold.csv, evaluation.svg; planning times in timing.csv)",
        e.out.display()
    );
    // The first policy is the one under test; the others are baselines,
    // whose broken limits are results to compare, not a failure.
    Ok(match limits.first().and_then(|l| l.failure()) {
        None => Outcome::GoalReached,
        Some(why) => Outcome::GoalMissed(format!("policy {}: {why}", runs.policy_names[0])),
    })
}
