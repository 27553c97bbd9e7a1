//! The plant of a closed loop: a truth model with effects, stepped one
//! command at a time as the real bridge is by its motors, and read by
//! sensors with noise.
//!
//! The plant owns everything that carries over from one command to the
//! next: the state, the motors' backlash memory, the thermal strain the
//! rest lengths are at, and the material the cable seats hold. Each command
//! goes, in this order: the temperature of the step sets the thermal strain
//! (rest lengths of steel, and the material in the segments, follow it);
//! the command goes through the motor model (slip, backlash); the payout
//! the drums make is applied in increments, each relaxed to equilibrium;
//! with joint eccentricity on, the truth's forward model follows the cable
//! seats to the end of the command ([`crate::model::solver::seats`]: the
//! material the arcs took up or gave back is moved out of or into the
//! segments and the state solved again, until the arcs change by less than
//! [`crate::model::SEAT_TOLERANCE_M`]). [`EffectModel::run`] replays
//! schedules through this same code.
//!
//! Temperatures are `Option`s as in logs: `None` means unknown, which the
//! model takes as its reference temperature (no thermal strain) and the
//! temperature sensor reads as no value.

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use super::effect_model::{EffectModel, PlantError};
use super::sensors::{Sensor, SensorTarget};
use crate::model::{
    CommandError, CommandReport, DeploymentState, Effects, ForwardModel, IncrementObserver,
    MotorModel, RelaxSettings, RelaxStatus, Structure, Workspace,
};

/// A truth model with effects, stepped one command at a time, as the real
/// bridge is by its motors.
///
/// Errors come placed at cycle 0 and the step of the command that failed
/// (1 for the first command sent, 0 for [`Plant::new`]); a caller that
/// knows better places them with [`PlantError::at`]. After an error the
/// state is where the solve stopped and the plant should not be stepped
/// further.
#[derive(Debug, Clone)]
pub struct Plant {
    effects: Effects,
    /// The structure with the effects that do not vary applied, at zero
    /// thermal strain.
    base: Structure,
    /// Members of the bridge itself; effects may append foundation members
    /// after them, which thermal strain leaves alone.
    bridge_members: usize,
    settings: RelaxSettings,
    increment_m: f64,
    /// The truth model at the current thermal strain.
    model: ForwardModel,
    state: DeploymentState,
    /// The state as built (zero payout, settled at the start's
    /// temperature, before any fold): kept for checks of the truth's own
    /// design ([`Self::as_built_state`]).
    as_built: DeploymentState,
    ws: Workspace,
    motor: MotorModel,
    /// Thermal strain the model's and state's rest lengths are at.
    strain: f64,
    temperature_c: Option<f64>,
    /// Commands applied so far (the step of the next error).
    commands: usize,
}

impl Plant {
    /// Builds the plant from a model with effects and settles it at its
    /// start: the as-built state (or, if `start_payout_m` is `Some`, that
    /// payout per motor applied from the as-built state in increments, e.g.
    /// the folded state: every motor paid out by 0.40 m), at
    /// `temperature_c`.
    ///
    /// The start payout is the payout the drums reached (no slip or
    /// backlash is applied to it); the drums stay engaged in its direction,
    /// so a first command the other way takes up the backlash.
    pub fn new(
        model: &EffectModel,
        start_payout_m: Option<&[f64]>,
        temperature_c: Option<f64>,
    ) -> Result<Plant, PlantError> {
        let at_start = |source| PlantError::Command {
            cycle: 0,
            step: 0,
            source,
        };
        if !(model.increment_m > 0.0 && model.increment_m.is_finite()) {
            return Err(at_start(CommandError::BadIncrement(model.increment_m)));
        }
        let forward = model.forward_model()?;
        let base = forward.structure().clone();
        // The as-built state has its arcs wrapped already.
        let state = forward.reference_state();
        let mut plant = Plant {
            as_built: state.clone(),
            effects: model.effects.clone(),
            bridge_members: model.structure.members.len(),
            settings: model.settings.clone(),
            increment_m: model.increment_m,
            motor: model.effects.motor_model(base.continuous_cables.len()),
            base,
            model: forward,
            state,
            ws: Workspace::default(),
            strain: 0.0,
            temperature_c: None,
            commands: 0,
        };
        plant.set_temperature(temperature_c)?;
        // Effects that change the structure (mass, stiffness, supports)
        // move it off the nominal as-built equilibrium; a state already in
        // equilibrium relaxes in zero iterations and is left as it is.
        // Before any fold, a solve that fails (the relax, or the seat
        // arcs' re-solves and their fixed point) is the bridge as built.
        let as_built = |e| match e {
            PlantError::Solver { status, .. } => PlantError::AsBuilt { status },
            PlantError::SeatsUnsettled { .. } => PlantError::AsBuilt {
                status: RelaxStatus::IterationLimit,
            },
            e => e,
        };
        plant.relax().map_err(as_built)?;
        plant.follow_seats().map_err(as_built)?;
        plant.as_built = plant.state.clone();
        if let Some(payout) = start_payout_m {
            // The fold moves material over the seats like any command: the
            // folded start is the settled state.
            plant.apply_payout(payout, &mut ())?;
            // Only to remember the drums' direction: the payout reached is
            // the one given.
            plant.motor.actual_payout(payout);
        }
        Ok(plant)
    }

    /// Sends one command (payout change per motor, m; positive pays out)
    /// through the motor model (slip, backlash) and applies it in
    /// increments at `temperature_c`; every increment's state goes to
    /// `observer` (so a caller can assert limits along the path); with
    /// cable seats the state they settle into, where the command ends,
    /// goes to `observer` as one more increment
    /// ([`ForwardModel::apply_payout`]; the report counts the payout's).
    pub fn apply(
        &mut self,
        command_m: &[f64],
        temperature_c: Option<f64>,
        observer: &mut dyn IncrementObserver,
    ) -> Result<CommandReport, PlantError> {
        self.commands += 1;
        let expected = self.base.continuous_cables.len();
        // Checked before the motors remember anything of it.
        if command_m.len() != expected {
            return Err(self.command_error(CommandError::WrongLength {
                given: command_m.len(),
                expected,
            }));
        }
        if let Some(cable) = command_m.iter().position(|d| !d.is_finite()) {
            return Err(self.command_error(CommandError::NotFinite { cable }));
        }
        self.set_temperature(temperature_c)?;
        let actual = self.motor.actual_payout(command_m);
        self.apply_payout(&actual, observer)
    }

    /// Holds the motors while the temperature becomes `temperature_c`:
    /// rest lengths follow the thermal strain, the state is relaxed if the
    /// strain changed, and the seat arcs are followed. What a step without
    /// a command (a log's step 0) does.
    pub fn hold(&mut self, temperature_c: Option<f64>) -> Result<(), PlantError> {
        if self.set_temperature(temperature_c)? {
            self.relax()?;
        }
        self.follow_seats()
    }

    /// The true state (for checks and logs; a controller must not read it
    /// — it reads [`Self::measure`]).
    pub fn state(&self) -> &DeploymentState {
        &self.state
    }

    /// The true state as built: zero payout, settled at the temperature
    /// [`Self::new`] was given, before any fold (the designed state the
    /// halves are built to meet at, with the truth's effects). Not read by
    /// a controller; a check of the truth's own design reads it.
    pub fn as_built_state(&self) -> &DeploymentState {
        &self.as_built
    }

    /// The truth forward model as it is now (effects applied; changes with
    /// temperature).
    pub fn model(&self) -> &ForwardModel {
        &self.model
    }

    /// The temperature the plant is at, °C (`None`: unknown, the model's
    /// reference temperature).
    pub fn temperature_c(&self) -> Option<f64> {
        self.temperature_c
    }

    /// Noise-free sensor values of the current state (load-cell bias
    /// included), one per sensor; `None` where the model gives none (the
    /// temperature, when unknown).
    pub fn read(&self, sensors: &[Sensor]) -> Vec<Option<f64>> {
        let forces = self.model.member_forces(&self.state);
        sensors
            .iter()
            .map(|s| match s.target {
                SensorTarget::SegmentTension { cable, segment } => {
                    let t = forces.segment_n[self.state.segment_offsets[cable] + segment];
                    Some(self.effects.load_cell_reading_n(t))
                }
                SensorTarget::MemberForce { member } => {
                    Some(self.effects.load_cell_reading_n(forces.member_n[member]))
                }
                SensorTarget::Position { node, axis } => {
                    Some(self.state.positions_m[node][axis.index()])
                }
                SensorTarget::Temperature => self.temperature_c,
            })
            .collect()
    }

    /// [`Self::read`] plus Gaussian noise of each sensor's `noise_sd`, drawn
    /// from `rng` in sensor order (one draw per sensor, also where the value
    /// is `None`, so that the draws of later sensors do not depend on it;
    /// the same draws as [`crate::measure::lab::run_lab`] makes).
    pub fn measure(&self, sensors: &[Sensor], rng: &mut impl Rng) -> Vec<Option<f64>> {
        self.read(sensors)
            .into_iter()
            .zip(sensors)
            .map(|(value, sensor)| {
                let z: f64 = StandardNormal.sample(rng);
                value.map(|v| v + sensor.noise_sd * z)
            })
            .collect()
    }

    /// Motor payouts actually reached (after slip/backlash), m, per motor,
    /// since the as-built state.
    pub fn payout_m(&self) -> &[f64] {
        &self.state.payout_m
    }

    /// Sets the thermal strain for `temperature_c`: rebuilds the model at
    /// it and scales the material in the segments with it. Returns whether
    /// the strain changed.
    fn set_temperature(&mut self, temperature_c: Option<f64>) -> Result<bool, PlantError> {
        self.temperature_c = temperature_c;
        let strain = self.effects.thermal_strain(temperature_c);
        if strain == self.strain {
            return Ok(false);
        }
        // Rest lengths of steel follow the temperature; the material in the
        // segments grows with them.
        let scale = (1.0 + strain) / (1.0 + self.strain);
        self.model = self.effects.forward_model_of(
            self.effects
                .structure_at_strain(&self.base, strain, self.bridge_members),
            self.settings.clone(),
        )?;
        for r in &mut self.state.segment_rest_lengths_m {
            *r *= scale;
        }
        self.strain = strain;
        Ok(true)
    }

    /// Relaxes the state with every joint stuck.
    fn relax(&mut self) -> Result<(), PlantError> {
        self.state.stick_all_joints();
        let r = self.model.relax(&mut self.state, &mut self.ws);
        if r.status.is_converged() {
            Ok(())
        } else {
            Err(self.solver_error(r.status))
        }
    }

    /// Applies `payout_m` (what the drums make) in increments.
    fn apply_payout(
        &mut self,
        payout_m: &[f64],
        observer: &mut dyn IncrementObserver,
    ) -> Result<CommandReport, PlantError> {
        let r = self
            .model
            .apply_payout(
                &mut self.state,
                &mut self.ws,
                payout_m,
                self.increment_m,
                observer,
            )
            .map_err(|source| self.command_error(source))?;
        if r.status.is_converged() {
            Ok(r)
        } else {
            Err(self.solver_error(r.status))
        }
    }

    /// Follows the seat arcs after a change other than a command (the
    /// effects, a temperature): nothing without seats.
    fn follow_seats(&mut self) -> Result<(), PlantError> {
        let r = self
            .model
            .follow_seats(&mut self.state, &mut self.ws)
            .map_err(|source| self.command_error(source))?;
        if r.status.is_converged() {
            Ok(())
        } else {
            Err(self.solver_error(r.status))
        }
    }

    fn command_error(&self, source: CommandError) -> PlantError {
        match source {
            CommandError::SeatsUnsettled { change_m } => PlantError::SeatsUnsettled {
                cycle: 0,
                step: self.commands,
                change_m,
            },
            source => PlantError::Command {
                cycle: 0,
                step: self.commands,
                source,
            },
        }
    }

    fn solver_error(&self, status: RelaxStatus) -> PlantError {
        PlantError::Solver {
            cycle: 0,
            step: self.commands,
            status,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{EffectKind, RelaxReport};
    use crate::sim::{standard_sensors, CycleSchedule};
    use nalgebra::Vector3;
    use rand::SeedableRng;

    const BACKLASH_M: f64 = 0.003;

    /// μ = 0.1, 3 mm of backlash, steel's thermal expansion.
    fn truth() -> EffectModel {
        let effects = Effects::default()
            .with_parameters(EffectKind::JointFriction, &[0.1])
            .with_parameters(EffectKind::Motor, &[0.0, BACKLASH_M])
            .with_parameters(EffectKind::Thermal, &[1.2e-5]);
        EffectModel {
            structure: reference_bridge(&BridgeParameters::default()).unwrap(),
            effects,
            settings: RelaxSettings::default(),
            increment_m: 0.01,
        }
    }

    fn out_and_in(cables: usize, d: f64, temperature_c: Vec<Option<f64>>) -> CycleSchedule {
        CycleSchedule {
            commands: (0..4)
                .map(|k| vec![if k < 2 { d } else { -d }; cables])
                .collect(),
            temperature_c,
        }
    }

    #[test]
    fn stepping_command_by_command_reproduces_the_replay() {
        let m = truth();
        let n = m.structure.continuous_cables.len();
        let sensors = standard_sensors(&m.structure);
        let t = |v: &[f64]| v.iter().map(|&t| Some(t)).collect::<Vec<_>>();
        let cycles = vec![
            out_and_in(n, 0.015, t(&[20.0, 25.0, 30.0, 30.0, 22.0])),
            out_and_in(n, 0.01, t(&[35.0, 35.0, 28.0, 20.0, 20.0])),
        ];
        let replay = m.run(&cycles, &sensors).unwrap();

        let mut plant = Plant::new(&m, None, cycles[0].temperature_c[0]).unwrap();
        let mut stepped = Vec::new();
        for (c, cycle) in cycles.iter().enumerate() {
            if c > 0 {
                plant.hold(cycle.temperature_c[0]).unwrap();
            }
            let mut steps = vec![plant.read(&sensors)];
            for (k, command) in cycle.commands.iter().enumerate() {
                plant
                    .apply(command, cycle.temperature_c[k + 1], &mut ())
                    .unwrap();
                steps.push(plant.read(&sensors));
            }
            stepped.push(steps);
            if c == 0 {
                // Out 2d, in 2d: the reversal's first 3 mm only took up the
                // play, so the drums end 3 mm out (no slip).
                for p in plant.payout_m() {
                    assert!((p - BACKLASH_M).abs() < 1e-12, "payout {p} m");
                }
            }
        }
        // Bit for bit: the same code path, the same numbers.
        assert_eq!(stepped, replay);
        // And the effects show: thermal growth and hysteresis move the
        // midspan x readings over the schedule.
        let x = |r: &[Option<f64>]| r[4].unwrap();
        assert!((x(&replay[1][0]) - x(&replay[0][0])).abs() > 1e-5);
    }

    #[test]
    fn measurements_are_seeded_and_scatter_about_the_reading_by_the_noise() {
        let m = truth();
        let sensors = standard_sensors(&m.structure);
        let plant = Plant::new(&m, None, Some(24.0)).unwrap();
        let clean = plant.read(&sensors);
        let draw = |seed: u64| {
            let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
            plant.measure(&sensors, &mut rng)
        };
        assert_eq!(draw(11), draw(11));
        assert_ne!(draw(11), draw(12));

        // Over n draws the sample mean of each sensor has standard error
        // σ/√n and the sample SD about σ/√(2(n−1)); each must lie within
        // four of those (a false alarm about once in 15 000 per check).
        let n = 4000;
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let draws: Vec<Vec<Option<f64>>> =
            (0..n).map(|_| plant.measure(&sensors, &mut rng)).collect();
        for (s, sensor) in sensors.iter().enumerate() {
            let truth = clean[s].unwrap();
            let values: Vec<f64> = draws.iter().map(|d| d[s].unwrap()).collect();
            let mean = values.iter().sum::<f64>() / n as f64;
            let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            let sd = sensor.noise_sd;
            let se_mean = sd / (n as f64).sqrt();
            let se_sd = sd / (2.0 * (n - 1) as f64).sqrt();
            assert!(
                (mean - truth).abs() < 4.0 * se_mean,
                "{}: mean {mean} vs {truth}",
                sensor.id
            );
            assert!(
                (var.sqrt() - sd).abs() < 4.0 * se_sd,
                "{}: SD {} vs {sd}",
                sensor.id,
                var.sqrt()
            );
        }
    }

    /// Records every increment the observer is shown.
    #[derive(Default)]
    struct Recorder {
        seen: Vec<(usize, usize, RelaxReport, DeploymentState)>,
    }

    impl IncrementObserver for Recorder {
        fn on_increment(
            &mut self,
            index: usize,
            count: usize,
            report: &RelaxReport,
            state: &DeploymentState,
        ) {
            self.seen.push((index, count, *report, state.clone()));
        }
    }

    /// Largest out-of-balance force on a free degree of freedom, N,
    /// summed here from the member forces (not the solver's residual).
    fn out_of_balance_n(model: &ForwardModel, state: &DeploymentState) -> f64 {
        let s = model.structure();
        let f = model.member_forces(state);
        let x = &state.positions_m;
        let mut net: Vec<Vector3<f64>> = s
            .nodes
            .iter()
            .map(|n| n.mass_kg * s.gravity_m_per_s2 + n.load_n)
            .collect();
        for (m, t) in s.members.iter().zip(&f.member_n) {
            let [a, b] = m.nodes;
            let u = (x[b] - x[a]).normalize();
            net[a] += *t * u;
            net[b] -= *t * u;
        }
        for (c, cable) in s.continuous_cables.iter().enumerate() {
            for (j, w) in cable.path.windows(2).enumerate() {
                let t = f.segment_n[state.segment_offsets[c] + j];
                let u = (x[w[1]] - x[w[0]]).normalize();
                net[w[0]] += t * u;
                net[w[1]] -= t * u;
            }
        }
        s.nodes
            .iter()
            .zip(&net)
            .map(|(node, r)| {
                (0..3)
                    .filter(|&a| !node.fixed[a])
                    .map(|a| r[a] * r[a])
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// Largest capstan violation `T_high − e^(μφ)·T_low` over the joints, N.
    fn capstan_excess_n(model: &ForwardModel, state: &DeploymentState) -> f64 {
        let s = model.structure();
        let f = model.member_forces(state);
        let x = &state.positions_m;
        let mut worst = f64::NEG_INFINITY;
        for (c, cable) in s.continuous_cables.iter().enumerate() {
            for (j, w) in cable.path.windows(3).enumerate() {
                let a = (x[w[1]] - x[w[0]]).normalize();
                let b = (x[w[2]] - x[w[1]]).normalize();
                let bound = model
                    .friction()
                    .ratio_bound(crate::model::sliding::interior_angle(&a, &b), false);
                let o = state.segment_offsets[c] + j;
                let (t_a, t_b) = (f.segment_n[o], f.segment_n[o + 1]);
                worst = worst.max(t_a.max(t_b) - bound * t_a.min(t_b));
            }
        }
        worst
    }

    #[test]
    fn the_observer_sees_every_increment_and_each_is_an_equilibrium() {
        let m = truth();
        let n = m.structure.continuous_cables.len();
        let mut plant = Plant::new(&m, None, Some(20.0)).unwrap();
        // Out 25 mm (3 increments), then back 25 mm across the backlash
        // (22 mm actual: 3 increments), warmer: joints stick and slide both
        // ways.
        for (command, t) in [(0.025, 20.0), (-0.025, 30.0)] {
            let mut rec = Recorder::default();
            let report = plant.apply(&vec![command; n], Some(t), &mut rec).unwrap();
            assert_eq!(rec.seen.len(), report.increments);
            assert!(report.increments >= 2);
            for (k, (index, count, r, state)) in rec.seen.iter().enumerate() {
                assert_eq!((*index, *count), (k, report.increments));
                assert!(r.status.is_converged());
                // Convergence means both residuals within the solver's
                // force tolerance; recomputed independently they may
                // differ from the solver's by rounding (1e-13 N on forces
                // of a few hundred N), which the 1 % margin covers.
                let tol = 1.01 * r.tolerance_n;
                let unbalanced = out_of_balance_n(plant.model(), state);
                assert!(unbalanced <= tol, "{unbalanced} N > {tol} N");
                let excess = capstan_excess_n(plant.model(), state);
                assert!(excess <= tol, "capstan exceeded by {excess} N");
                // Some joint slides, on its bound: the check above bites.
                assert!(excess > -tol, "no joint on its capstan bound");
            }
            // The last increment's state is the plant's (no seat arcs here).
            assert_eq!(&rec.seen.last().unwrap().3, plant.state());
        }
    }

    #[test]
    fn a_bad_command_is_refused_before_the_motors_remember_it() {
        let m = truth();
        let n = m.structure.continuous_cables.len();
        let mut plant = Plant::new(&m, None, None).unwrap();
        let before = plant.clone();
        let err = plant.apply(&[0.01], None, &mut ()).unwrap_err();
        assert_eq!(
            err,
            PlantError::Command {
                cycle: 0,
                step: 1,
                source: CommandError::WrongLength {
                    given: 1,
                    expected: n
                }
            }
        );
        let mut bad = vec![0.01; n];
        bad[2] = f64::NAN;
        let err = plant.apply(&bad, None, &mut ()).unwrap_err();
        assert_eq!(
            err,
            PlantError::Command {
                cycle: 0,
                step: 2,
                source: CommandError::NotFinite { cable: 2 }
            }
        );
        assert_eq!(plant.state(), before.state());
        assert_eq!(plant.motor, before.motor);
    }
}
