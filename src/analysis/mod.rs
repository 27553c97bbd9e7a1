//! Studies of the model: runs of the forward model compared with each
//! other, as the experiments in `experiments/` report them. Pure: no files.

pub mod friction_effect;

pub use friction_effect::{friction_effect, FrictionEffect, FrictionEffectSettings};
