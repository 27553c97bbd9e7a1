//! The one verdict on a run (a closed-loop deployment or a plan): what
//! `deploy`, `plan`, `evaluate`, `cycles` and the experiment report and
//! count, so that a run is called the same everywhere.
//!
//! A run is connected only when all three hold:
//! - the controller (or planner) stopped as connected and the judged
//!   midspan gaps (the truth's for a deployment, the model's for a plan)
//!   are within the connection tolerance;
//! - no limit was broken at any checked increment of any command (for a
//!   deployment, the truth's supervisor, [`Breach`]);
//! - every limit the start already broke was restored by the end
//!   ([`StartBrokenLimit`], see [`super::limits`]).
//!
//! Its label ([`RunVerdict::label`]) is the `status` every table writes:
//! `connected`; `limits_broken` (the truth broke a limit, whatever else
//! happened: the worst outcome, named first); the controller's own stop
//! (`not_reachable`, `command_limit`, `solver_failure`); `gap_out_of_tolerance`
//! (the controller stopped as connected, the judged gap is not within the
//! tolerance: an open-loop policy that saw no measurement); and
//! `limits_not_restored` (gaps within tolerance, a start-broken limit not
//! restored).

use serde::Serialize;

use super::limits::{force_rows, LimitViolation, Limits, StartBrokenLimit, StateBreach};
use super::outcome::{Plan, PlanStatus};
use super::problem::DeploymentProblem;
use crate::model::{DeploymentState, ForwardModel, Workspace};

/// How many broken limits a verdict's words name before "and N more".
const NAMED_IN_WORDS: usize = 5;

/// `words` of at most [`NAMED_IN_WORDS`] items joined by `; `, with
/// "and N more" for the rest.
fn named_in_words(words: impl ExactSizeIterator<Item = String>) -> String {
    let n = words.len();
    let mut named: Vec<String> = words.take(NAMED_IN_WORDS).collect();
    if n > NAMED_IN_WORDS {
        named.push(format!("and {} more", n - NAMED_IN_WORDS));
    }
    named.join("; ")
}

/// What [`RunVerdict::binds`] puts before a limit the truth's as-built
/// state breaks by itself (the prefix a run that did not start names its
/// as-built failure with, too: `truth as built: implausible_strain`).
pub const AS_BUILT_PREFIX: &str = "truth as built: ";

/// One limit broken during a run: its first breach and how often.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Breach {
    /// The command whose increments first broke it, 1 for the first.
    pub command: usize,
    /// The increment of that command, 1 for the first.
    pub increment: usize,
    /// The violation at that increment.
    pub violation: LimitViolation,
    /// Increments that broke it, over the whole run.
    pub increments: usize,
}

impl Breach {
    /// Plain words, e.g. `cable B_axial_m0_4 at 0.0 N, below 5.0 N in
    /// command 4 (increment 2; 7 increments)`.
    pub fn describe(&self) -> String {
        format!(
            "{} in command {} (increment {}; {} increment{})",
            self.violation.describe(),
            self.command,
            self.increment,
            self.increments,
            if self.increments == 1 { "" } else { "s" }
        )
    }

    /// One breach per limit from `(command, increment, violation)` in run
    /// order: the first of each limit, with the count of all.
    pub fn first_per_limit<'a>(
        all: impl IntoIterator<Item = (usize, usize, &'a LimitViolation)>,
    ) -> Vec<Breach> {
        let mut out: Vec<Breach> = Vec::new();
        let mut names: Vec<String> = Vec::new();
        for (command, increment, v) in all {
            let name = v.limit();
            match names.iter().position(|n| *n == name) {
                Some(k) => out[k].increments += 1,
                None => {
                    names.push(name);
                    out.push(Breach {
                        command,
                        increment,
                        violation: v.clone(),
                        increments: 1,
                    });
                }
            }
        }
        out
    }
}

/// What a run came to (see the module notes for the order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunOutcome {
    /// Gaps within tolerance, no limit broken, every start-broken limit
    /// restored.
    Connected,
    /// A limit was broken during the run.
    LimitsBroken,
    /// The controller stopped short (its status says why).
    Stopped,
    /// The controller stopped as connected; the judged gap is beyond the
    /// tolerance.
    GapOutOfTolerance,
    /// Gaps within tolerance; a start-broken limit not restored.
    LimitsNotRestored,
}

impl RunOutcome {
    /// The label the tables write for this outcome; `None` for
    /// [`RunOutcome::Stopped`], which writes the controller's status.
    pub fn label(self) -> Option<&'static str> {
        match self {
            RunOutcome::Connected => Some("connected"),
            RunOutcome::LimitsBroken => Some("limits_broken"),
            RunOutcome::Stopped => None,
            RunOutcome::GapOutOfTolerance => Some("gap_out_of_tolerance"),
            RunOutcome::LimitsNotRestored => Some("limits_not_restored"),
        }
    }
}

/// The verdict on one run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunVerdict {
    /// How the controller (or planner) itself ended.
    pub status: PlanStatus,
    /// Largest judged midspan gap at the end, m (`None`: unknown).
    pub largest_gap_m: Option<f64>,
    /// The connection tolerance, m.
    pub tolerance_m: f64,
    /// The limits broken, one per limit ([`Breach::first_per_limit`]).
    pub broken: Vec<Breach>,
    /// Violations over every command and increment (a limit broken at
    /// three increments counts three).
    pub violations: usize,
    /// The limits the start already broke, with whether they were
    /// restored.
    pub start_broken: Vec<StartBrokenLimit>,
    /// For a deployment that broke a truth limit or left one its start
    /// broke unrestored, the limits the truth breaks in its own as-built
    /// state (the designed state the halves
    /// are built to meet at, before any fold): a truth with a member cut
    /// off its length can be outside its limits there, where every
    /// deployment is meant to end. Context for the breach, not an excuse:
    /// the run still broke limits. Empty for plans, for runs that keep
    /// every limit, and for truths within every limit as built; named in
    /// [`Self::describe`] and [`Self::binds`] whatever the outcome.
    pub as_built_broken: Vec<StateBreach>,
}

impl RunVerdict {
    /// Every [`Self::label`] a run can have: the outcomes' own and the
    /// controller's stops ([`PlanStatus::LABELS`]).
    pub const LABELS: [&'static str; 7] = [
        "connected",
        "limits_broken",
        "not_reachable",
        "command_limit",
        "solver_failure",
        "gap_out_of_tolerance",
        "limits_not_restored",
    ];

    /// What the run came to.
    pub fn outcome(&self) -> RunOutcome {
        if !self.broken.is_empty() {
            RunOutcome::LimitsBroken
        } else if !self.status.is_connected() {
            RunOutcome::Stopped
        } else if !self.gap_within_tolerance() {
            RunOutcome::GapOutOfTolerance
        } else if !self.not_restored().is_empty() {
            RunOutcome::LimitsNotRestored
        } else {
            RunOutcome::Connected
        }
    }

    /// `true` only for [`RunOutcome::Connected`].
    pub fn is_connected(&self) -> bool {
        self.outcome() == RunOutcome::Connected
    }

    /// Whether the largest judged gap is known and within the tolerance.
    pub fn gap_within_tolerance(&self) -> bool {
        self.largest_gap_m.is_some_and(|g| g <= self.tolerance_m)
    }

    /// The start-broken limits not restored at the end.
    pub fn not_restored(&self) -> Vec<&StartBrokenLimit> {
        self.start_broken.iter().filter(|l| !l.restored).collect()
    }

    /// What decided a run that did not connect, each limit or motor named
    /// as the QP names its rows (`segment A_cc1[2] min`, `A_cc0 stroke
    /// min`, `A_cc1 slack`): the limits the truth broke, where it broke
    /// any; else, for a stop, what binds ([`NotReachable::binding`]:
    /// the limits the controller would not break; empty where the stop
    /// names none, e.g. a spent command budget or a solver failure); the
    /// start-broken limits left unrestored; nothing for a gap out of
    /// tolerance (no limit decided it). Then, whatever the outcome, the
    /// limits the truth's as-built state breaks by itself
    /// ([`Self::as_built_broken`]), each after [`AS_BUILT_PREFIX`]
    /// (`truth as built: cable B_ring0_1 max`). Empty for a connected run.
    ///
    /// [`NotReachable::binding`]: super::causes::NotReachable::binding
    pub fn binds(&self) -> Vec<String> {
        let mut names = match self.outcome() {
            RunOutcome::LimitsBroken => self.broken.iter().map(|b| b.violation.limit()).collect(),
            RunOutcome::Stopped => match &self.status {
                PlanStatus::NotReachable { cause } => cause.binding(),
                _ => Vec::new(),
            },
            RunOutcome::LimitsNotRestored => {
                self.not_restored().iter().map(|l| l.limit()).collect()
            }
            RunOutcome::Connected | RunOutcome::GapOutOfTolerance => Vec::new(),
        };
        names.extend(self.as_built_names());
        names
    }

    /// The `status` the tables write: `connected`, `limits_broken`, the
    /// controller's stop ([`PlanStatus::label`]), `gap_out_of_tolerance`
    /// or `limits_not_restored`.
    pub fn label(&self) -> &'static str {
        self.outcome().label().unwrap_or(self.status.label())
    }

    /// Plain words naming what decided the verdict, e.g. `connected, but
    /// 3 truth limits broken (12 violations): cable B_axial_m0_4 at 0.0 N,
    /// below 5.0 N in command 4 (increment 2; 7 increments); …`.
    pub fn describe(&self) -> String {
        let gap = match self.largest_gap_m {
            Some(g) => format!("{:.1} mm", 1e3 * g),
            None => "unknown".into(),
        };
        let tol = format!("{:.1} mm", 1e3 * self.tolerance_m);
        let mut text = match self.outcome() {
            RunOutcome::Connected => {
                format!("connected: largest gap {gap}, within {tol}; no limit broken")
            }
            RunOutcome::LimitsBroken => {
                let head = if self.status.is_connected() && self.gap_within_tolerance() {
                    "connected, but".to_string()
                } else {
                    format!(
                        "not connected: {} (largest gap {gap}), and",
                        self.status.describe()
                    )
                };
                let n = self.broken.len();
                format!(
                    "{head} {n} truth limit{} broken ({} violation{}): {}",
                    if n == 1 { "" } else { "s" },
                    self.violations,
                    if self.violations == 1 { "" } else { "s" },
                    named_in_words(self.broken.iter().map(Breach::describe))
                )
            }
            RunOutcome::Stopped => format!("not connected: {}", self.status.describe()),
            RunOutcome::GapOutOfTolerance => format!(
                "not connected: the controller stopped as connected, but the largest gap is {gap}, beyond the {tol} tolerance"
            ),
            RunOutcome::LimitsNotRestored => {
                format!("not connected: largest gap {gap}, within {tol}, but")
            }
        };
        let not_restored = self.not_restored();
        if !not_restored.is_empty() {
            let n = not_restored.len();
            let sep = if self.outcome() == RunOutcome::LimitsNotRestored {
                " "
            } else {
                "; "
            };
            text.push_str(&format!(
                "{sep}{n} limit{} broken at the start not restored: {}",
                if n == 1 { "" } else { "s" },
                named_in_words(not_restored.iter().map(|l| l.describe()))
            ));
        } else if !self.start_broken.is_empty() {
            let n = self.start_broken.len();
            text.push_str(&format!(
                "; {n} limit{} broken at the start, all restored",
                if n == 1 { "" } else { "s" }
            ));
        }
        let k = self.as_built_broken.len();
        if k > 0 {
            text.push_str(&format!(
                "; the truth breaks {k} limit{} in its own as-built state, before any fold: {}",
                if k == 1 { "" } else { "s" },
                named_in_words(self.as_built_broken.iter().map(StateBreach::describe))
            ));
        }
        text
    }

    /// The names [`Self::binds`] gives the limits of
    /// [`Self::as_built_broken`] (`truth as built: cable B_ring0_1 max`).
    fn as_built_names(&self) -> impl Iterator<Item = String> + '_ {
        self.as_built_broken
            .iter()
            .map(|b| format!("{AS_BUILT_PREFIX}{}", b.limit()))
    }
}

impl Plan {
    /// The verdict on an open-loop plan from `start` on `model` (its own
    /// truth): the model's gaps judged against the problem's tolerance,
    /// and the limits the start broke against the plan's final state (the
    /// planner accepts no trial that breaks a limit, so none is broken).
    pub fn verdict(
        &self,
        model: &ForwardModel,
        problem: &DeploymentProblem,
        start: &DeploymentState,
    ) -> RunVerdict {
        let limits = Limits::new(model, problem, start);
        // The final state is an equilibrium: relaxing a copy gives the
        // solver's force tolerance there without moving it.
        let mut end = self.final_state.clone();
        let tolerance_n = model.relax(&mut end, &mut Workspace::default()).tolerance_n;
        let rows = force_rows(model, &self.final_state);
        RunVerdict {
            status: self.status.clone(),
            largest_gap_m: self
                .final_state
                .midspan_gaps_m(model.structure())
                .into_iter()
                .reduce(f64::max),
            tolerance_m: problem.connection_tolerance_m,
            broken: Vec::new(),
            violations: 0,
            start_broken: limits.start_broken_limits(model.structure(), &rows, tolerance_n),
            as_built_broken: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::NotReachable;

    fn slack(member: &str, force_n: f64) -> LimitViolation {
        LimitViolation::BelowLower {
            member: member.into(),
            force_n,
            lower_n: 5.0,
        }
    }

    #[test]
    fn every_label_is_listed() {
        for status in [
            PlanStatus::Connected,
            PlanStatus::CommandLimit,
            PlanStatus::NotReachable {
                cause: NotReachable::QpInfeasible {
                    binding: Vec::new(),
                },
            },
        ] {
            for gap in [0.01, 0.05] {
                let mut v = verdict(status.clone(), gap);
                assert!(RunVerdict::LABELS.contains(&v.label()), "{}", v.label());
                v.broken.push(Breach {
                    command: 1,
                    increment: 1,
                    violation: slack("cable c", 0.0),
                    increments: 1,
                });
                assert!(RunVerdict::LABELS.contains(&v.label()), "{}", v.label());
            }
        }
        for l in PlanStatus::LABELS {
            assert!(RunVerdict::LABELS.contains(&l), "{l}");
        }
    }

    fn verdict(status: PlanStatus, gap: f64) -> RunVerdict {
        RunVerdict {
            status,
            largest_gap_m: Some(gap),
            tolerance_m: 0.030,
            broken: Vec::new(),
            violations: 0,
            start_broken: Vec::new(),
            as_built_broken: Vec::new(),
        }
    }

    #[test]
    fn broken_limits_outrank_gaps_and_the_controllers_own_stop() {
        let a = slack("cable B_axial_m0_4", 0.0);
        let b = slack("segment A_cc1[2]", 1.0);
        let all = [(4, 2, &a), (4, 3, &a), (5, 1, &b), (6, 1, &a)];
        let mut v = verdict(PlanStatus::Connected, 0.010);
        assert!(v.is_connected());
        v.broken = Breach::first_per_limit(all);
        v.violations = all.len();
        assert_eq!(v.broken.len(), 2);
        assert_eq!((v.broken[0].command, v.broken[0].increment), (4, 2));
        assert_eq!(v.broken[0].increments, 3);
        assert!(!v.is_connected());
        assert_eq!(v.label(), "limits_broken");
        assert_eq!(
            v.describe(),
            "connected, but 2 truth limits broken (4 violations): cable B_axial_m0_4 at 0.0 N, below 5.0 N in command 4 (increment 2; 3 increments); segment A_cc1[2] at 1.0 N, below 5.0 N in command 5 (increment 1; 1 increment)"
        );
        // Broken limits outrank the controller's own stop.
        v.status = PlanStatus::CommandLimit;
        assert_eq!(v.label(), "limits_broken");
        assert!(
            v.describe().starts_with("not connected: command limit"),
            "{}",
            v.describe()
        );
    }

    /// A truth that breaks a limit in its own as-built state (a member
    /// cut short overloading its ring) is named after what the run did,
    /// in words and in `binds`, without changing the outcome.
    #[test]
    fn a_truth_out_of_its_limits_as_built_is_named_after_the_breach() {
        let mut v = verdict(PlanStatus::Connected, 0.010);
        v.broken = Breach::first_per_limit([(4, 2, &slack("cable B_axial_m0_4", 0.0))]);
        v.violations = 1;
        v.as_built_broken = vec![StateBreach {
            member: "cable B_ring0_1".into(),
            lower: false,
            limit_n: 3000.0,
            force_n: 4765.14,
        }];
        assert_eq!(v.label(), "limits_broken");
        assert_eq!(
            v.describe(),
            "connected, but 1 truth limit broken (1 violation): cable B_axial_m0_4 at 0.0 N, below 5.0 N in command 4 (increment 2; 1 increment); the truth breaks 1 limit in its own as-built state, before any fold: cable B_ring0_1 at 4765.1 N, above its 3000.0 N maximum"
        );
        assert_eq!(
            v.binds(),
            vec![
                "cable B_axial_m0_4 min",
                "truth as built: cable B_ring0_1 max"
            ]
        );
        // A stop names it after what binds.
        v.broken.clear();
        v.violations = 0;
        v.status = PlanStatus::NotReachable {
            cause: NotReachable::QpInfeasible {
                binding: vec!["segment A_cc1[2] min".into()],
            },
        };
        assert_eq!(v.label(), "not_reachable");
        assert_eq!(
            v.binds(),
            vec![
                "segment A_cc1[2] min",
                "truth as built: cable B_ring0_1 max"
            ]
        );
    }

    /// `runs.csv`'s `binds`: the limits broken outrank the controller's
    /// stop, a stop names what it would not break, a start-broken limit
    /// left unrestored is named, a connected run names nothing.
    #[test]
    fn a_run_names_what_decided_it() {
        let stop = PlanStatus::NotReachable {
            cause: NotReachable::QpInfeasible {
                binding: vec!["segment A_cc1[2] min".into(), "A_cc0 stroke min".into()],
            },
        };
        let mut v = verdict(stop, 0.2);
        assert_eq!(v.binds(), vec!["segment A_cc1[2] min", "A_cc0 stroke min"]);
        v.broken = Breach::first_per_limit([(3, 1, &slack("cable B_axial_m0_4", 0.0))]);
        v.violations = 1;
        assert_eq!(v.binds(), vec!["cable B_axial_m0_4 min"]);
        assert!(verdict(PlanStatus::Connected, 0.01).binds().is_empty());
        assert!(verdict(PlanStatus::CommandLimit, 0.2).binds().is_empty());
        let mut left = verdict(PlanStatus::Connected, 0.01);
        left.start_broken.push(StartBrokenLimit {
            member: "segment A_cc1[3]".into(),
            lower: true,
            limit_n: 5.0,
            start_n: 0.0,
            end_n: 2.0,
            restored: false,
        });
        assert_eq!(left.label(), "limits_not_restored");
        assert_eq!(left.binds(), vec!["segment A_cc1[3] min"]);
    }

    #[test]
    fn a_connected_status_with_a_gap_beyond_tolerance_is_not_connected() {
        let v = verdict(PlanStatus::Connected, 0.097);
        assert_eq!(v.label(), "gap_out_of_tolerance");
        assert!(v.describe().contains("97.0 mm"), "{}", v.describe());
        let v = RunVerdict {
            largest_gap_m: None,
            ..verdict(PlanStatus::Connected, 0.0)
        };
        assert!(!v.is_connected());
        let v = verdict(
            PlanStatus::NotReachable {
                cause: NotReachable::QpInfeasible {
                    binding: vec!["segment A_cc1[2] min".into()],
                },
            },
            0.2,
        );
        assert_eq!(v.label(), "not_reachable");
        assert_eq!(v.outcome(), RunOutcome::Stopped);
        assert_eq!(
            v.describe(),
            "not connected: not reachable safely: segment A_cc1[2] min binds (no command meets the linearised limits (QP infeasible))"
        );
    }

    #[test]
    fn a_start_broken_limit_not_restored_is_reported_and_not_connected() {
        let mut l = StartBrokenLimit {
            member: "segment A_cc1[2]".into(),
            lower: true,
            limit_n: 5.0,
            start_n: 0.5,
            end_n: 2.0,
            restored: false,
        };
        let mut v = verdict(PlanStatus::Connected, 0.010);
        v.start_broken.push(l.clone());
        assert_eq!(v.label(), "limits_not_restored");
        assert_eq!(
            v.describe(),
            "not connected: largest gap 10.0 mm, within 30.0 mm, but 1 limit broken at the start not restored: segment A_cc1[2] slack at the start (0.5 N < 5.0 N), not restored (2.0 N at the end)"
        );
        l.restored = true;
        l.end_n = 12.0;
        v.start_broken = vec![l];
        assert!(v.is_connected());
        assert!(
            v.describe()
                .ends_with("1 limit broken at the start, all restored"),
            "{}",
            v.describe()
        );
    }
}
