//! The reversal dip of known limitations, item 15: the tensions of
//! `A_cc1`'s four segments through the first command after a fold, on the
//! default truth (μ = 0.2) with slip-event sub-steps, for several first
//! commands. The fold paid every cable out, so each joint's tension ratio
//! sits at its pay-out bound (the segment farthest from the motor the most
//! taut); a reel-in has to turn that gradient round before material
//! reaches the far segments, and meanwhile the retracting geometry
//! shortens their spans. Reeling every motor in alike lowers the far
//! segments first (after the uneven 45/33 cm fold `A_cc1[3]` 5.77 →
//! 4.35 N, below its 5 N minimum); reeling `cc1` in faster than the
//! others raises them from the first increment.
//!
//! `cargo run --release --example reversal_dip_probe -- [FOLD_A_M FOLD_B_M]`
//! (default the uneven fold 0.45 0.33). Prints each segment's smallest
//! tension over the command's increments and its tension at the end, N.

use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::IncrementObserver;
use tensegrity_deploy::model::{DeploymentState, RelaxReport};
use tensegrity_deploy::plan::limits::{force_row_name, force_rows};
use tensegrity_deploy::sim::{default_truth, Plant};

/// The watched force rows' values after each increment.
struct Watch<'a> {
    model: &'a tensegrity_deploy::model::ForwardModel,
    rows: Vec<usize>,
    out: Vec<Vec<f64>>,
}
impl IncrementObserver for Watch<'_> {
    fn on_increment(&mut self, _: usize, _: usize, _: &RelaxReport, s: &DeploymentState) {
        let f = force_rows(self.model, s);
        self.out.push(self.rows.iter().map(|&r| f[r]).collect());
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fold_a: f64 = args.first().map_or(Ok(0.45), |a| a.parse())?;
    let fold_b: f64 = args.get(1).map_or(Ok(0.33), |a| a.parse())?;
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let mut truth = default_truth(bridge);
    truth.settings.slip_event_substeps_enable = true;
    let mut fold = vec![fold_a; 5];
    fold.extend([fold_b; 5]);
    let base = Plant::new(&truth, Some(&fold), None)?;
    let model = base.model().clone();
    let s = model.structure();
    let n = s.members.len();
    // The four segments of cable 1 (`A_cc1`), as force rows.
    let rows: Vec<usize> = (0..4)
        .map(|k| n + base.state().segment_offsets[1] + k)
        .collect();
    let names: Vec<String> = rows.iter().map(|&r| force_row_name(s, r)).collect();
    let f0 = force_rows(&model, base.state());
    println!(
        "start: {}",
        rows.iter()
            .zip(&names)
            .map(|(&r, nm)| format!("{nm} {:.2}", f0[r]))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let cases: Vec<(&str, Vec<f64>)> = vec![
        ("all -50", vec![-0.05; 10]),
        ("all -10", vec![-0.01; 10]),
        ("all -5", vec![-0.005; 10]),
        (
            "cc1 held, others -50",
            (0..10)
                .map(|m| if m == 1 || m == 6 { 0.0 } else { -0.05 })
                .collect(),
        ),
        (
            "cc1 -50 only",
            (0..10)
                .map(|m| if m == 1 || m == 6 { -0.05 } else { 0.0 })
                .collect(),
        ),
        (
            "cc1 -80, others -50",
            (0..10)
                .map(|m| if m == 1 || m == 6 { -0.08 } else { -0.05 })
                .collect(),
        ),
        (
            "cc1 -25, others -50",
            (0..10)
                .map(|m| if m == 1 || m == 6 { -0.025 } else { -0.05 })
                .collect(),
        ),
    ];
    for (name, cmd) in cases {
        let mut p = base.clone();
        let mut w = Watch {
            model: &model,
            rows: rows.clone(),
            out: Vec::new(),
        };
        let r = p.apply(&cmd, None, &mut w);
        let min: Vec<f64> = (0..rows.len())
            .map(|k| w.out.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min))
            .collect();
        let end = w.out.last().cloned().unwrap_or_default();
        println!(
            "{name:24} ok={} min {:?} end {:?}",
            r.is_ok(),
            min.iter()
                .map(|x| (x * 100.0).round() / 100.0)
                .collect::<Vec<_>>(),
            end.iter()
                .map(|x| (x * 100.0).round() / 100.0)
                .collect::<Vec<_>>()
        );
    }
    Ok(())
}
