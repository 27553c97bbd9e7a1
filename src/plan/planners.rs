//! The planners a policy can name, built from its settings.

use super::baselines::{GreedyTreePlanner, NominalPlanner};
use super::planner::{CommandPlanner, PlanContext};
use super::policy::PlannerKind;
use super::search::QpPlanner;
use crate::model::DeploymentState;

/// The planner a policy names, starting from `start`.
pub fn planner_for(context: &PlanContext, start: &DeploymentState) -> Box<dyn CommandPlanner> {
    match context.policy.planner {
        PlannerKind::Nominal => Box::new(NominalPlanner::new(context, start)),
        PlannerKind::GreedyTree => Box::new(GreedyTreePlanner::new(context)),
        PlannerKind::Qp => Box::new(QpPlanner::new(context)),
    }
}
