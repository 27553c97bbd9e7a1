//! Which limits matter (issue 22, item 3), checked on the physics the
//! reasoning in `plan::limits` rests on: a tension-only member whose two
//! nodes are held by the abutment in every direction (the abutment-ring
//! cables) has no deployment minimum. With rigid supports it cannot change
//! length under any command, so its force is a constant of the assembly;
//! with flexible supports its force follows the commands and goes slack on
//! the way whatever the commands, while the foundation bars still hold
//! both its nodes in every direction.

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
    for (r, &is_fixed) in limits.between_supports.iter().enumerate() {
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

/// With flexible supports the ring cables' force follows the commands
/// (newtons, where rigid supports hold it to 1e-6), and along a uniform
/// reel-in from the 40 cm fold it reaches 0 N at every plausible
/// compliance (1e-5 to 5e-5 m/N), returning to its design prestress at the
/// design: a slackening no controller causes or avoids (see
/// `plan::limits`). Their nodes stay held by the foundation bars in every
/// direction, so they are still between supports and keep no minimum;
/// their upper bound stays.
#[test]
fn with_flexible_supports_the_ring_cables_slacken_on_the_way_and_keep_only_their_upper_limit() {
    let s = reference_structure();
    let fixed = between_rigid_supports();
    let problem = DeploymentProblem::default();
    for compliance in [1.0e-5, 3.0e-5, 5.0e-5] {
        let truth = with_supports(compliance);
        let (limits, before, after) = fold_and_reel_in(&truth);
        let mut largest_change = 0.0f64;
        for &r in &fixed {
            let name = force_row_name(&s, r);
            // Members keep their indices in the flexible structure.
            assert_eq!(force_row_name(&truth.structure, r), name);
            assert!(limits.between_supports[r], "{name}");
            assert_eq!(limits.required[r].lower_n, f64::NEG_INFINITY, "{name}");
            assert_eq!(limits.required[r].upper_n, problem.max_tension_n, "{name}");
            largest_change = largest_change.max((after[r] - before[r]).abs());
        }
        assert!(largest_change > 1.0, "{compliance}: {largest_change} N");
        // Only the ring: no member with a free node is between supports.
        // Along the reel-in the smallest ring force reaches 0 N and the
        // design restores it (300 N prestress).
        let n = truth.structure.continuous_cables.len();
        let mut plant = Plant::new(&truth, Some(&vec![FOLD_M; n]), None).unwrap();
        // Only the ring and the foundation bars (struts, which keep their
        // buckling bound) are between supports.
        let between = limits.between_supports.iter().filter(|b| **b).count();
        let bars = plant.model().structure().members.len() - s.members.len();
        assert!(bars >= 3, "{compliance}: {bars} bars");
        assert_eq!(between, fixed.len() + bars, "{compliance}");
        let ring_min = |plant: &Plant| {
            let f = force_rows(plant.model(), plant.state());
            fixed.iter().map(|&r| f[r]).fold(f64::INFINITY, f64::min)
        };
        let mut smallest = ring_min(&plant);
        for _ in 0..8 {
            plant.apply(&vec![-0.05; n], None, &mut ()).unwrap();
            smallest = smallest.min(ring_min(&plant));
        }
        assert!(smallest < 0.5, "{compliance}: {smallest} N");
        assert!(
            ring_min(&plant) > 250.0,
            "{compliance}: {} N",
            ring_min(&plant)
        );
    }
}
