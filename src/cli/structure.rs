//! `tdeploy structure`: the reference bridge, generated and written as a
//! structure file.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::bridge_params::read_bridge_parameters;
use tensegrity_deploy::io::structure_file::write_new_structure;

use super::{value, Outcome};

/// The `structure` subcommand's arguments.
pub fn command() -> Command {
    Command::new("structure")
        .about("Generate the reference hollow-rope footbridge and write its structure file")
        .arg(
            Arg::new("out")
                .long("out")
                .short('o')
                .default_value("reference-bridge.json")
                .value_parser(value_parser!(PathBuf)),
        )
        .arg(
            Arg::new("params")
                .long("params")
                .value_parser(value_parser!(PathBuf))
                .help(
                    "TOML file overriding bridge parameters (field names as in BridgeParameters)",
                ),
        )
        .arg(
            Arg::new("force")
                .long("force")
                .action(ArgAction::SetTrue)
                .help("Overwrite the output file if it exists with other contents"),
        )
}

/// Options of `tdeploy structure`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Structure file to write.
    pub out: PathBuf,
    /// Bridge-parameter file, if any.
    pub params: Option<PathBuf>,
    /// Overwrite an existing output file.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        Ok(Options {
            out: value(m, "out")?,
            params: m.get_one::<PathBuf>("params").cloned(),
            force: m.get_flag("force"),
        })
    }
}

/// Runs `tdeploy structure`.
pub fn run(o: &Options) -> Result<Outcome> {
    let params = match &o.params {
        Some(path) => read_bridge_parameters(path)?,
        None => BridgeParameters::default(),
    };
    let s = reference_bridge(&params).with_context(|| match &o.params {
        Some(path) => format!("{}: generating the bridge", path.display()),
        None => "generating the default bridge".into(),
    })?;
    write_new_structure(&o.out, &s, o.force)?;
    let count = |kind: &str| s.members.iter().filter(|m| m.kind.name() == kind).count();
    say!(
        "wrote {}: {} nodes, {} struts, {} cables, {} springs, {} continuous cables ({} segments)",
        o.out.display(),
        s.nodes.len(),
        count("strut"),
        count("cable"),
        count("spring"),
        s.continuous_cables.len(),
        s.segment_count()
    );
    Ok(Outcome::GoalReached)
}
