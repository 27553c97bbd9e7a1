//! What the closed loop measures and how it estimates what the model gets
//! wrong (`[control]` in policy files; read by `crate::control`, the open
//! loop planner reads its model's state).

use serde::{Deserialize, Serialize};

use crate::numerics::{check_ranges, FieldError, NumberRange, Ranged};

/// What the controller measures between commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Measurement {
    /// Positions of the midspan nodes.
    MidspanPositions,
    /// Load cells on the continuous cables at the midspan joints.
    LoadCells,
}

/// The closed loop's measurements and estimates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControlSettings {
    /// What the controller measures. Default both.
    pub measures: Vec<Measurement>,
    /// Prior standard deviation of each bridge half's payout scale (how
    /// much more or less the cables move than commanded), 1, in (0, 0.5];
    /// the closed loop estimates it from the measured midspan motion and
    /// compensates the commands (see [`crate::control::estimation`]).
    /// Default 0.05: drum slip of up to ±5 % plus the payout a softer or
    /// heavier bridge needs for the same motion. Off (`None`): no estimate
    /// (the model state then moves exactly as commanded). Needs
    /// `midspan_positions` measured.
    #[serde(with = "super::off")]
    pub payout_scale_prior_sd: Option<f64>,
    /// Random-walk standard deviation of the payout scale per command, 1,
    /// in [0, 0.5]. Default 0.02: the scale a stiffness error is
    /// equivalent to changes along the deployment, so old commands count
    /// for less.
    pub payout_scale_drift_sd: f64,
    /// How far the model's member forces may be from the bridge's, as a
    /// fraction of the predicted force (plus 1 N), per measurement, in
    /// [0, 100]: the closed loop filters the load-cell offsets with it
    /// (see [`crate::control::ForceOffsetFilter`]). Default 0.2: stiffness
    /// and mass errors of the plausible ranges move forces by up to about
    /// a fifth. Larger trusts each reading more.
    pub force_model_error_fraction: f64,
    /// Prior standard deviation of a bias common to the load cells, N, in
    /// (0, 10 000]: the closed loop separates it from the model's force
    /// error, so that a load cell zeroed off is not read as a member
    /// force (see [`crate::control::ForceOffsetFilter`]). It covers the
    /// sensor error of the effect `load_cell_bias`. Default
    /// [`load_cell_bias_prior_sd_n`]: that effect's plausible range
    /// (±50 N) as a uniform prior, 28.9 N. Off (`None`): every offset is
    /// the model's error (the filter before issue 22).
    #[serde(with = "super::off")]
    pub load_cell_bias_prior_sd_n: Option<f64>,
    /// Prior standard deviation of each motor's drum zero error, m, in
    /// (0, 0.1]: before the first command the controller estimates from
    /// the start readings how much material each cable holds beyond what
    /// its drum says, and plans on a model that holds it (see
    /// [`crate::control::drum_offsets`]). It covers the fault
    /// `drum_zero_error`; [`drum_offset_prior_sd_m`] gives that fault's
    /// plausible range (±15 mm) as a uniform prior, 8.7 mm. Default off
    /// (`None`: the model holds what the drums say). Measured on seed 301
    /// of `scenarios/wide.toml` (200 scenarios): on, 138 connected and 32
    /// runs with broken limits; off, 145 and 14. The midspan positions
    /// hardly identify one drum's offset (6 mm moves them 0.5 mm at a
    /// 30 cm fold) and only four cables have load cells, so the estimate
    /// mostly moves material to explain what the model lacks elsewhere.
    #[serde(with = "super::off")]
    pub drum_offset_prior_sd_m: Option<f64>,
}

/// The default prior standard deviation of a drum zero error, m: the
/// plausible range of the fault `drum_zero_error` as a uniform
/// distribution, `(high − low)/√12`.
pub fn drum_offset_prior_sd_m() -> f64 {
    let (low, high) = crate::model::FaultKind::DrumZeroError.parameters()[0].plausible;
    (high - low) / 12f64.sqrt()
}

/// The default prior standard deviation of the load cells' common bias,
/// N: the plausible range of the effect `load_cell_bias` as a uniform
/// distribution, `(high − low)/√12`.
pub fn load_cell_bias_prior_sd_n() -> f64 {
    let (low, high) = crate::model::EffectKind::LoadCellBias.parameters()[0].plausible;
    (high - low) / 12f64.sqrt()
}

impl ControlSettings {
    /// Every number of the settings with its admissible range.
    pub fn ranges(&self) -> [Ranged; 5] {
        [
            Ranged::optional(
                "drum_offset_prior_sd_m",
                self.drum_offset_prior_sd_m,
                NumberRange::positive_up_to(0.1),
            ),
            Ranged::optional(
                "load_cell_bias_prior_sd_n",
                self.load_cell_bias_prior_sd_n,
                NumberRange::positive_up_to(1e4),
            ),
            Ranged::optional(
                "payout_scale_prior_sd",
                self.payout_scale_prior_sd,
                NumberRange::positive_up_to(0.5),
            ),
            Ranged::real(
                "payout_scale_drift_sd",
                self.payout_scale_drift_sd,
                NumberRange::non_negative_up_to(0.5),
            ),
            Ranged::real(
                "force_model_error_fraction",
                self.force_model_error_fraction,
                NumberRange::non_negative_up_to(100.0),
            ),
        ]
    }
}

impl Default for ControlSettings {
    fn default() -> Self {
        ControlSettings {
            measures: vec![Measurement::MidspanPositions, Measurement::LoadCells],
            payout_scale_prior_sd: Some(0.05),
            payout_scale_drift_sd: 0.02,
            force_model_error_fraction: 0.2,
            load_cell_bias_prior_sd_n: Some(load_cell_bias_prior_sd_n()),
            drum_offset_prior_sd_m: None,
        }
    }
}

impl ControlSettings {
    /// Checks every number against its range.
    pub fn validate(&self) -> Result<(), FieldError> {
        check_ranges(&self.ranges())
    }

    /// The payout-scale prior's standard deviation when the loop estimates
    /// the scale: on, and the midspan positions measured (the motion it is
    /// learnt from).
    pub fn payout_scale_estimate_sd(&self) -> Option<f64> {
        self.payout_scale_prior_sd
            .filter(|_| self.measures.contains(&Measurement::MidspanPositions))
    }
}
