//! Re-runs scenarios of the deployment experiment one by one and prints
//! what happened at every command: the tool for finding out why a
//! scenario failed.
//!
//! `cargo run --release --example deployment_scenario -- POLICY SEED SCENARIO...`
//! (the experiment's scenarios: the default distribution of `tdeploy
//! evaluate`; the controller plans on the frictionless model).

use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::plan::{deploy_closed_loop, ClosedLoopSetup};
use tensegrity_deploy::sim::standard_sensors;
use tensegrity_deploy::sim::EffectModel;
use tensegrity_deploy::studies::evaluation::ScenarioDistribution;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let policy = read_policy(std::path::Path::new(&args[0]))?;
    let seed: u64 = args[1].parse()?;
    let wanted: Vec<usize> = args[2..]
        .iter()
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let structure = reference_bridge(&BridgeParameters::default())?;
    let model = ForwardModel::new(
        structure.clone(),
        JointFriction::constant(0.0)?,
        RelaxSettings::default(),
    )?;
    let distribution = ScenarioDistribution::default();
    let problem = DeploymentProblem::default();
    let sensors = standard_sensors(&structure);
    for s in wanted.iter().map(|&i| distribution.draw(seed, i)) {
        println!("== scenario {} effects {:?}", s.index, s.effects);
        let truth = EffectModel::for_measurement(structure.clone(), s.effects);
        let setup = ClosedLoopSetup {
            model: &model,
            problem: &problem,
            policy: &policy,
            truth: &truth,
            sensors: &sensors,
            temperature_c: None,
            seed: s.seed,
        };
        match deploy_closed_loop(&setup, &mut ()) {
            Err(e) => println!("error: {e}"),
            Ok(d) => {
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
                        println!("   VIOLATION {v}");
                    }
                }
                println!("status {:?}", d.status);
            }
        }
    }
    Ok(())
}
