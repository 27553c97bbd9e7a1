//! `tdeploy plan [MODEL] [--policy P] [--problem F] -o DIR [--force]`: an
//! open-loop deployment command sequence planned on a model, from the
//! folded state to the midspan connection. Writes `commands.csv` and
//! `plan.csv` in DIR as one results set (formats in
//! [`tensegrity_deploy::io::plan_files`]; an existing folder needs
//! `--force`, see [`tensegrity_deploy::io::output`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::plan_files::write_plan;
use tensegrity_deploy::model::JointFriction;
use tensegrity_deploy::plan::{folded_start, plan_open_loop};

use super::inputs::{planning_model, policy_or_default, problem_or_default};
use super::words::mm_list;
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
        .arg(super::force_arg())
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
    /// Replace an existing results folder.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(Options {
            model: m.get_one::<PathBuf>("model").cloned(),
            policy: m.get_one::<PathBuf>("policy").cloned(),
            problem: m.get_one::<PathBuf>("problem").cloned(),
            out: value(m, "out")?,
            force: m.get_flag("force"),
        })
    }
}

/// Runs `tdeploy plan`: the goal is a plan that connects the halves.
pub fn run(o: &Options) -> Result<Outcome> {
    let model = planning_model(o.model.as_deref(), JointFriction::constant(DEFAULT_MU)?)?;
    let policy = policy_or_default(o.policy.as_deref())?;
    let problem = problem_or_default(
        o.problem.as_deref(),
        model.structure().continuous_cables.len(),
    )?;
    let folder = ResultsFolder::claim(&o.out, "plan", o.force)?;
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
    let motors = problem.motor_limits(model.structure().continuous_cables.len())?;
    write_plan(
        folder.path(),
        model.structure(),
        motors.start_payout_m,
        &plan,
    )?;
    folder.commit()?;
    let out = &o.out;
    let verdict = plan.verdict(&model, &problem, &start);
    say!("{}", verdict.describe());
    say!(
        "{} commands; final gaps {} mm; commands in {}, per-command table in {}",
        plan.records.len(),
        mm_list(&plan.final_state.midspan_gaps_m(model.structure())),
        out.join("commands.csv").display(),
        out.join("plan.csv").display()
    );
    Ok(if verdict.is_connected() {
        Outcome::GoalReached
    } else {
        Outcome::GoalMissed(format!(
            "the plan does not connect the halves: {}",
            verdict.describe()
        ))
    })
}
