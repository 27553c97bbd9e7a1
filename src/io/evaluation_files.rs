//! The files of a policy evaluation (`tdeploy evaluate`, `tdeploy merge`,
//! the deployment experiment) and the scenario-distribution file.
//!
//! **Scenario distribution** (TOML, format
//! `tensegrity-deploy/scenarios/1`; see
//! [`crate::studies::evaluation::ScenarioDistribution`]):
//!
//! ```toml
//! format = "tensegrity-deploy/scenarios/1"
//! position_noise_m = [0.001, 0.001]
//! load_cell_noise_n = [7.0, 7.0]
//! fold_m = [0.35, 0.45]
//! temperature_c = [5.0, 35.0]      # optional
//! fold_difference_m = [-0.1, 0.1] # optional: half B folds fold_m + d
//! [effects.motor]
//! slip_fraction = [-0.05, 0.05]
//! backlash_m = [0.0, 0.005]
//! [faults.drum_zero_error]         # optional: a local fault
//! probability = 0.3                # that a scenario has it
//! offset_m = [-0.015, 0.015]
//! ```
//! A hidden `thermal` effect needs `temperature_c`. `scenarios/wide.toml`
//! uses every key.
//!
//! **`evaluation.toml`**: what was run (format
//! `tensegrity-deploy/evaluation/4`): seed, scenario count, cycles per
//! scenario, shard, policy names and fingerprints, the controller model's
//! source (with the fingerprint of a model file's contents), whether the
//! truths were split at slip events, and the distribution itself. Shards
//! merge only if everything but the shard agrees.
//!
//! **`runs.csv`**: one row per scenario and policy, in scenario then
//! policy order: `scenario,seed`, every drawn value (named as
//! [`crate::studies::evaluation::ScenarioDistribution::drawn_names`]),
//! then `policy,status,succeeded,commands,corrective_commands,
//! final_measured_gap_m,final_true_gap_m,cable_travel_m,
//! truth_worst_utilisation,truth_violations,largest_force_breach_n,
//! approach_gap_m,binds` (SI
//! units; empty = none; with several cycles per scenario, the last
//! cycle's, violations, utilisation and the largest breach over all
//! cycles). `status` is the
//! run's verdict label ([`crate::plan::RunVerdict::label`]: what the truth
//! did; `limits_broken` if any cycle broke a limit) and `succeeded` is
//! `true` exactly for `connected`. `binds` names what decided a run that
//! did not connect, `; `-separated ([`crate::plan::RunVerdict::binds`]:
//! the limits the truth broke, e.g. `cable A_axial_m0_0 min`, or the
//! limits and motors the controller stopped on, e.g. `segment A_cc1[3]
//! min`, `A_cc0 stroke min`); empty where nothing is named.
//! `largest_force_breach_n` is how far a truth force went beyond the
//! bound it was held to at worst (N; empty where no force bound broke:
//! a breach at the solver's rounding reads apart from a slack cable).
//! Format 1 had neither the cycles nor the approach gap, format 2 no
//! `binds`, format 3 no `largest_force_breach_n`.
//! Numbers are written as the shortest text that reads back to the same
//! value, so a merge re-writes the rows of its shards byte for byte.
//!
//! **`timing.csv`**: `scenario,policy,median_planning_time_s`, the one
//! file that differs from run to run.
//!
//! The set's summary tables (`summary.csv`, `paired.csv`, `by_fold.csv`)
//! and the writer
//! of the whole set are [`super::evaluation_summary`]'s.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::problem_file::{field_line, parse_versioned};
use super::toml_text::{field_error, parse_toml};
use super::{csv_records, csv_with_header, read_text, CsvTable, FileError};
use crate::numerics::NumberRange;
use crate::plan::policy::MAX_COMMANDS;
use crate::plan::{Policy, RunVerdict};
use crate::studies::evaluation::{RunResult, Scenario, ScenarioDistribution, Shard, NOT_STARTED};

/// The `format` of a scenario-distribution file.
pub const DISTRIBUTION_FORMAT: &str = "tensegrity-deploy/scenarios/1";
/// The `format` of `evaluation.toml`.
pub const EVALUATION_FORMAT: &str = "tensegrity-deploy/evaluation/4";

/// The columns of `runs.csv` after the drawn values.
const RESULT_COLUMNS: [&str; 13] = [
    "policy",
    "status",
    "succeeded",
    "commands",
    "corrective_commands",
    "final_measured_gap_m",
    "final_true_gap_m",
    "cable_travel_m",
    "truth_worst_utilisation",
    "truth_violations",
    "largest_force_breach_n",
    "approach_gap_m",
    "binds",
];

/// Separates the names of `runs.csv`'s `binds` column.
const BINDS_SEPARATOR: &str = "; ";
/// Longest name `binds` may hold, characters: the longest a run can write
/// is a clearance between two struts of ids at their
/// [`crate::model::structure::MAX_ID_CHARS`] (75).
const MAX_BIND_NAME_CHARS: usize = 80;

/// Whether `status` is one a run of `runs.csv` may have: a deployment's
/// verdict ([`RunVerdict::LABELS`]) or [`NOT_STARTED`].
fn is_run_status(status: &str) -> bool {
    RunVerdict::LABELS.contains(&status) || status == NOT_STARTED
}

/// Range of the non-negative results of `runs.csv` (gaps, cable travel,
/// utilisation): finite, and at most 1e6, far above any a deployment of a
/// bridge can give (travel is at most commands × motors × 10 m).
const NON_NEGATIVE_RESULT: NumberRange = NumberRange::closed(0.0, 1e6);

/// Reads and validates a scenario-distribution file.
pub fn read_distribution(path: &Path) -> Result<ScenarioDistribution, FileError> {
    let text = read_text(path)?;
    parse_distribution(&text, path)
}

/// Parses a scenario-distribution file; `path` names it in errors.
pub fn parse_distribution(text: &str, path: &Path) -> Result<ScenarioDistribution, FileError> {
    let d: ScenarioDistribution = parse_versioned(text, path, DISTRIBUTION_FORMAT)?;
    d.validate()
        .map_err(|e| field_error(text, path, &e.field, e.reason))?;
    Ok(d)
}

/// What an evaluation ran, as `evaluation.toml` records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvaluationRecord {
    /// [`EVALUATION_FORMAT`].
    pub format: String,
    /// Seed of the scenario draws.
    pub seed: u64,
    /// Scenarios in the whole sweep.
    pub scenarios: usize,
    /// This set's shard, `k/n` (`1/1` for a whole sweep or a merge).
    pub shard: String,
    /// Policy names, in order.
    pub policies: Vec<String>,
    /// FNV-1a fingerprint of each policy's settings (hex).
    pub policy_fingerprints: Vec<String>,
    /// The controller's model: `reference` or the model file given.
    pub model: String,
    /// [`fingerprint`] of the controller's model file as it was read (its
    /// canonical text, [`super::model_file::ModelFile::to_toml`]: its
    /// structure, effects, faults and `[solver]` settings, not its
    /// comments or layout), so that two shards run on model files of one
    /// name but other contents are not merged as one sweep. Absent for the
    /// reference model (and in records written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_fingerprint: Option<String>,
    /// Deployment-fold cycles per scenario and policy (each run reports
    /// its last cycle).
    pub cycles: usize,
    /// Whether the truths split their increments at their joints' slip
    /// events (`evaluate --slip-event-substeps`); written only when set,
    /// absent (as in records before it) means not.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub truth_slip_event_substeps: bool,
    /// The scenario distribution.
    pub distribution: ScenarioDistribution,
}

impl EvaluationRecord {
    /// The record of shard `shard` of a sweep of `scenarios` scenarios
    /// drawn from `distribution` with `seed`, `cycles` cycles each, for
    /// `policies` (their names and the fingerprints of their settings) on
    /// the controller's model `model` (`reference` or its file, with the
    /// file's `model_fingerprint`), the truths split at slip events when
    /// `truth_slip_event_substeps`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        seed: u64,
        scenarios: usize,
        shard: Shard,
        policies: &[Policy],
        model: String,
        model_fingerprint: Option<String>,
        cycles: usize,
        truth_slip_event_substeps: bool,
        distribution: ScenarioDistribution,
    ) -> Result<Self, FileError> {
        Ok(EvaluationRecord {
            format: EVALUATION_FORMAT.into(),
            seed,
            scenarios,
            shard: format!("{}/{}", shard.index, shard.count),
            policies: policies.iter().map(|p| p.name.clone()).collect(),
            policy_fingerprints: policies
                .iter()
                .map(policy_fingerprint)
                .collect::<Result<_, _>>()?,
            model,
            model_fingerprint,
            cycles,
            truth_slip_event_substeps,
            distribution,
        })
    }

    /// This record's shard.
    pub fn shard(&self) -> Option<Shard> {
        Shard::parse(&self.shard)
    }

    /// The fields (as `evaluation.toml` names them) in which `self` and
    /// `other` record different sweeps; the shard is not compared. Empty:
    /// shards of the same sweep.
    pub fn sweep_differences(&self, other: &EvaluationRecord) -> Vec<&'static str> {
        // Destructured so that a field added to the record is compared.
        let EvaluationRecord {
            format,
            seed,
            scenarios,
            shard: _,
            policies,
            policy_fingerprints,
            model,
            model_fingerprint,
            cycles,
            truth_slip_event_substeps,
            distribution,
        } = self;
        let mut fields = Vec::new();
        let mut differs = |field, d: bool| {
            if d {
                fields.push(field)
            }
        };
        differs("format", *format != other.format);
        differs("seed", *seed != other.seed);
        differs("scenarios", *scenarios != other.scenarios);
        differs("policies", *policies != other.policies);
        differs(
            "policy_fingerprints",
            *policy_fingerprints != other.policy_fingerprints,
        );
        differs("model", *model != other.model);
        differs(
            "model_fingerprint",
            *model_fingerprint != other.model_fingerprint,
        );
        differs("cycles", *cycles != other.cycles);
        differs(
            "truth_slip_event_substeps",
            *truth_slip_event_substeps != other.truth_slip_event_substeps,
        );
        differs("distribution", *distribution != other.distribution);
        fields
    }

    /// As TOML text.
    pub fn to_toml(&self) -> Result<String, FileError> {
        toml::to_string(self).map_err(|e| FileError::Invalid {
            path: "evaluation.toml".into(),
            entry: "record".into(),
            message: e.to_string(),
        })
    }
}

/// Reads an `evaluation.toml`.
pub fn read_evaluation_record(path: &Path) -> Result<EvaluationRecord, FileError> {
    let text = read_text(path)?;
    let record: EvaluationRecord = parse_toml(&text, path)?;
    if record.format != EVALUATION_FORMAT {
        return Err(FileError::field(
            path,
            field_line(&text, "format"),
            "format",
            format!(
                "expected \"{EVALUATION_FORMAT}\", found \"{}\"",
                record.format
            ),
        ));
    }
    if record.shard().is_none() {
        return Err(FileError::field(
            path,
            field_line(&text, "shard"),
            "shard",
            format!("\"{}\" is not k/n with 1 ≤ k ≤ n", record.shard),
        ));
    }
    Ok(record)
}

/// FNV-1a (64 bit) of `bytes`, as 16 hex digits: a fingerprint to tell
/// two policies' settings apart, not a security measure.
pub fn fingerprint(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The [`fingerprint`] of a policy's settings (their JSON text).
pub fn policy_fingerprint(policy: &Policy) -> Result<String, FileError> {
    let json = serde_json::to_string(policy).map_err(|e| FileError::Invalid {
        path: "evaluation.toml".into(),
        entry: format!("policy_fingerprints ({})", policy.name),
        message: e.to_string(),
    })?;
    Ok(fingerprint(json.as_bytes()))
}

/// One scenario's row prefix in `runs.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioRow {
    /// Scenario index.
    pub index: usize,
    /// Its seed.
    pub seed: u64,
    /// Its drawn values.
    pub drawn: Vec<f64>,
}

/// The rows of `runs.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct EvaluationRuns {
    /// Names of the drawn values (columns after `seed`).
    pub drawn_names: Vec<String>,
    /// Policy names (a result's `policy` indexes them).
    pub policy_names: Vec<String>,
    /// Each scenario once, by index.
    pub scenarios: BTreeMap<usize, ScenarioRow>,
    /// Every run, in (scenario, policy) order.
    pub results: Vec<RunResult>,
}

impl EvaluationRuns {
    /// The rows of `results` on `scenarios` drawn from `distribution`,
    /// for the policies named `policy_names`.
    pub fn new(
        distribution: &ScenarioDistribution,
        policy_names: Vec<String>,
        scenarios: &[Scenario],
        results: Vec<RunResult>,
    ) -> Self {
        EvaluationRuns {
            drawn_names: distribution.drawn_names(),
            policy_names,
            scenarios: scenarios
                .iter()
                .map(|s| {
                    let row = ScenarioRow {
                        index: s.index,
                        seed: s.seed,
                        drawn: s.drawn_values(distribution),
                    };
                    (s.index, row)
                })
                .collect(),
            results,
        }
    }

    /// How deep scenario `index` was folded: half A's drawn fold
    /// (`fold_m`), and half B's (`fold_b_m`) where the distribution folds
    /// it differently, m; `None` for a scenario not in the runs.
    pub fn half_folds_m(&self, index: usize) -> Option<(f64, Option<f64>)> {
        let row = self.scenarios.get(&index)?;
        let drawn = |name: &str| {
            self.drawn_names
                .iter()
                .position(|n| n == name)
                .and_then(|i| row.drawn.get(i).copied())
        };
        Some((drawn("fold_m")?, drawn("fold_b_m")))
    }

    /// `runs.csv` as a table.
    pub fn runs_table(&self) -> CsvTable {
        let mut header: Vec<&str> = vec!["scenario", "seed"];
        header.extend(self.drawn_names.iter().map(String::as_str));
        header.extend(RESULT_COLUMNS);
        let mut table = CsvTable::new(&header);
        let opt = |v: Option<f64>| v.map_or(String::new(), |x| x.to_string());
        for r in &self.results {
            let Some(s) = self.scenarios.get(&r.scenario) else {
                continue;
            };
            let mut row = vec![s.index.to_string(), s.seed.to_string()];
            row.extend(s.drawn.iter().map(|v| v.to_string()));
            row.extend([
                self.policy_names[r.policy].clone(),
                r.status.clone(),
                r.succeeded.to_string(),
                r.commands.to_string(),
                r.corrective_commands
                    .map_or(String::new(), |c| c.to_string()),
                opt(r.final_measured_gap_m),
                opt(r.final_true_gap_m),
                r.cable_travel_m.to_string(),
                r.worst_utilisation.to_string(),
                r.truth_violations.to_string(),
                opt(r.largest_force_breach_n),
                opt(r.approach_gap_m),
                r.binds.join(BINDS_SEPARATOR),
            ]);
            table.row(row);
        }
        table
    }

    /// `timing.csv` as a table.
    pub fn timing_table(&self) -> CsvTable {
        let mut table = CsvTable::new(&["scenario", "policy", "median_planning_time_s"]);
        for r in &self.results {
            table.row([
                r.scenario.to_string(),
                self.policy_names[r.policy].clone(),
                r.planning_time_median_s
                    .map_or(String::new(), |t| t.to_string()),
            ]);
        }
        table
    }
}

/// The names of a `binds` field (empty: none); `None` if a name is empty,
/// too long or not printable text on one line.
fn parse_binds(field: &str) -> Option<Vec<String>> {
    if field.is_empty() {
        return Some(Vec::new());
    }
    field
        .split(BINDS_SEPARATOR)
        .map(|name| {
            let chars = name.chars().count();
            let printable = name.chars().all(|c| !c.is_control());
            (chars > 0 && chars <= MAX_BIND_NAME_CHARS && printable && name.trim() == name)
                .then(|| name.to_string())
        })
        .collect()
}

/// Reads `runs.csv` written for `record` (its policies and drawn values),
/// and the planning times of `timing.csv` beside it if it is there.
pub fn read_runs(folder: &Path, record: &EvaluationRecord) -> Result<EvaluationRuns, FileError> {
    let path = folder.join("runs.csv");
    let text = read_text(&path)?;
    let drawn_names = record.distribution.drawn_names();
    let mut header: Vec<&str> = vec!["scenario", "seed"];
    header.extend(drawn_names.iter().map(String::as_str));
    header.extend(RESULT_COLUMNS);
    let mut reader = csv_with_header(&text, &path, &header)?;
    let mut runs = EvaluationRuns {
        drawn_names: drawn_names.clone(),
        policy_names: record.policies.clone(),
        scenarios: BTreeMap::new(),
        results: Vec::new(),
    };
    let d = drawn_names.len();
    for row in csv_records(&mut reader, &path) {
        let (line, r) = row?;
        let field = |i: usize| r.get(i).unwrap_or("");
        let bad = |i: usize, what: &str| {
            FileError::field(
                &path,
                line,
                header[i],
                format!("`{}` is not {what}", field(i)),
            )
        };
        let number = |i: usize| -> Result<f64, FileError> {
            field(i)
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(i, "a finite number"))
        };
        let count = |i: usize| -> Result<usize, FileError> {
            field(i).parse().map_err(|_| bad(i, "a count"))
        };
        let index = count(0)?;
        if index >= record.scenarios {
            return Err(bad(
                0,
                &format!("a scenario of the sweep (0 to {})", record.scenarios - 1),
            ));
        }
        let seed: u64 = field(1).parse().map_err(|_| bad(1, "a seed"))?;
        let drawn = (0..d)
            .map(|k| number(2 + k))
            .collect::<Result<Vec<_>, _>>()?;
        // The scenario as the recorded distribution and seed draw it: the
        // row must hold exactly those draws (runs.csv writes each number
        // in the shortest form that reads back equal).
        let expected = record.distribution.draw(record.seed, index);
        if seed != expected.seed {
            return Err(bad(
                1,
                &format!("scenario {index}'s seed in this sweep ({})", expected.seed),
            ));
        }
        for (k, (x, want)) in drawn
            .iter()
            .zip(expected.drawn_values(&record.distribution))
            .enumerate()
        {
            if x.to_bits() != want.to_bits() {
                return Err(bad(
                    2 + k,
                    &format!("what the recorded distribution draws for scenario {index} ({want})"),
                ));
            }
        }
        let at = 2 + d;
        let policy = record
            .policies
            .iter()
            .position(|p| p == field(at))
            .ok_or_else(|| bad(at, "one of the evaluation's policies"))?;
        let scenario = ScenarioRow { index, seed, drawn };
        match runs.scenarios.get(&index) {
            Some(known) if *known != scenario => {
                return Err(bad(1, "the seed and draws of the scenario's other rows"))
            }
            _ => {
                runs.scenarios.insert(index, scenario);
            }
        }
        let status = field(at + 1);
        if !is_run_status(status) {
            return Err(bad(
                at + 1,
                &format!(
                    "a run status ({}, {NOT_STARTED})",
                    RunVerdict::LABELS.join(", ")
                ),
            ));
        }
        let non_negative = |i: usize| -> Result<f64, FileError> {
            number(i).and_then(|v| {
                NON_NEGATIVE_RESULT
                    .contains(v)
                    .then_some(v)
                    .ok_or_else(|| bad(i, &format!("a number in {NON_NEGATIVE_RESULT}")))
            })
        };
        let optional_non_negative = |i: usize| -> Result<Option<f64>, FileError> {
            if field(i).is_empty() {
                Ok(None)
            } else {
                non_negative(i).map(Some)
            }
        };
        let commands = count(at + 3)?;
        if commands > MAX_COMMANDS {
            return Err(bad(
                at + 3,
                &format!("a command count (at most {MAX_COMMANDS}, a policy's largest)"),
            ));
        }
        let truth_violations = count(at + 9)?;
        let largest_force_breach_n = optional_non_negative(at + 10)?;
        if truth_violations == 0 && largest_force_breach_n.is_some() {
            return Err(bad(at + 10, "empty, as for every run that broke no limit"));
        }
        runs.results.push(RunResult {
            scenario: index,
            policy,
            status: status.to_string(),
            succeeded: field(at + 2)
                .parse()
                .map_err(|_| bad(at + 2, "true or false"))?,
            commands,
            corrective_commands: if field(at + 4).is_empty() {
                None
            } else {
                Some(count(at + 4)?)
                    .filter(|&k| k <= commands)
                    .ok_or_else(|| bad(at + 4, "a count no larger than the commands sent"))?
                    .into()
            },
            final_measured_gap_m: optional_non_negative(at + 5)?,
            final_true_gap_m: optional_non_negative(at + 6)?,
            cable_travel_m: non_negative(at + 7)?,
            worst_utilisation: non_negative(at + 8)?,
            truth_violations,
            largest_force_breach_n,
            approach_gap_m: optional_non_negative(at + 11)?,
            binds: parse_binds(field(at + 12))
                .ok_or_else(|| {
                    bad(
                        at + 12,
                        &format!(
                            "a `{BINDS_SEPARATOR}`-separated list of names (limits, motors or why a run did not start; each printable, one line, 1 to {MAX_BIND_NAME_CHARS} characters)"
                        ),
                    )
                })
                .and_then(|names| {
                    if status == "connected" && !names.is_empty() {
                        Err(bad(at + 12, "empty, as for every connected run"))
                    } else {
                        Ok(names)
                    }
                })?,
            planning_time_median_s: None,
        });
    }
    // Planning times, where the set has them (they are not part of the
    // comparison of sets).
    let timing = folder.join("timing.csv");
    if timing.exists() {
        let text = read_text(&timing)?;
        let mut reader = csv_with_header(
            &text,
            &timing,
            &["scenario", "policy", "median_planning_time_s"],
        )?;
        let mut times: BTreeMap<(usize, String), f64> = BTreeMap::new();
        for row in csv_records(&mut reader, &timing) {
            let (_, r) = row?;
            if let (Some(Ok(s)), Some(p), Some(Ok(t))) = (
                r.get(0).map(str::parse::<usize>),
                r.get(1),
                r.get(2).map(str::parse::<f64>),
            ) {
                times.insert((s, p.to_string()), t);
            }
        }
        for r in &mut runs.results {
            r.planning_time_median_s = times
                .get(&(r.scenario, record.policies[r.policy].clone()))
                .copied();
        }
    }
    Ok(runs)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `scenarios/default.toml` writes out the built-in default, so the
    /// two cannot drift apart.
    #[test]
    fn the_shipped_distribution_is_the_default() {
        let d = parse_distribution(
            include_str!("../../scenarios/default.toml"),
            Path::new("scenarios/default.toml"),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d, ScenarioDistribution::default());
    }

    /// `scenarios/wide.toml` hides every effect of the library and every
    /// local fault, and folds unevenly.
    #[test]
    fn the_wide_distribution_draws_every_effect_and_fault() {
        use crate::model::{EffectKind, FaultKind};
        let text = include_str!("../../scenarios/wide.toml");
        let d = parse_distribution(text, Path::new("scenarios/wide.toml"))
            .unwrap_or_else(|e| panic!("{e}"));
        for kind in EffectKind::ALL {
            assert!(d.effects.contains_key(kind.name()), "{}", kind.name());
        }
        for kind in FaultKind::ALL {
            assert!(d.faults[kind.name()].probability > 0.0, "{}", kind.name());
        }
        assert_eq!(d.fold_m, [0.10, 0.60]);
        assert!(d.fold_difference_m.is_some() && d.temperature_c.is_some());
        // A thermal effect without a temperature is refused, naming it.
        let no_temperature = text.replace("temperature_c = [0.0, 40.0]", "");
        let e = parse_distribution(&no_temperature, Path::new("w.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("w.toml: field `temperature_c`: missing"),
            "{e}"
        );
        let bad = text.replace("probability = 0.3\noffset_m", "probability = 1.3\noffset_m");
        let e = parse_distribution(&bad, Path::new("w.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("w.toml: line 61, field `faults.drum_zero_error.probability`"),
            "{e}"
        );
        let bad = text.replace("offset_m = [-0.015, 0.015]", "offset = [-0.015, 0.015]");
        let e = parse_distribution(&bad, Path::new("w.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(
                "w.toml: line 62, field `faults.drum_zero_error.offset`: unknown parameter"
            ),
            "{e}"
        );
    }

    /// `binds` reads back what `runs_table` writes, and refuses a name
    /// that is empty, not one printable line, padded or overlong (none of
    /// which a structure's ids can make since they are checked,
    /// `Structure::validate`).
    #[test]
    fn binds_read_back_and_refuse_what_no_run_writes() {
        let names = vec![
            "segment A_cc1[3] min".to_string(),
            "clearance A_s1–A_s7".to_string(),
        ];
        assert_eq!(parse_binds(&names.join(BINDS_SEPARATOR)), Some(names));
        assert_eq!(parse_binds(""), Some(Vec::new()));
        let long = "x".repeat(MAX_BIND_NAME_CHARS + 1);
        for bad in ["a; ; b", "a;  b", "a\u{7}b", " a", "a; ", long.as_str()] {
            assert_eq!(parse_binds(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn fingerprints_differ_and_repeat() {
        assert_eq!(fingerprint(b"qp"), fingerprint(b"qp"));
        assert_ne!(fingerprint(b"qp"), fingerprint(b"qq"));
        // FNV-1a of the empty input is its offset basis.
        assert_eq!(fingerprint(b""), "cbf29ce484222325");
    }
}
