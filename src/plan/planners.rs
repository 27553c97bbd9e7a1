//! The planners a policy can name, built from its settings.

use super::baselines::{GreedyTreePlanner, NominalPlanner};
use super::planner::{CommandPlanner, PlanContext};
use super::policy::PlannerSettings;
use super::search::QpPlanner;
use crate::model::DeploymentState;

/// The planner a policy names, with its settings, starting from `start`.
pub fn planner_for(context: &PlanContext, start: &DeploymentState) -> Box<dyn CommandPlanner> {
    match &context.policy.planner {
        PlannerSettings::Nominal(_) => Box::new(NominalPlanner::new(context, start)),
        PlannerSettings::GreedyTree(settings) => Box::new(GreedyTreePlanner::new(settings)),
        PlannerSettings::Qp(settings) => Box::new(QpPlanner::new(settings)),
    }
}
