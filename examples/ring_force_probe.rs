//! Force of the abutment-ring cables (`ring0`) along a uniform reel-in
//! from a 40 cm fold to the design, for support compliances across the
//! plausible range: whether their minimum can be kept at all.
//!
//! `cargo run --release --example ring_force_probe`
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{EffectKind, Effects, Workspace};
use tensegrity_deploy::sim::EffectModel;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let structure = reference_bridge(&BridgeParameters::default())?;
    let ring: Vec<usize> = (0..structure.members.len())
        .filter(|m| structure.members[*m].id.contains("ring0"))
        .collect();
    for compliance in [0.0, 1e-5, 3e-5, 5e-5] {
        let effects = if compliance > 0.0 {
            Effects::default().with_parameters(EffectKind::SupportFlexibility, &[compliance])
        } else {
            Effects::default()
        };
        let model = EffectModel::for_measurement(structure.clone(), effects).forward_model()?;
        let n = model.structure().continuous_cables.len();
        let mut ws = Workspace::default();
        let mut s = model.reference_state();
        let f = model.member_forces(&s);
        let smallest = |f: &tensegrity_deploy::model::MemberForces| {
            ring.iter()
                .map(|m| f.member_n[*m])
                .fold(f64::INFINITY, f64::min)
        };
        print!("compliance {compliance:.0e}: design {:.1} N;", smallest(&f));
        model.apply_payout(&mut s, &mut ws, &vec![0.4; n], 0.01, &mut ())?;
        for _ in 0..8 {
            let f = model.member_forces(&s);
            print!(" {:.0}cm {:.1}", s.payout_m[0] * 100.0, smallest(&f));
            model.apply_payout(&mut s, &mut ws, &vec![-0.05; n], 0.01, &mut ())?;
        }
        let f = model.member_forces(&s);
        println!(" {:.0}cm {:.1}", s.payout_m[0] * 100.0, smallest(&f));
    }
    Ok(())
}
