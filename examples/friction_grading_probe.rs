//! How well a frictionless model's path, graded by friction
//! ([`FrictionGrading`]), predicts the segment tensions of a model with
//! joint friction alone (constant μ, wrap angle, slip events located; no
//! backlash, unlike the default truth of `reversal_dip_probe`): after a
//! fold, then for three alternative first commands, each from the fold,
//! each segment's smallest tension over the command and its tension at
//! the end. Each line gives `A_cc1`'s four segments by the model with
//! friction, the frictionless model and the grading, and the worst error
//! of each prediction over every segment of every cable (known
//! limitations, item 18). Exits with an error if a solve does not
//! converge or the grading cannot follow.
//!
//! `cargo run --release --example friction_grading_probe -- [--detail] [MU FOLD_A_M FOLD_B_M]`
//! (default μ 0.2 and the uneven fold 0.45 0.33; `--detail` prints every
//! cable after the fold and at each command's end).

use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{
    DeploymentState, ForwardModel, IncrementObserver, JointFriction, RelaxReport, RelaxSettings,
    Workspace,
};
use tensegrity_deploy::plan::limits::force_rows;
use tensegrity_deploy::studies::friction_grading::{graded_fold, FrictionGrading};

struct Path<'a> {
    model: &'a ForwardModel,
    grading: Option<FrictionGrading>,
    out: Vec<(Vec<f64>, Vec<f64>)>,
    failed: Option<String>,
}
impl IncrementObserver for Path<'_> {
    fn on_increment(&mut self, _: usize, _: usize, r: &RelaxReport, s: &DeploymentState) {
        if self.failed.is_some() {
            return;
        }
        if !r.status.is_converged() {
            self.failed = Some(r.status.describe().to_string());
            return;
        }
        let n = self.model.structure().members.len();
        let model_t = force_rows(self.model, s)[n..].to_vec();
        let graded = match &mut self.grading {
            Some(g) => match g.advance(self.model.structure(), s) {
                Ok(_) => g.segment_tensions_n(self.model.structure(), s),
                Err(e) => {
                    self.failed = Some(e.to_string());
                    return;
                }
            },
            None => model_t.clone(),
        };
        self.out.push((model_t, graded));
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let detail = args.first().is_some_and(|a| a == "--detail");
    if detail {
        args.remove(0);
    }
    let mu: f64 = args.first().map_or(Ok(0.2), |a| a.parse())?;
    let fold_a: f64 = args.get(1).map_or(Ok(0.45), |a| a.parse())?;
    let fold_b: f64 = args.get(2).map_or(Ok(0.33), |a| a.parse())?;
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let settings = RelaxSettings {
        slip_event_substeps_enable: true,
        ..RelaxSettings::default()
    };
    let truth = ForwardModel::new(
        bridge.clone(),
        JointFriction::constant(mu)?,
        settings.clone(),
    )?;
    let free = ForwardModel::new(bridge.clone(), JointFriction::frictionless(), settings)?;
    let mut fold = vec![fold_a; 5];
    fold.extend([fold_b; 5]);
    let inc = 0.01;
    let (free_fold, grading) = graded_fold(&free, JointFriction::constant(mu)?, &fold, inc)?;
    let mut ws = Workspace::default();
    let mut truth_fold = truth.reference_state();
    let relaxed = truth.relax(&mut truth_fold, &mut ws).status;
    let folded = truth
        .apply_payout(&mut truth_fold, &mut ws, &fold, inc, &mut ())?
        .status;
    if !relaxed.is_converged() || !folded.is_converged() {
        return Err("the model with friction does not reach the fold".into());
    }
    let n = bridge.members.len();
    let segs = bridge.segment_count();
    let cmds: Vec<(&str, Vec<f64>)> = vec![
        ("all -5 cm", vec![-0.05; 10]),
        (
            "cc1 -8, others -5 cm",
            (0..10)
                .map(|m| if m % 5 == 1 { -0.08 } else { -0.05 })
                .collect(),
        ),
        (
            "cc1 held, others -5 cm",
            (0..10)
                .map(|m| if m % 5 == 1 { 0.0 } else { -0.05 })
                .collect(),
        ),
    ];
    let report = |name: &str, t: &[f64], f: &[f64], g: &[f64]| {
        let (mut ef, mut eg) = (0.0f64, 0.0f64);
        for k in 0..segs {
            ef = ef.max((f[k] - t[k]).abs());
            eg = eg.max((g[k] - t[k]).abs());
        }
        let o = free_fold.segment_offsets[1];
        let show = |v: &[f64]| {
            (0..4)
                .map(|k| format!("{:6.2}", v[o + k]))
                .collect::<Vec<_>>()
                .join(" ")
        };
        println!(
            "{name:28} A_cc1 truth [{}] frictionless [{}] graded [{}]  worst segment error: frictionless {ef:.2} N, graded {eg:.2} N",
            show(t),
            show(f),
            show(g)
        );
    };
    let t0 = force_rows(&truth, &truth_fold)[n..].to_vec();
    let f0 = force_rows(&free, &free_fold)[n..].to_vec();
    let g0 = grading.segment_tensions_n(free.structure(), &free_fold);
    report("after the fold", &t0, &f0, &g0);
    if detail {
        print_cables(&bridge, &free_fold.segment_offsets, &t0, &f0, &g0);
    }
    for (name, cmd) in &cmds {
        let mut ts = truth_fold.clone();
        let mut tp = Path {
            model: &truth,
            grading: None,
            out: Vec::new(),
            failed: None,
        };
        truth.apply_payout(&mut ts, &mut ws, cmd, inc, &mut tp)?;
        let mut fs = free_fold.clone();
        let mut fp = Path {
            model: &free,
            grading: Some(grading.clone()),
            out: Vec::new(),
            failed: None,
        };
        free.apply_payout(&mut fs, &mut ws, cmd, inc, &mut fp)?;
        if let Some(why) = tp.failed.as_ref().or(fp.failed.as_ref()) {
            return Err(format!("{name}: {why}").into());
        }
        // Smallest tension of each segment over the command.
        let min_of = |p: &Path, graded: bool| -> Vec<f64> {
            (0..segs)
                .map(|k| {
                    p.out
                        .iter()
                        .map(|(m, g)| if graded { g[k] } else { m[k] })
                        .fold(f64::INFINITY, f64::min)
                })
                .collect()
        };
        report(
            &format!("{name}: smallest"),
            &min_of(&tp, false),
            &min_of(&fp, false),
            &min_of(&fp, true),
        );
        let ((te, _), (fe, ge)) = match (tp.out.last(), fp.out.last()) {
            (Some(t), Some(f)) => (t, f),
            _ => return Err(format!("{name}: a model solved no increment").into()),
        };
        report(&format!("{name}: end"), te, fe, ge);
        if detail {
            print_cables(&bridge, &free_fold.segment_offsets, te, fe, ge);
        }
    }
    Ok(())
}

/// Every cable's segment tensions by the model with friction (`t`), the
/// frictionless model (`f`) and the grading (`g`), N.
fn print_cables(
    bridge: &tensegrity_deploy::model::Structure,
    offsets: &[usize],
    t: &[f64],
    f: &[f64],
    g: &[f64],
) {
    for (c, cable) in bridge.continuous_cables.iter().enumerate() {
        let row = |v: &[f64]| {
            v[offsets[c]..offsets[c + 1]]
                .iter()
                .map(|x| format!("{x:7.1}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        println!(
            "  {:8} truth [{}] free [{}] graded [{}]",
            cable.id,
            row(t),
            row(f),
            row(g)
        );
    }
}
