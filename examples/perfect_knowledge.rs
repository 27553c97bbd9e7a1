//! What perfect knowledge of the bridge would buy the controller: each
//! scenario of a distribution deployed by the default policy planning on
//!
//! - `nominal`: the frictionless reference bridge (the default);
//! - `truth_mu`: the reference bridge with the truth's own joint friction
//!   (its μ and angle convention, exactly);
//! - `truth_structure`: the truth's structure (its stiffness and mass
//!   errors and local faults) and cable seats, without friction;
//! - `truth_model`: both, the truth's forward model (the motor, thermal
//!   and sensor effects stay hidden: they act in the plant);
//! - `truth_seats`: the frictionless reference bridge over the truth's
//!   cable seats (its joint eccentricity, exactly);
//! - `truth_supports`: the frictionless reference bridge on the truth's
//!   flexible supports (its compliance, exactly; a model over flexible
//!   supports appends their nodes to the bridge's, see
//!   `control::check_same_bridge`).
//!
//! Flexible supports stay out of `truth_structure` and `truth_model`, as
//! they were measured before a model could have them.
//!
//! From the repository root:
//! `cargo run --release --example perfect_knowledge -- D.toml SEED N [POLICY [CONTROLLERS]]`
//! (POLICY default `policies/qp.toml`; CONTROLLERS a comma-separated
//! subset of the six, default all) prints one CSV row per scenario: for each controller its status,
//! whether it succeeded (connected, no truth limit broken), truth
//! violations, commands, final true gap (m) and wall time (s; the truth
//! is folded once per scenario, before the controllers' clocks start, and
//! each deploys a copy), then the
//! μ and fold the scenario drew. The truths, sensors and noise are the ones `tdeploy
//! evaluate --distribution D --seed S` draws; only the controller's model
//! changes (issue 22, items 4 and 6: how much an estimate of each part of
//! the model could be worth, measured before building the estimator).

use rayon::prelude::*;
use tensegrity_deploy::control::{deploy_guided, fold_truth, ClosedLoopSetup, Guidance};
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::studies::evaluation::RunResult;

const CONTROLLERS: [&str; 6] = [
    "nominal",
    "truth_mu",
    "truth_structure",
    "truth_model",
    "truth_seats",
    "truth_supports",
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !(3..=5).contains(&args.len()) {
        return Err("usage: DISTRIBUTION.toml SEED SCENARIOS [POLICY.toml [CONTROLLERS]]".into());
    }
    let chosen: Vec<&str> = match args.get(4) {
        Some(list) => list.split(',').collect(),
        None => CONTROLLERS.to_vec(),
    };
    if let Some(unknown) = chosen.iter().find(|c| !CONTROLLERS.contains(c)) {
        return Err(format!("unknown controller {unknown:?}; one of {CONTROLLERS:?}").into());
    }
    let distribution = read_distribution(std::path::Path::new(&args[0]))?;
    let seed: u64 = args[1].parse()?;
    let count: usize = args[2].parse()?;
    let policy = read_policy(std::path::Path::new(
        args.get(3).map_or("policies/qp.toml", String::as_str),
    ))?;
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let nominal = ForwardModel::new(
        bridge.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )?;
    let base = DeploymentProblem::default();
    let header: Vec<String> = chosen
        .iter()
        .flat_map(|c| {
            [
                "status",
                "succeeded",
                "violations",
                "commands",
                "final_true_gap_m",
                "time_s",
            ]
            .map(|f| format!("{c}_{f}"))
        })
        .chain(["drawn_mu".into(), "fold_m".into()])
        .collect();
    println!("scenario,{}", header.join(","));
    let rows: Vec<Result<String, String>> = (0..count)
        .into_par_iter()
        .map(|i| {
            let s = distribution.draw(seed, i);
            let truth = s.truth(&bridge);
            let mut known = truth.clone();
            known.effects.support_flexibility = None;
            let truth_model = known.forward_model().map_err(|e| e.to_string())?;
            let mut structure_only = known;
            structure_only.effects.joint_friction = None;
            let truth_mu = ForwardModel::new(
                bridge.clone(),
                truth.effects.joint_friction(),
                RelaxSettings::default(),
            )
            .map_err(|e| e.to_string())?;
            let truth_structure = structure_only.forward_model().map_err(|e| e.to_string())?;
            let truth_seats = match truth.effects.joint_eccentricity {
                Some(e) => nominal
                    .clone()
                    .with_cable_seats(e.seat_radius_m)
                    .map_err(|e| e.to_string())?,
                None => nominal.clone(),
            };
            let truth_supports = {
                let only = tensegrity_deploy::model::Effects {
                    support_flexibility: truth.effects.support_flexibility,
                    ..Default::default()
                };
                tensegrity_deploy::sim::EffectModel::for_measurement(bridge.clone(), only)
                    .forward_model()
                    .map_err(|e| e.to_string())?
            };
            // Folded once; each controller deploys a copy.
            let folded = s.with_setup(&bridge, &nominal, &base, &policy, fold_truth);
            let mut row = format!("{i}");
            for (k, model) in [
                &nominal,
                &truth_mu,
                &truth_structure,
                &truth_model,
                &truth_seats,
                &truth_supports,
            ]
            .into_iter()
            .enumerate()
            .filter(|(k, _)| chosen.contains(&CONTROLLERS[*k]))
            {
                let started = std::time::Instant::now();
                let r = s.with_setup(&bridge, &nominal, &base, &policy, |setup| {
                    let setup = ClosedLoopSetup { model, ..*setup };
                    let d = folded.as_ref().ok().and_then(|plant| {
                        deploy_guided(
                            &setup,
                            &Guidance::default(),
                            Some(&mut plant.clone()),
                            &mut (),
                        )
                        .ok()
                    });
                    RunResult::of(i, k, d.as_ref(), base.connection_tolerance_m)
                });
                row += &format!(
                    ",{},{},{},{},{},{:.2}",
                    r.status,
                    u8::from(r.succeeded),
                    r.truth_violations,
                    r.commands,
                    r.final_true_gap_m
                        .map_or(String::new(), |g| format!("{g:.4}")),
                    started.elapsed().as_secs_f64()
                );
            }
            let mu = truth.effects.joint_friction.map_or(0.0, |f| f.mu);
            Ok(format!("{row},{mu:.3},{:.3}", s.fold_m))
        })
        .collect();
    for r in rows {
        println!("{}", r?);
    }
    Ok(())
}
