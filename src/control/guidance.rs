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
    /// Where `feedforward_m` holds the take-up of the case it was learnt
    /// from, and so what the controller's own take-up before it
    /// ([`crate::plan::take_up`]) does to it. Absent in a file:
    /// [`CaseTakeUp::Inside`], what guidance before this field meant.
    #[serde(default)]
    pub case_take_up: CaseTakeUp,
}

/// The take-up of the case a learnt approach comes from, as the learnt
/// commands hold it (`crate::learn::adaptation::learnt_path`).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum CaseTakeUp {
    /// Somewhere inside the learnt commands, or not known (a case of a
    /// memory before format 4, or take-ups paced as commands): every
    /// take-up sent before the feedforward is taken out of it in
    /// proportion, each motor's commands scaled by `(t − sent)/t`, so that
    /// they still end at their learnt totals.
    #[default]
    Inside,
    /// The case took up no slack: a take-up this cycle is slack the case
    /// did not have, taken up in addition to the learnt commands.
    None,
    /// Added at the front of the learnt commands: the motion added to
    /// each of the first commands, per command and motor, m (drum). The
    /// controller's first own take-up replaces it: these additions are
    /// subtracted again, and the learnt moves after the take-up are sent
    /// as learnt; a fold that left more slack this time is taken up in
    /// full (further take-ups before the first learnt command add to it).
    InFront(Vec<Vec<f64>>),
}
