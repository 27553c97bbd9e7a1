//! `tdeploy memory repair FILE`: the case-memory file after a crash.
//!
//! A crash during an append can leave only a last line without its `\n`
//! ([`tensegrity_deploy::io::memory_file`]); loading or appending to such a
//! file is refused, naming the line. `repair` removes that line (atomically),
//! keeps every earlier case byte for byte and says how many bytes it
//! dropped. A file with any other fault (a wrong header, a corrupted case)
//! is refused unchanged: a crash cannot leave one.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{value_parser, Arg, ArgMatches, Command};

use tensegrity_deploy::io::memory_file::repair_torn_tail;

use super::{value, Outcome};

/// The `memory` subcommand's arguments.
pub fn command() -> Command {
    Command::new("memory")
        .about("Work on case-memory files")
        .subcommand_required(true)
        .subcommand(
            Command::new("repair")
                .about("Remove the torn last line an interrupted append left, keeping every complete case")
                .arg(
                    Arg::new("file")
                        .required(true)
                        .value_parser(value_parser!(PathBuf))
                        .help("Memory file (e.g. DIR/memory.tdm of `tdeploy cycles`)"),
                ),
        )
}

/// Options of `tdeploy memory`.
#[derive(Debug, Clone)]
pub enum Options {
    /// `tdeploy memory repair FILE`.
    Repair {
        /// The memory file.
        file: PathBuf,
    },
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        match m.subcommand() {
            Some(("repair", a)) => Ok(Options::Repair {
                file: value(a, "file")?,
            }),
            Some((other, _)) => bail!("memory: unknown action `{other}`"),
            None => bail!("memory: an action is required (repair)"),
        }
    }
}

/// Runs `tdeploy memory`.
pub fn run(o: &Options) -> Result<Outcome> {
    let Options::Repair { file } = o;
    let repair = repair_torn_tail(file)?;
    let cases = repair.memory.cases.len();
    if repair.dropped_bytes == 0 {
        say!(
            "{}: whole, nothing to repair ({cases} cases)",
            file.display()
        );
    } else {
        say!(
            "{}: dropped the torn last line ({} bytes); {cases} complete cases kept",
            file.display(),
            repair.dropped_bytes
        );
    }
    Ok(Outcome::GoalReached)
}
