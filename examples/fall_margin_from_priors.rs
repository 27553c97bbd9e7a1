//! How much more an unmeasured tension falls in the bridge than the
//! frictionless model predicts, over the prior of a scenario distribution:
//! the data behind `[margins] unmeasured_force_fall` (β), which was fitted
//! on two scenarios (issue 22, item 5).
//!
//! For each drawn scenario, the truth and the controller's frictionless
//! model are folded alike and reeled in by the same uniform 5 cm commands
//! to the design. For every tension-only force row no load cell reads
//! (cables, springs, continuous-cable segments) and every command in which
//! the model predicts a fall of more than `MIN_FALL_N`, the ratio of the
//! truth's fall to the model's is recorded; the quantiles of `ratio − 1`
//! are what a margin `β` must cover (the rule keeps `β ×` the predicted
//! fall above the limit, so the truth's extra fall `(ratio − 1) × fall`
//! must not exceed it).
//!
//! Open loop, so the truth's drum slip and backlash are in the ratio,
//! which the closed loop's payout-scale estimate partly removes: the
//! quantiles are an upper estimate of what the closed loop needs. With
//! `--no-motor` the truths keep every drawn effect but the motor's (slip
//! and backlash), the part the closed loop compensates.
//!
//! `cargo run --release --example fall_margin_from_priors -- [--no-motor] [SEED] [SCENARIOS] [DISTRIBUTION.toml]`
//! (default seed 7, 40 scenarios, `scenarios/default.toml`'s distribution).

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::model::{ForwardModel, JointFriction, MemberKind, RelaxSettings, Workspace};
use tensegrity_deploy::plan::limits::force_rows;
use tensegrity_deploy::sim::{standard_sensors, Plant, SensorTarget};
use tensegrity_deploy::studies::evaluation::ScenarioDistribution;

/// Smallest predicted fall that counts, N: below it the ratio is noise.
const MIN_FALL_N: f64 = 20.0;
/// The command, m per motor (a reel-in of 5 cm, the step limit).
const STEP_M: f64 = -0.05;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let no_motor = args.iter().any(|a| a == "--no-motor");
    args.retain(|a| a != "--no-motor");
    let seed: u64 = args.first().map_or(Ok(7), |a| a.parse())?;
    let count: usize = args.get(1).map_or(Ok(40), |a| a.parse())?;
    let distribution = match args.get(2) {
        Some(p) => read_distribution(std::path::Path::new(p))?,
        None => ScenarioDistribution::default(),
    };
    let structure = reference_bridge(&BridgeParameters::default())?;
    let model = ForwardModel::new(
        structure.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )?;
    let n = structure.continuous_cables.len();
    let members = structure.members.len();
    // Rows a load cell reads, and the tension-only rows.
    let read: Vec<usize> = standard_sensors(&structure)
        .iter()
        .filter_map(|s| match s.target {
            SensorTarget::SegmentTension { cable, segment } => {
                Some(members + model.reference_state().segment_offsets[cable] + segment)
            }
            _ => None,
        })
        .collect();
    let tension_only =
        |r: usize| r >= members || !matches!(structure.members[r].kind, MemberKind::Strut { .. });
    let mut ratios = Vec::new();
    let mut skipped = 0;
    for i in 0..count {
        let mut scenario = distribution.draw(seed, i);
        if no_motor {
            scenario.effects.motor = None;
        }
        let truth = scenario.truth(&structure);
        let fold = vec![scenario.fold_m; n];
        let Ok(mut plant) = Plant::new(&truth, Some(&fold), None) else {
            skipped += 1;
            continue;
        };
        let mut state = model.reference_state();
        let mut ws = Workspace::default();
        model.apply_payout(&mut state, &mut ws, &fold, 0.01, &mut ())?;
        let truth_members = plant.model().structure().members.len();
        // The truth's row of model row `r` (appended foundation bars shift
        // its segment rows).
        let truth_row = |r: usize| {
            if r < members {
                r
            } else {
                r - members + truth_members
            }
        };
        let steps = (scenario.fold_m / -STEP_M).round() as usize;
        for _ in 0..steps {
            let (m0, t0) = (
                force_rows(&model, &state),
                force_rows(plant.model(), plant.state()),
            );
            model.apply_payout(&mut state, &mut ws, &vec![STEP_M; n], 0.01, &mut ())?;
            if plant.apply(&vec![STEP_M; n], None, &mut ()).is_err() {
                skipped += 1;
                break;
            }
            let (m1, t1) = (
                force_rows(&model, &state),
                force_rows(plant.model(), plant.state()),
            );
            for r in (0..m0.len()).filter(|&r| tension_only(r) && !read.contains(&r)) {
                let model_fall = m0[r] - m1[r];
                if model_fall > MIN_FALL_N {
                    let tr = truth_row(r);
                    ratios.push((t0[tr] - t1[tr]) / model_fall);
                }
            }
        }
    }
    ratios.sort_by(f64::total_cmp);
    let q = |p: f64| ratios[((ratios.len() - 1) as f64 * p).round() as usize] - 1.0;
    println!(
        "{} falls over {count} scenarios (seed {seed}; {skipped} skipped): ratio − 1 at 50 % {:.2}, 90 % {:.2}, 95 % {:.2}, 99 % {:.2}, max {:.2}",
        ratios.len(),
        q(0.5),
        q(0.9),
        q(0.95),
        q(0.99),
        q(1.0)
    );
    Ok(())
}
