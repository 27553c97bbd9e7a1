//! `tdeploy calibrate MODEL LOG --add EFFECT -o NEW.toml`: fit one effect
//! to a log and write a new model file with it switched on.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::{read_model, write_new_model, ModelFile};
use tensegrity_deploy::measure::compare::compare;
use tensegrity_deploy::measure::diagnose::{fit_candidate, part, DiagnoseSettings};
use tensegrity_deploy::model::EffectKind;

use super::{fitted_parameter, replay_stopped, value, Outcome};

/// The `calibrate` subcommand's arguments.
pub fn command() -> Command {
    Command::new("calibrate")
        .about("Fit one effect to a log and write a new model file with it (never overwriting the input)")
        .arg(Arg::new("model").required(true).value_parser(value_parser!(PathBuf)).help("Model file (TOML)"))
        .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder"))
        .arg(Arg::new("add").long("add").required(true).help("Effect to add: joint_friction, motor, stiffness_error, thermal, joint_mass_error, load_cell_bias, joint_eccentricity, support_flexibility"))
        .arg(Arg::new("out").long("out").short('o').required(true).value_parser(value_parser!(PathBuf)).help("New model file (must not exist)"))
}

/// Options of `tdeploy calibrate`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Model file.
    pub model: PathBuf,
    /// Log folder.
    pub log: PathBuf,
    /// The effect to add and fit.
    pub add: EffectKind,
    /// New model file to write.
    pub out: PathBuf,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let name: String = value(m, "add")?;
        let Some(add) = EffectKind::ALL.into_iter().find(|k| k.name() == name) else {
            let known: Vec<_> = EffectKind::ALL.iter().map(|k| k.name()).collect();
            bail!(
                "--add: unknown effect \"{name}\" (known: {})",
                known.join(", ")
            );
        };
        let (model, out): (PathBuf, PathBuf) = (value(m, "model")?, value(m, "out")?);
        if out == model {
            bail!("--out must differ from the input model: calibration never overwrites it");
        }
        Ok(Options {
            model,
            log: value(m, "log")?,
            add,
            out,
        })
    }
}

/// Runs `tdeploy calibrate`.
pub fn run(o: &Options) -> Result<Outcome> {
    let model_file = read_model(&o.model)?;
    let model = model_file.measurement_model()?;
    let log = read_log(&o.log, &model.structure)?;
    let name = o.add.name();
    let context = || format!("fitting {name} to {}", o.log.display());
    let settings = DiagnoseSettings::default();
    let fitted = compare(&model, &log).and_then(|all| {
        let before = part(&all, log.cycles.len(), true, &settings);
        fit_candidate(&model, model.effects, o.add, &log, &settings).map(|c| (before, c))
    });
    let (before, c) = match fitted {
        Ok(fitted) => fitted,
        Err(e) => return replay_stopped(e, context()),
    };
    if !c.converged {
        return Ok(Outcome::GoalMissed(format!(
            "{}: the fit did not converge; no model written",
            context()
        )));
    }
    let new = ModelFile {
        structure: model_file.structure.clone(),
        effects: model.effects.with_parameters(o.add, &c.values),
    };
    write_new_model(&o.out, &new)?;
    for (p, (v, se)) in o
        .add
        .parameters()
        .iter()
        .zip(c.values.iter().zip(&c.std_errors))
    {
        say!("{name}.{}", fitted_parameter(p, *v, *se));
    }
    say!(
        "held-out RMS residual: {:.2} σ before, {:.2} σ after ({} readings)",
        before.overall.rms,
        c.held_out_rms,
        before.overall.count
    );
    say!("wrote {}", o.out.display());
    Ok(Outcome::GoalReached)
}
