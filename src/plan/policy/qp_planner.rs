//! The QP planner's settings: how it linearises the model, how long it
//! keeps a linearisation, its trust region and the weights of its step's
//! objective (read by `plan::search`).

use serde::{Deserialize, Serialize};

use super::trust_region::TrustRegion;
use crate::numerics::{check_ranges, FieldError, NumberRange, Ranged};

/// How the QP planner linearises the model at a state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensitivityKind {
    /// Exact one-sided derivatives from the consistent tangent: one
    /// factorisation per bridge half (~0.4 ms for all motors and both
    /// directions). Local: where every joint sticks they describe the
    /// first millimetre of a move, not a 5 cm move. On the reference
    /// bridge folded 40 cm with μ = 0.2 they predict that no command
    /// closes the gaps, and the plan stops where it starts.
    Tangent,
    /// The slip-onset tangent (`model::SlipOnset::Loaded`): the tangent in
    /// which every joint with friction may slide the way the move loads
    /// it, a complementarity problem deciding which do; the response of a
    /// move long against the millimetres a joint sticks for, at the
    /// tangent's cost (~1 ms). From the 40 cm fold with μ = 0.2 along a
    /// deployment (`examples/friction_responses.rs`) it predicts the
    /// model's own 1–5 cm trials with a median gap error of 24 % (worst
    /// 60 %) and a reduction ratio of 0.75–1.3, where single-motor 5 cm
    /// secants give 57 % (worst 136 %) and ratios of 0.42–0.72. But it
    /// decides each joint's slide per motor, and a command mixing motors
    /// that load a joint opposite ways is not the sum of their columns: in
    /// closed loop on the default truth (controller's model μ = 0.2) its
    /// per-motor differences led the QP to spread commands that stalled at
    /// a 121 mm gap with 22 truth limits broken. Not what `Auto` uses.
    SlipOnset,
    /// The tangent of the model with its friction removed, at the
    /// equilibrium it relaxes the state to (`PayoutResponse::sliding_tangent`):
    /// every joint slides both ways, the limit of a move long against the
    /// millimetres a joint sticks for; one linear map, so motors superpose.
    SlidingTangent,
    /// One-sided secants over `sensitivity_step_m`: every motor moved both
    /// ways through the friction model (20 forward solves per command on
    /// the reference bridge, ~100 times the tangent's cost). Near the
    /// designed state a single motor moved 5 cm against its neighbours
    /// mostly stretches cables: the secants then miss how a half's cables
    /// close the gaps together, and the superposed step slackens cables.
    Secant,
    /// The tangent on a frictionless model (where it is the exact
    /// response, and the deployment experiment connects 100 % of its
    /// scenarios against 88 % with secants), the sliding-limit tangent
    /// ([`SensitivityKind::SlidingTangent`]) on a model with joint
    /// friction: the model error it covers is the stick-slip the exact
    /// one-sided tangent cannot see (at a state where every joint sticks it
    /// says nothing slides, far too stiff for a 5 cm command).
    Auto,
}

impl SensitivityKind {
    /// The kind `Auto` stands for on a model with (`true`) or without
    /// joint friction; any other kind is itself.
    pub fn resolve(self, model_has_friction: bool) -> Self {
        match self {
            SensitivityKind::Auto if model_has_friction => SensitivityKind::SlidingTangent,
            SensitivityKind::Auto => SensitivityKind::Tangent,
            kind => kind,
        }
    }

    /// The concrete kinds the planner tries, in order, when this one gives
    /// no confirmed step or cannot be computed (a singular or unstable
    /// tangent); `Auto` must be resolved first. The tangents see nothing,
    /// or the wrong joints sliding, where the secants see the model's own
    /// moves, and the secants over single motors miss how a half's cables
    /// act together where the tangents do not. The exact tangent falls
    /// back on the secants only (without friction the slip-onset tangent
    /// is the exact one).
    pub fn fallbacks(self) -> &'static [SensitivityKind] {
        match self {
            SensitivityKind::Tangent => &[SensitivityKind::Secant],
            SensitivityKind::SlipOnset | SensitivityKind::SlidingTangent => {
                &[SensitivityKind::Secant, SensitivityKind::Tangent]
            }
            SensitivityKind::Secant | SensitivityKind::Auto => {
                &[SensitivityKind::SlipOnset, SensitivityKind::Tangent]
            }
        }
    }
}

/// Sequential convex programming: a QP on one-sided sensitivities in a
/// trust region, confirmed by a forward re-solve (`plan::search`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct QpPlannerSettings {
    /// How the planner linearises first; the other kind is tried when
    /// this one gives no confirmed step. Default `auto` (see
    /// [`SensitivityKind::Auto`]).
    pub sensitivities: SensitivityKind,
    /// One-sided finite-difference (secant) step of the sensitivities, m,
    /// in (0, 1]. Default 0.05, the largest step: with friction the local
    /// slope is not the response to a step. At the fold (μ = 0.2) every
    /// joint sticks for a small reel-in, and 2 mm slopes say a reel-in
    /// *opens* the gaps (the QP then finds no descent); over 5 cm the
    /// joints slip and the secant slopes close them, as the model does.
    pub sensitivity_step_m: f64,
    /// A command's responses, Broyden-updated by what it did, are kept for
    /// the next command when its reduction ratio ρ (actual over predicted)
    /// was within this of 1, in (0, 1]; the next command tries them first
    /// (one trial) and linearises afresh only if the model does not
    /// confirm it. Default 0.5; off (`None`): every command linearises
    /// afresh.
    #[serde(with = "super::off")]
    pub sensitivity_reuse_tolerance: Option<f64>,
    /// Trust region on each motor's move.
    pub trust_region: TrustRegion,
    /// Weights of the step's objective.
    pub weights: Weights,
}

impl QpPlannerSettings {
    /// Every number of the settings (outside their tables) with its
    /// admissible range.
    pub fn ranges(&self) -> [Ranged; 2] {
        [
            Ranged::real(
                "sensitivity_step_m",
                self.sensitivity_step_m,
                NumberRange::positive_up_to(1.0),
            ),
            Ranged::optional(
                "sensitivity_reuse_tolerance",
                self.sensitivity_reuse_tolerance,
                NumberRange::positive_up_to(1.0),
            ),
        ]
    }
}

impl Default for QpPlannerSettings {
    fn default() -> Self {
        QpPlannerSettings {
            sensitivities: SensitivityKind::Auto,
            sensitivity_step_m: 0.05,
            sensitivity_reuse_tolerance: Some(0.5),
            trust_region: TrustRegion::default(),
            weights: Weights::default(),
        }
    }
}

impl QpPlannerSettings {
    /// Checks every field, the trust region's and the weights'.
    pub fn validate(&self) -> Result<(), FieldError> {
        check_ranges(&self.ranges())?;
        self.trust_region
            .validate()
            .map_err(|e| e.within("trust_region"))?;
        self.weights.validate().map_err(|e| e.within("weights"))
    }
}

/// Weights of the QP step's objective.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Weights {
    /// Weight of each midspan pair's squared gap: one value for all or one
    /// per pair; each at least 0, one positive. Default 1.
    pub gap: Vec<f64>,
    /// η on the squared offsets of the midspan pairs' midpoints
    /// `½(x_a + x_b)` from their designed positions, dimensionless (the
    /// merit's terms are m², like a gap weight's), in [0, 10]. Default 1.
    ///
    /// The model error it covers is none: it covers a planning flaw. The
    /// gaps are relative, and far from the design the steepest way to
    /// close them is often to pay one half out towards the other: on an
    /// uneven fold (half A 45 cm, half B 33 cm) the gaps-only QP paid half
    /// B out by up to 2.5 cm, slackening its cables by ~5 N in the truth
    /// (147 truth violations on the default truth, 3 of 3 seeds). With η
    /// the step closes the gaps by moving both halves towards the design.
    /// The midpoint is orthogonal to the gap, so the term never holds a
    /// gap open, also when the measured gap offsets shift the gaps. The
    /// value was not swept: 1 gives the midpoints the weight the gaps have;
    /// 0 plans on the gaps alone (the planner before issue 22).
    pub design_position: f64,
    /// ρ on ‖u‖², dimensionless, in (0, 1] (positive keeps the QP
    /// strictly convex). Default 1e-5: far below the squared gap
    /// sensitivities (~1e-3), so it only settles motors that barely move
    /// the gaps.
    pub regularisation: f64,
    /// κ on Σ(u⁺ + u⁻), m, in [0, 1]. Default 1e-6: enough to break ties
    /// towards moving a motor one way only.
    pub split_penalty: f64,
    /// Cost of softening a linearised limit by one unit of its scale
    /// (100 N, 10 mm), m², positive. Default 10: a thousand times the gap
    /// objective of the folded bridge, so limits soften only when no
    /// command meets them. Off (`None`): no softened fallback (an
    /// infeasible step holds).
    #[serde(with = "super::off")]
    pub soft_limit_penalty: Option<f64>,
}

impl Weights {
    /// Every number of the weights (but the gap list) with its admissible
    /// range.
    pub fn ranges(&self) -> [Ranged; 4] {
        [
            Ranged::real(
                "design_position",
                self.design_position,
                NumberRange::non_negative_up_to(10.0),
            ),
            Ranged::real(
                "regularisation",
                self.regularisation,
                NumberRange::positive_up_to(1.0),
            ),
            Ranged::real(
                "split_penalty",
                self.split_penalty,
                NumberRange::non_negative_up_to(1.0),
            ),
            Ranged::optional(
                "soft_limit_penalty",
                self.soft_limit_penalty,
                NumberRange::above(0.0),
            ),
        ]
    }
}

impl Default for Weights {
    fn default() -> Self {
        Weights {
            gap: vec![1.0],
            design_position: 1.0,
            regularisation: 1e-5,
            split_penalty: 1e-6,
            soft_limit_penalty: Some(10.0),
        }
    }
}

impl Weights {
    /// Checks the gap list (not empty, no weight negative, one positive)
    /// and every other weight against its range.
    pub fn validate(&self) -> Result<(), FieldError> {
        if self.gap.is_empty() {
            return Err(FieldError::new(
                "gap",
                "an empty list; give one weight or one per midspan pair",
            ));
        }
        for &g in &self.gap {
            NumberRange::at_least(0.0)
                .check(g)
                .map_err(|reason| FieldError::new("gap", reason))?;
        }
        let total: f64 = self.gap.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Err(FieldError::new(
                "gap",
                format!("needs a positive weight and a finite sum, got {total}"),
            ));
        }
        check_ranges(&self.ranges())
    }

    /// Weight of each of `pairs` midspan pairs; `None` if the list has
    /// neither one entry nor one per pair.
    pub fn gap_weights(&self, pairs: usize) -> Option<Vec<f64>> {
        match self.gap.len() {
            1 => Some(vec![self.gap[0]; pairs]),
            n if n == pairs => Some(self.gap.clone()),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whatever kind a planner starts from, its fallbacks reach the
    /// secants (the model's own moves) and a tangent, never repeat the
    /// first kind, and never hold `Auto`: a linearisation that cannot be
    /// computed or confirmed leaves another to try.
    #[test]
    fn every_kind_falls_back_to_the_secants_and_a_tangent_without_repeating_itself() {
        use SensitivityKind::*;
        for friction in [false, true] {
            for kind in [Tangent, SlipOnset, SlidingTangent, Secant, Auto] {
                let first = kind.resolve(friction);
                assert_ne!(first, Auto);
                let rest = first.fallbacks();
                assert!(!rest.contains(&first) && !rest.contains(&Auto), "{first:?}");
                let all: Vec<_> = std::iter::once(first).chain(rest.iter().copied()).collect();
                assert!(all.contains(&Secant), "{all:?}");
                assert!(
                    all.iter()
                        .any(|k| matches!(k, Tangent | SlipOnset | SlidingTangent)),
                    "{all:?}"
                );
            }
        }
        assert_eq!(Auto.resolve(false), Tangent);
        assert_eq!(Auto.resolve(true), SlidingTangent);
    }
}
