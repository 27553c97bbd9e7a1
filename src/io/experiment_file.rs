//! Experiment files (TOML, in `experiments/`): which study to run, with
//! which numbers, and where its results go. The `kind` key picks the
//! study; unknown keys are errors, and every number must be finite and
//! lie in the range given below (else the error names file, line and key).
//!
//! # `kind = "friction-rig"`
//! The seed's friction-rig test matrix ([`FrictionRigExperiment`]):
//! ```toml
//! kind = "friction-rig"
//! mu = 0.2                              # true μ, in [0, 2]
//! convention = "wrap"                   # or "interior"; default "wrap"
//! interior_angles_deg = [117, 146, 170] # each in [1, 179]
//! tensions_kn = [[1, 2], [1, 2], [2]]   # one list per angle; each in [0.001, 100] kN
//! out = "out/friction-rig"
//! ```
//!
//! # `kind = "friction-effect"`
//! The bridge folded and deployed with and without friction
//! ([`FrictionEffectExperiment`]):
//! ```toml
//! kind = "friction-effect"
//! mu = 0.2               # [0, 2]
//! convention = "wrap"    # optional
//! fold_m = 0.05          # payout of every cable, [0, 1] m
//! deploy_m = 0.05        # reel-in afterwards, [0, 1] m
//! increment_m = 0.005    # (0, 0.1] m
//! force_floor_n = 50     # members below this force are left out, [0, 1e6] N
//! out = "out/friction-effect"
//! ```
//!
//! # `kind = "friction-vs-measurement"`
//! A synthetic load-cell measurement against simulations with and without
//! friction ([`FrictionVsMeasurementExperiment`]):
//! ```toml
//! kind = "friction-vs-measurement"
//! actuation_m = 0.05     # (0, 1] m
//! steps = 20             # 1 to 1000
//! model_mu = 0.1         # (0, 2]
//! seed = 1               # of the sensor noise
//! increment_m = 0.0025   # (0, 0.1] m
//! out = "out/friction-vs-measurement"
//!
//! [truth.joint_friction] # the truth's effects, as in a model file
//! mu = 0.1
//! ```
//!
//! # `kind = "deployment"`
//! Policies deploying the same seeded scenarios in closed loop
//! ([`DeploymentExperiment`]; see [`crate::studies::evaluation`]):
//! ```toml
//! kind = "deployment"
//! policies = ["../policies/qp.toml", "../policies/nominal.toml"]  # relative to this file
//! scenarios = 50                  # 1 to 100000
//! seed = 1                        # of the scenario draws and the sensor noise
//! hidden_effects = ["joint_friction", "motor", "stiffness_error"]  # drawn per scenario
//! model_mu = 0.0                  # the controller model's friction, [0, 2]
//! out = "out/deployment"
//! ```
//! `out` is a folder, relative to the working directory.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::toml_text::{field_error, parse_toml};
use super::FileError;
use crate::model::{AngleConvention, EffectKind, Effects};
use crate::numerics::NumberRange;

/// Range of a friction coefficient μ: beyond 2 no cable seat is plausible.
pub const MU_RANGE: NumberRange = NumberRange::non_negative_up_to(2.0);
/// Range of a rig test's interior angle, degrees: the rig's own range
/// ([`crate::design::friction_rig::MIN_RIG_ANGLE_RAD`] to
/// [`crate::design::friction_rig::MAX_RIG_ANGLE_RAD`]); the seat height is
/// 0.2 m / tan(θ/2), 11 m at 1°, and the back-calculation divides by θ and
/// by π − θ.
pub const INTERIOR_ANGLE_RANGE_DEG: NumberRange = NumberRange::closed(1.0, 179.0);
/// Range of a rig test's cable tension, kN: 1 N to 100 kN, twice the
/// breaking load of the rig's 4 mm cable (the seed tested 1 to 3 kN).
pub const TENSION_RANGE_KN: NumberRange = NumberRange::closed(1e-3, 100.0);
/// Range of a cable payout of a whole command (fold, deploy, actuation), m.
pub const PAYOUT_RANGE_M: NumberRange = NumberRange::non_negative_up_to(1.0);
/// Range of a command increment, m.
pub const INCREMENT_RANGE_M: NumberRange = NumberRange::positive_up_to(0.1);
/// Range of the force floor of the friction-effect study, N.
pub const FORCE_FLOOR_RANGE_N: NumberRange = NumberRange::non_negative_up_to(1e6);
/// Most actuation steps of the friction-vs-measurement study.
pub const MAX_STEPS: usize = 1000;

/// The experiments an experiment file can name.
pub const KINDS: [&str; 4] = [
    "friction-rig",
    "friction-effect",
    "friction-vs-measurement",
    "deployment",
];
/// Most scenarios of a deployment experiment.
pub const MAX_SCENARIOS: usize = 100_000;

/// A validated experiment file.
#[derive(Debug, Clone, PartialEq)]
pub enum Experiment {
    /// `kind = "friction-rig"`.
    FrictionRig(FrictionRigExperiment),
    /// `kind = "friction-effect"`.
    FrictionEffect(FrictionEffectExperiment),
    /// `kind = "friction-vs-measurement"` (boxed: its truth's effects,
    /// local faults included, make it the largest kind by far).
    FrictionVsMeasurement(Box<FrictionVsMeasurementExperiment>),
    /// `kind = "deployment"`.
    Deployment(DeploymentExperiment),
}

/// The seed's friction-rig test matrix: for a true μ, the load ratio at
/// which a joint slips at each interior angle and tension.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionRigExperiment {
    /// True friction coefficient.
    pub mu: f64,
    /// Angle in the capstan exponent of the truth.
    pub convention: AngleConvention,
    /// Interior angles tested, degrees.
    pub interior_angles_deg: Vec<f64>,
    /// Cable tensions tested at each angle, kN (one list per angle).
    pub tensions_kn: Vec<Vec<f64>>,
    /// Results folder.
    pub out: PathBuf,
}

/// The reference bridge folded and deployed with and without friction.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionEffectExperiment {
    /// Friction coefficient of the run with friction.
    pub mu: f64,
    /// Angle in the capstan exponent.
    pub convention: AngleConvention,
    /// Payout of every cable first (folding), m.
    pub fold_m: f64,
    /// Reel-in of every cable afterwards (deploying), m.
    pub deploy_m: f64,
    /// Largest command increment, m.
    pub increment_m: f64,
    /// Members below this frictionless force are left out of the force
    /// changes, N.
    pub force_floor_n: f64,
    /// Results folder.
    pub out: PathBuf,
}

/// Policies on the same seeded deployment scenarios.
#[derive(Debug, Clone, PartialEq)]
pub struct DeploymentExperiment {
    /// Policy files, resolved against the experiment file's folder. The
    /// first is the policy under test: the experiment exits 1 if its runs
    /// broke a truth limit or left one the fold broke unrestored; the
    /// others are baselines to compare with.
    pub policies: Vec<PathBuf>,
    /// Number of scenarios.
    pub scenarios: usize,
    /// Seed of the scenario draws.
    pub seed: u64,
    /// Effects hidden in the truths.
    pub hidden_effects: Vec<EffectKind>,
    /// Friction coefficient of the controller's model.
    pub model_mu: f64,
    /// Results folder.
    pub out: PathBuf,
}

/// A synthetic measurement with friction hidden in the truth, against
/// simulations with and without friction.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionVsMeasurementExperiment {
    /// Cable actuation, m.
    pub actuation_m: f64,
    /// Actuation steps each way.
    pub steps: usize,
    /// μ of the simulation with friction.
    pub model_mu: f64,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Largest command increment, m.
    pub increment_m: f64,
    /// The truth's effects.
    pub truth: Effects,
    /// Results folder.
    pub out: PathBuf,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DeploymentDoc {
    #[allow(dead_code)]
    kind: String,
    policies: Vec<PathBuf>,
    scenarios: usize,
    seed: u64,
    hidden_effects: Vec<String>,
    model_mu: f64,
    out: PathBuf,
}

#[derive(Deserialize)]
struct KindDoc {
    kind: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RigDoc {
    #[allow(dead_code)]
    kind: String,
    mu: f64,
    #[serde(default)]
    convention: AngleConvention,
    interior_angles_deg: Vec<f64>,
    tensions_kn: Vec<Vec<f64>>,
    out: PathBuf,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EffectDoc {
    #[allow(dead_code)]
    kind: String,
    mu: f64,
    #[serde(default)]
    convention: AngleConvention,
    fold_m: f64,
    deploy_m: f64,
    increment_m: f64,
    force_floor_n: f64,
    out: PathBuf,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeasurementDoc {
    #[allow(dead_code)]
    kind: String,
    actuation_m: f64,
    steps: usize,
    model_mu: f64,
    seed: u64,
    increment_m: f64,
    truth: Effects,
    out: PathBuf,
}

/// Reads and validates an experiment file.
pub fn read_experiment(path: &Path) -> Result<Experiment, FileError> {
    let text = super::read_text(path)?;
    parse_experiment(&text, path)
}

/// Parses and validates an experiment file; `path` names it in errors.
pub fn parse_experiment(text: &str, path: &Path) -> Result<Experiment, FileError> {
    let check = |key: &str, value: f64, range: NumberRange| {
        range
            .check(value)
            .map_err(|m| field_error(text, path, key, m))
    };
    let kind: KindDoc = parse_toml(text, path)?;
    match kind.kind.as_deref() {
        Some("friction-rig") => {
            let d: RigDoc = parse_toml(text, path)?;
            check("mu", d.mu, MU_RANGE)?;
            if d.interior_angles_deg.len() != d.tensions_kn.len() {
                return Err(field_error(
                    text,
                    path,
                    "tensions_kn",
                    format!(
                        "needs one list per entry of `interior_angles_deg` ({}), has {}",
                        d.interior_angles_deg.len(),
                        d.tensions_kn.len()
                    ),
                ));
            }
            for (i, angle) in d.interior_angles_deg.iter().enumerate() {
                check(
                    &format!("interior_angles_deg[{i}]"),
                    *angle,
                    INTERIOR_ANGLE_RANGE_DEG,
                )?;
            }
            for (i, list) in d.tensions_kn.iter().enumerate() {
                for (j, t) in list.iter().enumerate() {
                    check(&format!("tensions_kn[{i}][{j}]"), *t, TENSION_RANGE_KN)?;
                }
            }
            Ok(Experiment::FrictionRig(FrictionRigExperiment {
                mu: d.mu,
                convention: d.convention,
                interior_angles_deg: d.interior_angles_deg,
                tensions_kn: d.tensions_kn,
                out: d.out,
            }))
        }
        Some("friction-effect") => {
            let d: EffectDoc = parse_toml(text, path)?;
            check("mu", d.mu, MU_RANGE)?;
            check("fold_m", d.fold_m, PAYOUT_RANGE_M)?;
            check("deploy_m", d.deploy_m, PAYOUT_RANGE_M)?;
            check("increment_m", d.increment_m, INCREMENT_RANGE_M)?;
            check("force_floor_n", d.force_floor_n, FORCE_FLOOR_RANGE_N)?;
            Ok(Experiment::FrictionEffect(FrictionEffectExperiment {
                mu: d.mu,
                convention: d.convention,
                fold_m: d.fold_m,
                deploy_m: d.deploy_m,
                increment_m: d.increment_m,
                force_floor_n: d.force_floor_n,
                out: d.out,
            }))
        }
        Some("deployment") => {
            let d: DeploymentDoc = parse_toml(text, path)?;
            if d.policies.is_empty() {
                return Err(field_error(
                    text,
                    path,
                    "policies",
                    "names no policy file".into(),
                ));
            }
            if !(1..=MAX_SCENARIOS).contains(&d.scenarios) {
                return Err(field_error(
                    text,
                    path,
                    "scenarios",
                    format!("must be 1 to {MAX_SCENARIOS}, got {}", d.scenarios),
                ));
            }
            check("model_mu", d.model_mu, MU_RANGE)?;
            let mut hidden_effects = Vec::new();
            for (i, name) in d.hidden_effects.iter().enumerate() {
                let Some(kind) = EffectKind::ALL.iter().find(|k| k.name() == name) else {
                    let names: Vec<&str> = EffectKind::ALL.iter().map(|k| k.name()).collect();
                    return Err(field_error(
                        text,
                        path,
                        &format!("hidden_effects[{i}]"),
                        format!("unknown effect `{name}`; known: {}", names.join(", ")),
                    ));
                };
                hidden_effects.push(*kind);
            }
            let folder = path.parent().unwrap_or(Path::new(""));
            Ok(Experiment::Deployment(DeploymentExperiment {
                policies: d.policies.iter().map(|p| folder.join(p)).collect(),
                scenarios: d.scenarios,
                seed: d.seed,
                hidden_effects,
                model_mu: d.model_mu,
                out: d.out,
            }))
        }
        Some("friction-vs-measurement") => {
            let d: MeasurementDoc = parse_toml(text, path)?;
            check(
                "actuation_m",
                d.actuation_m,
                NumberRange {
                    min_exclusive: true,
                    ..PAYOUT_RANGE_M
                },
            )?;
            if !(1..=MAX_STEPS).contains(&d.steps) {
                return Err(field_error(
                    text,
                    path,
                    "steps",
                    format!("must be 1 to {MAX_STEPS}, got {}", d.steps),
                ));
            }
            check(
                "model_mu",
                d.model_mu,
                NumberRange {
                    min_exclusive: true,
                    ..MU_RANGE
                },
            )?;
            check("increment_m", d.increment_m, INCREMENT_RANGE_M)?;
            d.truth.validate().map_err(|e| {
                field_error(
                    text,
                    path,
                    &format!("truth.{}.{}", e.effect, e.parameter),
                    e.reason,
                )
            })?;
            super::model_file::check_reference_temperature(&d.truth, "truth", text, path)?;
            Ok(Experiment::FrictionVsMeasurement(Box::new(
                FrictionVsMeasurementExperiment {
                    actuation_m: d.actuation_m,
                    steps: d.steps,
                    model_mu: d.model_mu,
                    seed: d.seed,
                    increment_m: d.increment_m,
                    truth: d.truth,
                    out: d.out,
                },
            )))
        }
        Some(other) => Err(field_error(
            text,
            path,
            "kind",
            format!(
                "unknown experiment \"{other}\" (known: {})",
                KINDS.join(", ")
            ),
        )),
        None => Err(FileError::Invalid {
            path: path.to_path_buf(),
            entry: "field `kind`".into(),
            message: format!("missing (one of {})", KINDS.join(", ")),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EFFECT: &str = "kind = \"friction-effect\"\nmu = 0.2\nfold_m = 0.05\ndeploy_m = 0.05\nincrement_m = 0.005\nforce_floor_n = 50\nout = \"out/x\"\n";

    fn error(text: &str) -> String {
        parse_experiment(text, Path::new("e.toml"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn the_shipped_experiments_parse() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments");
        for (name, kind) in [
            ("friction-rig.toml", "friction-rig"),
            ("friction-effect.toml", "friction-effect"),
            ("friction-vs-measurement.toml", "friction-vs-measurement"),
            ("deployment.toml", "deployment"),
        ] {
            let e = read_experiment(&dir.join(name)).unwrap();
            let got = match e {
                Experiment::FrictionRig(_) => KINDS[0],
                Experiment::FrictionEffect(_) => KINDS[1],
                Experiment::FrictionVsMeasurement(_) => KINDS[2],
                Experiment::Deployment(_) => KINDS[3],
            };
            assert_eq!(got, kind);
        }
    }

    #[test]
    fn deployment_experiments_name_bad_fields() {
        let good = "kind = \"deployment\"\npolicies = [\"p.toml\"]\nscenarios = 5\nseed = 1\nhidden_effects = [\"motor\"]\nmodel_mu = 0\nout = \"o\"\n";
        match parse_experiment(good, Path::new("d/e.toml")).unwrap() {
            Experiment::Deployment(d) => {
                assert_eq!(d.policies, vec![Path::new("d/p.toml").to_path_buf()]);
                assert_eq!(d.hidden_effects, vec![EffectKind::Motor]);
            }
            other => panic!("{other:?}"),
        }
        assert!(
            error(&good.replace("\"motor\"", "\"gremlins\"")).contains("unknown effect `gremlins`")
        );
        assert!(error(&good.replace("scenarios = 5", "scenarios = 0"))
            .starts_with("e.toml: line 3, field `scenarios`"));
        assert!(error(&good.replace("model_mu = 0", "model_mu = -1"))
            .starts_with("e.toml: line 6, field `model_mu`"));
    }

    #[test]
    fn numbers_out_of_range_name_line_and_field() {
        assert_eq!(
            error(&EFFECT.replace("increment_m = 0.005", "increment_m = 0")),
            "e.toml: line 5, field `increment_m`: must be a finite number in (0, 0.1], got 0"
        );
        assert!(error(&EFFECT.replace("mu = 0.2", "mu = nan"))
            .starts_with("e.toml: line 2, field `mu`: must be a finite number"));
        let rig = "kind = \"friction-rig\"\nmu = 0.2\ninterior_angles_deg = [117, 180]\ntensions_kn = [[1], [1]]\nout = \"o\"\n";
        assert!(error(rig).starts_with("e.toml: line 3, field `interior_angles_deg[1]`"));
        let rig = rig
            .replace("[[1], [1]]", "[[1], [1, -2]]")
            .replace("180", "170");
        assert!(error(&rig).starts_with("e.toml: line 4, field `tensions_kn[1][1]`"));
        let rig = rig.replace("[[1], [1, -2]]", "[[1]]");
        assert!(error(&rig).contains("field `tensions_kn`: needs one list per entry"));
    }

    #[test]
    fn kind_and_truth_errors_name_the_field() {
        assert_eq!(
            error("kind = \"warp\"\n"),
            "e.toml: line 1, field `kind`: unknown experiment \"warp\" (known: friction-rig, friction-effect, friction-vs-measurement, deployment)"
        );
        assert!(error("mu = 1\n").contains("field `kind`: missing"));
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/friction-vs-measurement.toml"),
        )
        .unwrap();
        let e = error(&text.replace("seat_radius_m = 0.01", "seat_radius_m = -0.01"));
        assert!(
            e.contains("field `truth.joint_eccentricity.seat_radius_m`: must"),
            "{e}"
        );
        let e = error(&text.replace("steps = 20", "steps = 0"));
        assert!(e.contains("field `steps`: must be 1 to 1000"), "{e}");
    }

    #[test]
    fn syntax_and_unknown_keys_give_line_and_column_on_one_line() {
        let e = error(&EFFECT.replace("fold_m = 0.05", "fold_m = 0.05 0.06"));
        assert!(e.starts_with("e.toml:3:"), "{e}");
        assert_eq!(e.lines().count(), 1);
        let e = error(&EFFECT.replace("fold_m", "fold"));
        assert!(e.starts_with("e.toml:3:1: ") && e.contains("fold"), "{e}");
    }
}
