//! How far the cables really moved: an estimate of each bridge half's
//! payout scale, the ratio of the payout the cables made to the payout the
//! model predicted, learnt from the measured midspan motion.
//!
//! The output-bias correction ([`crate::plan::correction`]) makes the planner
//! close the *measured* gaps, but it leaves the model state where the
//! model's own commands put it. When the cables do not move as commanded
//! (drum slip, or a structure softer or heavier than the model, which
//! needs more payout for the same motion) the model then believes the
//! bridge nearer to, or further from, its designed state than it is: near
//! the design the gaps close steeply and the axial cables go slack about
//! 1 cm past it, so a 2 cm error in where the model thinks it is decides
//! between a refused command (the model sees slack that the bridge does
//! not have) and a slack cable the model never predicted.
//!
//! The estimator treats the discrepancy as a payout scale `s` per
//! independent part (each half of the bridge; its motors share it): a
//! planned payout `u` becomes `(1 + s)·u` in the bridge. Before a command
//! the controller sends `u / (1 + ŝ)`, so that what it planned and checked
//! on the model is what the cables should do. After the command the
//! measured motion of the part's midspan nodes `Δy` is compared with the
//! model's predicted motion `g` (trial state minus previous state); to
//! first order
//!
//! ```text
//!     Δy − g = ε·g + noise,    ε = s − ŝ,   noise variance 2σ² per reading
//! ```
//!
//! (differences of two readings, so a constant sensor or model offset
//! cancels). A scalar Kalman filter with a random-walk drift updates
//!
//! ```text
//!     P ← P + q²,   ε̂ = (Σ gᵢ(Δyᵢ − gᵢ)/Rᵢ) / (1/P + Σ gᵢ²/Rᵢ),
//!     P ← 1/(1/P + Σ gᵢ²/Rᵢ),   ŝ ← ŝ + ε̂,
//! ```
//!
//! and the model state is moved to where the command actually took the
//! bridge: the planned command scaled by `1 + ε̂`, re-solved from the
//! previous state. A small motion (a corrective millimetre) carries little
//! information and leaves `ŝ` near where it was, as it should.

use crate::model::{DeploymentState, ForwardModel};
use crate::plan::response::IndependentParts;
use crate::sim::{Sensor, SensorTarget};

/// The payout-scale estimate of each independent part.
#[derive(Debug, Clone, PartialEq)]
pub struct PayoutScaleEstimator {
    /// Part of each motor (`None`: the motor moves no free node).
    part_of_motor: Vec<Option<usize>>,
    /// Part of each node.
    part_of_node: Vec<Option<usize>>,
    /// Estimated scale `ŝ` per part (index = part id), 1.
    scale: Vec<f64>,
    /// Variance of `ŝ` per part, 1.
    variance: Vec<f64>,
    /// Random-walk variance added per command, 1.
    drift_variance: f64,
}

/// What one update found.
#[derive(Debug, Clone, PartialEq)]
pub struct ScaleUpdate {
    /// Per motor, the cable motion the command is now estimated to have
    /// made, as a factor of the planned motion: `c·(1 + ε̂)`, where `c` is
    /// what the sent command should have delivered at the old estimate
    /// (below 1 where the drum's step limit cut the compensated command)
    /// and `ε̂` this update's correction; 1 for a motor whose part was not
    /// measured and whose command was sent as planned.
    pub motion_factor: Vec<f64>,
}

impl PayoutScaleEstimator {
    /// An estimator for `model`'s structure, starting at `ŝ = 0` with
    /// standard deviation `prior_sd` and drifting by `drift_sd` per command.
    pub fn new(model: &ForwardModel, prior_sd: f64, drift_sd: f64) -> Self {
        let parts = IndependentParts::of(model);
        let count = parts
            .of_node
            .iter()
            .flatten()
            .copied()
            .max()
            .map_or(0, |m| m + 1);
        PayoutScaleEstimator {
            part_of_motor: parts.of_cable,
            part_of_node: parts.of_node,
            scale: vec![0.0; count],
            variance: vec![prior_sd * prior_sd; count],
            drift_variance: drift_sd * drift_sd,
        }
    }

    /// An estimator that starts from what a past cycle learnt: `ŝ` per
    /// part from `prior_scale` (index = part id, as [`Self::part_scale`]
    /// gives it), with standard deviation `prior_sd`. A `prior_scale` of
    /// another length is a different bridge: the estimator starts at 0.
    pub fn with_prior(
        model: &ForwardModel,
        prior_scale: &[f64],
        prior_sd: f64,
        drift_sd: f64,
    ) -> Self {
        let mut e = Self::new(model, prior_sd, drift_sd);
        if prior_scale.len() == e.scale.len() && prior_scale.iter().all(|s| s.is_finite()) {
            e.scale = prior_scale.to_vec();
        }
        e
    }

    /// Estimated scale `ŝ` of each independent part (index = part id), 1.
    pub fn part_scale(&self) -> &[f64] {
        &self.scale
    }

    /// Estimated scale `ŝ` of each motor's part, 1.
    pub fn motor_scale(&self) -> Vec<f64> {
        self.part_of_motor
            .iter()
            .map(|p| p.map_or(0.0, |p| self.scale[p]))
            .collect()
    }

    /// Standard deviation of each motor's part's estimate, 1.
    pub fn motor_scale_sd(&self) -> Vec<f64> {
        self.part_of_motor
            .iter()
            .map(|p| p.map_or(0.0, |p| self.variance[p].sqrt()))
            .collect()
    }

    /// The command to send for a planned payout change `planned_m`:
    /// `planned / (1 + ŝ)` per motor, m.
    pub fn motor_command(&self, planned_m: &[f64]) -> Vec<f64> {
        planned_m
            .iter()
            .zip(self.motor_scale())
            .map(|(u, s)| u / (1.0 + s))
            .collect()
    }

    /// Updates the estimate from one command: the cable motion planned
    /// (`planned_m`, which took the model from `before` to `predicted`),
    /// the command sent to the drums (`sent_m`: [`Self::motor_command`] of
    /// it, possibly cut by a step limit), and the readings of `sensors`
    /// before and after. Only position sensors of free nodes take part; a
    /// reading missing in either is skipped.
    ///
    /// The regression is on the motion the *sent* command should have
    /// made at the old estimate: if a step limit cut the compensated
    /// command to a fraction `c` of the planned motion, the model's motion
    /// `g` is scaled by `c` before it is compared with the measurement (a
    /// cut is not a slip).
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        sensors: &[Sensor],
        readings_before: &[Option<f64>],
        readings_after: &[Option<f64>],
        before: &DeploymentState,
        predicted: &DeploymentState,
        planned_m: &[f64],
        sent_m: &[f64],
    ) -> ScaleUpdate {
        let parts = self.scale.len();
        // Delivered fraction c per part: Σ|sent·(1 + ŝ)| / Σ|planned|.
        let mut delivered = vec![0.0; parts];
        let mut planned_total = vec![0.0; parts];
        for (m, part) in self.part_of_motor.iter().enumerate() {
            if let (Some(p), Some(u), Some(v)) = (part, planned_m.get(m), sent_m.get(m)) {
                delivered[*p] += (v * (1.0 + self.scale[*p])).abs();
                planned_total[*p] += u.abs();
            }
        }
        let fraction: Vec<f64> = delivered
            .iter()
            .zip(&planned_total)
            .map(|(d, t)| if *t > 0.0 { d / t } else { 1.0 })
            .collect();
        // Information sums per part: Σ g²/R and Σ g·r/R.
        let mut information = vec![0.0; parts];
        let mut weighted_residual = vec![0.0; parts];
        for (i, sensor) in sensors.iter().enumerate() {
            let SensorTarget::Position { node, axis } = sensor.target else {
                continue;
            };
            let Some(Some(part)) = self.part_of_node.get(node).copied() else {
                continue;
            };
            let (Some(Some(y0)), Some(Some(y1))) = (readings_before.get(i), readings_after.get(i))
            else {
                continue;
            };
            let variance = 2.0 * sensor.noise_sd * sensor.noise_sd;
            if !(variance > 0.0 && variance.is_finite()) {
                continue;
            }
            let g = fraction[part]
                * (predicted.positions_m[node][axis.index()]
                    - before.positions_m[node][axis.index()]);
            let r = (y1 - y0) - g;
            information[part] += g * g / variance;
            weighted_residual[part] += g * r / variance;
        }
        let mut correction = vec![0.0; parts];
        for p in 0..parts {
            let prior = self.variance[p] + self.drift_variance;
            if information[p] == 0.0 || prior <= 0.0 {
                self.variance[p] = prior;
                continue;
            }
            let precision = 1.0 / prior + information[p];
            correction[p] = weighted_residual[p] / precision;
            self.variance[p] = 1.0 / precision;
            self.scale[p] += correction[p];
        }
        ScaleUpdate {
            motion_factor: self
                .part_of_motor
                .iter()
                .map(|p| p.map_or(1.0, |p| fraction[p] * (1.0 + correction[p])))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::reference_bridge::{reference_bridge, BridgeParameters};
    use crate::model::{JointFriction, RelaxSettings, Workspace};
    use crate::sim::standard_sensors;

    /// The frictionless reference bridge, its standard sensors, and its
    /// state with every motor paid out 20 cm.
    fn half_folded_bridge() -> (ForwardModel, Vec<Sensor>, DeploymentState) {
        let s = reference_bridge(&BridgeParameters::default()).unwrap();
        let model = ForwardModel::new(
            s,
            JointFriction::constant(0.0).unwrap(),
            RelaxSettings::default(),
        )
        .unwrap();
        let sensors = standard_sensors(model.structure());
        let motors = model.structure().continuous_cables.len();
        let mut start = model.reference_state();
        model
            .apply_payout(
                &mut start,
                &mut Workspace::default(),
                &vec![0.20; motors],
                0.01,
                &mut (),
            )
            .unwrap();
        (model, sensors, start)
    }

    /// Exact readings of the position sensors at `state` (others missing).
    fn noise_free_positions(sensors: &[Sensor], state: &DeploymentState) -> Vec<Option<f64>> {
        sensors
            .iter()
            .map(|s| match s.target {
                SensorTarget::Position { node, axis } => {
                    Some(state.positions_m[node][axis.index()])
                }
                _ => None,
            })
            .collect()
    }

    /// A noise-free measurement of a command that moved the cables 4 %
    /// less than planned: the estimate recovers −0.04 in each half to the
    /// linearisation error of a 5 cm step, and a second identical command
    /// sent through the estimator's compensation is then met almost
    /// exactly.
    #[test]
    fn recovers_a_uniform_slip_from_noise_free_motion() {
        let (model, sensors, start) = half_folded_bridge();
        let motors = model.structure().continuous_cables.len();
        let mut ws = Workspace::default();
        let read = |state: &DeploymentState| noise_free_positions(&sensors, state);
        let planned = vec![-0.05; motors];
        let mut predicted = start.clone();
        model
            .apply_payout(&mut predicted, &mut ws, &planned, 0.01, &mut ())
            .unwrap();
        let slip = -0.04;
        let actual: Vec<f64> = planned.iter().map(|u| u * (1.0 + slip)).collect();
        let mut truth = start.clone();
        model
            .apply_payout(&mut truth, &mut ws, &actual, 0.01, &mut ())
            .unwrap();

        // A wide prior: the data decide.
        let mut estimator = PayoutScaleEstimator::new(&model, 1.0, 0.0);
        let update = estimator.update(
            &sensors,
            &read(&start),
            &read(&truth),
            &start,
            &predicted,
            &planned,
            &planned,
        );
        for (s, f) in estimator.motor_scale().iter().zip(&update.motion_factor) {
            // 5 cm is not infinitesimal: the gaps close faster than
            // linearly toward the design, allow 0.01 on the 0.04.
            assert!((s - slip).abs() < 0.01, "estimated {s}, true {slip}");
            assert!((f - (1.0 + s)).abs() < 1e-12);
        }
        // With no slip the estimate stays put.
        let mut still = PayoutScaleEstimator::new(&model, 1.0, 0.0);
        still.update(
            &sensors,
            &read(&start),
            &read(&predicted),
            &start,
            &predicted,
            &planned,
            &planned,
        );
        assert!(still.motor_scale().iter().all(|s| s.abs() < 1e-9));
        // The compensated command is larger than the planned one.
        let sent = estimator.motor_command(&planned);
        assert!(sent.iter().all(|u| *u < -0.05));
    }

    /// A step limit that cuts the compensated command is not a slip: at
    /// ŝ = −0.04 (cables moving 4 % less than the drums) a planned 5 cm
    /// of cable motion needs 5.21 cm of drum, the 5 cm step limit cuts it
    /// to 5 cm, and the cables move 4.8 cm. The estimate must stay at
    /// −0.04 (regressing on the planned motion would read the cut as a
    /// further slip of −0.04).
    #[test]
    fn a_command_cut_by_the_step_limit_is_not_read_as_slip() {
        let (model, sensors, start) = half_folded_bridge();
        let motors = model.structure().continuous_cables.len();
        let mut ws = Workspace::default();
        let read = |state: &DeploymentState| noise_free_positions(&sensors, state);
        let scale = -0.04;
        let planned = vec![-0.05; motors];
        let sent = vec![-0.05; motors];
        let mut predicted = start.clone();
        model
            .apply_payout(&mut predicted, &mut ws, &planned, 0.01, &mut ())
            .unwrap();
        let made: Vec<f64> = sent.iter().map(|u| u * (1.0 + scale)).collect();
        let mut truth = start.clone();
        model
            .apply_payout(&mut truth, &mut ws, &made, 0.01, &mut ())
            .unwrap();
        // Already at the true scale, with a tight prior: the data must not
        // move it.
        let mut estimator = PayoutScaleEstimator::new(&model, 0.05, 0.0);
        estimator.scale.iter_mut().for_each(|s| *s = scale);
        let update = estimator.update(
            &sensors,
            &read(&start),
            &read(&truth),
            &start,
            &predicted,
            &planned,
            &sent,
        );
        for (s, f) in estimator.motor_scale().iter().zip(&update.motion_factor) {
            assert!((s - scale).abs() < 0.003, "estimate moved to {s}");
            // The model is moved by what the drums delivered: 5 · 0.96 cm
            // of the planned 5 cm.
            assert!((f - 0.96).abs() < 0.006, "{f}");
        }
    }
}
