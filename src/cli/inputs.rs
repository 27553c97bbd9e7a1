//! The library objects the commands' flags name, read through
//! [`tensegrity_deploy::io`] or built in when a flag is not given: the
//! model a controller plans on, the policy, the problem, and the
//! controller's model as a model file for the records.

use std::path::Path;

use anyhow::{Context, Result};

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::fingerprint;
use tensegrity_deploy::io::model_file::{
    read_model, ModelFile, ModelSolver, StructureSource, REFERENCE_TEMPERATURE_RANGE_C,
};
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::io::problem_file::read_problem_for;
use tensegrity_deploy::model::{Effects, ForwardModel, JointFriction, RelaxSettings, Structure};
use tensegrity_deploy::plan::{DeploymentProblem, Policy};
use tensegrity_deploy::sim::default_truth::{default_truth, default_truth_effects};
use tensegrity_deploy::sim::EffectModel;

/// The model a controller plans on: a model file's structure with its
/// structural effects and joint friction (motor, thermal and sensor
/// effects belong to a truth, not to a plan), or, without a file, the
/// reference bridge with `default_friction`.
pub fn planning_model(
    path: Option<&Path>,
    default_friction: JointFriction,
) -> Result<ForwardModel> {
    Ok(planning_model_and_bridge(path, default_friction)?.0)
}

/// [`planning_model`] and the structure it was built on before the model
/// file's effects: the bridge a simulated truth is drawn on.
pub fn planning_model_and_bridge(
    path: Option<&Path>,
    default_friction: JointFriction,
) -> Result<(ForwardModel, Structure)> {
    Ok(match path {
        Some(p) => {
            let file = read_model(p)?;
            let bridge = file.load_structure()?;
            let model = file
                .measurement_model_on(bridge.clone())
                .forward_model()
                .with_context(|| format!("{}: applying its effects", p.display()))?;
            (model, bridge)
        }
        None => {
            let bridge = reference_bridge(&BridgeParameters::default())?;
            let model =
                ForwardModel::new(bridge.clone(), default_friction, RelaxSettings::default())?;
            (model, bridge)
        }
    })
}

/// The controller's model as the measurement tools replay it: the model
/// file's bridge with its effects and solver settings, or the reference
/// bridge with none (the frictionless default of [`planning_model`]).
pub fn planning_effect_model(path: Option<&Path>) -> Result<EffectModel> {
    Ok(match path {
        Some(p) => read_model(p)?.measurement_model()?,
        None => EffectModel::for_measurement(
            reference_bridge(&BridgeParameters::default())?,
            Effects::default(),
        ),
    })
}

/// The controller's model file as given, or the frictionless reference
/// bridge, with how a summary names it.
pub fn controller_model_file(path: Option<&Path>) -> Result<(ModelFile, String)> {
    Ok(match path {
        Some(p) => (read_model(p)?, p.display().to_string()),
        None => (
            ModelFile {
                structure: StructureSource::Reference,
                effects: Effects::default(),
                solver: ModelSolver::default(),
            },
            "the reference bridge without friction".to_string(),
        ),
    })
}

/// The fingerprint of the model file at `path` as it reads: of its
/// canonical text (structure as the file names it, effects, faults and
/// `[solver]` settings), so that comments and layout do not change it
/// and any setting does.
pub fn model_fingerprint(path: &Path) -> Result<String> {
    let file = read_model(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    Ok(fingerprint(file.to_toml(dir).as_bytes()))
}

/// A model file's structure source made independent of the working
/// folder, so that a copy written elsewhere still finds its structure.
pub fn absolute(file: ModelFile) -> Result<ModelFile> {
    Ok(match file.structure {
        StructureSource::File(p) if p.is_relative() => ModelFile {
            structure: StructureSource::File(
                std::env::current_dir()
                    .context("the working folder")?
                    .join(p),
            ),
            ..file
        },
        _ => file,
    })
}

/// The air temperature of a deployment, °C, from `--temperature`,
/// checked against the truth it acts on. A thermal truth needs one: its
/// effect is the members' expansion from the reference temperature, and
/// taking that reference for the air temperature would silently switch
/// the effect off. Without a thermal effect the temperature changes
/// nothing, and may be left out.
pub fn deployment_temperature(
    flag: Option<f64>,
    truth: &Effects,
    truth_words: &str,
) -> Result<Option<f64>> {
    if let Some(t) = flag {
        if let Err(m) = REFERENCE_TEMPERATURE_RANGE_C.check(t) {
            anyhow::bail!("--temperature: {m}");
        }
    }
    match (&truth.thermal, flag) {
        (Some(th), None) => anyhow::bail!(
            "the truth {truth_words} has a thermal effect (reference {} °C): give the air temperature with --temperature °C",
            th.reference_temperature_c
        ),
        _ => Ok(flag),
    }
}

/// The policy file's policy, or the built-in default.
pub fn policy_or_default(path: Option<&Path>) -> Result<Policy> {
    Ok(match path {
        Some(p) => read_policy(p)?,
        None => Policy::default(),
    })
}

/// The problem file's problem, its per-motor lists checked for a
/// structure of `motors` motors, or the documented default.
pub fn problem_or_default(path: Option<&Path>, motors: usize) -> Result<DeploymentProblem> {
    Ok(match path {
        Some(p) => read_problem_for(p, motors)?,
        None => DeploymentProblem::default(),
    })
}

/// The truth a simulated deployment runs on: its model file (structure
/// made absolute), the model it loads as, and how summaries name it.
/// Without a truth file, the controller's bridge (`model`'s structure, or
/// the reference) with the default effects. With `slip_event_substeps`
/// (`--slip-event-substeps`) the truth splits its increments at its
/// joints' slip events, as a truth file's `[solver] slip_event_substeps`
/// does; the returned file records it, and the name says so either way.
pub fn truth_or_default(
    truth: Option<&Path>,
    model: Option<&Path>,
    slip_event_substeps: bool,
) -> Result<(ModelFile, EffectModel, String)> {
    let (mut file, mut model, mut words) = match truth {
        Some(p) => {
            let file = absolute(read_model(p)?)?;
            let model = file.measurement_model()?;
            (file, model, p.display().to_string())
        }
        None => {
            let structure = match model {
                Some(p) => absolute(read_model(p)?)?.structure,
                None => StructureSource::Reference,
            };
            let file = ModelFile {
                structure,
                effects: default_truth_effects(),
                solver: ModelSolver::default(),
            };
            let model = default_truth(file.load_structure()?);
            (
                file,
                model,
                "default (μ = 0.2 wrap angle, 3 mm backlash)".to_string(),
            )
        }
    };
    if slip_event_substeps {
        file.solver.slip_event_substeps = true;
        file.solver.apply_to(&mut model.settings);
    }
    if file.solver.slip_event_substeps {
        words.push_str(", increments split at slip events");
    }
    Ok((file, model, words))
}
