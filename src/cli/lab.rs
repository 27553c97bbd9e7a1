//! `tdeploy lab TRUTH.toml`: a synthetic measurement log from a truth model.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::ArgMatches;

use tensegrity_deploy::io::log::write_log;
use tensegrity_deploy::io::model_file::read_model;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::measure::lab::{run_lab, standard_cycles};
use tensegrity_deploy::sim::standard_sensors;

/// Runs `tdeploy lab`.
pub fn lab(a: &ArgMatches) -> Result<()> {
    let truth_path = a.get_one::<PathBuf>("truth").unwrap();
    let out = a.get_one::<PathBuf>("out").unwrap();
    let seed = *a.get_one::<u64>("seed").unwrap();
    let steps = *a.get_one::<usize>("steps").unwrap();
    let swing_k = *a.get_one::<f64>("temperature-swing").unwrap();
    let amplitudes: Vec<f64> = a.get_many::<f64>("amplitudes").unwrap().copied().collect();
    if steps == 0 {
        bail!("--steps must be at least 1");
    }
    if let Some(bad) = amplitudes.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        bail!("--amplitudes: {bad} is not a positive length in metres");
    }
    let truth = read_model(truth_path)?;
    let model = super::effect_model(&truth)?;
    let sensors = standard_sensors(&model.structure);
    if !(swing_k.is_finite() && swing_k >= 0.0) {
        bail!("--temperature-swing: {swing_k} is not a non-negative number of kelvin");
    }
    let cycles = standard_cycles(
        model.structure.continuous_cables.len(),
        &amplitudes,
        steps,
        swing_k,
    );
    let log = run_lab(&model, &sensors, &cycles, seed)
        .with_context(|| format!("truth model {}", truth_path.display()))?;
    write_log(out, &log, &model.structure)?;
    // The truth stays outside the log folder: compare, diagnose and
    // calibrate read only the log.
    let truth_copy = truth_record_path(out);
    let record = format!(
        "# The truth behind the log {}: seed {seed}, amplitudes {amplitudes:?} m, {steps} steps each way, temperature 20 ± {swing_k} °C.\n# Nothing in compare, diagnose or calibrate reads this file.\n{}",
        out.display(),
        truth.to_toml(truth_copy.parent().unwrap_or(Path::new(".")))
    );
    write_atomically(&truth_copy, record.as_bytes())?;
    let readings: usize = log
        .cycles
        .iter()
        .map(|c| c.readings.len() * log.sensors.len())
        .sum();
    say!(
        "lab: {} cycles ({} steps each), {} sensors, {readings} readings, seed {seed}",
        log.cycles.len(),
        2 * steps,
        log.sensors.len()
    );
    say!(
        "log in {}; truth recorded in {}",
        out.display(),
        truth_copy.display()
    );
    Ok(())
}

/// `out/log` → `out/log.truth.toml`.
fn truth_record_path(log_dir: &Path) -> PathBuf {
    let mut name = log_dir
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "log".into());
    name.push(".truth.toml");
    log_dir.with_file_name(name)
}
