//! The one progress display of the commands ([`Progress`]): a bar on
//! stderr while a command works, drawn only when stderr is a terminal and
//! the command was not asked to be quiet (`simulate -q`, `deploy --json`);
//! the lines a command prints as it goes are printed above the bar. It is
//! the library's observer for every command that shows progress: the
//! deployments of an evaluation (its `run_done` callback: `evaluate`, the
//! deployment experiment), the commands of a closed-loop deployment
//! ([`DeployObserver`]: `deploy`), the steps of a simulation
//! ([`IncrementObserver`]: `simulate`).

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};

use tensegrity_deploy::control::{DeployObserver, DeployRecord, DeployStart};
use tensegrity_deploy::model::{DeploymentState, IncrementObserver, RelaxReport};

use super::words::{deployment_command_line, deployment_start_line};

/// What the bar counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Deployments of a sweep, with the time left.
    Deployments,
    /// Commands of a deployment, out of the policy's budget.
    Commands,
    /// Steps of a simulation, with the increment being solved.
    Steps,
}

impl Unit {
    fn template(self) -> &'static str {
        match self {
            Unit::Deployments => "{bar:30} {pos}/{len} deployments {eta}",
            Unit::Commands => "{bar:30} {pos}/{len} commands (budget)",
            Unit::Steps => "{bar:30} {pos}/{len} steps {msg}",
        }
    }
}

/// A command's progress: its bar and the lines it prints as it goes.
#[derive(Debug, Clone)]
pub struct Progress {
    bar: ProgressBar,
    quiet: bool,
}

impl Progress {
    /// A bar of `len` `unit`s; `quiet`: no bar and no lines.
    pub fn new(unit: Unit, len: u64, quiet: bool) -> Progress {
        let bar = if !quiet && std::io::stderr().is_terminal() {
            ProgressBar::new(len)
        } else {
            ProgressBar::hidden()
        };
        if let Ok(style) = ProgressStyle::with_template(unit.template()) {
            bar.set_style(style);
        }
        Progress { bar, quiet }
    }

    /// One more unit done (any thread).
    pub fn tick(&self) {
        self.bar.inc(1);
    }

    /// Prints `line` on stdout above the bar (nothing when quiet).
    pub fn say(&self, line: &str) {
        if !self.quiet {
            self.bar.suspend(|| say!("{line}"));
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// A closed-loop deployment: one line per command, the bar out of the
/// command budget.
impl DeployObserver for Progress {
    fn on_start(&mut self, start: &DeployStart) {
        self.bar.set_length(start.max_commands as u64);
        self.say(&deployment_start_line(start));
    }

    fn on_command(&mut self, record: &DeployRecord) {
        self.tick();
        self.say(&deployment_command_line(record));
    }
}

/// A simulation step: the increment being solved, as the bar's message.
impl IncrementObserver for Progress {
    fn on_increment(&mut self, index: usize, count: usize, r: &RelaxReport, _: &DeploymentState) {
        self.bar.set_message(format!(
            "increment {}/{count}: {} iterations",
            index + 1,
            r.iterations
        ));
    }
}
