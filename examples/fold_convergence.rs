//! How far the truth's folded start depends on its increment: each drawn
//! scenario's truth folded from as built at 5 mm, 1 cm and 2 cm
//! increments, measured against the same fold at 2.5 mm (largest node
//! distance and largest force-row difference), and the time each took.
//! The folded start is where every run of `evaluate` is judged from, so
//! its discretisation error bounds what a run's figures can mean.
//!
//! `cargo run --release --example fold_convergence -- [SEED] [SCENARIOS]
//! [DISTRIBUTION.toml] [--no-seats | --slip-event-substeps]` (default seed
//! 9090, 20 scenarios, `scenarios/wide.toml`); `--no-seats` takes the
//! cable seats out of every truth, `--slip-event-substeps` splits the
//! truths' increments at slip events.
//!
//! Measured (fourteenth session, seed 9090, 20 scenarios): with each
//! increment moving what the seat arcs took in the increment before, the
//! 1 cm fold was up to 2.9 mm and 34 N from the 2.5 mm one (scenario 1,
//! folds 11/19 cm), first order in the increment; without seats at most
//! 61 µm and 0.46 N. With the arcs' change over the increment before as
//! the prediction of the increment's own, at most 0.45 mm and 3.7 N.

use std::time::Instant;

use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::plan::limits::force_rows;
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::sim::Plant;

/// The reference increment and those compared with it, m.
const REFERENCE_M: f64 = 0.0025;
const COMPARED_M: [f64; 3] = [0.005, 0.01, 0.02];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let no_seats = args.iter().any(|a| a == "--no-seats");
    let substeps = args.iter().any(|a| a == "--slip-event-substeps");
    args.retain(|a| !a.starts_with("--"));
    let seed: u64 = args.first().map_or(Ok(9090), |a| a.parse())?;
    let count: usize = args.get(1).map_or(Ok(20), |a| a.parse())?;
    let path = args.get(2).map_or("scenarios/wide.toml", |a| a.as_str());
    let distribution = read_distribution(std::path::Path::new(path))?;
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let base = DeploymentProblem::default();
    let mut seconds = [0.0f64; 1 + COMPARED_M.len()];
    for i in 0..count {
        let scenario = distribution.draw(seed, i);
        let problem = scenario.problem(&base, &bridge);
        let motors = bridge.continuous_cables.len();
        let fold = problem
            .start_payout_m
            .expand(motors)
            .ok_or("the scenario's fold does not fit the bridge's motors")?;
        let mut folded = Vec::new();
        for (k, increment_m) in std::iter::once(REFERENCE_M).chain(COMPARED_M).enumerate() {
            let mut truth = scenario.truth(&bridge);
            truth.increment_m = increment_m;
            if no_seats {
                truth.effects.joint_eccentricity = None;
            }
            truth.settings.slip_event_substeps_enable = substeps;
            let t0 = Instant::now();
            let plant = Plant::new(&truth, Some(&fold), scenario.temperature_c);
            seconds[k] += t0.elapsed().as_secs_f64();
            folded.push(plant.ok().map(|p| {
                let rows = force_rows(p.model(), p.state());
                (p.state().positions_m.clone(), rows)
            }));
        }
        let Some((x0, f0)) = folded[0].clone() else {
            println!("{i}: the {} mm fold failed", REFERENCE_M * 1e3);
            continue;
        };
        let apart: Vec<String> = folded[1..]
            .iter()
            .zip(COMPARED_M)
            .map(|(f, inc)| match f {
                None => format!("{} mm failed", inc * 1e3),
                Some((x, f)) => {
                    let dx = x
                        .iter()
                        .zip(&x0)
                        .map(|(a, b)| (a - b).norm())
                        .fold(0.0, f64::max);
                    let df = f
                        .iter()
                        .zip(&f0)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f64::max);
                    format!("{} mm {:.1} µm {:.2} N", inc * 1e3, dx * 1e6, df)
                }
            })
            .collect();
        println!(
            "{i}: fold {:.3}/{:.3} m; {}",
            fold[0],
            fold[motors - 1],
            apart.join(" | ")
        );
    }
    println!(
        "time: {}",
        std::iter::once(REFERENCE_M)
            .chain(COMPARED_M)
            .zip(seconds)
            .map(|(inc, s)| format!("{} mm {s:.2} s", inc * 1e3))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
