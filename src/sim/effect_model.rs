//! A model with effects (the structure, the effects switched on, solver
//! settings and the command increment): what a truth, a lab and every
//! measurement command run, and the one way it becomes a
//! [`ForwardModel`] (the effects applied to the structure, its joint
//! friction). [`PlantError`] says why running it stopped.

use thiserror::Error;

use crate::model::{
    CommandError, Effects, ForwardModel, RelaxSettings, RelaxStatus, SettingsError, Structure,
    StructureError,
};

/// A model with effects: what `compare`, `diagnose` and `lab` run.
#[derive(Debug, Clone)]
pub struct EffectModel {
    /// The structure without effects.
    pub structure: Structure,
    /// The effects switched on.
    pub effects: Effects,
    /// Solver settings.
    pub settings: RelaxSettings,
    /// Largest command increment, m.
    pub increment_m: f64,
}

impl EffectModel {
    /// The model as every measurement command (lab, compare, diagnose,
    /// calibrate) runs it: default solver settings, and commands applied in
    /// increments of at most 1 cm, the seed's actuation step (a larger step
    /// is applied in several increments).
    pub fn for_measurement(structure: Structure, effects: Effects) -> EffectModel {
        EffectModel {
            structure,
            effects,
            settings: RelaxSettings::default(),
            increment_m: 0.01,
        }
    }

    /// The forward model of this bridge at its reference temperature:
    /// the effects that change the structure applied to it (mass,
    /// stiffness, local faults, supports), with the effects' joint
    /// friction, cable seats (joint eccentricity) and these solver
    /// settings. Motor, thermal and sensor effects act in a
    /// [`super::Plant`] and in the readings, not here.
    pub fn forward_model(&self) -> Result<ForwardModel, PlantError> {
        let structure = self.effects.apply_to_structure(&self.structure)?;
        self.effects
            .forward_model_of(structure, self.settings.clone())
            .map_err(PlantError::from)
    }
}

/// Why a run stopped.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PlantError {
    /// The effects cannot be applied to the structure.
    #[error("applying the effects: {0}")]
    Structure(#[from] StructureError),
    /// The solver settings are invalid.
    #[error("{0}")]
    Settings(#[from] SettingsError),
    /// The cable-seat arcs did not settle within the re-solves allowed.
    #[error("cycle {cycle}, step {step}: the cable-seat arcs did not settle ({change_m:.2e} m still changing)")]
    SeatsUnsettled {
        /// Cycle index.
        cycle: usize,
        /// Step index.
        step: usize,
        /// Largest arc change at the last re-solve, m.
        change_m: f64,
    },
    /// A command the model cannot apply.
    #[error("cycle {cycle}, step {step}: {source}")]
    Command {
        /// Cycle index.
        cycle: usize,
        /// Step index (1-based, as commands start at step 1).
        step: usize,
        /// Cause.
        source: CommandError,
    },
    /// The bridge as built, with its effects, has no equilibrium the
    /// solver can reach within the plausible strain: the effects do not
    /// let it stand (e.g. supports so compliant that, with a member error
    /// and softer cables, the bridge gives way before any fold), or the
    /// solver fails there (a seat-arc fixed point that does not settle
    /// counts as its iteration limit). On 200 scenarios of
    /// `scenarios/wide.toml`, seed 9090, four (7, 67, 121, 123); three
    /// were followed from stiff supports in steps (7, 67, 121): they stand
    /// up to 0.6, 0.85 and 0.25 of the drawn compliance, and the next step
    /// collapses (implausible strain) or does not converge.
    #[error("the bridge as built does not stand with these effects: {}", .status.describe())]
    AsBuilt {
        /// How the as-built solve ended.
        status: RelaxStatus,
    },
    /// A solve did not converge.
    #[error("cycle {cycle}, step {step}: {}", .status.describe())]
    Solver {
        /// Cycle index.
        cycle: usize,
        /// Step index.
        step: usize,
        /// Its status.
        status: RelaxStatus,
    },
}

impl PlantError {
    /// The same error, placed at `cycle` and `step` (errors of a
    /// [`super::Plant`] come at cycle 0 and the plant's own command count).
    pub fn at(self, cycle: usize, step: usize) -> PlantError {
        match self {
            PlantError::Command { source, .. } => PlantError::Command {
                cycle,
                step,
                source,
            },
            PlantError::Solver { status, .. } => PlantError::Solver {
                cycle,
                step,
                status,
            },
            PlantError::SeatsUnsettled { change_m, .. } => PlantError::SeatsUnsettled {
                cycle,
                step,
                change_m,
            },
            e @ (PlantError::Structure(_)
            | PlantError::Settings(_)
            | PlantError::AsBuilt { .. }) => e,
        }
    }
}
