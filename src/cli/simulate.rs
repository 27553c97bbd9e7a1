//! `tdeploy simulate`: a command sequence applied to a structure, results as
//! CSV and an SVG of the final state over the initial one.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use clap::ArgMatches;
use indicatif::{ProgressBar, ProgressStyle};

use tensegrity_deploy::design::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::commands::{read_commands, CommandSequence};
use tensegrity_deploy::io::results::{write_simulation, StepRecord};
use tensegrity_deploy::io::structure_file::read_structure;
use tensegrity_deploy::io::write_atomically;
use tensegrity_deploy::model::{
    CommandReport, DeploymentState, ForwardModel, IncrementObserver, RelaxReport, RelaxSettings,
    RelaxStatus, Structure, Workspace,
};
use tensegrity_deploy::report::drawing::{state_views_svg, DrawnState};

use super::friction_from;

struct Progress(ProgressBar);

impl IncrementObserver for Progress {
    fn on_increment(&mut self, index: usize, count: usize, r: &RelaxReport, _: &DeploymentState) {
        self.0.set_message(format!(
            "increment {}/{count}: {} iterations",
            index + 1,
            r.iterations
        ));
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

/// Runs `tdeploy simulate`.
pub fn simulate(a: &ArgMatches) -> Result<()> {
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
    let model = ForwardModel::new(structure, friction_from(a)?, settings)?;
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
    let (first, last) = (&records[0].state, &records[records.len() - 1].state);
    let (f0, f1) = (model.member_forces(first), model.member_forces(last));
    let svg = state_views_svg(
        &model.structure(),
        DrawnState {
            state: last,
            forces: &f1,
            label: "final state",
        },
        Some(DrawnState {
            state: first,
            forces: &f0,
            label: "initial state",
        }),
        &model.structure().name,
    )?;
    write_atomically(&out.join("state.svg"), svg.as_bytes())?;
    print_summary(&model, &records, out);
    if worst != RelaxStatus::Converged {
        bail!("simulation stopped: {}", worst.describe());
    }
    Ok(())
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
            .max_midspan_gap_m(&model.structure())
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
