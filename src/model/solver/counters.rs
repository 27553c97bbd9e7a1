//! Counters of how Newton fares, kept in the [`super::Workspace`] so that
//! benchmarks and tests can see where a solve's time goes (issue 12)
//! without the solver printing anything.

/// Why a Newton solve (one continuation step, or the Newton ahead of DR in
/// [`super::ForwardModel::relax`]) gave up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum NewtonGaveUp {
    /// `newton_max_iter` reached.
    IterationLimit,
    /// More than `newton_max_active_set_rounds` revisions of the slip
    /// states were needed.
    SlipStateRounds,
    /// The tangent could not be factorised.
    Singular,
    /// A freshly factorised step was no descent direction.
    NotDescent,
    /// Every halving of a freshly factorised step raised the residual
    /// beyond the watchdog.
    LineSearch,
}

/// Counts of the Newton solves a [`super::Workspace`] has run, since it was
/// made or [`super::Workspace::reset_newton_counters`] was called.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NewtonCounters {
    /// Payout increments solved by Newton with continuation to the end.
    pub increments_by_newton: usize,
    /// Payout increments whose continuation fell below the smallest step
    /// and were handed to DR.
    pub increments_to_dr: usize,
    /// DR iterations spent on the increments handed to DR.
    pub dr_iterations_after_newton: usize,
    /// Newton solves tried from a DR iterate (see
    /// `RelaxSettings::dr_newton_restart_enable`) that converged and ended
    /// the solve.
    pub restarts_from_dr_converged: usize,
    /// Newton solves tried from a DR iterate that gave up (DR went on from
    /// where it was; each is also counted by its reason below).
    pub restarts_from_dr_failed: usize,
    /// Continuation steps that converged.
    pub steps_converged: usize,
    /// Continuation steps that failed (and were halved).
    pub steps_failed: usize,
    /// Newton solves that gave up at `newton_max_iter`.
    pub gave_up_iteration_limit: usize,
    /// Newton solves that gave up after `newton_max_active_set_rounds`
    /// revisions of the joints' slip states.
    pub gave_up_slip_state_rounds: usize,
    /// Newton solves that gave up on a singular tangent.
    pub gave_up_singular: usize,
    /// Newton solves that gave up on a step that was no descent direction.
    pub gave_up_not_descent: usize,
    /// Newton solves that gave up when no halving of a step passed the
    /// watchdog.
    pub gave_up_line_search: usize,
    /// Revisions of slip states (active-set rounds) in Newton solves that
    /// converged.
    pub slip_state_revisions: usize,
    /// Residual evaluations (each maps the friction of every cable).
    pub residual_evaluations: usize,
    /// Tangent factorisations (predictors and Newton steps; a chord step
    /// reuses one).
    pub factorisations: usize,
    /// Payout increments (or sub-steps) re-solved in two halves because a
    /// joint that was sliding at their start stopped or reversed in them
    /// (see `RelaxSettings::slip_event_substeps_enable`).
    pub slip_event_splits: usize,
}

impl NewtonCounters {
    /// Counts one Newton solve that gave up for `why`.
    pub(super) fn gave_up(&mut self, why: NewtonGaveUp) {
        *match why {
            NewtonGaveUp::IterationLimit => &mut self.gave_up_iteration_limit,
            NewtonGaveUp::SlipStateRounds => &mut self.gave_up_slip_state_rounds,
            NewtonGaveUp::Singular => &mut self.gave_up_singular,
            NewtonGaveUp::NotDescent => &mut self.gave_up_not_descent,
            NewtonGaveUp::LineSearch => &mut self.gave_up_line_search,
        } += 1;
    }
}
