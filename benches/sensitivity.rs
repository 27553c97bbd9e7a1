//! Speed of the payout sensitivities. Run:
//! `cargo bench --bench sensitivity -- --warm-up-time 1 --measurement-time 3`.
//!
//! The full reference bridge after every cable has paid out 5 cm (1 cm
//! increments), μ = 0 and 0.2, default tolerance: all 10 motors, both
//! directions, per call. The number of joints sliding per direction is
//! printed once before timing.

use criterion::{criterion_group, criterion_main, Criterion};
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings, Workspace};

fn payout_sensitivities(c: &mut Criterion) {
    for mu in [0.0, 0.2] {
        let model = ForwardModel::new(
            reference_bridge(&BridgeParameters::default()).unwrap(),
            JointFriction::constant(mu).unwrap(),
            RelaxSettings::default(),
        )
        .unwrap();
        let mut ws = Workspace::default();
        let mut state = model.reference_state();
        let n = model.structure().continuous_cables.len();
        let r = model
            .apply_payout(&mut state, &mut ws, &vec![0.05; n], 0.01, &mut ())
            .unwrap();
        assert!(r.status.is_converged());
        let sens = model.payout_sensitivities(&state, &mut ws).unwrap();
        let count = |rs: &[tensegrity_deploy::model::MotorResponse]| {
            rs.iter().map(|r| r.sliding_joints).collect::<Vec<_>>()
        };
        eprintln!(
            "μ = {mu}: sliding joints paying out {:?}, reeling in {:?}",
            count(&sens.pay_out),
            count(&sens.reel_in)
        );
        c.bench_function(&format!("bridge_payout_sensitivities_mu{mu}"), |b| {
            b.iter(|| model.payout_sensitivities(&state, &mut ws).unwrap())
        });
    }
}

criterion_group!(benches, payout_sensitivities);
criterion_main!(benches);
