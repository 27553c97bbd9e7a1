//! Re-runs scenarios of the deployment experiment one by one and prints
//! what happened at every command: the tool for finding out why a
//! scenario failed.
//!
//! `cargo run --release --example deployment_scenario -- POLICY SEED [--cycles N] [--distribution D.toml] [--model M.toml] SCENARIO...`
//! (the scenarios of `tdeploy evaluate`: the default distribution or D, each
//! scenario's fold, sensors and temperature; the controller plans on the
//! frictionless model, or on M). With `--cycles N` every scenario runs N
//! deployment-fold cycles as `tdeploy evaluate --cycles N` does, and each
//! cycle's commands are printed.

use tensegrity_deploy::control::{check_same_bridge, deploy_closed_loop, Deployment};
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::learn::{Case, CaseMemory};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::studies::cycles::{run_cycles, CycleObserver, CycleResult};
use tensegrity_deploy::studies::evaluation::ScenarioDistribution;

/// Prints each cycle's deployment as it ends.
struct PrintCycles;

impl CycleObserver for PrintCycles {
    fn on_cycle(&mut self, result: &CycleResult, deployment: &Deployment, _: &Case) {
        println!("-- cycle {}", result.cycle);
        print_deployment(deployment);
        let mm = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{:.1}", x * 1e3));
        println!(
            "learnt from case {:?}: {} learnt commands, ILC predicted {} mm, approach reached {} mm (error {} mm)",
            result.learnt_from_case,
            result.learnt_commands.map_or("no".to_string(), |n| n.to_string()),
            mm(result.ilc_predicted_gap_m),
            mm(result.approach_gap_m),
            mm(result.ilc_error_m),
        );
        if let Some(why) = &result.memory_declined {
            println!("memory declined: {why}");
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut cycles = 1;
    if let Some(k) = args.iter().position(|a| a == "--cycles") {
        cycles = args.get(k + 1).ok_or("--cycles needs a number")?.parse()?;
        args.drain(k..k + 2);
    }
    let mut distribution = ScenarioDistribution::default();
    if let Some(k) = args.iter().position(|a| a == "--distribution") {
        let path = args.get(k + 1).ok_or("--distribution needs a file")?;
        distribution = read_distribution(std::path::Path::new(path))?;
        args.drain(k..k + 2);
    }
    // The truths are drawn on the bridge the model file names, before its
    // effects (those are the controller's belief), as `tdeploy evaluate`
    // draws them.
    let mut bridge = reference_bridge(&BridgeParameters::default())?;
    let mut model = ForwardModel::new(
        bridge.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )?;
    if let Some(k) = args.iter().position(|a| a == "--model") {
        let path = args.get(k + 1).ok_or("--model needs a file")?;
        let file = read_model(std::path::Path::new(path))?;
        bridge = file.load_structure()?;
        model = file.measurement_model()?.forward_model()?;
        check_same_bridge(model.structure(), &bridge)?;
        args.drain(k..k + 2);
    }
    if args.len() < 3 {
        return Err(
            "usage: POLICY SEED [--cycles N] [--distribution D.toml] [--model M.toml] SCENARIO..."
                .into(),
        );
    }
    let policy = read_policy(std::path::Path::new(&args[0]))?;
    let seed: u64 = args[1].parse()?;
    let wanted: Vec<usize> = args[2..]
        .iter()
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let base_problem = DeploymentProblem::default();
    for s in wanted.iter().map(|&i| distribution.draw(seed, i)) {
        println!("== scenario {} effects {:?}", s.index, s.effects);
        // As `tdeploy evaluate` sets a scenario up.
        s.with_setup(&bridge, &model, &base_problem, &policy, |setup| {
            if cycles > 1 {
                match run_cycles(
                    setup,
                    cycles,
                    &mut CaseMemory::default(),
                    None,
                    &mut PrintCycles,
                ) {
                    Err(e) => println!("error: {e}"),
                    Ok(end) => {
                        if let Some(why) = end.stopped {
                            println!("stopped: {}", why.describe());
                        }
                    }
                }
                return;
            }
            match deploy_closed_loop(setup, &mut ()) {
                Err(e) => println!("error: {e}"),
                Ok(d) => print_deployment(&d),
            }
        });
    }
    Ok(())
}

/// Prints a deployment command by command.
fn print_deployment(d: &Deployment) {
    println!(
        "start measured {:?} true {:?}",
        d.start
            .measured_gaps_m
            .iter()
            .map(|g| g.map(|g| (g * 1e3).round()))
            .collect::<Vec<_>>(),
        d.start
            .true_gaps_m
            .iter()
            .map(|g| (g * 1e3).round())
            .collect::<Vec<_>>()
    );
    for r in &d.records {
        println!(
                        "cmd {:2} u[mm] {:?}\n   pred {:?} meas {:?} true {:?} util {:.2} minT {:.1} N qp {:?} tr {:?} rej {} active {:?}",
                        r.index,
                        r.command_m.iter().map(|u| (u * 1e3).round()).collect::<Vec<_>>(),
                        r.predicted_gaps_m.iter().map(|g| (g * 1e3).round()).collect::<Vec<_>>(),
                        r.measured_gaps_m.iter().map(|g| g.map(|g| (g * 1e3).round())).collect::<Vec<_>>(),
                        r.true_gaps_m.iter().map(|g| (g * 1e3).round()).collect::<Vec<_>>(),
                        r.truth_worst_utilisation, r.truth_min_tension_n, r.qp_status, r.trust_region_m, r.rejected_trials, r.active_constraints
                    );
        for v in &r.truth_violations {
            println!("   VIOLATION {}", v.describe());
        }
    }
    println!("status {:?}", d.status);
}
