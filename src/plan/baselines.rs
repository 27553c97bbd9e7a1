//! The two baselines the QP planner is measured against.
//!
//! - **Nominal**: even actuation by the design amount, as the seed lab's
//!   predetermined commands did: every motor reeled in by its fold payout
//!   in equal steps no larger than its largest step. Open loop, no search.
//! - **Greedy tree** (after Sychterz & Smith 2018): from the current state,
//!   each candidate move of ±δ on one motor is simulated; the admissible
//!   one that reduces the largest gap most is kept (ties within 0.1 mm go
//!   to the smaller sum of gaps). When none helps, δ is halved, down to
//!   the policy's smallest move.

use rayon::prelude::*;

use super::causes::NotReachable;
use super::outcome::PlanStatus;
use super::planner::{CommandPlanner, Decision, PlanContext, PlannedCommand, Trial};
use super::policy::GreedyTreeSettings;
use crate::model::DeploymentState;

/// Even actuation back to the designed payout.
#[derive(Debug, Clone)]
pub struct NominalPlanner {
    per_step_m: Vec<f64>,
    steps: usize,
    done: usize,
}

impl NominalPlanner {
    /// Plans `ceil(max_c |p_c| / max_step_c)` equal steps from `start`'s
    /// payouts `p` to zero.
    pub fn new(context: &PlanContext, start: &DeploymentState) -> Self {
        let steps = start
            .payout_m
            .iter()
            .zip(&context.motors.max_step_m)
            .map(|(p, s)| (p.abs() / s * (1.0 - 1e-12)).ceil() as usize)
            .max()
            .unwrap_or(0);
        NominalPlanner {
            per_step_m: start
                .payout_m
                .iter()
                .map(|p| -p / steps.max(1) as f64)
                .collect(),
            steps,
            done: 0,
        }
    }
}

impl CommandPlanner for NominalPlanner {
    fn next_command(&mut self, context: &PlanContext, state: &DeploymentState) -> Decision {
        if self.done >= self.steps {
            let worst = state
                .max_midspan_gap_m(context.model.structure())
                .unwrap_or(0.0);
            return Decision::Stop(PlanStatus::NotReachable {
                cause: NotReachable::NominalSequenceSpent {
                    largest_gap_m: worst,
                },
            });
        }
        if !context.command_admissible(state, &self.per_step_m) {
            return Decision::Stop(PlanStatus::NotReachable {
                cause: NotReachable::NominalStepLeavesStroke {
                    step: self.done + 1,
                },
            });
        }
        let trial = context.trial(state, &self.per_step_m);
        if let Some(failure) = trial.failure() {
            return Decision::Stop(PlanStatus::NotReachable {
                cause: NotReachable::NominalStepRejected {
                    step: self.done + 1,
                    failure,
                },
            });
        }
        self.done += 1;
        Decision::Command(Box::new(PlannedCommand {
            command_m: self.per_step_m.clone(),
            predicted_gaps_m: None,
            trial,
            active_constraints: vec![],
            qp_status: None,
            trust_region_m: None,
            rejected_trials: 0,
            linearisations: 0,
            take_up: false,
        }))
    }
}

/// One-motor moves of ±δ, the best kept.
#[derive(Debug, Clone)]
pub struct GreedyTreePlanner {
    move_m: f64,
    min_move_m: f64,
}

impl GreedyTreePlanner {
    /// Starts with the settings' move size.
    pub fn new(settings: &GreedyTreeSettings) -> Self {
        GreedyTreePlanner {
            move_m: settings.move_m,
            min_move_m: settings.min_move_m,
        }
    }
}

/// Largest gap, then sum of gaps, m.
fn score(context: &PlanContext, state: &DeploymentState) -> (f64, f64) {
    let g = context.gaps_m(state);
    (g.iter().fold(0.0f64, |a, b| a.max(*b)), g.iter().sum())
}

/// Ties in the largest gap within this are broken by the sum, m.
const TIE_M: f64 = 1e-4;

impl CommandPlanner for GreedyTreePlanner {
    fn next_command(&mut self, context: &PlanContext, state: &DeploymentState) -> Decision {
        let n = state.payout_m.len();
        let (current, _) = score(context, state);
        let mut rejected = 0;
        loop {
            let candidates: Vec<Vec<f64>> = (0..2 * n)
                .map(|k| {
                    let mut cmd = vec![0.0; n];
                    let c = k / 2;
                    let size = self.move_m.min(context.motors.max_step_m[c]);
                    cmd[c] = if k % 2 == 0 { -size } else { size };
                    cmd
                })
                .filter(|cmd| context.command_admissible(state, cmd))
                .collect();
            // Simulated in parallel; the choice below scans them in
            // candidate order, so it does not depend on thread count.
            let trials: Vec<Trial> = candidates
                .par_iter()
                .map(|cmd| context.trial(state, cmd))
                .collect();
            let mut best: Option<(usize, (f64, f64))> = None;
            for (k, t) in trials.iter().enumerate() {
                if !t.admissible() {
                    rejected += 1;
                    continue;
                }
                let s = score(context, &t.state);
                let better = match best {
                    None => true,
                    Some((_, b)) => s.0 < b.0 - TIE_M || (s.0 <= b.0 + TIE_M && s.1 < b.1),
                };
                if better {
                    best = Some((k, s));
                }
            }
            if let Some((k, s)) = best {
                if s.0 < current - 1e-5 {
                    let c = candidates[k].iter().position(|d| *d != 0.0).unwrap_or(0);
                    return Decision::Command(Box::new(PlannedCommand {
                        command_m: candidates[k].clone(),
                        predicted_gaps_m: None,
                        active_constraints: vec![format!(
                            "best of {} moves of ±{:.1} mm: {}",
                            candidates.len(),
                            1e3 * self.move_m,
                            context.model.structure().continuous_cables[c].id
                        )],
                        trial: trials[k].clone(),
                        qp_status: None,
                        trust_region_m: None,
                        rejected_trials: rejected,
                        linearisations: 0,
                        take_up: false,
                    }));
                }
            }
            self.move_m *= 0.5;
            if self.move_m < self.min_move_m {
                return Decision::Stop(PlanStatus::NotReachable {
                    cause: NotReachable::NoGreedyMove {
                        min_move_m: self.min_move_m,
                        largest_gap_m: current,
                    },
                });
            }
        }
    }
}
