//! `tdeploy plan [MODEL] [--policy P] [--problem F] -o DIR`: an open-loop
//! deployment command sequence planned on a model, from the folded state
//! to the midspan connection.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::commands::{commands_to_csv, CommandSequence};
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::io::problem_file::read_problem;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::{
    folded_start, plan_open_loop, DeploymentProblem, Plan, PlanStatus, Policy,
};

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

/// Runs `tdeploy plan`; `Ok(true)` when the plan connects the halves.
pub fn run(a: &ArgMatches) -> Result<bool> {
    let model = match a.get_one::<PathBuf>("model") {
        Some(p) => {
            let file = read_model(p)?;
            let structure = file
                .effects
                .apply_to_structure(&file.load_structure()?)
                .with_context(|| format!("{}: applying its effects", p.display()))?;
            ForwardModel::new(
                structure,
                file.effects.joint_friction(),
                RelaxSettings::default(),
            )?
        }
        None => ForwardModel::new(
            reference_bridge(&BridgeParameters::default())?,
            JointFriction::constant(DEFAULT_MU)?,
            RelaxSettings::default(),
        )?,
    };
    let policy = match a.get_one::<PathBuf>("policy") {
        Some(p) => read_policy(p)?,
        None => Policy::default(),
    };
    let problem = match a.get_one::<PathBuf>("problem") {
        Some(p) => read_problem(p)?,
        None => DeploymentProblem::default(),
    };
    let out = a.get_one::<PathBuf>("out").expect("has a default");
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
    // Step 0 is the fold itself (from the designed state, where `simulate`
    // starts), so that `tdeploy simulate -c commands.csv` replays the plan.
    let motors = problem.motor_limits(model.structure().continuous_cables.len())?;
    let mut payout_change_m = vec![motors.start_payout_m];
    payout_change_m.extend(plan.commands());
    let sequence = CommandSequence {
        step_labels: (0..=plan.records.len() as u64).collect(),
        payout_change_m,
    };
    write_atomically(
        &out.join("commands.csv"),
        commands_to_csv(&sequence, model.structure()).as_bytes(),
    )?;
    write_atomically(&out.join("plan.csv"), plan_table(&plan)?.as_bytes())?;
    say!("{}", plan.status.describe());
    say!(
        "{} commands; final gaps {} mm; commands in {}, per-command table in {}",
        plan.records.len(),
        mm_list(&plan.final_state.midspan_gaps_m(model.structure())),
        out.join("commands.csv").display(),
        out.join("plan.csv").display()
    );
    Ok(matches!(plan.status, PlanStatus::Connected))
}

fn mm_list(v: &[f64]) -> String {
    v.iter()
        .map(|g| format!("{:.1}", 1e3 * g))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `plan.csv`: one row per command.
fn plan_table(plan: &Plan) -> Result<String> {
    let pairs = plan.start_gaps_m.len();
    let mut w = csv::Writer::from_writer(Vec::new());
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
    w.write_record(&header)?;
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
        w.write_record(&row)?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}
