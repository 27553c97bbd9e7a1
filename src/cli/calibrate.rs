//! `tdeploy calibrate MODEL LOG --add EFFECT -o NEW.toml`: fit one effect
//! to a log and write a new model file with it switched on.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::ArgMatches;

use tensegrity_deploy::io::log::read_log;
use tensegrity_deploy::io::model_file::{read_model, write_new_model, ModelFile};
use tensegrity_deploy::measure::compare::compare;
use tensegrity_deploy::measure::diagnose::{fit_candidate, part};
use tensegrity_deploy::model::EffectKind;

/// Runs `tdeploy calibrate`.
pub fn calibrate(a: &ArgMatches) -> Result<()> {
    let model_path = a.get_one::<PathBuf>("model").unwrap();
    let log_dir = a.get_one::<PathBuf>("log").unwrap();
    let out = a.get_one::<PathBuf>("out").unwrap();
    let name = a.get_one::<String>("add").unwrap();
    let Some(kind) = EffectKind::ALL.into_iter().find(|k| k.name() == name) else {
        let known: Vec<_> = EffectKind::ALL.iter().map(|k| k.name()).collect();
        bail!(
            "--add: unknown effect \"{name}\" (known: {})",
            known.join(", ")
        );
    };
    if out == model_path {
        bail!("--out must differ from the input model: calibration never overwrites it");
    }
    let model_file = read_model(model_path)?;
    let model = super::effect_model(&model_file)?;
    let log = read_log(log_dir, &model.structure)?;
    let before = part(&compare(&model, &log)?, log.cycles.len(), true);
    let c = fit_candidate(&model, model.effects, kind, &log, &before)
        .with_context(|| format!("fitting {name} to {}", log_dir.display()))?;
    let new = ModelFile {
        structure: model_file.structure.clone(),
        effects: model.effects.with_parameters(kind, &c.values),
    };
    write_new_model(out, &new)?;
    for (p, (v, se)) in kind
        .parameters()
        .iter()
        .zip(c.values.iter().zip(&c.std_errors))
    {
        say!("{name}.{}", super::fitted_parameter(p, *v, *se));
    }
    say!(
        "held-out RMS residual: {:.2} σ before, {:.2} σ after ({} readings)",
        before.overall.rms,
        c.held_out_rms,
        before.overall.count
    );
    say!("wrote {}", out.display());
    Ok(())
}
