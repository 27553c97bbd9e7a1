//! Which limits matter (issue 22, item 3), checked on the physics the
//! reasoning in `plan::limits` rests on: a tension-only member whose two
//! nodes are fixed in every direction (the abutment-ring cables with rigid
//! supports) cannot change length under any command, so its force is a
//! constant of the assembly and its minimum is no deployment limit; with
//! flexible supports the same member's force follows the commands, and
//! its minimum is a limit like any other.

mod common;

use common::fixtures::reference_structure;
use tensegrity_deploy::model::effects::SupportFlexibilityEffect;
use tensegrity_deploy::model::{Effects, MemberKind};
use tensegrity_deploy::plan::limits::{force_row_name, force_rows, Limits};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::sim::{EffectModel, Plant};

/// The fold of the default problem, m, and a reel-in of half of it.
const FOLD_M: f64 = 0.40;
const REEL_IN_M: f64 = 0.20;

/// The limits on `truth` folded by [`FOLD_M`], and its force rows before
/// and after every motor reels in [`REEL_IN_M`], N.
fn fold_and_reel_in(truth: &EffectModel) -> (Limits, Vec<f64>, Vec<f64>) {
    let n = truth.structure.continuous_cables.len();
    let mut plant = Plant::new(truth, Some(&vec![FOLD_M; n]), None).unwrap();
    let limits = Limits::new(plant.model(), &DeploymentProblem::default(), plant.state());
    let before = force_rows(plant.model(), plant.state());
    plant.apply(&vec![-REEL_IN_M; n], None, &mut ()).unwrap();
    let after = force_rows(plant.model(), plant.state());
    (limits, before, after)
}

fn with_supports(compliance_m_per_n: f64) -> EffectModel {
    let effects = Effects {
        support_flexibility: Some(SupportFlexibilityEffect { compliance_m_per_n }),
        ..Effects::default()
    };
    EffectModel::for_measurement(reference_structure(), effects)
}

/// The members between two rigidly supported nodes: row indices.
fn between_rigid_supports() -> Vec<usize> {
    let s = reference_structure();
    (0..s.members.len())
        .filter(|&m| {
            s.members[m]
                .nodes
                .iter()
                .all(|&n| s.nodes[n].fixed.iter().all(|f| *f))
        })
        .collect()
}

#[test]
fn a_member_between_rigid_supports_keeps_its_force_and_has_no_minimum() {
    let s = reference_structure();
    let fixed = between_rigid_supports();
    assert!(
        !fixed.is_empty(),
        "the reference bridge has an abutment ring"
    );
    let (limits, before, after) =
        fold_and_reel_in(&EffectModel::for_measurement(s.clone(), Effects::default()));
    let problem = DeploymentProblem::default();
    for (r, &is_fixed) in limits.fixed_length.iter().enumerate() {
        assert_eq!(is_fixed, fixed.contains(&r), "row {r}");
    }
    // The commands move the bridge: some other member's force changes by
    // far more than the solver's tolerance.
    let moved = (0..before.len())
        .filter(|r| !fixed.contains(r))
        .map(|r| (after[r] - before[r]).abs())
        .fold(0.0, f64::max);
    assert!(moved > 100.0, "{moved} N");
    for &r in &fixed {
        let name = force_row_name(&s, r);
        assert!(
            !matches!(s.members[r].kind, MemberKind::Strut { .. }),
            "{name}"
        );
        // Constant to the solver's force tolerance (1e-6 relative).
        assert!(
            (after[r] - before[r]).abs() <= 1e-6 * before[r].abs().max(1.0),
            "{name}: {} N, then {} N",
            before[r],
            after[r]
        );
        assert_eq!(limits.required[r].lower_n, f64::NEG_INFINITY, "{name}");
        assert_eq!(limits.required[r].upper_n, problem.max_tension_n, "{name}");
        assert!(!limits.start_broken[r], "{name}");
    }
}

#[test]
fn with_flexible_supports_a_ring_members_force_follows_the_commands_and_its_minimum_holds() {
    let s = reference_structure();
    let fixed = between_rigid_supports();
    // The middle of the plausible support compliance (1e-5 to 5e-5 m/N).
    let (limits, before, after) = fold_and_reel_in(&with_supports(3.0e-5));
    let problem = DeploymentProblem::default();
    let mut largest_change = 0.0f64;
    for &r in &fixed {
        let name = force_row_name(&s, r);
        // Members keep their indices in the flexible structure.
        assert_eq!(force_row_name(&with_supports(3.0e-5).structure, r), name);
        assert!(!limits.fixed_length[r], "{name}");
        assert_eq!(limits.required[r].lower_n, problem.min_tension_n, "{name}");
        largest_change = largest_change.max((after[r] - before[r]).abs());
    }
    // The rigid case holds these forces to 1e-6 relative; here the
    // commands move them by newtons (the ring's supports give by c·ΔR).
    assert!(largest_change > 1.0, "{largest_change} N");
}
