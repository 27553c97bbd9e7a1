//! Settings of the equilibrium solver: one flat struct, every field with
//! its meaning, default, unit and the effect of changing it, and its
//! range declared beside the struct (`RelaxSettings::ranges`).

use crate::numerics::{check_ranges, FieldError, NumberRange, Ranged};

/// Settings of the DR solver. Defaults are what the reference bridge needs
/// for 0.01 mm-level positions; every field says what changing it does.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RelaxSettings {
    /// Largest number of DR iterations per solve. Default 200 000.
    /// A solve that reaches it reports [`super::RelaxStatus::IterationLimit`].
    pub max_iter: usize,
    /// Out-of-balance force tolerance relative to the largest member force.
    /// Default 1e-6. Smaller: more accurate, more iterations (about a
    /// constant number per decade).
    pub tol_force_rel: f64,
    /// Absolute floor of the force tolerance, N. Default 1e-9, so that an
    /// unloaded structure still has a finite tolerance.
    pub tol_force_abs: f64,
    /// Fictitious time step Δt, s. Default 1. Masses scale with Δt², so this
    /// only rescales velocities; it is kept for readers of Barnes' papers.
    pub time_step: f64,
    /// Safety factor on the Gershgorin fictitious masses. Default 1.0 (which
    /// already holds a factor two of margin). Raise it if a solve diverges.
    pub mass_factor: f64,
    /// Fictitious masses are recomputed after this many kinetic-damping
    /// resets, because geometry and tensions change. Default 16.
    pub mass_update_resets: usize,
    /// A solve that moves any node farther than this fraction of the
    /// structure's bounding-box diagonal stops with
    /// [`super::RelaxStatus::UnstableMechanism`]. Default 0.5.
    pub max_displacement_rel: f64,
    /// Newton–Raphson iterations per solve before DR takes over, with the
    /// consistent tangent of the friction mapping ([`crate::model::stiffness`]).
    /// Default 16 (a converging solve takes 3 to 9, but one that revises
    /// the joints' slip states restarts from a residual raised by the
    /// revision and needs up to about 8 more: at 12, 6 of the 40 increments
    /// of the μ = 0.2 bridge deployment ran out and went to DR, about
    /// 4000 DR iterations each; at 16, 2; see `Workspace::newton_counters`);
    /// 0 gives pure DR. Newton reaches the tolerance in a few iterations
    /// where DR needs thousands; DR takes over from the best Newton iterate
    /// whenever Newton stalls (slackening members, loss of stability), and
    /// the convergence test is the same either way.
    pub newton_max_iter: usize,
    /// Newton is skipped on structures with a block of more free degrees
    /// of freedom than this stored dense (its memory grows with their
    /// square; blocks that factorise faster sparse are stored sparse and
    /// not limited). Default 1500.
    pub newton_max_dofs: usize,
    /// Newton is skipped where one factorisation of the tangent is
    /// estimated to cost more than this many DR iterations (see
    /// `ForwardModel::newton_cost_ratio`): a dense factorisation grows with
    /// the cube of the coupled DOFs, a DR iteration with the members.
    /// Default 40: a solve takes about 5 factorisations and DR needs at
    /// least about 200 iterations from rest on every benchmark structure,
    /// so Newton is kept only where it cannot lose much. Lower: DR more
    /// often; raise it to force Newton.
    pub newton_max_cost_ratio: f64,
    /// Largest Newton step, as a fraction of the bounding-box diagonal;
    /// longer steps are shortened. Default 0.05: one step may not fold the
    /// structure into another equilibrium.
    pub newton_max_step_rel: f64,
    /// A Newton step is rejected (and halved) when it multiplies the
    /// residual norm by more than this. Default 100: a correct step along a
    /// soft mode stretches the stiff struts to second order and raises the
    /// residual for one iteration, so a monotone line search would stall.
    pub newton_watchdog: f64,
    /// Halvings of a rejected Newton step before Newton gives up. Default 6.
    pub newton_max_halvings: usize,
    /// Revisions of the joints' slip states (active-set rounds) per Newton
    /// solve. Default 4; more lets Newton follow more stick-slip changes
    /// before DR takes over.
    pub newton_max_active_set_rounds: usize,
    /// First continuation step of a command with friction, as a fraction of
    /// its increment. Default 1/16: joints start sliding early in an
    /// increment from rest, and a failed step costs a whole Newton solve
    /// (without friction the first step is the whole increment). Later
    /// increments of a command start from the step that last succeeded.
    pub newton_first_continuation_step: f64,
    /// Smallest continuation step, as a fraction of the increment; below it
    /// DR solves the increment from the farthest partial solution. Default
    /// 1/64.
    pub newton_min_continuation_step: f64,
    /// Force tolerance of the intermediate continuation steps of a Newton
    /// increment (λ < 1), relative to the largest member force; the last
    /// step (λ = 1) is solved to `tol_force_rel`. Default 1e-4. Every
    /// partial problem starts from the increment's start state, so its
    /// answer is only the next step's initial guess and slip states, never
    /// part of the result: a looser value saves Newton iterations on each
    /// intermediate step; too loose a guess costs iterations (and slip
    /// state revisions) at the last. Values below `tol_force_rel` act as
    /// `tol_force_rel` (every step solved to full accuracy).
    pub newton_tol_continuation_rel: f64,
    /// Whether DR hands the solve back to Newton once its iterates have
    /// settled the joints' slip states. Default `true`.
    ///
    /// Newton gives up on an increment where the joints' slip states cycle
    /// between active-set rounds (two neighbouring joints of a cable each
    /// sliding only while the other sticks, or a whole cable reversing) or
    /// its iterates leave the region where the fixed-slip tangent holds;
    /// DR, which maps the friction at every iterate, then settles those
    /// states within a few hundred iterations but closes the residual at
    /// the slow rate of the bridge's stiff-to-soft mode ratio (thousands
    /// of iterations). On: at a kinetic-damping reset after
    /// `dr_newton_restart_after_iter` DR iterations, Newton is tried from
    /// the DR iterate with the slip states DR holds there; its answer is
    /// accepted only when the return mapping confirms it to the same
    /// tolerance as DR's own test, and a failed try leaves the DR iterate
    /// as it was and doubles the wait before the next. Measured (seeded
    /// runs, 2-core machine): the 40 cm deployment over 2 cm seats at
    /// μ = 0.2 as eight commands spends 54 392 DR iterations after failed
    /// Newton solves off and about 18 500 on; `evaluate` of 200 scenarios of
    /// `scenarios/wide.toml` (seed 9090) 50.8 → 41.5 s with every status
    /// and violation count the same and gaps within 1 µm. Off: DR alone
    /// finishes what Newton left.
    pub dr_newton_restart_enable: bool,
    /// DR iterations before the first Newton try from a DR iterate (see
    /// `dr_newton_restart_enable`); the wait doubles after each failed try,
    /// so a solve Newton cannot finish spends at most about log₂ of its DR
    /// iterations on tries. Default 128: DR's first hundred iterations after
    /// Newton gave up are still moving joints between states; 32 to 256
    /// gave the same time on the seat deployment.
    pub dr_newton_restart_after_iter: usize,
    /// Tolerance of the friction return mapping relative to the force
    /// tolerance. Default 1e-2: the mapping need only be a little tighter
    /// than the force test, since DR and Newton call it at every iterate.
    pub tol_mapping_rel: f64,
    /// Whether increments are split where friction makes the path depend
    /// on their size. Default `false` (see the cost below).
    ///
    /// Each increment is a backward-Euler step of the friction law: its
    /// sliding is mapped once, from the material at its start to its end
    /// geometry. That is exact while every joint keeps one state through
    /// the increment, but a joint that reverses inside it (the command
    /// turned from reeling in to paying out) is mapped as if it had done so
    /// at the end, and the path depends on the increment size: 1.7 mm
    /// after a 5 cm reel-in and pay-out at μ = 0.2 between 1 cm and 1 mm
    /// increments. On: an increment in which a sliding joint reverses
    /// (passing more than `slip_event_min_transfer_m` the new way) is
    /// solved again in halves, and inside it every sub-step in which a
    /// joint stops or reverses likewise, down to `slip_event_min_substep_m`;
    /// a sub-step whose Newton solve fails is also halved before DR (the
    /// slow fallback) finishes it (a whole increment goes to DR as without
    /// the setting, and is split afterwards if a joint reversed in it). Measured (`examples/slip_event_probe.rs`,
    /// `cargo bench --bench relaxation -- bridge_deploy_40cm` and
    /// `cargo bench --bench planner -- closed_loop`, each pair in one run):
    /// the cycle above ends within 62 µm between 1 cm and 1 mm increments;
    /// the 40 cm deployment at μ = 0.2 in 1 cm increments costs 1.17× (82.3
    /// against 70.3 ms), a closed-loop deployment of the default truth
    /// with the setting on in the truth 1.11× (158.2 against 143.1 ms). Off:
    /// every increment is one step, as before. Why it stays off: switched
    /// on in the truth, the more exact path breaks a limit the controller
    /// cannot see. The first command after a fold reverses every sliding
    /// joint; located, the reversal shows the joints sticking first, so
    /// reeling in tensions the segments next to the motor while the ones
    /// beyond them fall (the uneven 45/33 cm fold, seed 1: segment
    /// `A_cc1[2]`, at 4.8 N below its 5 N minimum since the start, dips to
    /// 4.3 N and `A_cc1[3]` to 4.4 N in the first two increments, then
    /// both recover). Once
    /// mapped at the end of a 1 cm increment, the reversal slides at once
    /// and hides the dip; the frictionless controller predicts equal
    /// tension along the cable and cannot see it either. The memory
    /// policy's learning on the default truth also slows on seed 1 (cycle-4
    /// true gap 2.1×, not 3×, below cycle 1's; the mean over seeds 1–4 of
    /// cycles 4–6 is 3.2× against 3.7× off). Planning on the friction-aware
    /// model is what would see the dip (issue 22). The commands that
    /// deploy a truth (`deploy`, `cycles`, `evaluate`, `rig`) switch it on
    /// in the truth alone with `--slip-event-substeps`; a model file (a
    /// truth's or the controller's) asks for it with `[solver]
    /// slip_event_substeps = true` (`io::model_file::ModelSolver`).
    pub slip_event_substeps_enable: bool,
    /// Smallest sub-step of the splitting, m of the largest motor payout.
    /// Default 0.001 (the finest increment the tools use): a 1 cm increment
    /// locates its events to 1.25 mm, a 1 mm increment is not split, and
    /// the two paths agree to 62 µm; 0.125 mm gives 101 µm at 1.5× the
    /// cost (the 1 mm path is then split too), 2 mm gives 342 µm.
    pub slip_event_min_substep_m: f64,
    /// Material, m, a reversing joint must pass in the new direction
    /// within one increment for the increment to be split. Default 1e-4.
    ///
    /// While a joint is stuck its response is elastic and path
    /// independent, so mapping a reversal once at the increment's end
    /// misplaces at most the material that slid the new way, and a reversal
    /// passing less than this is mapped at the end. A monotone deployment
    /// has such reversals where the geometry shifts the tension ratio of a
    /// joint near its bound (16–54 µm at μ = 0.2 on the 40 cm deployment);
    /// splitting them bought nothing (its 1 cm and 1 mm paths stayed
    /// 129.9 µm apart either way) and cost 3 of its 8 splits. A command
    /// reversal passes millimetres in its first increment and is always
    /// located; 0 splits every reversal.
    pub slip_event_min_transfer_m: f64,
}

impl RelaxSettings {
    /// Every bounded setting with its admissible range (the iteration and
    /// size limits take any count).
    pub fn ranges(&self) -> [Ranged; 16] {
        let unit = NumberRange::positive_up_to(1.0);
        // A looser equilibrium tolerance is no equilibrium, and looser
        // partial answers are poor initial guesses.
        let tolerance = NumberRange::positive_up_to(1e-2);
        [
            Ranged::real("tol_force_rel", self.tol_force_rel, tolerance),
            Ranged::real("tol_force_abs", self.tol_force_abs, unit),
            Ranged::real("time_step", self.time_step, NumberRange::above(0.0)),
            // Below 1 the explicit step is unstable.
            Ranged::real("mass_factor", self.mass_factor, NumberRange::at_least(1.0)),
            Ranged::count(
                "mass_update_resets",
                self.mass_update_resets,
                NumberRange::at_least(1.0),
            ),
            Ranged::real(
                "max_displacement_rel",
                self.max_displacement_rel,
                NumberRange::above(0.0),
            ),
            Ranged::real("newton_max_step_rel", self.newton_max_step_rel, unit),
            Ranged::real(
                "newton_max_cost_ratio",
                self.newton_max_cost_ratio,
                NumberRange::above(0.0),
            ),
            Ranged::real(
                "newton_watchdog",
                self.newton_watchdog,
                NumberRange::above(1.0),
            ),
            Ranged::real(
                "newton_first_continuation_step",
                self.newton_first_continuation_step,
                unit,
            ),
            Ranged::real(
                "newton_min_continuation_step",
                self.newton_min_continuation_step,
                unit,
            ),
            Ranged::real(
                "newton_tol_continuation_rel",
                self.newton_tol_continuation_rel,
                tolerance,
            ),
            // 0 would try Newton at every reset, a cost with no answer.
            Ranged::count(
                "dr_newton_restart_after_iter",
                self.dr_newton_restart_after_iter,
                NumberRange::at_least(1.0),
            ),
            Ranged::real("tol_mapping_rel", self.tol_mapping_rel, unit),
            Ranged::real(
                "slip_event_min_substep_m",
                self.slip_event_min_substep_m,
                NumberRange::positive_up_to(1.0),
            ),
            Ranged::real(
                "slip_event_min_transfer_m",
                self.slip_event_min_transfer_m,
                NumberRange::non_negative_up_to(1.0),
            ),
        ]
    }
}

impl Default for RelaxSettings {
    fn default() -> Self {
        RelaxSettings {
            max_iter: 200_000,
            tol_force_rel: 1e-6,
            tol_force_abs: 1e-9,
            time_step: 1.0,
            mass_factor: 1.0,
            mass_update_resets: 16,
            max_displacement_rel: 0.5,
            newton_max_iter: 16,
            newton_max_dofs: 1500,
            newton_max_cost_ratio: 40.0,
            newton_max_step_rel: 0.05,
            newton_watchdog: 100.0,
            newton_max_halvings: 6,
            newton_max_active_set_rounds: 4,
            newton_first_continuation_step: 1.0 / 16.0,
            newton_min_continuation_step: 1.0 / 64.0,
            newton_tol_continuation_rel: 1e-4,
            dr_newton_restart_enable: true,
            dr_newton_restart_after_iter: 128,
            tol_mapping_rel: 1e-2,
            slip_event_substeps_enable: false,
            slip_event_min_substep_m: 0.001,
            slip_event_min_transfer_m: 1e-4,
        }
    }
}

/// A setting outside its admissible range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("solver setting `{field}`: {reason}")]
pub struct SettingsError {
    /// The field, as named in [`RelaxSettings`].
    pub field: String,
    /// What is wrong, e.g. `must be a finite number in [1, ∞), got 0.5`.
    pub reason: String,
}

impl From<FieldError> for SettingsError {
    fn from(e: FieldError) -> Self {
        SettingsError {
            field: e.field,
            reason: e.reason,
        }
    }
}

impl RelaxSettings {
    /// Checks every setting against its admissible range, and the smallest
    /// continuation step not above the first.
    pub fn validate(&self) -> Result<(), SettingsError> {
        check_ranges(&self.ranges())?;
        if self.newton_min_continuation_step > self.newton_first_continuation_step {
            return Err(SettingsError {
                field: "newton_min_continuation_step".into(),
                reason: format!(
                    "must be at most newton_first_continuation_step ({}), got {}",
                    self.newton_first_continuation_step, self.newton_min_continuation_step
                ),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_settings_are_named() {
        RelaxSettings::default().validate().unwrap();
        let bad = |edit: fn(&mut RelaxSettings)| {
            let mut s = RelaxSettings::default();
            edit(&mut s);
            s.validate().unwrap_err()
        };
        let e = bad(|s| s.mass_factor = 0.5);
        assert_eq!(e.field, "mass_factor");
        assert_eq!(
            e.to_string(),
            "solver setting `mass_factor`: must be a finite number in [1, ∞), got 0.5"
        );
        assert_eq!(bad(|s| s.newton_watchdog = 1.0).field, "newton_watchdog");
        assert_eq!(
            bad(|s| s.mass_update_resets = 0).field,
            "mass_update_resets"
        );
        assert_eq!(bad(|s| s.tol_force_rel = 0.1).field, "tol_force_rel");
        assert_eq!(bad(|s| s.time_step = f64::INFINITY).field, "time_step");
        assert_eq!(
            bad(|s| s.newton_min_continuation_step = 0.5).field,
            "newton_min_continuation_step"
        );
    }
}
