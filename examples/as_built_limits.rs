//! Which drawn truths of a scenario distribution break a limit in their
//! own as-built state (zero payout, at the scenario's temperature, before
//! any fold: the state the halves are built to meet at), and which local
//! fault each carries: the truths no deployment can end near its design
//! within every limit. `tdeploy evaluate` names the same limits in
//! `runs.csv`'s `binds` for the runs that broke limits (`truth as built:
//! …`); this lists every scenario, whatever its run did.
//!
//! From the repository root:
//! `cargo run --release --example as_built_limits -- scenarios/wide.toml SEED COUNT`
//! prints one line per scenario: its index, how many limits its as-built
//! state breaks, their names, and its local faults; then the count.

use tensegrity_deploy::control::as_built_breaches;
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::sim::Plant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [distribution, seed, count] = args.as_slice() else {
        return Err("usage: DISTRIBUTION.toml SEED COUNT".into());
    };
    let distribution = read_distribution(std::path::Path::new(distribution))?;
    let (seed, count): (u64, usize) = (seed.parse()?, count.parse()?);
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let problem = DeploymentProblem::default();
    let mut out_of_limits = 0;
    for index in 0..count {
        let scenario = distribution.draw(seed, index);
        let truth = scenario.truth(&bridge);
        match Plant::new(&truth, None, scenario.temperature_c) {
            Ok(built) => {
                let broken = as_built_breaches(&built, &problem);
                out_of_limits += usize::from(!broken.is_empty());
                let names: Vec<String> = broken.iter().map(|b| b.describe()).collect();
                println!(
                    "{index}\t{}\t{}\t{:?}",
                    broken.len(),
                    names.join("; "),
                    truth.effects.faults
                );
            }
            Err(e) => println!("{index}\tdoes not stand as built: {e}"),
        }
    }
    println!("{out_of_limits} of {count} truths break a limit as built");
    Ok(())
}
