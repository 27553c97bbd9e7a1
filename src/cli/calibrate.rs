//! `tdeploy calibrate MODEL LOG --add EFFECT -o NEW.toml`: fit one effect
//! to a log and write a new model file with it switched on.
//!
//! The calibration is [`tensegrity_deploy::measure::calibrate`]'s, the one
//! `tdeploy replay --fit` makes, with one difference of purpose: here the
//! effect is kept whenever its fit converged
//! ([`KeepFit::IfConverged`]), whether or not it lowered the held-out
//! residual (the user named the effect; the printed held-out figures
//! before and after tell whether it helped). A fit that did not converge
//! writes no model (exit 1).

use std::path::PathBuf;

use anyhow::{anyhow, bail, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::{read_model, write_new_model, ModelFile};
use tensegrity_deploy::measure::calibrate::{
    calibrate_on_log, CalibrationError, CalibrationMethod, KeepFit,
};
use tensegrity_deploy::model::EffectKind;

use super::words::fitted_parameter;
use super::{plant_stopped, value, Outcome};

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
    let method = CalibrationMethod::Fit {
        effects: vec![o.add],
        keep: KeepFit::IfConverged,
    };
    let c = match calibrate_on_log(&model, &log, &method) {
        Ok(c) => c,
        Err(CalibrationError::Replay(e)) => return plant_stopped(e, context()),
        Err(e) => return Err(anyhow::Error::new(e).context(context())),
    };
    let fitted = c
        .fitted
        .first()
        .ok_or_else(|| anyhow!("{}: no fit made", context()))?;
    if !fitted.converged {
        return Ok(Outcome::GoalMissed(format!(
            "{}: the fit did not converge; no model written",
            context()
        )));
    }
    let new = ModelFile {
        effects: c.effects,
        ..model_file.clone()
    };
    write_new_model(&o.out, &new)?;
    for (p, (v, se)) in o
        .add
        .parameters()
        .iter()
        .zip(fitted.values.iter().zip(&fitted.std_errors))
    {
        say!("{name}.{}", fitted_parameter(p, *v, *se));
    }
    // A μ table's `mu` is its level: say what was written.
    if let Some(table) = new
        .effects
        .joint_friction
        .as_ref()
        .filter(|f| o.add == EffectKind::JointFriction && f.angle_shape.is_some())
    {
        say!(
            "  (mu is the level of the model's μ table, the mean of its values; written scaled, keeping its shape: mu = {:?})",
            table.tabulated_mu()
        );
    }
    say!(
        "held-out RMS residual: {:.2} σ before, {:.2} σ after ({} readings)",
        c.held_out_rms_before,
        c.held_out_rms_after,
        c.held_out_readings
    );
    say!("wrote {}", o.out.display());
    Ok(Outcome::GoalReached)
}
