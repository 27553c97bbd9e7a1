//! One drawn scenario of a distribution deployed by the default policy on
//! the frictionless reference bridge, exactly as `tdeploy evaluate
//! --distribution D --seed S` deploys scenario I, with every command, the
//! truth's violations (command, increment, member) and the start-broken
//! limits printed: where `evaluate`'s `runs.csv` counts a run's
//! violations, this shows them.
//!
//! From the repository root:
//! `cargo run --release --example one_scenario -- scenarios/wide.toml SEED INDEX [SEAT_RADIUS_M] [--truth-model]`
//! (with `SEAT_RADIUS_M`, the controller's model runs over cable seats of
//! that radius, [`ForwardModel::with_cable_seats`]; with `--truth-model`
//! the controller plans on the truth's own forward model instead, its
//! friction, structure, faults and seats, without its flexible supports:
//! `perfect_knowledge`'s `truth_model` controller, run by run).
//!
//! Each command line gives the truth's checked and total increments (with
//! cable seats, the settled state is the last), the command per motor in
//! mm, the largest true gap, the truth's smallest tension and the QP's
//! active constraints.

use tensegrity_deploy::control::deploy_closed_loop;
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::{DeploymentProblem, Policy};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let truth_model = args.iter().any(|a| a == "--truth-model");
    args.retain(|a| a != "--truth-model");
    let (distribution, seed, index, seat_radius_m) = match args.as_slice() {
        [d, s, i] => (d, s, i, None),
        [d, s, i, r] => (d, s, i, Some(r.parse::<f64>()?)),
        _ => {
            return Err(
                "usage: DISTRIBUTION.toml SEED INDEX [SEAT_RADIUS_M] [--truth-model]".into(),
            )
        }
    };
    let scenario =
        read_distribution(std::path::Path::new(distribution))?.draw(seed.parse()?, index.parse()?);
    println!("{scenario:?}");
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let nominal = ForwardModel::new(
        bridge.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )?;
    let nominal = match seat_radius_m {
        Some(r) => nominal.with_cable_seats(r)?,
        None => nominal,
    };
    let problem = DeploymentProblem::default();
    let policy = Policy::default();
    let nominal = if truth_model {
        let mut known = scenario.truth(&bridge);
        known.effects.support_flexibility = None;
        known.forward_model()?
    } else {
        nominal
    };
    let deployment = scenario.with_setup(&bridge, &nominal, &problem, &policy, |setup| {
        deploy_closed_loop(setup, &mut ())
    })?;
    for r in &deployment.records {
        let command: Vec<String> = r
            .command_m
            .iter()
            .map(|u| format!("{:.1}", u * 1e3))
            .collect();
        let gap = r.true_gaps_m.iter().fold(0.0f64, |a, b| a.max(*b));
        println!(
            "{}: increments {}/{} [{}] mm; largest true gap {:.1} mm; least tension {:.2} N; {:?}",
            r.index,
            r.truth_increments_checked,
            r.truth_increments,
            command.join(" "),
            1e3 * gap,
            r.truth_min_tension_n,
            r.active_constraints
        );
        for (v, increment) in r.truth_violations.iter().zip(&r.truth_violation_increments) {
            println!("   increment {increment}: {}", v.describe());
        }
    }
    // The status in full: a stop names the trial refused last.
    println!("status: {:?}", deployment.status);
    for l in &deployment.truth_start_broken {
        println!(
            "start-broken {}: {:.2} N at the start, {:.2} N at the end, restored {}",
            l.member, l.start_n, l.end_n, l.restored
        );
    }
    Ok(())
}
