//! How much joint friction changes a deployment: the seed's Table 2 and
//! Fig. 12 question, asked of the model.
//!
//! The same command sequence (every cable paid out `fold_m`, then reeled in
//! `deploy_m`, in increments of `increment_m`) is applied to the same
//! structure twice, once with frictionless joints and once with friction.
//! Without friction the response is elastic and path independent; with it,
//! joints stick on the way back, so the structure "does not deploy as far"
//! (the seed's words). Reported: the shift of each midspan node between the
//! two final states and the relative change of member forces by member type,
//! counting only members above a force floor (the seed used 50 N: "presenting
//! relative changes is not meaningful" for lightly loaded members).

use crate::model::{
    CommandError, CommandReport, DeploymentState, ForwardModel, JointFriction, MemberForces,
    MemberKind, RelaxSettings, Structure, Workspace,
};

/// Why a study could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyError {
    /// The solver settings are invalid.
    #[error("{0}")]
    Settings(#[from] crate::model::SettingsError),
    /// A command could not be applied.
    #[error("{0}")]
    Command(#[from] CommandError),
}

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionEffectSettings {
    /// Joint friction of the "with friction" run.
    pub friction: JointFriction,
    /// Payout of every cable first (folding), m.
    pub fold_m: f64,
    /// Reel-in of every cable afterwards (deploying), m.
    pub deploy_m: f64,
    /// Largest command increment, m.
    pub increment_m: f64,
    /// Members whose frictionless force is below this (in magnitude) are
    /// left out of the relative force changes, N.
    pub force_floor_n: f64,
    /// Solver settings for both runs.
    pub relax: RelaxSettings,
}

/// One run: its final state, forces and how the commands went.
#[derive(Debug, Clone)]
pub struct Run {
    /// Final state.
    pub state: DeploymentState,
    /// Its forces.
    pub forces: MemberForces,
    /// The fold command.
    pub fold: CommandReport,
    /// The deploy command.
    pub deploy: CommandReport,
}

/// Relative force change over one member type.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceChange {
    /// `strut`, `cable`, `spring` or `continuous cable`.
    pub kind: &'static str,
    /// Members counted (above the force floor).
    pub counted: usize,
    /// Mean of `|T_friction − T_frictionless| / |T_frictionless|`.
    pub mean_relative: f64,
    /// Largest of the same.
    pub max_relative: f64,
}

/// The comparison.
#[derive(Debug, Clone)]
pub struct FrictionEffect {
    /// Frictionless run.
    pub frictionless: Run,
    /// Run with friction.
    pub with_friction: Run,
    /// Node index and position shift of every midspan node, m (both halves,
    /// pair by pair: half A's node, then half B's).
    pub midspan_shift_m: Vec<(usize, f64)>,
    /// Relative force change per member type.
    pub force_change: Vec<ForceChange>,
    /// Relative change of every member and segment counted (member index in
    /// `structure.members`, or `members.len() + segment`), for the CSV.
    pub member_change: Vec<(usize, f64)>,
}

fn run(
    structure: &Structure,
    friction: JointFriction,
    s: &FrictionEffectSettings,
) -> Result<Run, StudyError> {
    let model = ForwardModel::new(structure.clone(), friction, s.relax.clone())?;
    let mut ws = Workspace::default();
    let mut state = model.reference_state();
    let n = structure.continuous_cables.len();
    let fold = model.apply_payout(
        &mut state,
        &mut ws,
        &vec![s.fold_m; n],
        s.increment_m,
        &mut (),
    )?;
    let deploy = model.apply_payout(
        &mut state,
        &mut ws,
        &vec![-s.deploy_m; n],
        s.increment_m,
        &mut (),
    )?;
    let forces = model.member_forces(&state);
    Ok(Run {
        state,
        forces,
        fold,
        deploy,
    })
}

/// Runs both deployments and compares them. Errors only for commands the
/// model cannot apply; solver status is in each run's reports.
pub fn friction_effect(
    structure: &Structure,
    settings: &FrictionEffectSettings,
) -> Result<FrictionEffect, StudyError> {
    let frictionless = run(structure, JointFriction::frictionless(), settings)?;
    let with_friction = run(structure, settings.friction.clone(), settings)?;
    let midspan_shift_m = structure
        .midspan_pairs
        .iter()
        .flatten()
        .map(|&i| {
            let d = with_friction.state.positions_m[i] - frictionless.state.positions_m[i];
            (i, d.norm())
        })
        .collect();
    let kind_of = |i: usize| -> &'static str {
        match structure.members.get(i).map(|m| &m.kind) {
            Some(MemberKind::Strut { .. }) => "strut",
            Some(MemberKind::Cable { .. }) => "cable",
            Some(MemberKind::Spring { .. }) => "spring",
            None => "continuous cable",
        }
    };
    let before = frictionless
        .forces
        .member_n
        .iter()
        .chain(&frictionless.forces.segment_n);
    let after = with_friction
        .forces
        .member_n
        .iter()
        .chain(&with_friction.forces.segment_n);
    let member_change: Vec<(usize, f64)> = before
        .zip(after)
        .enumerate()
        .filter(|(_, (t0, _))| t0.abs() >= settings.force_floor_n)
        .map(|(i, (t0, t1))| (i, (t1 - t0).abs() / t0.abs()))
        .collect();
    let force_change = ["strut", "cable", "spring", "continuous cable"]
        .into_iter()
        .map(|kind| {
            let rel: Vec<f64> = member_change
                .iter()
                .filter(|(i, _)| kind_of(*i) == kind)
                .map(|(_, r)| *r)
                .collect();
            ForceChange {
                kind,
                counted: rel.len(),
                mean_relative: if rel.is_empty() {
                    0.0
                } else {
                    rel.iter().sum::<f64>() / rel.len() as f64
                },
                max_relative: rel.iter().copied().fold(0.0, f64::max),
            }
        })
        .collect();
    Ok(FrictionEffect {
        frictionless,
        with_friction,
        midspan_shift_m,
        force_change,
        member_change,
    })
}
