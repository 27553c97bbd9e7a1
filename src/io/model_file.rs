//! Model files (TOML): which structure, and which physical effects are
//! switched on with which parameters.
//!
//! ```toml
//! format = "tensegrity-deploy/model/1"
//! # "reference" for the built-in bridge, or a structure JSON file,
//! # relative to this file.
//! structure = "reference"
//!
//! [effects.joint_friction]
//! mu = 0.12
//! convention = "wrap"        # or "interior"
//!
//! [effects.motor]
//! slip_fraction = 0.01       # fraction of each command lost
//! backlash_m = 0.002         # play taken up on each reversal
//!
//! [effects.stiffness_error]
//! strut_scale = 1.0
//! cable_scale = 0.9
//! spring_scale = 1.0
//!
//! [effects.thermal]
//! expansion_per_k = 1.2e-5
//! reference_temperature_c = 20
//!
//! [effects.joint_mass_error]
//! scale = 1.1
//!
//! [effects.load_cell_bias]
//! bias_n = 12
//!
//! [effects.joint_eccentricity]
//! seat_radius_m = 0.015      # cable arc radius on each joint's seat
//!
//! [effects.support_flexibility]
//! compliance_m_per_n = 2e-5  # 50 kN/m in every supported direction
//! ```
//! A missing `[effects.*]` table is an effect switched off. Every effect,
//! its physics, parameters, units and plausible ranges are documented in
//! [`crate::model::effects`]. Unknown keys are errors, not ignored.
//!
//! Written as: a calibrated model (`tdeploy calibrate -o`,
//! [`write_new_model`], never over an existing file); `truth.toml` and
//! `model.toml` of a deployment ([`super::deployment_files`]); the truth
//! record `LOG.truth.toml` beside a synthetic log ([`write_truth_record`]:
//! the model file after two `#` comment lines naming the lab run).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::structure_file::read_structure;
use super::toml_text::{field_error, parse_toml};
use super::{write_atomically, FileError};
use crate::design::{reference_bridge, BridgeParameters};
use crate::model::{Effects, Structure};
use crate::numerics::NumberRange;
use crate::sim::EffectModel;

/// The `format` a model file must declare.
pub const MODEL_FORMAT: &str = "tensegrity-deploy/model/1";

/// Where a model's structure comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum StructureSource {
    /// The built-in reference bridge with default parameters.
    Reference,
    /// A structure file (absolute, or resolved against the model file).
    File(PathBuf),
}

/// A model: a structure and the effects on it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelFile {
    /// The structure.
    pub structure: StructureSource,
    /// The effects switched on.
    pub effects: Effects,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelDoc {
    format: String,
    structure: String,
    #[serde(default)]
    effects: Effects,
}

/// Range of a thermal effect's reference temperature, °C: the
/// temperatures a bridge is built and deployed at.
pub const REFERENCE_TEMPERATURE_RANGE_C: NumberRange = NumberRange::closed(-100.0, 100.0);

/// Checks the one effect number [`Effects::validate`] leaves alone, the
/// thermal effect's reference temperature, at key `prefix.thermal.…`.
pub(crate) fn check_reference_temperature(
    effects: &Effects,
    prefix: &str,
    text: &str,
    path: &Path,
) -> Result<(), FileError> {
    match &effects.thermal {
        Some(t) => REFERENCE_TEMPERATURE_RANGE_C
            .check(t.reference_temperature_c)
            .map_err(|m| {
                field_error(
                    text,
                    path,
                    &format!("{prefix}.thermal.reference_temperature_c"),
                    m,
                )
            }),
        None => Ok(()),
    }
}

/// Reads and validates a model file.
pub fn read_model(path: &Path) -> Result<ModelFile, FileError> {
    let text = super::read_text(path)?;
    parse_model(&text, path)
}

/// Parses a model file; `path` names it in errors and anchors a relative
/// structure path.
pub fn parse_model(text: &str, path: &Path) -> Result<ModelFile, FileError> {
    let doc: ModelDoc = parse_toml(text, path)?;
    let invalid = |entry: &str, message: String| FileError::Invalid {
        path: path.to_path_buf(),
        entry: entry.to_string(),
        message,
    };
    if doc.format != MODEL_FORMAT {
        return Err(invalid(
            "format",
            format!("expected \"{MODEL_FORMAT}\", found \"{}\"", doc.format),
        ));
    }
    doc.effects.validate().map_err(|e| {
        field_error(
            text,
            path,
            &format!("effects.{}.{}", e.effect, e.parameter),
            e.reason.clone(),
        )
    })?;
    check_reference_temperature(&doc.effects, "effects", text, path)?;
    let structure = if doc.structure == "reference" {
        StructureSource::Reference
    } else {
        let p = PathBuf::from(&doc.structure);
        StructureSource::File(if p.is_absolute() {
            p
        } else {
            path.parent().unwrap_or(Path::new(".")).join(p)
        })
    };
    Ok(ModelFile {
        structure,
        effects: doc.effects,
    })
}

impl ModelFile {
    /// Loads the structure the model names (effects not yet applied).
    pub fn load_structure(&self) -> Result<Structure, FileError> {
        match &self.structure {
            StructureSource::Reference => {
                reference_bridge(&BridgeParameters::default()).map_err(|e| FileError::Invalid {
                    path: PathBuf::from("reference"),
                    entry: "structure".into(),
                    message: e.to_string(),
                })
            }
            StructureSource::File(p) => read_structure(p),
        }
    }

    /// The model as every measurement command (`lab`, `compare`,
    /// `diagnose`, `calibrate`) runs it: its structure and effects with
    /// [`EffectModel::for_measurement`]'s solver settings and increment.
    pub fn measurement_model(&self) -> Result<EffectModel, FileError> {
        Ok(EffectModel::for_measurement(
            self.load_structure()?,
            self.effects,
        ))
    }

    /// The model file's text. A structure file is written relative to
    /// `dir` when it lies inside it.
    pub fn to_toml(&self, dir: &Path) -> String {
        let structure = match &self.structure {
            StructureSource::Reference => "reference".to_string(),
            StructureSource::File(p) => p
                .strip_prefix(dir)
                .unwrap_or(p)
                .to_string_lossy()
                .into_owned(),
        };
        let doc = ModelDoc {
            format: MODEL_FORMAT.into(),
            structure,
            effects: self.effects,
        };
        toml::to_string(&doc).expect("a model serialises to TOML")
    }
}

/// Writes a model file atomically, refusing to replace an existing file:
/// a calibration never overwrites the model it started from.
pub fn write_new_model(path: &Path, model: &ModelFile) -> Result<(), FileError> {
    if path.exists() {
        return Err(FileError::Invalid {
            path: path.to_path_buf(),
            entry: "file".into(),
            message: "already exists; model files are never overwritten, choose another name"
                .into(),
        });
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    write_atomically(path, model.to_toml(dir).as_bytes())
}

/// The settings of a synthetic lab run, as a truth record names them.
#[derive(Debug, Clone, Copy)]
pub struct LabRun<'a> {
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Cable actuation of each cycle, m.
    pub amplitudes_m: &'a [f64],
    /// Steps each way per cycle.
    pub steps: usize,
    /// Amplitude of the daily temperature swing about 20 °C, K.
    pub swing_k: f64,
}

/// Where `tdeploy lab` records the truth behind the log folder `log_dir`:
/// beside it, `out/log` → `out/log.truth.toml`. It stays outside the log
/// folder: compare, diagnose and calibrate read only the log.
pub fn truth_record_path(log_dir: &Path) -> PathBuf {
    let mut name = log_dir
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "log".into());
    name.push(".truth.toml");
    log_dir.with_file_name(name)
}

/// Checks, before the work, that the truth record of `log_dir` may be
/// written: there is none, the log folder is a results set tdeploy wrote
/// (the record is that set's), or `force`.
pub fn check_truth_record(log_dir: &Path, force: bool) -> Result<(), FileError> {
    let replaces_own = log_dir.join(super::output::RESULTS_MARKER).is_file();
    super::output::check_absent(&truth_record_path(log_dir), force || replaces_own)
}

/// Writes the truth record of the log `log_dir` ([`truth_record_path`]):
/// two comment lines naming the log and the lab run, then `truth` as a
/// model file (a structure file relative to the record's folder).
pub fn write_truth_record(
    log_dir: &Path,
    truth: &ModelFile,
    lab: &LabRun,
) -> Result<(), FileError> {
    let path = truth_record_path(log_dir);
    let record = format!(
        "# The truth behind the log {}: seed {}, amplitudes {:?} m, {} steps each way, temperature 20 ± {} °C.\n# Nothing in compare, diagnose or calibrate reads this file.\n{}",
        log_dir.display(),
        lab.seed,
        lab.amplitudes_m,
        lab.steps,
        lab.swing_k,
        truth.to_toml(path.parent().unwrap_or(Path::new(".")))
    );
    write_atomically(&path, record.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::EffectKind;

    const GOOD: &str = r#"
format = "tensegrity-deploy/model/1"
structure = "reference"

[effects.joint_friction]
mu = 0.12

[effects.motor]
slip_fraction = 0.01
backlash_m = 0.002
"#;

    #[test]
    fn reads_effects_and_leaves_the_rest_off() {
        let m = parse_model(GOOD, Path::new("m.toml")).unwrap();
        assert_eq!(m.structure, StructureSource::Reference);
        assert_eq!(
            m.effects.enabled(),
            vec![EffectKind::JointFriction, EffectKind::Motor]
        );
        assert_eq!(
            m.effects.parameters(EffectKind::Motor),
            Some(vec![0.01, 0.002])
        );
    }

    #[test]
    fn round_trips_through_its_text() {
        let m = parse_model(GOOD, Path::new("m.toml")).unwrap();
        let again = parse_model(&m.to_toml(Path::new(".")), Path::new("m.toml")).unwrap();
        assert_eq!(m, again);
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let typo = GOOD.replace("backlash_m", "backlash");
        let e = parse_model(&typo, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.toml:10:"), "{e}");
        assert!(e.contains("backlash"), "{e}");
        let negative = GOOD.replace("mu = 0.12", "mu = -0.1");
        let e = parse_model(&negative, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "m.toml: line 6, field `effects.joint_friction.mu`: must be ≥ 0, got -0.1"
        );
        let text = "format = \"tensegrity-deploy/model/1\"\nstructure = \"reference\"\n[effects.thermal]\nexpansion_per_k = 1.2e-5\nreference_temperature_c = nan\n";
        let e = parse_model(text, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("m.toml: line 5, field `effects.thermal.reference_temperature_c`: must be a finite number in [-100, 100]"),
            "{e}"
        );
        let text = GOOD.replace("mu = 0.12", "mu = \"high\"");
        let e = parse_model(&text, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.toml:6:"), "{e}");
        let wrong = GOOD.replace("model/1", "model/9");
        let e = parse_model(&wrong, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("format"), "{e}");
    }

    #[test]
    fn never_overwrites_an_existing_model() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        let m = parse_model(GOOD, &path).unwrap();
        write_new_model(&path, &m).unwrap();
        let e = write_new_model(&path, &m).unwrap_err().to_string();
        assert!(e.contains("never overwritten"), "{e}");
        assert_eq!(read_model(&path).unwrap(), m);
    }
}
