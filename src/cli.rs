//! Command-line interface: argument parsing, files and printing. The
//! numerics it calls never print.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};
use indicatif::{ProgressBar, ProgressStyle};

use tensegrity_deploy::io::commands::{read_commands, CommandSequence};
use tensegrity_deploy::io::results::{write_simulation, StepRecord};
use tensegrity_deploy::io::structure_file::{read_structure, write_structure};
use tensegrity_deploy::model::friction_rig::modelled_slip_ratio;
use tensegrity_deploy::model::{
    reference_bridge, AngleConvention, BridgeParameters, CommandReport, ForwardModel,
    IncrementObserver, JointFriction, RelaxReport, RelaxSettings, RelaxStatus, Structure,
    Workspace,
};

/// The `tdeploy` command with its subcommands.
pub fn command() -> Command {
    let friction_args = [
        Arg::new("mu")
            .long("mu")
            .value_parser(value_parser!(f64))
            .default_value("0")
            .help("Joint friction coefficient μ (constant). 0: frictionless clustered cables"),
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
                .arg(Arg::new("commands").long("commands").short('c').value_parser(value_parser!(PathBuf)).help("Command CSV (default: reel every cable in 2 mm per step for 5 steps)"))
                .args(friction_args.clone())
                .arg(Arg::new("increment").long("increment").value_parser(value_parser!(f64)).default_value("0.001").help("Largest payout increment per relaxation, m"))
                .arg(Arg::new("tol").long("tol").value_parser(value_parser!(f64)).default_value("1e-6").help("Force tolerance relative to the largest member force"))
                .arg(Arg::new("out").long("out").short('o').default_value("out/simulate").value_parser(value_parser!(PathBuf)))
                .arg(Arg::new("quiet").long("quiet").short('q').action(ArgAction::SetTrue).help("No progress bar")),
        )
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
        Some(("simulate", a)) => simulate_cmd(a),
        Some(("experiment", a)) => experiment_cmd(a),
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
    println!(
        "wrote {}: {} nodes, {n_struts} struts, {n_cables} cables, {n_springs} springs, {} continuous cables ({} segments)",
        out.display(),
        s.nodes.len(),
        s.continuous_cables.len(),
        s.segment_count()
    );
    Ok(())
}

fn friction_from(a: &ArgMatches) -> Result<JointFriction> {
    let mu = *a.get_one::<f64>("mu").unwrap();
    let convention = match a.get_one::<String>("angle").map(String::as_str) {
        Some("interior") => AngleConvention::Interior,
        _ => AngleConvention::Wrap,
    };
    Ok(JointFriction::new(
        tensegrity_deploy::model::FrictionCoefficient::Constant(mu),
        convention,
    )?)
}

struct Progress(ProgressBar);

impl IncrementObserver for Progress {
    fn on_increment(&mut self, index: usize, count: usize, r: &RelaxReport) {
        self.0.set_message(format!(
            "increment {}/{count}: {} iterations",
            index + 1,
            r.iterations
        ));
    }
}

fn default_commands(s: &Structure) -> CommandSequence {
    CommandSequence {
        step_labels: (1..=5).collect(),
        payout_change_m: vec![vec![-0.002; s.continuous_cables.len()]; 5],
    }
}

fn simulate_cmd(a: &ArgMatches) -> Result<()> {
    let structure = match a.get_one::<PathBuf>("structure") {
        Some(p) => read_structure(p)?,
        None => reference_bridge(&BridgeParameters::default())?,
    };
    let commands = match a.get_one::<PathBuf>("commands") {
        Some(p) => read_commands(p, &structure)?,
        None => default_commands(&structure),
    };
    let increment = *a.get_one::<f64>("increment").unwrap();
    let tol = *a.get_one::<f64>("tol").unwrap();
    if !(tol > 0.0 && tol.is_finite()) {
        bail!("--tol must be a positive number, got {tol}");
    }
    let settings = RelaxSettings {
        tol_force_rel: tol,
        ..RelaxSettings::default()
    };
    let model = ForwardModel::new(structure, friction_from(a)?, settings);
    let mut ws = Workspace::default();
    let mut state = model.reference_state();
    let initial = model.relax(&mut state, &mut ws);
    let mut records = vec![StepRecord {
        step: 0,
        report: CommandReport {
            status: initial.status,
            increments: 0,
            iterations: initial.iterations,
            newton_iterations: initial.newton_iterations,
            max_residual_n: initial.max_residual_n,
            max_friction_residual_n: initial.max_friction_residual_n,
        },
        state: state.clone(),
    }];
    let bar = if a.get_flag("quiet") {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(commands.step_labels.len() as u64)
    };
    bar.set_style(ProgressStyle::with_template("{bar:30} {pos}/{len} steps {msg}").unwrap());
    let mut progress = Progress(bar.clone());
    let mut worst = initial.status;
    for (label, change) in commands.step_labels.iter().zip(&commands.payout_change_m) {
        let report = model.apply_payout(&mut state, &mut ws, change, increment, &mut progress)?;
        bar.inc(1);
        if report.status.severity() > worst.severity() {
            worst = report.status;
        }
        let stop = !report.status.is_converged();
        records.push(StepRecord {
            step: *label,
            report,
            state: state.clone(),
        });
        if stop {
            break;
        }
    }
    bar.finish_and_clear();
    let out = a.get_one::<PathBuf>("out").unwrap();
    write_simulation(out, &model, &records)?;
    print_summary(&model, &records, out);
    if worst != RelaxStatus::Converged {
        bail!("simulation stopped: {}", worst.describe());
    }
    Ok(())
}

fn print_summary(model: &ForwardModel, records: &[StepRecord], out: &Path) {
    println!(
        "{:>5} {:>10} {:>6} {:>10} {:>12} {:>14}",
        "step", "status", "incr", "iterations", "residual N", "max gap mm"
    );
    for r in records {
        let gap = r
            .state
            .max_midspan_gap_m(&model.structure)
            .map(|g| format!("{:.3}", 1e3 * g))
            .unwrap_or_else(|| "-".into());
        println!(
            "{:>5} {:>10} {:>6} {:>10} {:>12.2e} {:>14}",
            r.step,
            r.report.status.as_str(),
            r.report.increments,
            r.report.iterations,
            r.report.max_residual_n,
            gap
        );
    }
    println!("results in {}", out.display());
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RigExperiment {
    kind: String,
    mu: f64,
    #[serde(default)]
    convention: AngleConvention,
    interior_angles_deg: Vec<f64>,
    tensions_kn: Vec<Vec<f64>>,
    out: PathBuf,
}

fn experiment_cmd(a: &ArgMatches) -> Result<()> {
    let path = a.get_one::<PathBuf>("file").unwrap();
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let kind: toml::Table =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    match kind.get("kind").and_then(|k| k.as_str()) {
        Some("friction-rig") => {
            let e: RigExperiment =
                toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            debug_assert_eq!(e.kind, "friction-rig");
            friction_rig_experiment(&e, path)
        }
        Some(other) => bail!(
            "{}: field `kind`: unknown experiment \"{other}\" (known: friction-rig)",
            path.display()
        ),
        None => bail!("{}: field `kind` is missing", path.display()),
    }
}

fn friction_rig_experiment(e: &RigExperiment, path: &Path) -> Result<()> {
    if e.interior_angles_deg.len() != e.tensions_kn.len() {
        bail!(
            "{}: `tensions_kn` needs one list per entry of `interior_angles_deg`",
            path.display()
        );
    }
    let friction = JointFriction::new(
        tensegrity_deploy::model::FrictionCoefficient::Constant(e.mu),
        e.convention,
    )?;
    let mut csv = String::from("interior_angle_deg,tension_kn,slip_ratio_model,slip_ratio_formula,slip_load_n,mu_backcalc_interior,mu_backcalc_wrap\n");
    println!(
        "friction rig, true μ = {} ({:?} convention)",
        e.mu, e.convention
    );
    println!(
        "{:>6} {:>6} {:>12} {:>12} {:>12} {:>10} {:>10}",
        "θ deg", "T kN", "ratio model", "ratio e^μα", "slip load N", "μ(θ)", "μ(π−θ)"
    );
    for (theta_deg, tensions) in e.interior_angles_deg.iter().zip(&e.tensions_kn) {
        let theta = theta_deg.to_radians();
        for t_kn in tensions {
            let t = 1e3 * t_kn;
            let ratio = modelled_slip_ratio(&friction, theta, t);
            let formula = friction.ratio_bound(theta, false);
            let mu_interior = ratio.ln() / theta;
            let mu_wrap = ratio.ln() / (std::f64::consts::PI - theta);
            let load = t * (ratio - 1.0);
            println!("{theta_deg:>6.0} {t_kn:>6.1} {ratio:>12.6} {formula:>12.6} {load:>12.1} {mu_interior:>10.4} {mu_wrap:>10.4}");
            csv +=
                &format!("{theta_deg},{t_kn},{ratio},{formula},{load},{mu_interior},{mu_wrap}\n");
        }
    }
    std::fs::create_dir_all(&e.out)
        .with_context(|| format!("{}: cannot create", e.out.display()))?;
    let file = e.out.join("friction-rig.csv");
    tensegrity_deploy::io::write_atomically(&file, csv.as_bytes())?;
    println!("The seed back-calculates μ with the interior angle θ; with the wrap angle π−θ the same slips give the μ(π−θ) column.");
    println!("results in {}", file.display());
    Ok(())
}
