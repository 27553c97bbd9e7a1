//! `tdeploy policy migrate OLD -o NEW`: a policy file of the old flat
//! format (`tensegrity-deploy/policy/1`) written in the current one, the
//! same policy (see `io::policy_file` for what moved where). Settings the
//! named planner never read are left out, each said on stdout.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};

use tensegrity_deploy::io::output::check_new_file;
use tensegrity_deploy::io::policy_file::{policy_to_toml, read_policy_to_migrate, POLICY_FORMAT};
use tensegrity_deploy::io::write_atomically;

use super::{value, Outcome};

/// The `policy` subcommand's arguments.
pub fn command() -> Command {
    Command::new("policy")
        .about("Work on policy files")
        .subcommand_required(true)
        .subcommand(
            Command::new("migrate")
                .about("Write a policy file of the old format 1 in the current format")
                .arg(
                    Arg::new("old")
                        .required(true)
                        .value_parser(value_parser!(PathBuf))
                        .help("Policy file of format tensegrity-deploy/policy/1"),
                )
                .arg(
                    Arg::new("out")
                        .long("out")
                        .short('o')
                        .required(true)
                        .value_parser(value_parser!(PathBuf))
                        .help("Policy file to write"),
                )
                .arg(
                    Arg::new("force")
                        .long("force")
                        .action(ArgAction::SetTrue)
                        .help("Overwrite the output file if it exists with other contents"),
                ),
        )
}

/// Options of `tdeploy policy`.
#[derive(Debug, Clone)]
pub enum Options {
    /// `tdeploy policy migrate`.
    Migrate {
        /// The format-1 file.
        old: PathBuf,
        /// The file to write.
        out: PathBuf,
        /// Overwrite an existing output file.
        force: bool,
    },
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        match m.subcommand() {
            Some(("migrate", a)) => Ok(Options::Migrate {
                old: value(a, "old")?,
                out: value(a, "out")?,
                force: a.get_flag("force"),
            }),
            Some((other, _)) => bail!("policy: unknown action `{other}`"),
            None => bail!("policy: an action is required (migrate)"),
        }
    }
}

/// Runs `tdeploy policy`.
pub fn run(o: &Options) -> Result<Outcome> {
    let Options::Migrate { old, out, force } = o;
    let (policy, notes) = read_policy_to_migrate(old)?;
    let text = format!(
        "# {} migrated to {POLICY_FORMAT} by `tdeploy policy migrate`.\n{}",
        old.display(),
        policy_to_toml(&policy)
    );
    check_new_file(out, text.as_bytes(), *force)?;
    write_atomically(out, text.as_bytes())?;
    for note in &notes {
        say!("{}: {note}", old.display());
    }
    say!("wrote {} (policy {})", out.display(), policy.name);
    Ok(Outcome::GoalReached)
}
