//! Inputs several tests build the same way.

use tensegrity_deploy::control::{deploy_closed_loop, ClosedLoopSetup, DeployObserver, Deployment};
use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::measure::lab::{run_lab, standard_cycles};
use tensegrity_deploy::measure::log::MeasurementLog;
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings, Structure};
use tensegrity_deploy::plan::{DeploymentProblem, Policy};
use tensegrity_deploy::sim::{standard_sensors, EffectModel, Sensor};

use super::cli::{succeeded, tdeploy};

/// Two free-standing supports and one free node on two cables, with one
/// continuous cable `cc` over it: small enough to solve in milliseconds.
pub const TWO_CABLES: &str = r#"{
  "format": "tensegrity-deploy/structure/1",
  "name": "two cables",
  "gravity_m_per_s2": [0, 0, -9.81],
  "nodes": [
    {"id": "a", "position_m": [0, 0, 0], "mass_kg": 0, "fixed": [true, true, true]},
    {"id": "b", "position_m": [1, 0, 0], "mass_kg": 1},
    {"id": "c", "position_m": [2, 0, 0], "mass_kg": 0, "fixed": [true, true, true]}
  ],
  "cables": [
    {"id": "c0", "nodes": ["a", "b"], "ea_n": 1e5, "rest_length_m": 0.99},
    {"id": "c1", "nodes": ["b", "c"], "ea_n": 1e5, "rest_length_m": 0.99}
  ],
  "continuous_cables": [
    {"id": "cc", "path": ["a", "b", "c"], "ea_n": 1e5, "segment_rest_lengths_m": [0.99, 0.99]}
  ]
}"#;

/// A command file for [`TWO_CABLES`]: 1 mm out on `cc`, then 1 mm in.
pub const TWO_STEP_COMMANDS: &str = "step,cable,payout_change_m\n1,cc,0.001\n2,cc,-0.001\n";

/// A model file: the reference bridge with no effects.
pub const REFERENCE_MODEL: &str =
    "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n";

/// A temporary folder holding `files` (name, text).
pub fn dir_with(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    dir
}

/// A temporary folder with [`REFERENCE_MODEL`] as `model.toml` and a small
/// lab log of it in `log/`: one cycle per amplitude of `amplitudes_m` (a
/// comma-separated list, m), one step each way.
pub fn lab_log_folder(amplitudes_m: &str) -> tempfile::TempDir {
    let dir = dir_with(&[("model.toml", REFERENCE_MODEL)]);
    let args = [
        "lab",
        "model.toml",
        "-o",
        "log",
        "--amplitudes",
        amplitudes_m,
        "--steps",
        "1",
    ];
    succeeded(&tdeploy(&args, dir.path()));
    dir
}

/// The reference bridge with its default parameters.
pub fn reference_structure() -> Structure {
    reference_bridge(&BridgeParameters::default()).unwrap()
}

/// The controller's model of the reference bridge in the closed-loop
/// tests: frictionless, default solver settings.
pub fn frictionless_reference_model() -> ForwardModel {
    ForwardModel::new(
        reference_structure(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )
    .unwrap()
}

/// A closed-loop deployment of `truth` read by `sensors` at
/// `temperature_c`, the controller planning on
/// [`frictionless_reference_model`].
pub fn deploy_frictionless_controller(
    truth: &EffectModel,
    sensors: &[Sensor],
    problem: &DeploymentProblem,
    policy: &Policy,
    temperature_c: Option<f64>,
    seed: u64,
    observer: &mut dyn DeployObserver,
) -> Deployment {
    let model = frictionless_reference_model();
    deploy_planning_on(
        &model,
        truth,
        sensors,
        problem,
        policy,
        temperature_c,
        seed,
        observer,
    )
}

/// [`deploy_frictionless_controller`] with the controller planning on
/// `model`.
#[allow(clippy::too_many_arguments)]
pub fn deploy_planning_on(
    model: &ForwardModel,
    truth: &EffectModel,
    sensors: &[Sensor],
    problem: &DeploymentProblem,
    policy: &Policy,
    temperature_c: Option<f64>,
    seed: u64,
    observer: &mut dyn DeployObserver,
) -> Deployment {
    let setup = ClosedLoopSetup {
        model,
        problem,
        policy,
        truth,
        sensors,
        temperature_c,
        seed,
    };
    deploy_closed_loop(&setup, observer).unwrap()
}

/// The cycles of the diagnosis tests' lab logs, m: both halves of a
/// fitted/held-out split see a 20 cm cycle.
pub const LAB_AMPLITUDES_M: [f64; 4] = [0.05, 0.2, 0.1, 0.2];

/// Steps each way of every cycle of the diagnosis tests' lab logs.
pub const LAB_STEPS: usize = 4;

/// A lab log of `truth` with the standard sensors: cycles of
/// [`LAB_AMPLITUDES_M`] in [`LAB_STEPS`] steps each way, the temperature
/// swinging by `swing_k`, noise drawn from `seed`.
pub fn standard_lab_log(truth: &EffectModel, seed: u64, swing_k: f64) -> MeasurementLog {
    let sensors = standard_sensors(&truth.structure);
    let cycles = standard_cycles(
        truth.structure.continuous_cables.len(),
        &LAB_AMPLITUDES_M,
        LAB_STEPS,
        swing_k,
    );
    run_lab(truth, &sensors, &cycles, seed).unwrap()
}
