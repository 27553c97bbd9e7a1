//! `tdeploy experiment FILE`: the experiments in `experiments/`, each a TOML
//! file ([`tensegrity_deploy::io::experiment_file`]) whose `kind` picks the
//! study; results as CSV and SVG, and a table beside the seed's values.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::design::friction_rig::{modelled_slip_ratio, RigError};
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::{
    EvaluationRecord, EvaluationRuns, EVALUATION_FORMAT,
};
use tensegrity_deploy::io::experiment_file::{
    read_experiment, DeploymentExperiment, Experiment, FrictionEffectExperiment,
    FrictionRigExperiment, FrictionVsMeasurementExperiment,
};
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::io::{write_atomically, CsvTable};
use tensegrity_deploy::model::ForwardModel;
use tensegrity_deploy::model::{FrictionCoefficient, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::report::drawing::{state_views_svg, DrawnState};
use tensegrity_deploy::report::figures::grouped_bars_svg;
use tensegrity_deploy::studies::evaluation::{evaluate, EvaluationSetup, ScenarioDistribution};
use tensegrity_deploy::studies::friction_study::{
    friction_study, CellComparison, FrictionStudySettings,
};
use tensegrity_deploy::studies::{friction_effect, FrictionEffectSettings};

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};

use super::evaluation_report::report;
use super::{replay_stopped, value, Outcome};

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
        Experiment::FrictionVsMeasurement(e) => friction_vs_measurement(&e),
        Experiment::Deployment(e) => deployment_experiment(&e),
    }
}

/// Creates the results folder `dir`.
fn results_folder(dir: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))
}

fn friction_rig(e: &FrictionRigExperiment) -> Result<Outcome> {
    let friction = JointFriction::new(FrictionCoefficient::Constant(e.mu), e.convention)?;
    let mut csv = CsvTable::new(&[
        "interior_angle_deg",
        "tension_kn",
        "slip_ratio_model",
        "slip_ratio_formula",
        "slip_load_n",
        "mu_backcalc_interior",
        "mu_backcalc_wrap",
    ]);
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
    for (theta_deg, tensions) in e.interior_angles_deg.iter().zip(&e.tensions_kn) {
        let theta = theta_deg.to_radians();
        for t_kn in tensions {
            let t = 1e3 * t_kn;
            let ratio = match modelled_slip_ratio(&friction, theta, t) {
                Ok(ratio) => ratio,
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
            let formula = friction.ratio_bound(theta, false);
            let mu_interior = ratio.ln() / theta;
            let mu_wrap = ratio.ln() / (std::f64::consts::PI - theta);
            let load = t * (ratio - 1.0);
            say!("{theta_deg:>6.0} {t_kn:>6.1} {ratio:>12.6} {formula:>12.6} {load:>12.1} {mu_interior:>10.4} {mu_wrap:>10.4}");
            csv.row(
                [
                    theta_deg,
                    t_kn,
                    &ratio,
                    &formula,
                    &load,
                    &mu_interior,
                    &mu_wrap,
                ]
                .map(f64::to_string),
            );
        }
    }
    results_folder(&e.out)?;
    let file = e.out.join("friction-rig.csv");
    csv.write(&file)?;
    say!("The seed back-calculates μ with the interior angle θ; with the wrap angle π−θ the same slips give the μ(π−θ) column.");
    say!("results in {}", file.display());
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
    let mut shifts = CsvTable::new(&["node", "shift_m", "percent_of_30mm"]);
    for (node, shift) in &r.midspan_shift_m {
        shifts.row([
            structure.nodes[*node].id.clone(),
            shift.to_string(),
            (100.0 * shift / 0.03).to_string(),
        ]);
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
    let mut kinds = CsvTable::new(&[
        "kind",
        "members",
        "mean_relative_change",
        "max_relative_change",
    ]);
    for c in &r.force_change {
        say!(
            "{:>18} {:>8} {:>10.2} {:>10.2}",
            c.kind,
            c.counted,
            100.0 * c.mean_relative,
            100.0 * c.max_relative
        );
        kinds.row([
            c.kind.to_string(),
            c.counted.to_string(),
            c.mean_relative.to_string(),
            c.max_relative.to_string(),
        ]);
    }
    say!("seed (Fig. 12): continuous cables change least, discontinuous cables moderately, struts most.");
    let mut members = CsvTable::new(&["member", "relative_change"]);
    let n_members = structure.members.len();
    for (i, rel) in &r.member_change {
        let name = match structure.members.get(*i) {
            Some(m) => m.id.clone(),
            None => format!("segment_{}", i - n_members),
        };
        members.row([name, rel.to_string()]);
    }
    results_folder(&e.out)?;
    shifts.write(&e.out.join("midspan_shift.csv"))?;
    kinds.write(&e.out.join("force_change_by_type.csv"))?;
    members.write(&e.out.join("force_change_by_member.csv"))?;
    let svg = state_views_svg(
        &structure,
        DrawnState {
            state: &r.with_friction.state,
            forces: &r.with_friction.forces,
            label: "with friction",
        },
        Some(DrawnState {
            state: &r.frictionless.state,
            forces: &r.frictionless.forces,
            label: "without friction",
        }),
        "Friction effect after a fold-deploy cycle",
    )?;
    write_atomically(&e.out.join("overlay.svg"), svg.as_bytes())?;
    say!("results in {}", e.out.display());
    Ok(Outcome::GoalReached)
}

/// The seed's finding: friction cut the mean difference by 50 % and the
/// standard deviation by 40 %.
const SEED_CUTS_PERCENT: (f64, f64) = (50.0, 40.0);

fn friction_vs_measurement(e: &FrictionVsMeasurementExperiment) -> Result<Outcome> {
    let structure = reference_bridge(&BridgeParameters::default())?;
    let study = match friction_study(
        &structure,
        &FrictionStudySettings {
            truth_effects: e.truth,
            model_mu: e.model_mu,
            actuation_m: e.actuation_m,
            steps: e.steps,
            seed: e.seed,
            increment_m: e.increment_m,
        },
    ) {
        Ok(study) => study,
        Err(err) => return replay_stopped(err, "friction-vs-measurement study".into()),
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
    let mut csv = CsvTable::new(&[
        "sensor",
        "step",
        "measured_n",
        "no_friction_n",
        "friction_n",
    ]);
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
        for k in 0..c.measured_n.len() {
            csv.row([
                c.sensor.clone(),
                (k + 1).to_string(),
                c.measured_n[k].to_string(),
                c.no_friction_n[k].to_string(),
                c.friction_n[k].to_string(),
            ]);
        }
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
    let labels: Vec<String> = study.cells.iter().map(|c| c.sensor.clone()).collect();
    let averages = |f: fn(&CellComparison) -> &Vec<f64>| -> Vec<f64> {
        study
            .cells
            .iter()
            .map(|c| CellComparison::average(f(c)) / 1000.0)
            .collect()
    };
    let svg = grouped_bars_svg(
        &format!(
            "Average tension over a {} cm deployment (seed Fig. 16)",
            100.0 * e.actuation_m
        ),
        "tension, kN",
        &labels,
        &[
            (
                "simulation without friction",
                averages(|c| &c.no_friction_n),
            ),
            ("simulation with friction", averages(|c| &c.friction_n)),
            ("measurement", averages(|c| &c.measured_n)),
        ],
    )?;
    results_folder(&e.out)?;
    csv.write(&e.out.join("tensions.csv"))?;
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
        structure,
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
    let bar = if std::io::stderr().is_terminal() {
        ProgressBar::new((e.scenarios * policies.len()) as u64)
    } else {
        ProgressBar::hidden()
    };
    if let Ok(style) = ProgressStyle::with_template("{bar:30} {pos}/{len} deployments {eta}") {
        bar.set_style(style);
    }
    let setup = EvaluationSetup {
        model: &model,
        policies: &policies,
        distribution: &distribution,
        problem: &problem,
        seed: e.seed,
        cycles: 1,
    };
    let indices: Vec<usize> = (0..e.scenarios).collect();
    let (scenarios, results) = evaluate(&setup, &indices, &|| bar.inc(1));
    bar.finish_and_clear();
    let names: Vec<String> = policies.iter().map(|p| p.name.clone()).collect();
    let record = EvaluationRecord {
        format: EVALUATION_FORMAT.into(),
        seed: e.seed,
        scenarios: e.scenarios,
        shard: "1/1".into(),
        policies: names.clone(),
        policy_fingerprints: policies
            .iter()
            .map(super::evaluate::policy_fingerprint)
            .collect::<Result<_>>()?,
        model: format!("reference, joint friction mu = {}", e.model_mu),
        cycles: 1,
        distribution: distribution.clone(),
    };
    let runs = EvaluationRuns::new(&distribution, names, &scenarios, results);
    results_folder(&e.out)?;
    report(&record, &runs, &e.out)?;
    say!(
        "seed lab practice: predetermined 5 cm commands of every cable, no feedback (the nominal policy); connection judged by eye, success rate not reported"
    );
    say!(
        "results in {} (evaluation.toml, runs.csv, summary.csv, paired.csv, evaluation.svg; planning times in timing.csv)",
        e.out.display()
    );
    Ok(Outcome::GoalReached)
}
