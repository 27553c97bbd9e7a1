//! Policies as data: which planner with its own settings, the margins a
//! plan keeps from the problem's goal and limits, what the closed loop
//! measures and estimates, whether the policy learns from past cycles,
//! and how many commands it may use. Files in `policies/` hold them (read
//! by `io::policy_file`). The policy is read by plan, control and learn;
//! it stays in the plan layer, which the other two sit above.
//!
//! - [`planner_settings`]: the planner a policy runs (`[planner]`, with
//!   `kind`): nominal, greedy tree or QP;
//! - [`qp_planner`]: the QP planner's settings, with its
//!   [`trust_region`] (parameters and radius update);
//! - [`margins`]: margins on the connection, force and clearance limits
//!   (`[margins]`);
//! - [`control`]: measurements and estimation in closed loop
//!   (`[control]`);
//! - [`memory`]: learning from past cycles (`[memory]`, optional);
//! - [`off`]: settings that can be switched off (`"off"` in files,
//!   `None` in code).
//!
//! Every section declares its fields' ranges (`ranges()`, with
//! [`crate::numerics::NumberRange`]) and checks them in `validate()`; an
//! error names the field's path in the file (`planner.trust_region.shrink`).

pub mod control;
pub mod margins;
pub mod memory;
pub mod off;
pub mod planner_settings;
pub mod qp_planner;
pub mod trust_region;

pub use control::{ControlSettings, Measurement};
pub use margins::Margins;
pub use memory::{LearntPath, MemorySettings};
pub use planner_settings::{GreedyTreeSettings, NominalSettings, PlannerSettings};
pub use qp_planner::{QpPlannerSettings, SensitivityKind, Weights};
pub use trust_region::TrustRegion;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::numerics::{check_label, check_ranges, FieldError, NumberRange, Ranged};

/// Smallest [`Policy::increment_m`], m: the longest payout change a
/// problem allows in one solve (10 m) over the solver's increments per
/// command.
pub const SMALLEST_INCREMENT_M: f64 =
    10.0 / crate::model::solver::command::MAX_INCREMENTS_PER_COMMAND as f64;

/// Largest [`Policy::max_commands`].
pub const MAX_COMMANDS: usize = 10_000;

/// A control policy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Policy {
    /// Name for reports: one printable line of 1 to 64 characters
    /// ([`crate::numerics::check_label`]), since it is a column of
    /// `runs.csv` and of the printed tables. Default `qp`.
    pub name: String,
    /// Largest number of commands, 1 to 10 000. Default 40: five times the
    /// nominal sequence's 8 steps for a 40 cm fold.
    pub max_commands: usize,
    /// Largest payout increment of a forward solve, m, in [0.001, 1].
    /// Default 0.01: the seed's 1 cm actuation step, as every model command
    /// uses. At least 1 mm so that any payout change a problem allows in
    /// one solve (a command's step or the fold, each at most 10 m: the
    /// problem's ranges) needs no more than the solver's 10 000 increments
    /// per command
    /// ([`crate::model::solver::command::MAX_INCREMENTS_PER_COMMAND`]).
    pub increment_m: f64,
    /// Which planner, with its settings. Default the QP planner.
    pub planner: PlannerSettings,
    /// Margins on the goal and the limits.
    pub margins: Margins,
    /// What the closed loop measures and estimates.
    pub control: ControlSettings,
    /// Learning from past cycles (`None`: the policy has no memory).
    pub memory: Option<MemorySettings>,
}

impl Policy {
    /// Every number of the policy outside its sections with its admissible
    /// range.
    pub fn ranges(&self) -> [Ranged; 2] {
        [
            Ranged::count(
                "max_commands",
                self.max_commands,
                NumberRange::count(1, MAX_COMMANDS),
            ),
            Ranged::real(
                "increment_m",
                self.increment_m,
                NumberRange::closed(SMALLEST_INCREMENT_M, 1.0),
            ),
        ]
    }
}

impl Default for Policy {
    fn default() -> Self {
        Policy {
            name: "qp".into(),
            max_commands: 40,
            increment_m: 0.01,
            planner: PlannerSettings::default(),
            margins: Margins::default(),
            control: ControlSettings::default(),
            memory: None,
        }
    }
}

/// A policy field outside its range.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("policy field `{field}`: {reason}")]
pub struct PolicyError {
    /// Field path as in policy files, e.g. `planner.trust_region.shrink`.
    pub field: String,
    /// What is wrong.
    pub reason: String,
}

impl From<FieldError> for PolicyError {
    fn from(e: FieldError) -> Self {
        PolicyError {
            field: e.field,
            reason: e.reason,
        }
    }
}

impl Policy {
    /// Checks every field: finite and in range, section by section.
    pub fn validate(&self) -> Result<(), PolicyError> {
        check_label("name", &self.name)?;
        check_ranges(&self.ranges())?;
        self.planner.validate().map_err(|e| e.within("planner"))?;
        self.margins.validate().map_err(|e| e.within("margins"))?;
        self.control.validate().map_err(|e| e.within("control"))?;
        if let Some(m) = &self.memory {
            m.validate().map_err(|e| e.within("memory"))?;
        }
        Ok(())
    }

    /// Weight of each of `pairs` midspan pairs in the gap merit (the QP
    /// planner's and the case memory's); `None` if the QP planner's list
    /// has neither one entry nor one per pair. Other planners weigh every
    /// pair alike.
    pub fn gap_weights(&self, pairs: usize) -> Option<Vec<f64>> {
        match &self.planner {
            PlannerSettings::Qp(q) => q.weights.gap_weights(pairs),
            _ => Weights::default().gap_weights(pairs),
        }
    }

    /// Weight η of the midspan nodes' offsets from the design in the
    /// merit: the QP planner's `design_position`; 0 for the other
    /// planners, which reduce the gaps alone.
    pub fn design_position_weight(&self) -> f64 {
        match &self.planner {
            PlannerSettings::Qp(q) => q.weights.design_position,
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The policy with `edit` applied to its QP planner's settings.
    fn qp(edit: impl Fn(&mut QpPlannerSettings)) -> Policy {
        let mut p = Policy::default();
        let PlannerSettings::Qp(q) = &mut p.planner else {
            unreachable!("the default planner is the QP planner")
        };
        edit(q);
        p
    }

    #[test]
    fn default_policy_is_valid_and_bad_fields_are_named() {
        Policy::default().validate().unwrap();
        let p = qp(|q| q.trust_region.shrink = 1.5);
        assert_eq!(
            p.validate().unwrap_err().field,
            "planner.trust_region.shrink"
        );
        let p = qp(|q| q.trust_region.initial_m = 0.2);
        assert_eq!(
            p.validate().unwrap_err().field,
            "planner.trust_region.initial_m"
        );
        let p = qp(|q| q.weights.gap = vec![1.0, 2.0]);
        assert_eq!(p.gap_weights(5), None);
        for beta in [-0.1, 10.5, f64::NAN, 0.0] {
            let mut p = Policy::default();
            p.margins.unmeasured_force_fall = Some(beta);
            assert_eq!(
                p.validate().unwrap_err().field,
                "margins.unmeasured_force_fall"
            );
        }
        let mut off = Policy::default();
        off.margins.unmeasured_force_fall = None;
        off.validate().unwrap();
        let p = Policy {
            max_commands: 0,
            ..Policy::default()
        };
        assert_eq!(p.validate().unwrap_err().field, "max_commands");
        // Issue 25: 1e-9 passed and failed later, naming neither the file
        // nor the field ("…needs more than 10000 increments").
        let p = Policy {
            increment_m: 1e-9,
            ..Policy::default()
        };
        let e = p.validate().unwrap_err();
        assert_eq!(e.field, "increment_m");
        assert!(e.reason.contains("[0.001, 1]"), "{}", e.reason);
        let p = Policy {
            planner: PlannerSettings::GreedyTree(GreedyTreeSettings {
                move_m: 0.01,
                min_move_m: 0.02,
            }),
            ..Policy::default()
        };
        assert_eq!(p.validate().unwrap_err().field, "planner.min_move_m");
        let memory = |edit: fn(&mut MemorySettings)| {
            let mut settings = MemorySettings::default();
            edit(&mut settings);
            Policy {
                memory: Some(settings),
                ..Policy::default()
            }
            .validate()
            .map_err(|e| e.field)
        };
        assert_eq!(memory(|_| ()), Ok(()));
        let field = |f: &str| Err(f.to_string());
        assert_eq!(memory(|m| m.neighbours = 0), field("memory.neighbours"));
        assert_eq!(
            memory(|m| m.match_distance = f64::NAN),
            field("memory.match_distance")
        );
        assert_eq!(
            memory(|m| m.ilc_regularisation = 0.0),
            field("memory.ilc_regularisation")
        );
        assert_eq!(
            memory(|m| m.ilc_max_change_m = 0.0),
            field("memory.ilc_max_change_m")
        );
        assert_eq!(
            memory(|m| m.ilc_max_spread_m = -0.001),
            field("memory.ilc_max_spread_m")
        );
        assert_eq!(
            memory(|m| m.payout_scale_prior_sd = -0.1),
            field("memory.payout_scale_prior_sd")
        );
    }

    #[test]
    fn weights_and_control_settings_are_checked() {
        let p = qp(|q| q.weights.gap = vec![]);
        assert_eq!(p.validate().unwrap_err().field, "planner.weights.gap");
        let p = qp(|q| q.weights.gap = vec![0.0, 0.0]);
        assert_eq!(p.validate().unwrap_err().field, "planner.weights.gap");
        let p = qp(|q| q.weights.soft_limit_penalty = Some(0.0));
        assert_eq!(
            p.validate().unwrap_err().field,
            "planner.weights.soft_limit_penalty"
        );
        let p = qp(|q| q.sensitivity_reuse_tolerance = Some(1.5));
        assert_eq!(
            p.validate().unwrap_err().field,
            "planner.sensitivity_reuse_tolerance"
        );
        let mut p = Policy::default();
        p.control.payout_scale_prior_sd = Some(0.6);
        assert_eq!(
            p.validate().unwrap_err().field,
            "control.payout_scale_prior_sd"
        );
        p.control.payout_scale_prior_sd = None;
        p.validate().unwrap();
        assert_eq!(p.control.payout_scale_estimate_sd(), None);
        assert_eq!(
            Policy::default().control.payout_scale_estimate_sd(),
            Some(0.05)
        );
    }
}
