//! The default truth of a closed-loop deployment: what `tdeploy deploy`
//! runs its controller against when no truth model file is given.
//!
//! Two effects, both of the kind the seed's lab bridge has and a
//! frictionless clustered-cable model lacks:
//!
//! - **joint friction**, μ = [`DEFAULT_TRUTH_MU`] = 0.2 in the capstan
//!   law with the wrap angle φ = π − θ (the library's default and the
//!   physically consistent convention, as `experiments/lab/truth-friction.toml`
//!   uses). The seed's friction rig gave coefficients of order 0.1 to 0.3
//!   over its interior angles; 0.2 is the middle of that range, and twice
//!   the lab truth's 0.1, so that a deployment is clearly path dependent.
//! - **motor backlash** of [`DEFAULT_TRUTH_BACKLASH_M`] = 3 mm: the gear
//!   train of a drum motor has play, taken up on each reversal of a
//!   cable's direction. The seed does not report it; 3 mm is inside the
//!   effect's plausible range (0–5 mm) and small beside the seed's 1 cm
//!   actuation step, but it makes the first reel-in after the fold (the
//!   drums were paying out) and every later reversal fall short.
//!
//! No drum slip: the seed's drums hold their cable clamped and wound, and
//! report no creep. Slip would also act on the fold itself in a replay of
//! the deployment's log (which records the fold as its first command),
//! while the plant reaches its start payout exactly, so a log of the run
//! would no longer replay to the truth. A slipping truth is one model file
//! away (`tdeploy deploy --truth`).

use super::effect_model::EffectModel;
use crate::model::effects::{JointFrictionEffect, MotorEffect};
use crate::model::{AngleConvention, Effects, Structure};

/// Joint friction coefficient of the default truth (wrap-angle capstan law).
pub const DEFAULT_TRUTH_MU: f64 = 0.2;
/// Motor backlash of the default truth, m.
pub const DEFAULT_TRUTH_BACKLASH_M: f64 = 0.003;

/// The default truth's effects: joint friction μ = 0.2 (wrap angle) and
/// 3 mm of motor backlash, nothing else (see the module notes).
pub fn default_truth_effects() -> Effects {
    Effects {
        joint_friction: Some(JointFrictionEffect::constant(
            DEFAULT_TRUTH_MU,
            AngleConvention::Wrap,
        )),
        motor: Some(MotorEffect {
            slip_fraction: 0.0,
            backlash_m: DEFAULT_TRUTH_BACKLASH_M,
        }),
        ..Effects::default()
    }
}

/// `structure` with the default truth's effects, run as every
/// measurement is ([`EffectModel::for_measurement`]: default solver
/// settings, 1 cm increments).
pub fn default_truth(structure: Structure) -> EffectModel {
    EffectModel::for_measurement(structure, default_truth_effects())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::EffectKind;

    #[test]
    fn the_default_truth_is_valid_and_has_friction_and_backlash_only() {
        let e = default_truth_effects();
        e.validate().unwrap();
        assert_eq!(
            e.enabled(),
            vec![EffectKind::JointFriction, EffectKind::Motor]
        );
        assert_eq!(e.parameters(EffectKind::JointFriction), Some(vec![0.2]));
        assert_eq!(e.parameters(EffectKind::Motor), Some(vec![0.0, 0.003]));
        // The one parameter set is inside each effect's plausible range.
        for kind in e.enabled() {
            let values = e.parameters(kind).unwrap_or_default();
            for (v, spec) in values.iter().zip(kind.parameters()) {
                assert!(
                    spec.plausible.0 <= *v && *v <= spec.plausible.1,
                    "{}.{} = {v}",
                    kind.name(),
                    spec.name
                );
            }
        }
    }
}
