//! A drawn scenario of `tdeploy evaluate`, set up for a closed-loop run
//! exactly as the evaluation sets it up (shared by the integration tests).

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::{ClosedLoopSetup, DeploymentProblem, Policy};
use tensegrity_deploy::studies::evaluation::ScenarioDistribution;

/// Runs `run` on the setup of scenario `index` of `seed` from the default
/// distribution with `policy`: the frictionless reference model, the
/// scenario's truth, sensors, fold, temperature and noise seed.
pub fn with_evaluation_setup<R>(
    policy: &Policy,
    seed: u64,
    index: usize,
    run: impl FnOnce(&ClosedLoopSetup) -> R,
) -> R {
    let structure = reference_bridge(&BridgeParameters::default()).expect("reference bridge");
    let model = ForwardModel::new(
        structure.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )
    .expect("model");
    let scenario = ScenarioDistribution::default().draw(seed, index);
    let truth = scenario.truth(&structure);
    let sensors = scenario.sensors(&structure);
    let problem = scenario.problem(&DeploymentProblem::default());
    run(&ClosedLoopSetup {
        model: &model,
        problem: &problem,
        policy,
        truth: &truth,
        sensors: &sensors,
        temperature_c: scenario.temperature_c,
        seed: scenario.seed,
    })
}
