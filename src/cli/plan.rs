//! `tdeploy plan [MODEL] [--policy P] [--problem F] -o DIR`: an open-loop
//! deployment command sequence planned on a model, from the folded state
//! to the midspan connection.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::commands::{write_commands, CommandSequence};
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::io::problem_file::read_problem;
use tensegrity_deploy::io::CsvTable;
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings, Structure};
use tensegrity_deploy::plan::{folded_start, plan_open_loop, DeploymentProblem, Plan, Policy};
use tensegrity_deploy::sim::EffectModel;

use super::{value, Outcome};

/// Friction of the built-in default model (the seed's joints are of order
/// 0.1–0.3; 0.2 is the middle).
const DEFAULT_MU: f64 = 0.2;

/// The `plan` subcommand.
pub fn command() -> Command {
    Command::new("plan")
        .about("Plan an open-loop deployment from the folded state to the midspan connection; exit code 1 if it does not connect")
        .arg(Arg::new("model").value_parser(value_parser!(PathBuf)).help("Model file (TOML) planned on; its structure, stiffness and friction are used (motor, thermal and sensor effects are the truth's, not the plan's). Default: the reference bridge with μ = 0.2"))
        .arg(Arg::new("policy").long("policy").value_parser(value_parser!(PathBuf)).help("Policy file (default: policies/qp.toml's settings, built in)"))
        .arg(Arg::new("problem").long("problem").value_parser(value_parser!(PathBuf)).help("Problem file (default: fold 0.40 m, 30 mm connection, documented limits)"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/plan").value_parser(value_parser!(PathBuf)).help("Folder for commands.csv (step 0: the fold from the designed state; steps 1…: the plan) and plan.csv (one row per planned command)"))
}

/// Options of `tdeploy plan`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Model file planned on; `None`: the reference bridge with μ = 0.2.
    pub model: Option<PathBuf>,
    /// Policy file; `None`: the built-in default (`policies/qp.toml`).
    pub policy: Option<PathBuf>,
    /// Problem file; `None`: the documented default problem.
    pub problem: Option<PathBuf>,
    /// Results folder.
    pub out: PathBuf,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(Options {
            model: m.get_one::<PathBuf>("model").cloned(),
            policy: m.get_one::<PathBuf>("policy").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            out: value(m, "out")?,
        })
    }
}

/// The model a controller plans on: a model file's structure with its
/// structural effects and joint friction (motor, thermal and sensor
/// effects belong to a truth, not to a plan), or, without a file, the
/// reference bridge with `default_friction`.
pub(super) fn planning_model(
    path: Option<&Path>,
    default_friction: JointFriction,
) -> Result<ForwardModel> {
    Ok(match path {
        Some(p) => {
            let file = read_model(p)?;
            EffectModel::for_measurement(file.load_structure()?, file.effects)
                .forward_model()
                .with_context(|| format!("{}: applying its effects", p.display()))?
        }
        None => ForwardModel::new(
            reference_bridge(&BridgeParameters::default())?,
            default_friction,
            RelaxSettings::default(),
        )?,
    })
}

/// The policy file's policy, or the built-in default.
pub(super) fn policy_or_default(path: Option<&Path>) -> Result<Policy> {
    Ok(match path {
        Some(p) => read_policy(p)?,
        None => Policy::default(),
    })
}

/// The problem file's problem, or the documented default.
pub(super) fn problem_or_default(path: Option<&Path>) -> Result<DeploymentProblem> {
    Ok(match path {
        Some(p) => read_problem(p)?,
        None => DeploymentProblem::default(),
    })
}

/// Writes `commands` as a command file whose step 0 is the fold from the
/// designed state (where `simulate` starts), so that `tdeploy simulate
/// -c FILE` replays the whole deployment; steps 1… are the commands.
pub(super) fn write_fold_and_commands(
    path: &Path,
    structure: &Structure,
    start_payout_m: Vec<f64>,
    commands: Vec<Vec<f64>>,
) -> Result<()> {
    let mut payout_change_m = vec![start_payout_m];
    payout_change_m.extend(commands);
    let sequence = CommandSequence {
        step_labels: (0..payout_change_m.len() as u64).collect(),
        payout_change_m,
    };
    write_commands(path, &sequence, structure)?;
    Ok(())
}

/// Runs `tdeploy plan`: the goal is a plan that connects the halves.
pub fn run(o: &Options) -> Result<Outcome> {
    let model = planning_model(o.model.as_deref(), JointFriction::constant(DEFAULT_MU)?)?;
    let policy = policy_or_default(o.policy.as_deref())?;
    let problem = problem_or_default(o.problem.as_deref())?;
    let out = &o.out;
    let start = folded_start(&model, &problem, policy.increment_m)?;
    say!(
        "plan: policy {} ({}), start gaps {} mm",
        policy.name,
        policy.planner.as_str(),
        mm_list(&start.midspan_gaps_m(model.structure()))
    );
    let plan = plan_open_loop(&model, &problem, &policy, &start)?;
    for (k, r) in plan.records.iter().enumerate() {
        let largest = r.gaps_m.iter().fold(0.0f64, |x, y| x.max(*y));
        let predicted = r
            .predicted_gaps_m
            .as_ref()
            .map(|p| {
                format!(
                    " (predicted {:.1})",
                    1e3 * p.iter().fold(0.0f64, |x, y| x.max(*y))
                )
            })
            .unwrap_or_default();
        say!(
            "{:>3}: largest gap {:6.1} mm{predicted}, worst utilisation {:.2}, min tension {:.0} N, {}{} active limits",
            k + 1,
            1e3 * largest,
            r.worst_utilisation,
            r.min_tension_n,
            r.qp_status.map(|s| format!("QP {}, ", s.as_str())).unwrap_or_default(),
            r.active_constraints.len()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let motors = problem.motor_limits(model.structure().continuous_cables.len())?;
    write_fold_and_commands(
        &out.join("commands.csv"),
        model.structure(),
        motors.start_payout_m,
        plan.commands(),
    )?;
    plan_table(&plan).write(&out.join("plan.csv"))?;
    say!("{}", plan.status.describe());
    say!(
        "{} commands; final gaps {} mm; commands in {}, per-command table in {}",
        plan.records.len(),
        mm_list(&plan.final_state.midspan_gaps_m(model.structure())),
        out.join("commands.csv").display(),
        out.join("plan.csv").display()
    );
    Ok(if plan.status.is_connected() {
        Outcome::GoalReached
    } else {
        Outcome::GoalMissed(format!(
            "the plan does not connect the halves: {}",
            plan.status.describe()
        ))
    })
}

/// Values in m as a list in mm, one decimal.
pub(super) fn mm_list(v: &[f64]) -> String {
    v.iter()
        .map(|g| format!("{:.1}", 1e3 * g))
        .collect::<Vec<_>>()
        .join(", ")
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
