//! What past cycles tell a deployment: the learnt approach to send first
//! and the payout-scale prior (from the case memory, `crate::learn`).

/// What past cycles tell a deployment (from the case memory, see
/// `crate::learn`). The default is no guidance: the memoryless controller.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Guidance {
    /// Drum commands to send first, in order, m per motor: the learnt
    /// approach. Each is tried on the controller's model before it is sent
    /// (as cable motion `sent·(1 + ŝ)`); the first the model finds beyond
    /// a limit or a motor's stroke ends the feedforward, and the planner
    /// takes over (after `feedforward_splits` halvings of that command).
    /// The connection test waits until the feedforward is sent
    /// unless the next feedforward command is predicted not to reduce the
    /// largest gap.
    pub feedforward_m: Vec<Vec<f64>>,
    /// Payout scale per independent part to start the estimator from
    /// (index = part id), 1; `None`: start at 0.
    pub payout_scale_prior: Option<Vec<f64>>,
    /// Standard deviation of that prior, 1 (used with `payout_scale_prior`);
    /// `None`: the policy's own prior standard deviation.
    pub payout_scale_prior_sd: Option<f64>,
    /// How many times a feedforward command the model refuses is halved
    /// (the halves sent one after the other, each checked) before the
    /// planner takes over; see `MemorySettings::feedforward_splits`.
    /// Absent in a file: 0.
    #[serde(default)]
    pub feedforward_splits: usize,
    /// The take-up of the case learnt from, held at the front of
    /// `feedforward_m` (drum, m per motor; see
    /// `crate::learn::adaptation::learnt_path`); `None` where the case
    /// recorded none. Where the controller takes up this cycle's slack
    /// first, its take-up replaces the case's: this motion is taken out of
    /// the front of the feedforward. A fold that left more slack this time
    /// is taken up in full, and the learnt moves after it are sent as
    /// learnt. Absent in a file: `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub take_up_in_front_m: Option<Vec<f64>>,
}
