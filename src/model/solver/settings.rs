//! Settings of the equilibrium solver: one flat struct, every field with
//! its meaning, default, unit and the effect of changing it.

/// Settings of the DR solver. Defaults are what the reference bridge needs
/// for 0.01 mm-level positions; every field says what changing it does.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RelaxSettings {
    /// Largest number of DR iterations per solve. Default 200 000.
    /// A solve that reaches it reports [`RelaxStatus::IterationLimit`].
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
    /// [`RelaxStatus::UnstableMechanism`]. Default 0.5.
    pub max_displacement_rel: f64,
    /// Newton–Raphson iterations per solve before DR takes over, with the
    /// consistent tangent of the friction mapping ([`super::stiffness`]).
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
    /// Tolerance of the friction return mapping relative to the force
    /// tolerance. Default 1e-2: the mapping need only be a little tighter
    /// than the force test, since DR and Newton call it at every iterate.
    pub tol_mapping_rel: f64,
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
            tol_mapping_rel: 1e-2,
        }
    }
}

/// A setting outside its admissible range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("solver setting `{field}` = {value}: {expected}")]
pub struct SettingsError {
    /// The field, as named in [`RelaxSettings`].
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// What it must be.
    pub expected: &'static str,
}

impl RelaxSettings {
    /// Checks every field against its admissible range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let check = |field: &'static str, value: f64, ok: bool, expected: &'static str| {
            if ok && value.is_finite() {
                Ok(())
            } else {
                Err(SettingsError {
                    field,
                    value,
                    expected,
                })
            }
        };
        check("max_iter", self.max_iter as f64, true, "a count")?;
        check(
            "tol_force_rel",
            self.tol_force_rel,
            self.tol_force_rel > 0.0 && self.tol_force_rel <= 1e-2,
            "in (0, 1e-2]: a looser tolerance is no equilibrium",
        )?;
        check(
            "tol_force_abs",
            self.tol_force_abs,
            self.tol_force_abs > 0.0 && self.tol_force_abs <= 1.0,
            "in (0, 1] N",
        )?;
        check(
            "time_step",
            self.time_step,
            self.time_step > 0.0,
            "positive",
        )?;
        check(
            "mass_factor",
            self.mass_factor,
            self.mass_factor >= 1.0,
            "at least 1 (below 1 the explicit step is unstable)",
        )?;
        check(
            "mass_update_resets",
            self.mass_update_resets as f64,
            self.mass_update_resets >= 1,
            "at least 1",
        )?;
        check(
            "max_displacement_rel",
            self.max_displacement_rel,
            self.max_displacement_rel > 0.0,
            "positive",
        )?;
        check(
            "newton_max_step_rel",
            self.newton_max_step_rel,
            self.newton_max_step_rel > 0.0 && self.newton_max_step_rel <= 1.0,
            "in (0, 1]",
        )?;
        check(
            "newton_max_cost_ratio",
            self.newton_max_cost_ratio,
            self.newton_max_cost_ratio > 0.0,
            "positive",
        )?;
        check(
            "newton_watchdog",
            self.newton_watchdog,
            self.newton_watchdog > 1.0,
            "above 1",
        )?;
        check(
            "newton_first_continuation_step",
            self.newton_first_continuation_step,
            self.newton_first_continuation_step > 0.0 && self.newton_first_continuation_step <= 1.0,
            "in (0, 1]",
        )?;
        check(
            "newton_min_continuation_step",
            self.newton_min_continuation_step,
            self.newton_min_continuation_step > 0.0
                && self.newton_min_continuation_step <= self.newton_first_continuation_step,
            "in (0, newton_first_continuation_step]",
        )?;
        check(
            "newton_tol_continuation_rel",
            self.newton_tol_continuation_rel,
            self.newton_tol_continuation_rel > 0.0 && self.newton_tol_continuation_rel <= 1e-2,
            "in (0, 1e-2]: looser partial answers are poor initial guesses",
        )?;
        check(
            "tol_mapping_rel",
            self.tol_mapping_rel,
            self.tol_mapping_rel > 0.0 && self.tol_mapping_rel <= 1.0,
            "in (0, 1]",
        )?;
        Ok(())
    }
}
