//! Command-line interface: argument parsing, files and printing. The
//! numerics it calls never print.
//!
//! - `structure`: generate the reference bridge ([`structure_cmd`]);
//! - `simulate`: apply a command sequence ([`simulate`]);
//! - `experiment`: run an experiment file ([`experiment`]);
//! - `lab`: a synthetic measurement log from a truth model ([`lab`]);
//! - `compare`: a model against a log ([`compare`]);
//! - `diagnose`: which effect the model lacks ([`diagnose`]);
//! - `calibrate`: a new model file with one effect added and fitted
//!   ([`calibrate`]).

/// `println!` that ends the program quietly when stdout is closed early
/// (`tdeploy … | head`), where `println!` would panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
        }
    }};
}

mod calibrate;
mod compare;
mod diagnose;
mod experiment;
mod lab;
mod plan;
mod simulate;

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::friction_table::read_friction_table;
use tensegrity_deploy::io::structure_file::write_structure;
use tensegrity_deploy::model::{AngleConvention, FrictionCoefficient, JointFriction};

/// The `tdeploy` command with its subcommands.
pub fn command() -> Command {
    let friction_args = [
        Arg::new("mu")
            .long("mu")
            .value_parser(value_parser!(f64))
            .default_value("0")
            .conflicts_with("mu-table")
            .help("Joint friction coefficient μ (constant). 0: frictionless clustered cables"),
        Arg::new("mu-table")
            .long("mu-table")
            .value_parser(value_parser!(PathBuf))
            .help("CSV `interior_angle_deg,mu`: μ interpolated over the joint's interior angle"),
        Arg::new("angle")
            .long("angle")
            .value_parser(["wrap", "interior"])
            .default_value("wrap")
            .help("Angle in the capstan exponent: wrap angle π−θ (physical) or interior angle θ (the seed's Eq. 6)"),
    ];
    Command::new("tdeploy")
        .about("Plan and learn the deployment of a tensegrity footbridge")
        .version(env!("CARGO_PKG_VERSION"))
        .subcommand_required(true)
        .subcommand(
            Command::new("structure")
                .about("Generate the reference hollow-rope footbridge and write its structure file")
                .arg(Arg::new("out").long("out").short('o').default_value("reference-bridge.json").value_parser(value_parser!(PathBuf)))
                .arg(Arg::new("params").long("params").value_parser(value_parser!(PathBuf)).help("TOML file overriding bridge parameters (field names as in BridgeParameters)")),
        )
        .subcommand(
            Command::new("simulate")
                .about("Apply a command sequence to a structure and write positions, forces and sliding per step")
                .arg(Arg::new("structure").long("structure").short('s').value_parser(value_parser!(PathBuf)).help("Structure file (default: the built-in reference bridge)"))
                .arg(Arg::new("commands").long("commands").short('c').value_parser(value_parser!(PathBuf)).help("Command CSV (default: a 5 cm fold-deploy cycle: every cable paid out 1 cm per step for 5 steps, then reeled in 1 cm per step for 5 steps)"))
                .args(friction_args.clone())
                .arg(Arg::new("increment").long("increment").value_parser(value_parser!(f64)).default_value("0.001").help("Largest payout increment per relaxation, m"))
                .arg(Arg::new("tol").long("tol").value_parser(value_parser!(f64)).default_value("1e-6").help("Force tolerance relative to the largest member force"))
                .arg(Arg::new("out").long("out").short('o').default_value("out/simulate").value_parser(value_parser!(PathBuf)))
                .arg(Arg::new("quiet").long("quiet").short('q').action(ArgAction::SetTrue).help("No progress bar")),
        )
        .subcommand(
            Command::new("lab")
                .about("Run deployment-fold cycles on a truth model file and write a measurement log with sensor noise")
                .arg(Arg::new("truth").required(true).value_parser(value_parser!(PathBuf)).help("Truth model file (TOML: structure and effects)"))
                .arg(Arg::new("out").long("out").short('o').default_value("out/lab-log").value_parser(value_parser!(PathBuf)).help("Log folder to write; the truth is recorded beside it as <out>.truth.toml"))
                .arg(Arg::new("seed").long("seed").default_value("1").value_parser(value_parser!(u64)).help("Seed of the sensor noise"))
                .arg(Arg::new("amplitudes").long("amplitudes").value_delimiter(',').default_value("0.01,0.05,0.1,0.4").value_parser(value_parser!(f64)).help("Cable actuation of each cycle, m (paid out, then reeled back in)"))
                .arg(Arg::new("steps").long("steps").default_value("5").value_parser(value_parser!(usize)).help("Steps in each direction of a cycle"))
                .arg(Arg::new("temperature-swing").long("temperature-swing").default_value("12").value_parser(value_parser!(f64)).help("Amplitude of the temperature's daily swing about 20 °C, K")),
        )
        .subcommand(
            Command::new("compare")
                .about("Replay a measurement log through a model and report the residuals per sensor, step and direction")
                .arg(Arg::new("model").required(true).value_parser(value_parser!(PathBuf)).help("Model file (TOML)"))
                .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder"))
                .arg(Arg::new("out").long("out").short('o').default_value("out/compare").value_parser(value_parser!(PathBuf)).help("Report folder (CSV and SVG)")),
        )
        .subcommand(
            Command::new("diagnose")
                .about("Fit every effect the model lacks to a log, score each on held-out cycles, and say which is missing")
                .arg(Arg::new("model").required(true).value_parser(value_parser!(PathBuf)).help("Model file (TOML)"))
                .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder"))
                .arg(Arg::new("rounds").long("rounds").default_value("2").value_parser(value_parser!(usize)).help("Effects to look for at most, one per round")),
        )
        .subcommand(
            Command::new("calibrate")
                .about("Fit one effect to a log and write a new model file with it (never overwriting the input)")
                .arg(Arg::new("model").required(true).value_parser(value_parser!(PathBuf)).help("Model file (TOML)"))
                .arg(Arg::new("log").required(true).value_parser(value_parser!(PathBuf)).help("Log folder"))
                .arg(Arg::new("add").long("add").required(true).help("Effect to add: joint_friction, motor, stiffness_error, thermal, joint_mass_error, load_cell_bias"))
                .arg(Arg::new("out").long("out").short('o').required(true).value_parser(value_parser!(PathBuf)).help("New model file (must not exist)")),
        )
        .subcommand(plan::command())
        .subcommand(
            Command::new("experiment")
                .about("Run an experiment file from experiments/")
                .arg(Arg::new("file").required(true).value_parser(value_parser!(PathBuf))),
        )
}

/// Runs the parsed command line.
pub fn run(m: &ArgMatches) -> Result<()> {
    match m.subcommand() {
        Some(("structure", a)) => structure_cmd(a),
        Some(("simulate", a)) => simulate::simulate(a),
        Some(("experiment", a)) => experiment::experiment(a),
        Some(("lab", a)) => lab::lab(a),
        Some(("compare", a)) => compare::compare(a),
        Some(("diagnose", a)) => diagnose::diagnose(a),
        Some(("calibrate", a)) => calibrate::calibrate(a),
        Some(("plan", a)) => match plan::run(a)? {
            true => Ok(()),
            false => Err(anyhow::anyhow!("the plan does not connect the halves")),
        },
        _ => unreachable!("clap requires a subcommand"),
    }
}

fn bridge_parameters(path: Option<&PathBuf>) -> Result<BridgeParameters> {
    match path {
        None => Ok(BridgeParameters::default()),
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("{}: cannot read", p.display()))?;
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))
        }
    }
}

fn structure_cmd(a: &ArgMatches) -> Result<()> {
    let params = bridge_parameters(a.get_one::<PathBuf>("params"))?;
    let s = reference_bridge(&params)?;
    let out = a.get_one::<PathBuf>("out").unwrap();
    write_structure(out, &s)?;
    let n_struts = s
        .members
        .iter()
        .filter(|m| m.kind.name() == "strut")
        .count();
    let n_cables = s
        .members
        .iter()
        .filter(|m| m.kind.name() == "cable")
        .count();
    let n_springs = s
        .members
        .iter()
        .filter(|m| m.kind.name() == "spring")
        .count();
    say!(
        "wrote {}: {} nodes, {n_struts} struts, {n_cables} cables, {n_springs} springs, {} continuous cables ({} segments)",
        out.display(),
        s.nodes.len(),
        s.continuous_cables.len(),
        s.segment_count()
    );
    Ok(())
}

/// Joint friction from `--mu` or `--mu-table` and `--angle`.
fn friction_from(a: &ArgMatches) -> Result<JointFriction> {
    let convention = match a.get_one::<String>("angle").map(String::as_str) {
        Some("interior") => AngleConvention::Interior,
        _ => AngleConvention::Wrap,
    };
    let mu = match a.get_one::<PathBuf>("mu-table") {
        Some(path) => read_friction_table(path)?,
        None => FrictionCoefficient::Constant(*a.get_one::<f64>("mu").unwrap()),
    };
    Ok(JointFriction::new(mu, convention)?)
}

/// The model a model file describes, run as every measurement command runs
/// it: default solver settings, commands applied in 1 cm increments (the
/// seed's actuation step).
fn effect_model(
    file: &tensegrity_deploy::io::model_file::ModelFile,
) -> Result<tensegrity_deploy::sim::EffectModel> {
    Ok(tensegrity_deploy::sim::EffectModel {
        structure: file.load_structure()?,
        effects: file.effects,
        settings: tensegrity_deploy::model::RelaxSettings::default(),
        increment_m: 0.01,
    })
}

/// `name = value ± error unit` of one fitted parameter (no unit for
/// dimensionless ones).
fn fitted_parameter(
    spec: &tensegrity_deploy::model::effects::ParameterSpec,
    value: f64,
    std_error: f64,
) -> String {
    let unit = if spec.unit == "1" {
        String::new()
    } else {
        format!(" {}", spec.unit)
    };
    format!(
        "{} = {}{unit}",
        spec.name,
        value_with_error(value, std_error)
    )
}

/// A fitted value with its standard error, to four significant figures
/// whatever the unit's scale (a compliance of 3e-5 m/N must not print as
/// 0.0000).
fn value_with_error(value: f64, std_error: f64) -> String {
    let magnitude = value.abs().max(std_error.abs());
    if magnitude == 0.0 || (1e-2..1e4).contains(&magnitude) {
        format!("{value:.4} ± {std_error:.2e}")
    } else {
        format!("{value:.4e} ± {std_error:.2e}")
    }
}
