//! `tdeploy simulate`: a command sequence applied to a structure, results as
//! CSV ([`tensegrity_deploy::io::simulation_files`]) and an SVG of the
//! final state over the initial one
//! ([`tensegrity_deploy::report::drawing::simulation_svg`]).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Result};
use clap::{value_parser, Arg, ArgAction, ArgMatches, Command};

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::commands::{check_increments, read_commands, CommandSequence};
use tensegrity_deploy::io::experiment_file::{INCREMENT_RANGE_M, MU_RANGE};
use tensegrity_deploy::io::friction_table::read_friction_table;
use tensegrity_deploy::io::output::ResultsFolder;
use tensegrity_deploy::io::simulation_files::{write_simulation, StepRecord};
use tensegrity_deploy::io::structure_file::read_structure;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::model::{
    AngleConvention, CommandError, CommandReport, ForwardModel, FrictionCoefficient, JointFriction,
    RelaxSettings, RelaxStatus, Structure, Workspace,
};
use tensegrity_deploy::numerics::NumberRange;
use tensegrity_deploy::report::drawing::simulation_svg;

use super::progress::{Progress, Unit};
use super::{number_in, value, Outcome};

/// Range of `--tol`: what [`RelaxSettings::validate`] admits.
const TOL_RANGE: NumberRange = NumberRange::positive_up_to(1e-2);

/// The `simulate` subcommand's arguments.
pub fn command() -> Command {
    Command::new("simulate")
        .about("Apply a command sequence to a structure and write positions, forces and sliding per step")
        .arg(Arg::new("structure").long("structure").short('s').value_parser(value_parser!(PathBuf)).help("Structure file (default: the built-in reference bridge)"))
        .arg(Arg::new("commands").long("commands").short('c').value_parser(value_parser!(PathBuf)).help("Command CSV (default: a 5 cm fold-deploy cycle: every cable paid out 1 cm per step for 5 steps, then reeled in 1 cm per step for 5 steps)"))
        .arg(
            Arg::new("mu")
                .long("mu")
                .value_parser(value_parser!(f64))
                .default_value("0")
                .conflicts_with("mu-table")
                .help("Joint friction coefficient μ (constant), 0 to 2. 0: frictionless clustered cables"),
        )
        .arg(
            Arg::new("mu-table")
                .long("mu-table")
                .value_parser(value_parser!(PathBuf))
                .help("CSV `interior_angle_deg,mu`: μ interpolated over the joint's interior angle"),
        )
        .arg(
            Arg::new("angle")
                .long("angle")
                .value_parser(["wrap", "interior"])
                .default_value("wrap")
                .help("Angle in the capstan exponent: wrap angle π−θ (physical) or interior angle θ (the seed's Eq. 6)"),
        )
        .arg(Arg::new("increment").long("increment").value_parser(value_parser!(f64)).default_value("0.001").help("Largest payout increment per relaxation, m, in (0, 0.1]"))
        .arg(Arg::new("tol").long("tol").value_parser(value_parser!(f64)).default_value("1e-6").help("Force tolerance relative to the largest member force, in (0, 0.01]"))
        .arg(Arg::new("slip-event-substeps").long("slip-event-substeps").action(clap::ArgAction::SetTrue).help("Split increments at friction reversals (and their sub-steps where Newton fails) down to 1 mm, so the path hardly depends on --increment (62 µm between 1 cm and 1 mm over a 5 cm reel-in and pay-out at μ 0.2, against 1.7 mm); about 1.17× the time of a 40 cm deployment"))
        .arg(Arg::new("max-iter").long("max-iter").value_parser(value_parser!(usize)).default_value("200000").help("Most dynamic-relaxation iterations per solve; a solve that needs more stops the run (exit 1)"))
        .arg(Arg::new("out").long("out").short('o').default_value("out/simulate").value_parser(value_parser!(PathBuf)))
        .arg(Arg::new("quiet").long("quiet").short('q').action(ArgAction::SetTrue).help("No progress bar"))
        .arg(super::force_arg())
}

/// Where μ comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum MuSource {
    /// `--mu`.
    Constant(f64),
    /// `--mu-table`: a friction table file.
    Table(PathBuf),
}

/// Options of `tdeploy simulate`.
#[derive(Debug, Clone)]
pub struct Options {
    /// Structure file; `None`: the reference bridge.
    pub structure: Option<PathBuf>,
    /// Command file; `None`: the default fold-deploy cycle.
    pub commands: Option<PathBuf>,
    /// Joint friction coefficient.
    pub mu: MuSource,
    /// Angle in the capstan exponent.
    pub convention: AngleConvention,
    /// Largest payout increment, m.
    pub increment_m: f64,
    /// Solver settings (`--tol`, `--max-iter`, `--slip-event-substeps`; the
    /// rest default).
    pub settings: RelaxSettings,
    /// Results folder.
    pub out: PathBuf,
    /// No progress bar.
    pub quiet: bool,
    /// Replace an output folder that holds other files.
    pub force: bool,
}

impl Options {
    /// The options of the parsed subcommand.
    pub fn from_matches(m: &ArgMatches) -> Result<Options> {
        let mu = match m.get_one::<PathBuf>("mu-table") {
            Some(path) => MuSource::Table(path.clone()),
            None => MuSource::Constant(number_in(m, "mu", MU_RANGE)?),
        };
        let convention = match value::<String>(m, "angle")?.as_str() {
            "interior" => AngleConvention::Interior,
            _ => AngleConvention::Wrap,
        };
        let max_iter: usize = value(m, "max-iter")?;
        if max_iter == 0 {
            return Err(anyhow!("--max-iter: must be at least 1"));
        }
        Ok(Options {
            structure: m.get_one::<PathBuf>("structure").cloned(),
            commands: m.get_one::<PathBuf>("commands").cloned(),
            mu,
            convention,
            increment_m: number_in(m, "increment", INCREMENT_RANGE_M)?,
            settings: RelaxSettings {
                tol_force_rel: number_in(m, "tol", TOL_RANGE)?,
                max_iter,
                slip_event_substeps_enable: m.get_flag("slip-event-substeps"),
                ..RelaxSettings::default()
            },
            out: value(m, "out")?,
            quiet: m.get_flag("quiet"),
            force: m.get_flag("force"),
        })
    }
}

/// A 5 cm fold-deploy cycle, the range of the seed's tests: every cable paid
/// out 1 cm per step for 5 steps, then reeled in 1 cm per step for 5 steps.
fn default_commands(s: &Structure) -> CommandSequence {
    let n = s.continuous_cables.len();
    CommandSequence {
        step_labels: (1..=10).collect(),
        payout_change_m: (0..10)
            .map(|k| vec![if k < 5 { 0.01 } else { -0.01 }; n])
            .collect(),
    }
}

/// Runs `tdeploy simulate`. Steps stop at the first that does not
/// converge; what was reached is written, and the outcome says the goal
/// was missed.
pub fn run(o: &Options) -> Result<Outcome> {
    let structure = match &o.structure {
        Some(p) => read_structure(p)?,
        None => reference_bridge(&BridgeParameters::default())?,
    };
    let commands = match &o.commands {
        Some(p) => read_commands(p, &structure)?,
        None => default_commands(&structure),
    };
    let commands_name = o
        .commands
        .clone()
        .unwrap_or_else(|| PathBuf::from("the default commands"));
    check_increments(&commands, o.increment_m, &commands_name)?;
    let mu = match &o.mu {
        MuSource::Constant(mu) => FrictionCoefficient::Constant(*mu),
        MuSource::Table(path) => read_friction_table(path)?,
    };
    let friction = JointFriction::new(mu, o.convention)?;
    let model = ForwardModel::new(structure, friction, o.settings.clone())?;
    // Claimed before the work, so that a refusal costs nothing.
    let folder = ResultsFolder::claim(&o.out, "simulate", o.force)?;
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
    let mut progress = Progress::new(Unit::Steps, commands.step_labels.len() as u64, o.quiet);
    let mut worst = initial.status;
    let mut refused = None;
    if initial.status.is_converged() {
        for (label, change) in commands.step_labels.iter().zip(&commands.payout_change_m) {
            let report = match model.apply_payout(
                &mut state,
                &mut ws,
                change,
                o.increment_m,
                &mut progress,
            ) {
                Ok(report) => report,
                Err(e) => {
                    // The steps before it are written all the same.
                    // Name the cable by its id, not its index.
                    let e = match e {
                            CommandError::ReeledThrough { cable, left_m } => format!(
                                "continuous cable \"{}\": reeling in would leave {left_m:.4} m in the first segment",
                                model.structure().continuous_cables[cable].id
                            ),
                            other => other.to_string(),
                        };
                    refused = Some(anyhow!(
                        "step {label} cannot be applied: {e} (results up to step {} in {})",
                        records.last().map(|r| r.step).unwrap_or(0),
                        o.out.display()
                    ));
                    break;
                }
            };
            progress.tick();
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
    }
    progress.finish();
    write_simulation(folder.path(), &model, &records)?;
    let (first, last) = (&records[0].state, &records[records.len() - 1].state);
    let svg = simulation_svg(&model, first, last)?;
    write_atomically(&folder.path().join("state.svg"), svg.as_bytes())?;
    folder.commit()?;
    print_summary(&model, &records, &o.out);
    if let Some(e) = refused {
        return Err(e);
    }
    if worst != RelaxStatus::Converged {
        let step = records.last().map(|r| r.step).unwrap_or(0);
        return Ok(Outcome::GoalMissed(format!(
            "simulation stopped at step {step}: {} (results up to it in {})",
            worst.describe(),
            o.out.display()
        )));
    }
    Ok(Outcome::GoalReached)
}

fn print_summary(model: &ForwardModel, records: &[StepRecord], out: &Path) {
    say!(
        "{:>5} {:>10} {:>6} {:>8} {:>8} {:>12} {:>14}",
        "step",
        "status",
        "incr",
        "Newton",
        "DR",
        "residual N",
        "max gap mm"
    );
    for r in records {
        let gap = r
            .state
            .max_midspan_gap_m(model.structure())
            .map(|g| format!("{:.3}", 1e3 * g))
            .unwrap_or_else(|| "-".into());
        say!(
            "{:>5} {:>10} {:>6} {:>8} {:>8} {:>12.2e} {:>14}",
            r.step,
            r.report.status.as_str(),
            r.report.increments,
            r.report.newton_iterations,
            r.report.iterations,
            r.report.max_residual_n,
            gap
        );
    }
    say!(
        "results in {} (steps.csv, positions.csv, member_forces.csv, segments.csv, state.svg)",
        out.display()
    );
}
