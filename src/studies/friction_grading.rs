//! Friction grading on a frictionless path: how far a model whose joints
//! slide freely, with each cable's friction state carried along its path,
//! predicts the segment tensions of a model with joint friction (known
//! limitations, item 18, fifteenth session).
//!
//! A frictionless model holds one tension along each continuous cable.
//! Joint friction grades it: where a joint slides, the tensions of its two
//! segments stand in the capstan ratio `e^(μα)`, the higher on the side the
//! material slides from; where it sticks, each segment answers its own
//! length change. [`FrictionGrading`] is each cable's material
//! distribution and joint slip states as friction `μ` would leave them,
//! carried increment by increment on the frictionless model's geometry:
//! at every increment the return mapping of [`map_cable`] (the forward
//! model's own) is applied to the model's segment lengths and directions,
//! from the distribution the last increment left, with each motor's payout
//! change entering its cable at the motor segment. Material is conserved
//! per cable.
//!
//! What it shows (`cargo run --release --example friction_grading_probe`,
//! and the tests below): on the path of the model with friction itself
//! the grading reproduces that model's tensions (the mapping is the
//! same); on the frictionless model's path, after a fold, where every
//! joint has slid the same way, it predicts them well (the 45/33 cm fold
//! at μ = 0.2: worst segment 7.5 N off, against 35.0 N for the
//! frictionless model's one tension). Through the reel-in after it, it
//! does not: at the end of a uniform 5 cm reel-in 31.2 N off against
//! 12.2 N, and over the command its smallest values 39.3 against 15.5 N.
//! A joint that sticks makes its segments fixed-length links, and in the
//! soft folded bridge those links hold the geometry (a segment's `EA/L`
//! is 0.8–1.6e6 N/m folded, so 0.01 mm of span is 8–16 N), while the
//! frictionless geometry moves as if they slid. So the tensions a stuck
//! joint leaves are set by the structure with friction, not by the
//! frictionless model's geometry, and the reversal dip (known
//! limitations, item 15) can only be predicted by a model with friction.
//! A planner that checked its limits on this grading (tried, scratch
//! code not in the tree: trials and QP rows, wide seed 31337 on the split
//! truth) connected 42 % of 100 runs against 73 % on the model's own
//! tensions.
//!
//! The grading books material only through the motors: a model with
//! cable seats, which moves material between segments without payout,
//! would break its conservation (the reference bridge has none).

use nalgebra::Vector3;

use crate::model::sliding::{map_cable, segment_tension, IncrementStart};
use crate::model::{
    CommandError, DeploymentState, ForwardModel, IncrementObserver, JointFriction, JointSlip,
    RelaxReport, RelaxStatus, Structure, Workspace,
};

/// The least material a motor segment may keep, m (as the forward
/// model's commands require).
const MIN_SEGMENT_REST_M: f64 = 1e-3;

/// A payout change that would reel more out of a cable's motor segment
/// than it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cable {cable}: the reel-in empties its motor segment")]
pub struct ReeledThrough {
    /// The cable (motor).
    pub cable: usize,
}

/// Tolerance of the return mapping, N: well below any limit's meaning
/// (load cells read to 5–15 N) and above the mapping's rounding.
const MAPPING_TOLERANCE_N: f64 = 1e-6;

/// Each continuous cable's material distribution and joint slip states as
/// friction leaves them along a frictionless model's path (flat as the
/// state's segments).
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionGrading {
    friction: JointFriction,
    /// Rest length of material in each segment, m.
    rest_m: Vec<f64>,
    /// Slip state of each joint (entry 0 of each cable unused).
    slip: Vec<JointSlip>,
    /// Each motor's payout the distribution includes, m.
    payout_m: Vec<f64>,
}

impl FrictionGrading {
    /// The grading at `state` taken as a state friction has not graded
    /// (the as-built bridge): the state's own distribution, every joint
    /// stuck.
    pub fn ungraded(state: &DeploymentState, friction: JointFriction) -> Self {
        FrictionGrading {
            friction,
            rest_m: state.segment_rest_lengths_m.clone(),
            slip: vec![JointSlip::Stuck; state.segment_rest_lengths_m.len()],
            payout_m: state.payout_m.clone(),
        }
    }

    /// Carries the grading to `state` (the model's next increment): each
    /// motor's payout since the last one enters its cable's motor segment,
    /// and the joints slide or stick on `state`'s geometry, mapped as the
    /// forward model maps an increment (every joint stuck at its start,
    /// so a joint that slides in it is held to the kinetic bound only if
    /// it was already sliding that way within the increment). Returns the
    /// friction force left unbalanced at the joints, N (0 when the mapping
    /// settled), or the cable whose motor segment the payout change would
    /// empty (a reel-in of more than it holds), leaving the grading as it
    /// was.
    pub fn advance(
        &mut self,
        structure: &Structure,
        state: &DeploymentState,
    ) -> Result<f64, ReeledThrough> {
        for (c, _) in structure.continuous_cables.iter().enumerate() {
            let first =
                self.rest_m[state.segment_offsets[c]] + state.payout_m[c] - self.payout_m[c];
            if first < MIN_SEGMENT_REST_M {
                return Err(ReeledThrough { cable: c });
            }
        }
        let mut left = 0.0f64;
        for (c, cable) in structure.continuous_cables.iter().enumerate() {
            let (o0, o1) = (state.segment_offsets[c], state.segment_offsets[c + 1]);
            let (lengths, dirs) = segment_geometry(&cable.path, &state.positions_m);
            let mut start_rest = self.rest_m[o0..o1].to_vec();
            start_rest[0] += state.payout_m[c] - self.payout_m[c];
            let start_slip = vec![JointSlip::Stuck; o1 - o0];
            let rest = &mut self.rest_m[o0..o1];
            rest.copy_from_slice(&start_rest);
            // The last mapping's slip states are the active-set guess.
            let slip = &mut self.slip[o0..o1];
            left = left.max(map_cable(
                cable.ea_n,
                &lengths,
                &dirs,
                rest,
                slip,
                IncrementStart {
                    rest_m: &start_rest,
                    slip: &start_slip,
                },
                &self.friction,
                MAPPING_TOLERANCE_N,
            ));
        }
        self.payout_m.clone_from(&state.payout_m);
        Ok(left)
    }

    /// Each segment's tension on `state`'s geometry with the grading's
    /// material distribution, N, flat as the state's segments.
    pub fn segment_tensions_n(&self, structure: &Structure, state: &DeploymentState) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.rest_m.len());
        for (c, cable) in structure.continuous_cables.iter().enumerate() {
            let o0 = state.segment_offsets[c];
            let (lengths, _) = segment_geometry(&cable.path, &state.positions_m);
            out.extend(
                lengths
                    .iter()
                    .enumerate()
                    .map(|(k, &l)| segment_tension(cable.ea_n, l, self.rest_m[o0 + k])),
            );
        }
        out
    }
}

/// Length and unit direction (motor to end) of each segment of the cable
/// through `path`.
fn segment_geometry(path: &[usize], positions_m: &[Vector3<f64>]) -> (Vec<f64>, Vec<Vector3<f64>>) {
    path.windows(2)
        .map(|w| {
            let d = positions_m[w[1]] - positions_m[w[0]];
            let l = d.norm();
            (l, d / l)
        })
        .unzip()
}

/// The grading carried along `model`'s path through each increment it
/// solves (an [`crate::model::IncrementObserver`]).
pub struct GradingObserver<'a> {
    /// The structure the path runs on.
    pub structure: &'a Structure,
    /// The grading, advanced at every converged increment.
    pub grading: FrictionGrading,
    /// The first failure: an increment that did not converge, or one the
    /// grading could not follow. The grading stops there.
    pub failed: Option<GradingFailure>,
    /// The largest friction force a mapping left unbalanced, N.
    pub friction_left_n: f64,
}

impl<'a> GradingObserver<'a> {
    /// An observer carrying `grading` along a path on `structure`.
    pub fn new(structure: &'a Structure, grading: FrictionGrading) -> Self {
        GradingObserver {
            structure,
            grading,
            failed: None,
            friction_left_n: 0.0,
        }
    }
}

/// Why a grading stopped following a path.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GradingFailure {
    /// The model's increment did not converge.
    #[error("an increment of the path: {}", .0.describe())]
    Increment(RelaxStatus),
    /// The grading's own motor segment ran out.
    #[error("{0}")]
    ReeledThrough(#[from] ReeledThrough),
}

impl IncrementObserver for GradingObserver<'_> {
    fn on_increment(&mut self, _: usize, _: usize, r: &RelaxReport, state: &DeploymentState) {
        if self.failed.is_some() {
            return;
        }
        if !r.status.is_converged() {
            self.failed = Some(GradingFailure::Increment(r.status));
            return;
        }
        match self.grading.advance(self.structure, state) {
            Ok(left) => self.friction_left_n = self.friction_left_n.max(left),
            Err(e) => self.failed = Some(e.into()),
        }
    }
}

/// The friction grading along `model`'s fold: `model` relaxed as built,
/// then paid out by `fold_m` (per motor) at `increment_m`, the grading
/// carried from the as-built state (joints stuck, the model's own
/// distribution) through every increment, so each joint ends on its
/// pay-out bound. Returns the folded state and its grading.
pub fn graded_fold(
    model: &ForwardModel,
    friction: JointFriction,
    fold_m: &[f64],
    increment_m: f64,
) -> Result<(DeploymentState, FrictionGrading), GradedFoldError> {
    let mut ws = Workspace::default();
    let mut state = model.reference_state();
    let r = model.relax(&mut state, &mut ws);
    if !r.status.is_converged() {
        return Err(GradedFoldError::AsBuilt(r.status));
    }
    let mut observer = GradingObserver::new(
        model.structure(),
        FrictionGrading::ungraded(&state, friction),
    );
    let r = model.apply_payout(&mut state, &mut ws, fold_m, increment_m, &mut observer)?;
    if !r.status.is_converged() {
        return Err(GradedFoldError::Fold(r.status));
    }
    if let Some(f) = observer.failed {
        return Err(GradedFoldError::Grading(f));
    }
    Ok((state, observer.grading))
}

/// Why [`graded_fold`] has no folded state.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GradedFoldError {
    /// The as-built state does not relax.
    #[error("the as-built state: {}", .0.describe())]
    AsBuilt(RelaxStatus),
    /// The fold is refused.
    #[error("the fold: {0}")]
    Command(#[from] CommandError),
    /// The fold does not converge.
    #[error("the fold: {}", .0.describe())]
    Fold(RelaxStatus),
    /// The grading could not follow the fold.
    #[error("the grading along the fold: {0}")]
    Grading(GradingFailure),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::reference_bridge::{reference_bridge, BridgeParameters};
    use crate::model::RelaxSettings;
    use crate::plan::limits::force_rows;

    /// The uneven fold of the reversal dip: 45 cm (half A), 33 cm (half B).
    fn uneven_fold_m() -> Vec<f64> {
        let mut fold = vec![0.45; 5];
        fold.extend([0.33; 5]);
        fold
    }

    /// The reference bridge with μ = 0.2 (slip events located when
    /// `substeps`) and without friction.
    fn models(substeps: bool) -> (ForwardModel, ForwardModel) {
        let bridge = reference_bridge(&BridgeParameters::default()).unwrap();
        let settings = RelaxSettings {
            slip_event_substeps_enable: substeps,
            ..RelaxSettings::default()
        };
        let mu = JointFriction::constant(0.2).unwrap();
        let with = ForwardModel::new(bridge.clone(), mu, settings.clone()).unwrap();
        let free = ForwardModel::new(bridge, JointFriction::frictionless(), settings).unwrap();
        (with, free)
    }

    /// `model` folded from as built by `fold_m`, every solve converged.
    fn folded(model: &ForwardModel, fold_m: &[f64]) -> DeploymentState {
        let mut ws = Workspace::default();
        let mut state = model.reference_state();
        assert!(model.relax(&mut state, &mut ws).status.is_converged());
        let r = model
            .apply_payout(&mut state, &mut ws, fold_m, 0.01, &mut ())
            .unwrap();
        assert!(r.status.is_converged());
        state
    }

    /// Worst |prediction − friction model| over every segment, N.
    fn worst_error(predicted: &[f64], with: &[f64]) -> f64 {
        predicted
            .iter()
            .zip(with)
            .fold(0.0f64, |a, (p, t)| a.max((p - t).abs()))
    }

    #[test]
    fn on_the_friction_models_own_path_the_grading_is_that_model() {
        // The grading maps each increment as the forward model does; on
        // the model's own geometry it must give its tensions, through
        // the fold and the reversal after it. Tolerance: ten times the
        // solver's force tolerance (1e-6 of the largest member force,
        // about a kilonewton).
        let (with, _) = models(false);
        let s = with.structure();
        let n = s.members.len();
        let mut ws = Workspace::default();
        let mut state = with.reference_state();
        assert!(with.relax(&mut state, &mut ws).status.is_converged());
        let mut observer = GradingObserver::new(
            s,
            FrictionGrading::ungraded(&state, JointFriction::constant(0.2).unwrap()),
        );
        for command in [uneven_fold_m(), vec![-0.05; 10]] {
            let r = with
                .apply_payout(&mut state, &mut ws, &command, 0.01, &mut observer)
                .unwrap();
            assert!(r.status.is_converged());
            assert_eq!(observer.failed, None);
            let graded = observer.grading.segment_tensions_n(s, &state);
            let error = worst_error(&graded, &force_rows(&with, &state)[n..]);
            assert!(error < 0.01, "{error} N");
        }
    }

    #[test]
    fn after_a_fold_the_grading_predicts_the_friction_models_segments_and_holds_the_material() {
        let (with, free) = models(true);
        let with_state = folded(&with, &uneven_fold_m());
        let mu = JointFriction::constant(0.2).unwrap();
        let (free_state, grading) = graded_fold(&free, mu, &uneven_fold_m(), 0.01).unwrap();
        let s = free.structure();
        let n = s.members.len();
        let truth = &force_rows(&with, &with_state)[n..];
        let frictionless = &force_rows(&free, &free_state)[n..];
        let graded = grading.segment_tensions_n(s, &free_state);
        let (e_free, e_graded) = (
            worst_error(frictionless, truth),
            worst_error(&graded, truth),
        );
        // Measured: 35.0 N against 7.5 N. An ungraded distribution is the
        // frictionless one (ratio 1); a third leaves room for solver-level
        // change and fails if the fold's friction state is not carried.
        assert!(
            e_graded < e_free / 3.0,
            "graded {e_graded} N, frictionless {e_free} N"
        );
        for (c, cable) in s.continuous_cables.iter().enumerate() {
            let (o0, o1) = (
                free_state.segment_offsets[c],
                free_state.segment_offsets[c + 1],
            );
            // Every joint on its pay-out bound: the far segments the most taut.
            assert!(
                graded[o0..o1].windows(2).all(|w| w[1] > w[0]),
                "{}: {:?}",
                cable.id,
                &graded[o0..o1]
            );
            // The grading holds the material the model's cable holds.
            let held: f64 = grading.rest_m[o0..o1].iter().sum();
            assert!((held - free_state.cable_material_m(c)).abs() < 1e-9);
        }
    }

    #[test]
    fn through_the_reversal_the_grading_on_the_frictionless_geometry_is_further_off_than_one_tension(
    ) {
        // A characterisation of the limitation (known limitations 18):
        // the test above shows the grading itself is exact on the right
        // geometry, so what this measures is the frictionless geometry.
        let (with, free) = models(true);
        let mut with_state = folded(&with, &uneven_fold_m());
        let mu = JointFriction::constant(0.2).unwrap();
        let (mut free_state, grading) = graded_fold(&free, mu, &uneven_fold_m(), 0.01).unwrap();
        let s = free.structure();
        let n = s.members.len();
        let mut ws = Workspace::default();
        let reel_in = vec![-0.05; 10];
        let r = with
            .apply_payout(&mut with_state, &mut ws, &reel_in, 0.01, &mut ())
            .unwrap();
        assert!(r.status.is_converged());
        let mut observer = GradingObserver::new(s, grading);
        let r = free
            .apply_payout(&mut free_state, &mut ws, &reel_in, 0.01, &mut observer)
            .unwrap();
        assert!(r.status.is_converged());
        assert_eq!(observer.failed, None);
        let truth = &force_rows(&with, &with_state)[n..];
        let frictionless = &force_rows(&free, &free_state)[n..];
        let graded = observer.grading.segment_tensions_n(s, &free_state);
        // Measured: 31.2 N against 12.2 N.
        let (e_free, e_graded) = (
            worst_error(frictionless, truth),
            worst_error(&graded, truth),
        );
        assert!(
            e_graded > e_free,
            "graded {e_graded} N, frictionless {e_free} N"
        );
    }

    #[test]
    fn a_reel_in_that_empties_the_motor_segment_is_refused_not_mapped() {
        let (_, free) = models(false);
        let state = free.reference_state();
        let mut grading = FrictionGrading::ungraded(&state, JointFriction::constant(0.2).unwrap());
        let before = grading.clone();
        let mut next = state.clone();
        next.payout_m[2] -= 2.0 * state.segment_rest_lengths_m[state.segment_offsets[2]];
        assert_eq!(
            grading.advance(free.structure(), &next),
            Err(ReeledThrough { cable: 2 })
        );
        assert_eq!(grading, before);
    }
}
