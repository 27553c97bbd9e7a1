//! What the truth's fold costs: each drawn truth of a scenario
//! distribution folded from its as-built state to its start, as `tdeploy
//! evaluate` folds it before the controller's first command (about 40 %
//! of a run on `scenarios/wide.toml`: 4.0 of 10.4 s over 40 scenarios of
//! seed 9393 on one thread).
//!
//! From the repository root:
//! `cargo run --release --example fold_cost -- scenarios/wide.toml SEED COUNT [WITHOUT]`
//! prints one line per scenario (its fold, the fold's wall time, its
//! increments, Newton and DR iterations), then its Newton counters (how
//! many continuation steps failed and why Newton gave up), and the
//! totals; `WITHOUT` drops
//! one effect from every truth first (`seats`: joint eccentricity;
//! `supports`: support flexibility), to see what it adds. The as-built
//! relaxation is not timed.

use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::model::Workspace;
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::sim::Plant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (distribution, seed, count, without) = match args.as_slice() {
        [d, s, c] => (d, s, c, None),
        [d, s, c, w] if w == "seats" || w == "supports" => (d, s, c, Some(w.as_str())),
        _ => return Err("usage: DISTRIBUTION.toml SEED COUNT [seats|supports]".into()),
    };
    let distribution = read_distribution(std::path::Path::new(distribution))?;
    let (seed, count): (u64, usize) = (seed.parse()?, count.parse()?);
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let base = DeploymentProblem::default();
    let (mut time_s, mut increments, mut newton, mut dr) = (0.0, 0, 0, 0);
    for index in 0..count {
        let scenario = distribution.draw(seed, index);
        let mut truth = scenario.truth(&bridge);
        match without {
            Some("seats") => truth.effects.joint_eccentricity = None,
            Some("supports") => truth.effects.support_flexibility = None,
            _ => {}
        }
        let motors = scenario
            .problem(&base, &bridge)
            .motor_limits(bridge.continuous_cables.len())?;
        let built = match Plant::new(&truth, None, scenario.temperature_c) {
            Ok(built) => built,
            Err(e) => {
                println!("{index}\tdoes not stand as built: {e}");
                continue;
            }
        };
        let mut state = built.state().clone();
        let clock = std::time::Instant::now();
        let mut ws = Workspace::default();
        let report = built.model().apply_payout(
            &mut state,
            &mut ws,
            &motors.start_payout_m,
            truth.increment_m,
            &mut (),
        );
        let t = clock.elapsed().as_secs_f64();
        match report {
            Ok(r) if !r.status.is_converged() => {
                println!(
                    "{index}\tthe fold did not converge: {}",
                    r.status.describe()
                )
            }
            Ok(r) => {
                time_s += t;
                increments += r.increments;
                newton += r.newton_iterations;
                dr += r.iterations;
                println!(
                    "{index}\tfold {:.2} m\t{:.1} ms\t{} increments\t{} Newton\t{} DR",
                    scenario.fold_m,
                    1e3 * t,
                    r.increments,
                    r.newton_iterations,
                    r.iterations
                );
                println!("\t{:?}", ws.newton_counters());
            }
            Err(e) => println!("{index}\tthe fold failed: {e}"),
        }
    }
    println!(
        "folds {time_s:.2} s, {increments} increments, {newton} Newton and {dr} DR iterations ({:.0} and {:.0} per increment)",
        newton as f64 / increments.max(1) as f64,
        dr as f64 / increments.max(1) as f64
    );
    Ok(())
}
