use std::time::Instant;
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings, Workspace};
use tensegrity_deploy::plan::{folded_start, DeploymentProblem, Policy};
fn main() {
    let model = ForwardModel::new(
        reference_bridge(&BridgeParameters::default()).unwrap(),
        JointFriction::constant(0.2).unwrap(),
        RelaxSettings::default(),
    )
    .unwrap();
    let problem = DeploymentProblem::default();
    let policy = Policy::default();
    let start = folded_start(&model, &problem, policy.increment_m).unwrap();
    let n = start.payout_m.len();
    for inc in [0.01, 0.05] {
        for sign in [1.0, -1.0] {
            for m in 0..n {
                let mut s = start.clone();
                let mut d = vec![0.0; n];
                d[m] = sign * 0.05;
                let t = Instant::now();
                let r = model
                    .apply_payout(&mut s, &mut Workspace::default(), &d, inc, &mut ())
                    .unwrap();
                println!(
                    "inc {inc} sign {sign} motor {m}: {:.1} ms, {:?} newton {} all {}",
                    t.elapsed().as_secs_f64() * 1e3,
                    r.status.is_converged(),
                    r.newton_iterations,
                    r.iterations
                );
            }
        }
    }
}
