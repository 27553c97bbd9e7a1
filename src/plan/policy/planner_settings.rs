//! Which planner a policy runs, each with its own settings (`[planner]`
//! in policy files, `kind` naming the planner); `plan::planners` builds
//! the planner from them.

use serde::{Deserialize, Serialize};

use super::qp_planner::QpPlannerSettings;
use crate::numerics::{check_ranges, FieldError, NumberRange, Ranged};

/// Which planner a policy runs, with its settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum PlannerSettings {
    /// Even actuation: every motor reeled in by its fold payout in equal
    /// steps of the largest step, the seed lab's predetermined commands.
    Nominal(NominalSettings),
    /// Candidate moves of ±δ per motor, each simulated, the one that
    /// reduces the largest gap most kept (Sychterz & Smith 2018).
    GreedyTree(GreedyTreeSettings),
    /// Sequential convex programming: a QP on one-sided sensitivities in a
    /// trust region, confirmed by a forward re-solve.
    Qp(QpPlannerSettings),
}

impl Default for PlannerSettings {
    fn default() -> Self {
        PlannerSettings::Qp(QpPlannerSettings::default())
    }
}

impl PlannerSettings {
    /// Short name, as `kind` in policy files.
    pub fn as_str(&self) -> &'static str {
        match self {
            PlannerSettings::Nominal(_) => "nominal",
            PlannerSettings::GreedyTree(_) => "greedy_tree",
            PlannerSettings::Qp(_) => "qp",
        }
    }

    /// Checks the planner's settings.
    pub fn validate(&self) -> Result<(), FieldError> {
        match self {
            PlannerSettings::Nominal(_) => Ok(()),
            PlannerSettings::GreedyTree(g) => g.validate(),
            PlannerSettings::Qp(q) => q.validate(),
        }
    }
}

/// The nominal planner has no settings: its steps are the problem's.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NominalSettings {}

/// The greedy tree's move sizes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GreedyTreeSettings {
    /// The move size δ, m, in (0, 1]. Default 0.05 (one full step).
    pub move_m: f64,
    /// δ is halved when no move helps, down to this, m, in (0, `move_m`].
    /// Default 0.005.
    pub min_move_m: f64,
}

impl GreedyTreeSettings {
    /// Every number of the settings with its admissible range.
    pub fn ranges(&self) -> [Ranged; 2] {
        let length = NumberRange::positive_up_to(1.0);
        [
            Ranged::real("move_m", self.move_m, length),
            Ranged::real("min_move_m", self.min_move_m, length),
        ]
    }
}

impl Default for GreedyTreeSettings {
    fn default() -> Self {
        GreedyTreeSettings {
            move_m: 0.05,
            min_move_m: 0.005,
        }
    }
}

impl GreedyTreeSettings {
    /// Checks both sizes, the smallest not above the first.
    pub fn validate(&self) -> Result<(), FieldError> {
        check_ranges(&self.ranges())?;
        if self.min_move_m > self.move_m {
            return Err(FieldError::new(
                "min_move_m",
                format!(
                    "must be at most move_m ({}), got {}",
                    self.move_m, self.min_move_m
                ),
            ));
        }
        Ok(())
    }
}
