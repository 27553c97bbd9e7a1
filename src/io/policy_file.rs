//! Policy files (TOML): top-level name, command budget and forward-solve
//! increment, then one table per section of [`crate::plan::Policy`].
//! `policies/` holds the four shipped ones, each commented.
//!
//! ```toml
//! format = "tensegrity-deploy/policy/2"
//! name = "qp"
//! max_commands = 40
//! increment_m = 0.01
//! [planner]
//! kind = "qp"                     # "nominal", "greedy_tree" or "qp"
//! sensitivity_step_m = 0.05
//! [planner.trust_region]          # the QP planner's own settings
//! initial_m = 0.05
//! [planner.weights]
//! gap = [1.0]
//! [margins]
//! connection_m = 0.005
//! unmeasured_force_fall = 0.4     # a number, or "off"
//! [control]
//! measures = ["midspan_positions", "load_cells"]
//! [memory]                        # optional: absent, the policy does not learn
//! neighbours = 8
//! ```
//! Every field may be left out (the default of [`crate::plan::Policy`]
//! applies; `[planner]` needs its `kind`, and then takes that planner's
//! defaults); unknown keys are errors. A setting that can be switched off
//! takes a number or `"off"`. Errors name file, line and field.
//!
//! **Format 1** (`tensegrity-deploy/policy/1`, before the sections) is
//! refused with an error naming `tdeploy policy migrate OLD -o NEW`, which
//! writes the same policy in this format ([`migrate_policy`]): planner
//! settings move under `[planner]` (`planner = "qp"` becomes `kind`,
//! `greedy_move_m` becomes `move_m`, `greedy_min_move_m` `min_move_m`,
//! `[trust_region]` and `[weights]` become `[planner.trust_region]` and
//! `[planner.weights]`), the margins under `[margins]`
//! (`connection_margin_m` becomes `connection_m`, `force_margin_n`
//! `force_n`, `clearance_margin_m` `clearance_m`,
//! `unmeasured_force_fall_margin` `unmeasured_force_fall`), and
//! `measures`, `payout_scale_prior_sd`, `payout_scale_drift_sd` and
//! `force_model_error_fraction` under `[control]`; a 0 that switched a
//! setting off becomes `"off"`; settings the named planner never read are
//! left out.

use std::path::Path;

use serde::Deserialize;

use super::problem_file::parse_versioned;
use super::toml_text::field_error;
use super::FileError;
use crate::plan::{
    ControlSettings, GreedyTreeSettings, Margins, Measurement, MemorySettings, NominalSettings,
    PlannerSettings, Policy, QpPlannerSettings, SensitivityKind, TrustRegion, Weights,
};

/// The `format` a policy file must declare.
pub const POLICY_FORMAT: &str = "tensegrity-deploy/policy/2";

/// The flat format before the policy had sections (read only by
/// [`migrate_policy`]).
pub const POLICY_FORMAT_1: &str = "tensegrity-deploy/policy/1";

/// Reads and validates a policy file.
pub fn read_policy(path: &Path) -> Result<Policy, FileError> {
    let text = super::read_text(path)?;
    parse_policy(&text, path)
}

/// Parses a policy file; `path` names it in errors.
pub fn parse_policy(text: &str, path: &Path) -> Result<Policy, FileError> {
    if declared_format(text).as_deref() == Some(POLICY_FORMAT_1) {
        return Err(field_error(
            text,
            path,
            "format",
            format!(
                "\"{POLICY_FORMAT_1}\" is the old flat policy format; \"{POLICY_FORMAT}\" groups \
                 the settings in [planner] (with kind), [margins] and [control] and writes \"off\" \
                 where 0 switched a setting off: convert it with `tdeploy policy migrate {} -o NEW`",
                path.display()
            ),
        ));
    }
    let policy: Policy = parse_versioned(text, path, POLICY_FORMAT)?;
    policy
        .validate()
        .map_err(|e| field_error(text, path, &e.field, e.reason))?;
    Ok(policy)
}

/// The `format` a TOML text declares, if it parses and has one.
fn declared_format(text: &str) -> Option<String> {
    let table: toml::Table = toml::from_str(text).ok()?;
    table.get("format")?.as_str().map(str::to_string)
}

/// The text of a policy file for `policy`, every field written out.
/// [`parse_policy`] reads it back.
pub fn policy_to_toml(policy: &Policy) -> String {
    // A policy is plain numbers, words and lists: serialising cannot fail.
    let body = toml::to_string(policy).expect("a policy serialises to TOML");
    format!("format = \"{POLICY_FORMAT}\"\n{body}")
}

/// The format-1 policy file at `path` read as the policy it stood for,
/// with notes (see [`migrate_policy`]).
pub fn read_policy_to_migrate(path: &Path) -> Result<(Policy, Vec<String>), FileError> {
    let text = super::read_text(path)?;
    migrate_policy(&text, path)
}

/// A format-1 policy file read as the policy it stood for, with notes on
/// what did not carry over (settings the named planner never read); `path`
/// names the file in errors.
pub fn migrate_policy(text: &str, path: &Path) -> Result<(Policy, Vec<String>), FileError> {
    let old: PolicyV1 = parse_versioned(text, path, POLICY_FORMAT_1)?;
    let (policy, notes) = old.into_policy();
    // Format 1 had the same ranges: a file that fails here was refused
    // before too; the field is named as format 2 names it.
    policy.validate().map_err(|e| FileError::Invalid {
        path: path.to_path_buf(),
        entry: format!("field `{}` (in format 2)", e.field),
        message: e.reason,
    })?;
    Ok((policy, notes))
}

/// A format-1 policy file: every field optional (left out: the default,
/// which format 2 keeps).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PolicyV1 {
    name: Option<String>,
    planner: Option<PlannerKindV1>,
    max_commands: Option<usize>,
    increment_m: Option<f64>,
    connection_margin_m: Option<f64>,
    force_margin_n: Option<f64>,
    unmeasured_force_fall_margin: Option<f64>,
    clearance_margin_m: Option<f64>,
    clearance_watch_m: Option<f64>,
    sensitivity_step_m: Option<f64>,
    sensitivities: Option<SensitivityKind>,
    sensitivity_reuse_tolerance: Option<f64>,
    greedy_move_m: Option<f64>,
    greedy_min_move_m: Option<f64>,
    trust_region: Option<TrustRegion>,
    weights: Option<WeightsV1>,
    measures: Option<Vec<Measurement>>,
    payout_scale_prior_sd: Option<f64>,
    payout_scale_drift_sd: Option<f64>,
    force_model_error_fraction: Option<f64>,
    memory: Option<MemorySettings>,
}

/// Format 1's `planner`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(rename_all = "snake_case")]
enum PlannerKindV1 {
    Nominal,
    GreedyTree,
    Qp,
}

/// Format 1's `[weights]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WeightsV1 {
    gap: Option<Vec<f64>>,
    regularisation: Option<f64>,
    split_penalty: Option<f64>,
    soft_limit_penalty: Option<f64>,
}

/// A format-1 value where 0 switched the setting off.
fn off_if_zero(value: f64) -> Option<f64> {
    (value != 0.0).then_some(value)
}

impl PolicyV1 {
    /// The policy this file stood for, and notes on what was left out.
    fn into_policy(self) -> (Policy, Vec<String>) {
        let (policy, margins, control) = (
            Policy::default(),
            Margins::default(),
            ControlSettings::default(),
        );
        let qp = QpPlannerSettings::default();
        let greedy = GreedyTreeSettings::default();
        let kind = self.planner.unwrap_or(PlannerKindV1::Qp);
        let mut notes = Vec::new();
        let mut unread = |given: bool, field: &str, reader: &str| {
            if given {
                notes.push(format!("`{field}` left out: only the {reader} read it"));
            }
        };
        if kind != PlannerKindV1::Qp {
            unread(
                self.sensitivity_step_m.is_some(),
                "sensitivity_step_m",
                "QP planner",
            );
            unread(self.sensitivities.is_some(), "sensitivities", "QP planner");
            unread(
                self.sensitivity_reuse_tolerance.is_some(),
                "sensitivity_reuse_tolerance",
                "QP planner",
            );
            unread(self.trust_region.is_some(), "trust_region", "QP planner");
            unread(self.weights.is_some(), "weights", "QP planner");
        }
        if kind != PlannerKindV1::GreedyTree {
            unread(self.greedy_move_m.is_some(), "greedy_move_m", "greedy tree");
            unread(
                self.greedy_min_move_m.is_some(),
                "greedy_min_move_m",
                "greedy tree",
            );
        }
        let planner = match kind {
            PlannerKindV1::Nominal => PlannerSettings::Nominal(NominalSettings {}),
            PlannerKindV1::GreedyTree => PlannerSettings::GreedyTree(GreedyTreeSettings {
                move_m: self.greedy_move_m.unwrap_or(greedy.move_m),
                min_move_m: self.greedy_min_move_m.unwrap_or(greedy.min_move_m),
            }),
            PlannerKindV1::Qp => {
                let w = self.weights.unwrap_or(WeightsV1 {
                    gap: None,
                    regularisation: None,
                    split_penalty: None,
                    soft_limit_penalty: None,
                });
                PlannerSettings::Qp(QpPlannerSettings {
                    sensitivities: self.sensitivities.unwrap_or(qp.sensitivities),
                    sensitivity_step_m: self.sensitivity_step_m.unwrap_or(qp.sensitivity_step_m),
                    sensitivity_reuse_tolerance: self
                        .sensitivity_reuse_tolerance
                        .map_or(qp.sensitivity_reuse_tolerance, off_if_zero),
                    trust_region: self.trust_region.unwrap_or(qp.trust_region),
                    weights: Weights {
                        gap: w.gap.unwrap_or(qp.weights.gap),
                        design_position: qp.weights.design_position,
                        regularisation: w.regularisation.unwrap_or(qp.weights.regularisation),
                        split_penalty: w.split_penalty.unwrap_or(qp.weights.split_penalty),
                        soft_limit_penalty: w
                            .soft_limit_penalty
                            .map_or(qp.weights.soft_limit_penalty, off_if_zero),
                    },
                })
            }
        };
        let policy = Policy {
            name: self.name.unwrap_or(policy.name),
            max_commands: self.max_commands.unwrap_or(policy.max_commands),
            increment_m: self.increment_m.unwrap_or(policy.increment_m),
            planner,
            margins: Margins {
                connection_m: self.connection_margin_m.unwrap_or(margins.connection_m),
                force_n: self.force_margin_n.unwrap_or(margins.force_n),
                unmeasured_force_fall: self
                    .unmeasured_force_fall_margin
                    .map_or(margins.unmeasured_force_fall, off_if_zero),
                clearance_m: self.clearance_margin_m.unwrap_or(margins.clearance_m),
                clearance_watch_m: self.clearance_watch_m.unwrap_or(margins.clearance_watch_m),
            },
            control: ControlSettings {
                measures: self.measures.unwrap_or(control.measures),
                payout_scale_prior_sd: self
                    .payout_scale_prior_sd
                    .map_or(control.payout_scale_prior_sd, off_if_zero),
                payout_scale_drift_sd: self
                    .payout_scale_drift_sd
                    .unwrap_or(control.payout_scale_drift_sd),
                force_model_error_fraction: self
                    .force_model_error_fraction
                    .unwrap_or(control.force_model_error_fraction),
                load_cell_bias_prior_sd_n: control.load_cell_bias_prior_sd_n,
                drum_offset_prior_sd_m: control.drum_offset_prior_sd_m,
            },
            memory: self.memory,
        };
        (policy, notes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_policies_parse() {
        for (name, text) in [
            ("nominal", include_str!("../../policies/nominal.toml")),
            (
                "greedy-tree",
                include_str!("../../policies/greedy-tree.toml"),
            ),
            ("qp", include_str!("../../policies/qp.toml")),
            ("memory", include_str!("../../policies/memory.toml")),
        ] {
            let p = parse_policy(text, Path::new(name)).unwrap_or_else(|e| panic!("{e}"));
            assert!(!p.name.is_empty());
        }
    }

    #[test]
    fn a_written_policy_reads_back_equal() {
        let mut policy = Policy {
            memory: Some(MemorySettings::default()),
            ..Policy::default()
        };
        policy.margins.unmeasured_force_fall = None;
        let text = policy_to_toml(&policy);
        assert_eq!(parse_policy(&text, Path::new("p.toml")).unwrap(), policy);
        for planner in [
            PlannerSettings::GreedyTree(GreedyTreeSettings::default()),
            PlannerSettings::Nominal(NominalSettings {}),
        ] {
            let other = Policy {
                planner,
                ..Policy::default()
            };
            let text = policy_to_toml(&other);
            assert_eq!(parse_policy(&text, Path::new("p.toml")).unwrap(), other);
        }
    }

    #[test]
    fn format_1_is_refused_naming_the_migration_and_migrates() {
        let old = "format = \"tensegrity-deploy/policy/1\"\nplanner = \"greedy_tree\"\n\
                   greedy_move_m = 0.04\nsensitivity_step_m = 0.02\n\
                   unmeasured_force_fall_margin = 0\n";
        let e = parse_policy(old, Path::new("old.toml")).unwrap_err();
        let FileError::Field { line, field, .. } = &e else {
            panic!("{e}")
        };
        assert_eq!((*line, field.as_str()), (1, "format"));
        let e = e.to_string();
        assert!(
            e.contains("old.toml") && e.contains("tdeploy policy migrate old.toml -o NEW"),
            "{e}"
        );
        let (policy, notes) = migrate_policy(old, Path::new("old.toml")).unwrap();
        assert_eq!(
            policy.planner,
            PlannerSettings::GreedyTree(GreedyTreeSettings {
                move_m: 0.04,
                min_move_m: 0.005
            })
        );
        assert_eq!(policy.margins.unmeasured_force_fall, None);
        assert_eq!(
            notes,
            ["`sensitivity_step_m` left out: only the QP planner read it"]
        );
    }

    /// Issue 25: `name = "x\ny"` split the policy column of `runs.csv` and
    /// the printed table over two lines; `name = ""` left it blank.
    #[test]
    fn a_policy_name_that_is_not_one_printable_line_is_refused() {
        for (name, says) in [
            (r#""x\ny""#, "one line of printable characters"),
            (r#""""#, "must not be empty"),
        ] {
            let text = format!("format = \"{POLICY_FORMAT}\"\nname = {name}\n");
            let e = parse_policy(&text, Path::new("p.toml")).unwrap_err();
            let FileError::Field { line, field, .. } = &e else {
                panic!("{e}")
            };
            assert_eq!((*line, field.as_str()), (2, "name"), "{e}");
            assert!(e.to_string().contains(says), "{e}");
        }
    }
}
