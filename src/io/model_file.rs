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
//! # or, instead of `mu`, μ over the interior angle (linear between the
//! # points, held beyond them; calibration scales the table's level):
//! # mu_over_angle = { interior_angle_deg = [117, 146, 170], mu = [0.14, 0.10, 0.05] }
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
//!
//! # Local faults: one part each, named by its id in the structure.
//! [faults.drum_zero_error]
//! motor = "A_cc1"            # the motor's continuous cable
//! offset_m = 0.015           # drum zeroed 15 mm off: cable 15 mm slacker
//!
//! [faults.member_error]
//! member = "A_strut_m0_a1"
//! rest_length_error_m = 0.005  # 5 mm long
//! stiffness_scale = 1.0
//!
//! [faults.half_difference]
//! half = "B"                 # "A" or "B"
//! strut_scale = 1.0
//! cable_scale = 0.85
//! spring_scale = 1.0
//! joint_mass_scale = 1.0
//!
//! # How the model's path is computed (not what the bridge is).
//! [solver]
//! slip_event_substeps = true # split increments at joints' slip events
//! ```
//! A missing `[effects.*]` table is an effect switched off. Every effect,
//! its physics, parameters, units and plausible ranges are documented in
//! [`crate::model::effects`]. Unknown keys are errors, not ignored.
//!
//! The `[solver]` table ([`ModelSolver`]) holds what a model file says
//! about the computation rather than the bridge: left out, every setting
//! is off. It travels with the model, so a deployment's `truth.toml`
//! reproduces the truth it ran (with `--slip-event-substeps` it records
//! `slip_event_substeps = true`), and a controller's model file can ask
//! for the more exact path too.
//!
//! A `[faults.*]` table is a local fault ([`crate::model::faults`]): its
//! part by id (key `motor`, `member` or `half`, [`FaultKind::part_key`])
//! and its parameters ([`FaultKind::parameters`]); a parameter left out
//! takes its neutral value (no error of that kind). The ids are resolved
//! against the model's structure when the file is read, so a model file
//! with faults loads its structure then; an unknown id, a parameter out
//! of its admissible range or a rest length a fault makes non-positive is
//! an error naming the file, line and field.
//!
//! Written as: a calibrated model (`tdeploy calibrate -o`,
//! [`write_new_model`], never over an existing file); `truth.toml` and
//! `model.toml` of a deployment ([`super::deployment_files`]); the truth
//! record `LOG.truth.toml` beside a synthetic log ([`write_truth_record`]:
//! the model file after two `#` comment lines naming the lab run).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::structure_file::read_structure;
use super::toml_text::{field_error, parse_toml};
use super::{write_atomically, FileError};
use crate::design::{reference_bridge, BridgeParameters};
use crate::model::{Effects, FaultKind, Faults, RelaxSettings, Structure};
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

/// A model: a structure, the effects on it, and how its path is solved.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelFile {
    /// The structure.
    pub structure: StructureSource,
    /// The effects switched on.
    pub effects: Effects,
    /// The solver settings the file sets (`[solver]`; all off when left out).
    pub solver: ModelSolver,
}

/// The solver settings a model file may set: how the model's path is
/// computed, not what the bridge is. Each is off when left out, which is
/// how every tool solved a model file before the table existed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSolver {
    /// Split each increment in which a joint reverses or stops, down to
    /// about 1 mm ([`RelaxSettings::slip_event_substeps_enable`]). The
    /// model error it removes: a joint that slips and re-grips inside one
    /// 1 cm increment is mapped once at the increment's end, so the path
    /// through a reversal depends on the increment size (1.7 mm between
    /// 1 cm and 1 mm increments over a 5 cm reel-in and pay-out at μ 0.2,
    /// 62 µm with the setting) and the dip of the far segments at a
    /// reversal is hidden. About 1.1–1.2× the time of a path with
    /// friction (1.17× the 40 cm deployment at μ 0.2, 1.11× a closed-loop
    /// deployment of the default truth); nothing changes without joint
    /// friction. Default off.
    #[serde(default)]
    pub slip_event_substeps: bool,
}

impl ModelSolver {
    /// Whether every setting is off (the table is then not written).
    pub fn is_default(&self) -> bool {
        *self == ModelSolver::default()
    }

    /// `settings` with this table's settings applied.
    pub fn apply_to(&self, settings: &mut RelaxSettings) {
        settings.slip_event_substeps_enable = self.slip_event_substeps;
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelDoc {
    format: String,
    structure: String,
    #[serde(default, skip_serializing_if = "ModelSolver::is_default")]
    solver: ModelSolver,
    #[serde(default)]
    effects: Effects,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    faults: BTreeMap<String, BTreeMap<String, toml::Value>>,
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
    let mut model = ModelFile {
        structure,
        effects: doc.effects,
        solver: doc.solver,
    };
    if !doc.faults.is_empty() {
        model.effects.faults = read_faults(&doc.faults, &model, text, path)?;
    }
    Ok(model)
}

/// The `[faults.*]` tables resolved against `model`'s structure (see the
/// module notes).
fn read_faults(
    tables: &BTreeMap<String, BTreeMap<String, toml::Value>>,
    model: &ModelFile,
    text: &str,
    path: &Path,
) -> Result<Faults, FileError> {
    let structure = model.load_structure()?;
    let mut faults = Faults::default();
    for (name, table) in tables {
        let at = |key: &str| format!("faults.{name}.{key}");
        let kind = FaultKind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .ok_or_else(|| {
                field_error(
                    text,
                    path,
                    &format!("faults.{name}"),
                    format!(
                        "unknown fault (known: {})",
                        FaultKind::ALL.map(|k| k.name()).join(", ")
                    ),
                )
            })?;
        for key in table.keys() {
            if key != kind.part_key() && !kind.parameters().iter().any(|p| p.name == key) {
                return Err(field_error(
                    text,
                    path,
                    &at(key),
                    format!(
                        "unknown key of {name} (its keys: {}, {})",
                        kind.part_key(),
                        kind.parameters()
                            .iter()
                            .map(|p| p.name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
        }
        let id = match table.get(kind.part_key()) {
            Some(toml::Value::String(id)) => id,
            Some(_) => {
                return Err(field_error(
                    text,
                    path,
                    &at(kind.part_key()),
                    "must be a string: the part's id".into(),
                ))
            }
            None => {
                return Err(field_error(
                    text,
                    path,
                    &format!("faults.{name}"),
                    format!("missing key `{}`: which part is faulty", kind.part_key()),
                ))
            }
        };
        let part = kind.find_part(&structure, id).ok_or_else(|| {
            field_error(
                text,
                path,
                &at(kind.part_key()),
                format!(
                    "no {} \"{id}\" in the structure (e.g. \"{}\")",
                    kind.part_key(),
                    kind.part_id(&structure, 0)
                ),
            )
        })?;
        let mut values = Vec::new();
        for spec in kind.parameters() {
            values.push(match table.get(spec.name) {
                None => spec.neutral,
                Some(toml::Value::Float(v)) => *v,
                Some(toml::Value::Integer(v)) => *v as f64,
                Some(_) => {
                    return Err(field_error(
                        text,
                        path,
                        &at(spec.name),
                        format!("must be a number, {}", spec.unit),
                    ))
                }
            });
        }
        faults = faults.with_fault(kind, part, &values);
    }
    faults.validate().map_err(|e| {
        field_error(
            text,
            path,
            &format!("faults.{}.{}", e.fault, e.parameter),
            e.reason.clone(),
        )
    })?;
    faults.apply(&structure).map_err(|e| {
        // A part that is not there, or else the one check a fault can
        // fail in a valid structure: a rest length made non-positive.
        let key = match &e {
            crate::model::structure::StructureError::BadFault { fault, .. } => {
                format!("faults.{fault}")
            }
            _ => "faults.member_error.rest_length_error_m".to_string(),
        };
        field_error(text, path, &key, e.to_string())
    })?;
    Ok(faults)
}

/// The `[faults.*]` tables of `faults` on `structure` (`None`: the
/// structure could not be loaded; parts are then named `#INDEX`, which no
/// reader accepts).
fn fault_tables(
    faults: &Faults,
    structure: Option<&Structure>,
) -> BTreeMap<String, BTreeMap<String, toml::Value>> {
    faults
        .present()
        .into_iter()
        .filter_map(|kind| {
            let (part, values) = faults.part_and_parameters(kind)?;
            let id = match structure {
                Some(s) if part < kind.part_count(s) => kind.part_id(s, part),
                _ => format!("#{part}"),
            };
            let mut table = BTreeMap::new();
            table.insert(kind.part_key().to_string(), toml::Value::String(id));
            for (spec, v) in kind.parameters().iter().zip(values) {
                table.insert(spec.name.to_string(), toml::Value::Float(v));
            }
            Some((kind.name().to_string(), table))
        })
        .collect()
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
    /// [`EffectModel::for_measurement`]'s solver settings and increment,
    /// and the file's `[solver]` settings over them.
    pub fn measurement_model(&self) -> Result<EffectModel, FileError> {
        Ok(self.measurement_model_on(self.load_structure()?))
    }

    /// [`Self::measurement_model`] on `structure`, already loaded from
    /// the file's structure source.
    pub fn measurement_model_on(&self, structure: Structure) -> EffectModel {
        let mut model = EffectModel::for_measurement(structure, self.effects.clone());
        self.solver.apply_to(&mut model.settings);
        model
    }

    /// The model file's text. A structure file is written relative to
    /// `dir` when it lies inside it. Faults name their parts by id, read
    /// from the structure (loaded again for that).
    pub fn to_toml(&self, dir: &Path) -> String {
        let structure = match &self.structure {
            StructureSource::Reference => "reference".to_string(),
            StructureSource::File(p) => p
                .strip_prefix(dir)
                .unwrap_or(p)
                .to_string_lossy()
                .into_owned(),
        };
        let faults = if self.effects.faults.is_empty() {
            BTreeMap::new()
        } else {
            fault_tables(&self.effects.faults, self.load_structure().ok().as_ref())
        };
        let doc = ModelDoc {
            format: MODEL_FORMAT.into(),
            structure,
            solver: self.solver,
            effects: self.effects.clone(),
            faults,
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

    /// A model file's `[solver]` table: read, applied to the model every
    /// tool builds from the file, written back; left out it is off and
    /// not written (files from before the table read as they did).
    #[test]
    fn a_model_file_asks_for_slip_event_substeps_in_its_solver_table() {
        let plain = parse_model(GOOD, Path::new("m.toml")).unwrap();
        assert!(plain.solver.is_default());
        assert!(!plain.to_toml(Path::new(".")).contains("[solver]"));
        let text = GOOD.replace(
            "[effects.joint_friction]",
            "[solver]\nslip_event_substeps = true\n\n[effects.joint_friction]",
        );
        let m = parse_model(&text, Path::new("m.toml")).unwrap();
        assert!(m.solver.slip_event_substeps);
        assert!(
            m.measurement_model()
                .unwrap()
                .settings
                .slip_event_substeps_enable
        );
        assert!(
            !plain
                .measurement_model()
                .unwrap()
                .settings
                .slip_event_substeps_enable
        );
        let again = parse_model(&m.to_toml(Path::new(".")), Path::new("m.toml")).unwrap();
        assert_eq!(m, again);
        let typo = text.replace("slip_event_substeps =", "slip_events =");
        let e = parse_model(&typo, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("m.toml:6:") && e.contains("slip_events"),
            "{e}"
        );
        let not_a_flag = text.replace("= true", "= 1");
        let e = parse_model(&not_a_flag, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.toml:6:"), "{e}");
    }

    /// Issue 24, item 5: the seed's main finding, μ falling with the
    /// interior angle, in a model file.
    #[test]
    fn a_model_file_takes_mu_as_a_table_over_the_interior_angle() {
        let table = GOOD.replace(
            "mu = 0.12",
            "mu_over_angle = { interior_angle_deg = [117, 146, 170], mu = [0.14, 0.10, 0.05] }",
        );
        let m = parse_model(&table, Path::new("m.toml")).unwrap();
        let law = m.effects.joint_friction();
        let at = |deg: f64| law.static_mu.at(f64::to_radians(deg));
        assert!((at(146.0) - 0.10).abs() < 1e-12);
        assert!((at(158.0) - 0.075).abs() < 1e-12);
        // Calibration sees one parameter, the table's level.
        let level = m.effects.parameters(EffectKind::JointFriction).unwrap();
        assert!((level[0] - 0.29 / 3.0).abs() < 1e-15);
        let again = parse_model(&m.to_toml(Path::new(".")), Path::new("m.toml")).unwrap();
        let back = again.effects.joint_friction.unwrap().tabulated_mu();
        for (a, b) in back.iter().zip([0.14, 0.10, 0.05]) {
            assert!((a - b).abs() < 1e-15, "{a} vs {b}");
        }
        let both = table.replace("mu_over_angle", "mu = 0.1\nmu_over_angle");
        let e = parse_model(&both, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.toml:5:"), "{e}");
        assert!(e.contains("not both"), "{e}");
        let bad = table.replace("[117, 146, 170]", "[117, 196, 170]");
        let e = parse_model(&bad, Path::new("m.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("interior_angle_deg[1]"), "{e}");
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

    const FAULTY: &str = r#"format = "tensegrity-deploy/model/1"
structure = "reference"

[faults.drum_zero_error]
motor = "A_cc1"
offset_m = 0.015

[faults.member_error]
member = "A_strut_m0_a1"
rest_length_error_m = 0.005

[faults.half_difference]
half = "B"
cable_scale = 0.85
"#;

    #[test]
    fn reads_faults_by_part_id_and_writes_them_back() {
        let m = parse_model(FAULTY, Path::new("m.toml")).unwrap();
        let s = m.load_structure().unwrap();
        let f = m.effects.faults;
        assert_eq!(f.present(), FaultKind::ALL.to_vec());
        let drum = f.drum_zero_error.unwrap();
        assert_eq!(s.continuous_cables[drum.cable].id, "A_cc1");
        assert_eq!(drum.offset_m, 0.015);
        let member = f.member_error.unwrap();
        assert_eq!(s.members[member.member].id, "A_strut_m0_a1");
        // Left out: neutral.
        assert_eq!(
            (member.rest_length_error_m, member.stiffness_scale),
            (0.005, 1.0)
        );
        let half = f.half_difference.unwrap();
        assert_eq!(half.half, crate::model::Half::B);
        assert_eq!((half.cable_scale, half.strut_scale), (0.85, 1.0));
        assert!(m.effects.enabled().is_empty(), "faults are no effect kinds");
        let text = m.to_toml(Path::new("."));
        assert!(text.contains("motor = \"A_cc1\""), "{text}");
        assert_eq!(parse_model(&text, Path::new("m.toml")).unwrap(), m);
    }

    #[test]
    fn fault_errors_name_file_line_and_field() {
        let cases = [
            (
                FAULTY.replace("\"A_strut_m0_a1\"", "\"A_strut_m9\""),
                "m.toml: line 9, field `faults.member_error.member`: no member \"A_strut_m9\" in the structure",
            ),
            (
                FAULTY.replace("offset_m = 0.015", "offset_m = \"far\""),
                "m.toml: line 6, field `faults.drum_zero_error.offset_m`: must be a number, m",
            ),
            (
                FAULTY.replace("cable_scale = 0.85", "cable_scale = 0"),
                "m.toml: line 14, field `faults.half_difference.cable_scale`: must be ≥ 0.001, got 0",
            ),
            (
                FAULTY.replace("cable_scale = 0.85", "cable_scal = 0.85"),
                "m.toml: line 14, field `faults.half_difference.cable_scal`: unknown key",
            ),
            (
                FAULTY.replace("half = \"B\"", "half = \"C\""),
                "m.toml: line 13, field `faults.half_difference.half`: no half \"C\"",
            ),
            (
                FAULTY.replace("rest_length_error_m = 0.005", "rest_length_error_m = -9.0"),
                "m.toml: line 10, field `faults.member_error.rest_length_error_m`: struts[3] (\"A_strut_m0_a1\"): field `rest_length_m` must be positive",
            ),
            (
                FAULTY.replace("[faults.member_error]", "[faults.member_eror]"),
                "m.toml: line 8, field `faults.member_eror`: unknown fault",
            ),
        ];
        for (text, want) in cases {
            let e = parse_model(&text, Path::new("m.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(want), "{e}\nwanted {want}");
            assert!(!e.contains('\n'), "{e}");
        }
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
