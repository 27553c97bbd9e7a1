//! Which hidden effect makes the controller break a truth limit: each
//! listed scenario of a distribution deployed by the default policy on the
//! frictionless reference bridge (as `tdeploy evaluate --distribution D
//! --seed S` deploys it), then again with one effect (or the local faults)
//! taken out of its truth, one at a time. A limit broken on the full truth
//! and kept without effect E says E (with the others) breaks it.
//!
//! From the repository root:
//! `cargo run --release --example effect_ablation -- D.toml SEED I1,I2,…`
//! prints one CSV row per scenario and truth: the effect taken out
//! (`none` for the full truth), status, violations, commands and the
//! limits broken.

use rayon::prelude::*;
use tensegrity_deploy::control::deploy_closed_loop;
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::{DeploymentProblem, Policy};
use tensegrity_deploy::studies::evaluation::RunResult;

const TAKEN_OUT: [&str; 10] = [
    "none",
    "friction",
    "motor",
    "stiffness",
    "thermal",
    "mass",
    "bias",
    "seats",
    "supports",
    "faults",
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [d, seed, list] = args.as_slice() else {
        return Err("usage: DISTRIBUTION.toml SEED I1,I2,…".into());
    };
    let distribution = read_distribution(std::path::Path::new(d))?;
    let seed: u64 = seed.parse()?;
    let indices: Vec<usize> = list.split(',').map(str::parse).collect::<Result<_, _>>()?;
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let model = ForwardModel::new(
        bridge.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )?;
    let (base, policy) = (DeploymentProblem::default(), Policy::default());
    let jobs: Vec<(usize, &str)> = indices
        .iter()
        .flat_map(|&i| TAKEN_OUT.iter().map(move |&e| (i, e)))
        .collect();
    let rows: Vec<String> = jobs
        .par_iter()
        .map(|&(i, out)| {
            let mut s = distribution.draw(seed, i);
            let e = &mut s.effects;
            match out {
                "friction" => e.joint_friction = None,
                "motor" => e.motor = None,
                "stiffness" => e.stiffness_error = None,
                "thermal" => e.thermal = None,
                "mass" => e.joint_mass_error = None,
                "bias" => e.load_cell_bias = None,
                "seats" => e.joint_eccentricity = None,
                "supports" => e.support_flexibility = None,
                "faults" => s.faults.iter_mut().for_each(|f| f.present = false),
                _ => {}
            }
            let r = s.with_setup(&bridge, &model, &base, &policy, |setup| {
                let d = deploy_closed_loop(setup, &mut ()).ok();
                RunResult::of(i, 0, d.as_ref(), base.connection_tolerance_m)
            });
            format!(
                "{i},{out},{},{},{},\"{}\"",
                r.status,
                r.truth_violations,
                r.commands,
                r.binds.join("; ")
            )
        })
        .collect();
    println!("scenario,taken_out,status,violations,commands,binds");
    for r in rows {
        println!("{r}");
    }
    Ok(())
}
