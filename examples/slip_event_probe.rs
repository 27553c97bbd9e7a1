//! Slip-event sub-steps (`RelaxSettings::slip_event_substeps_enable`,
//! issue 25): the cost on the 40 cm deployment at μ = 0.2 in 1 cm
//! increments (time, Newton and DR work, splits) and the accuracy on a
//! 5 cm reel-in and pay-out (largest node distance between 1 cm and 1 mm
//! increments), with the setting off and on.
//!
//! `cargo run --release --example slip_event_probe [-- MIN_SUBSTEP_M]`
//! (default the setting's default, 0.001).
use std::time::Instant;
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings, Workspace};

fn main() {
    let min: f64 = std::env::args()
        .nth(1)
        .map_or(RelaxSettings::default().slip_event_min_substep_m, |a| {
            a.parse().unwrap()
        });
    for enable in [false, true] {
        let settings = RelaxSettings {
            slip_event_substeps_enable: enable,
            slip_event_min_substep_m: min,
            ..RelaxSettings::default()
        };
        let model = ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::constant(0.2).unwrap(),
            settings,
        )
        .unwrap();
        let n = model.structure().continuous_cables.len();
        let mut ws = Workspace::default();
        let mut folded = model.reference_state();
        model
            .apply_payout(&mut folded, &mut ws, &vec![0.4; n], 0.01, &mut ())
            .unwrap();
        ws.reset_newton_counters();
        let mut s = folded.clone();
        let t = Instant::now();
        let r = model
            .apply_payout(&mut s, &mut ws, &vec![-0.4; n], 0.01, &mut ())
            .unwrap();
        println!(
            "enable {enable}: {:?} {:.1} ms, {} Newton + {} DR",
            r.status,
            t.elapsed().as_secs_f64() * 1e3,
            r.newton_iterations,
            r.iterations
        );
        println!("  {:?}", ws.newton_counters());
        println!(
            "  cycle 1 cm vs 1 mm: {:.1} um",
            1e6 * cycle_difference(enable, min)
        );
    }
}

/// Largest node distance, m, between the cycle (every cable reeled in
/// 5 cm, then paid out 5 cm) at 1 cm and at 1 mm increments.
fn cycle_difference(enable: bool, min: f64) -> f64 {
    let settings = RelaxSettings {
        slip_event_substeps_enable: enable,
        slip_event_min_substep_m: min,
        ..RelaxSettings::default()
    };
    let model = ForwardModel::new(
        reference_bridge(&BridgeParameters::default()).unwrap(),
        JointFriction::constant(0.2).unwrap(),
        settings,
    )
    .unwrap();
    let n = model.structure().continuous_cables.len();
    let run = |inc: f64| {
        let mut ws = Workspace::default();
        let mut s = model.reference_state();
        let mut out = Vec::new();
        for d in [-0.05, 0.05] {
            model
                .apply_payout(&mut s, &mut ws, &vec![d; n], inc, &mut ())
                .unwrap();
            out.push(s.positions_m.clone());
        }
        out
    };
    let (a, b) = (run(0.01), run(0.001));
    a.iter()
        .zip(&b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).norm()))
        .fold(0.0, f64::max)
}
