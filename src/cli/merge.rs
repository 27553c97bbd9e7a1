//! `tdeploy merge DIR… -o OUT [--force]`: joins the shards `1/n … n/n`
//! of one `tdeploy evaluate` sweep (each DIR one shard's results) into the
//! results of the whole sweep: the same files, byte for byte, as the
//! sweep run in one piece (timing.csv aside).
//!
//! Refuses (exit 2, naming the folder) shards of different sweeps (seed,
//! scenario count, policies and their settings, model, distribution), a
//! missing or repeated shard, and a shard whose runs are not exactly its
//! scenarios times the policies.

use std::collections::BTreeSet;
use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::evaluation_files::{
    read_evaluation_record, read_runs, EvaluationRecord, EvaluationRuns,
};
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::studies::evaluation::Shard;

use super::evaluation_table::{all_policies, print_and_write};
use super::{value, Outcome};

/// The `merge` subcommand's arguments.
pub fn command() -> Command {
    Command::new("merge")
        .about("Join the shards of one `tdeploy evaluate` sweep into the sweep's results (the same files as one run)")
        .arg(Arg::new("shards").required(true).num_args(1..).value_parser(value_parser!(PathBuf)).help("The shards' results folders"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/evaluate").value_parser(value_parser!(PathBuf)).help("Folder for the merged results"))
        .arg(super::force_arg())
}

/// Options of `tdeploy merge`.
#[derive(Debug, Clone)]
pub struct Options {
    /// The shards' folders.
    pub shards: Vec<PathBuf>,
    /// Results folder.
    pub out: PathBuf,
    /// Replace a folder of other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(Options {
            shards: m
                .get_many::<PathBuf>("shards")
                .map(|v| v.cloned().collect())
                .unwrap_or_default(),
            out: value(m, "out")?,
            force: m.get_flag("force"),
        })
    }
}

/// Runs `tdeploy merge`.
pub fn run(o: &Options) -> Result<Outcome> {
    let mut first: Option<(PathBuf, EvaluationRecord)> = None;
    let mut seen = BTreeSet::new();
    let mut merged: Option<EvaluationRuns> = None;
    for dir in &o.shards {
        let record = read_evaluation_record(&dir.join("evaluation.toml"))?;
        let Some(shard) = record.shard() else {
            bail!("{}: no valid shard", dir.display());
        };
        match &first {
            None => first = Some((dir.clone(), record.clone())),
            Some((dir0, r0)) => {
                let differ = r0.sweep_differences(&record);
                if !differ.is_empty() {
                    bail!(
                        "{} and {}: not shards of the same sweep: their evaluation.toml differ in {}",
                        dir0.display(),
                        dir.display(),
                        differ.join(", ")
                    );
                }
                if r0.shard().map(|s| s.count) != Some(shard.count) {
                    bail!(
                        "{}: shard {} of a sweep cut into {} shards, {} was cut into {}",
                        dir.display(),
                        record.shard,
                        shard.count,
                        dir0.display(),
                        r0.shard().map_or(0, |s| s.count)
                    );
                }
            }
        }
        if !seen.insert(shard.index) {
            bail!("{}: shard {} given twice", dir.display(), record.shard);
        }
        let runs = read_runs(dir, &record)?;
        // Exactly the shard's scenarios, each with every policy once.
        let expected: BTreeSet<(usize, usize)> = shard
            .scenarios(record.scenarios)
            .into_iter()
            .flat_map(|s| (0..record.policies.len()).map(move |p| (s, p)))
            .collect();
        let found: Vec<(usize, usize)> = runs
            .results
            .iter()
            .map(|r| (r.scenario, r.policy))
            .collect();
        let unique: BTreeSet<(usize, usize)> = found.iter().copied().collect();
        if unique.len() != found.len() || unique != expected {
            bail!(
                "{}/runs.csv: the runs are not shard {}'s scenarios times the policies ({} runs, {} expected)",
                dir.display(),
                record.shard,
                found.len(),
                expected.len()
            );
        }
        match &mut merged {
            None => merged = Some(runs),
            Some(m) => {
                m.scenarios.extend(runs.scenarios);
                m.results.extend(runs.results);
            }
        }
    }
    let (Some((_, record)), Some(mut runs)) = (first, merged) else {
        bail!("no shard given");
    };
    let count = record.shard().map_or(0, |s| s.count);
    let missing: Vec<usize> = (1..=count).filter(|k| !seen.contains(k)).collect();
    if !missing.is_empty() {
        bail!(
            "shards {} of {count} are missing",
            missing
                .iter()
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    runs.results.sort_by_key(|r| (r.scenario, r.policy));
    let whole = EvaluationRecord {
        shard: format!("{}/{}", Shard::ALL.index, Shard::ALL.count),
        ..record
    };
    // The set is an evaluation's, whichever command put it together.
    let folder = ResultsFolder::claim(&o.out, "evaluate", o.force)?;
    say!(
        "merge: {} shards, {} scenarios × {} policies",
        count,
        runs.scenarios.len(),
        runs.policy_names.len()
    );
    let limits = print_and_write(&whole, &runs, folder.path())?;
    folder.commit()?;
    say!("results in {}", o.out.display());
    Ok(match all_policies(&limits).failure() {
        None => Outcome::GoalReached,
        Some(why) => Outcome::GoalMissed(why),
    })
}
