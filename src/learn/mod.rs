//! Learning from past deployment cycles: the case memory.
//!
//! - [`case`]: one deployment cycle as a case: its conditions, the
//!   commands sent, the measured response, the model's prediction error
//!   per command and the outcome;
//! - [`memory`]: the cases of many cycles and the retrieval of the nearest
//!   by scaled features of their conditions.
//!
//! - [`ilc`]: the norm-optimal ILC update of a case's commands, a QP
//!   within the motor and member limits;
//! - [`acceptance`]: whether the newest learnt cycle bore the update out
//!   (a refuted update is not sent again);
//! - [`adaptation`]: retrieval, linearisation at the case's end and the
//!   update: the guidance a new cycle's deployment runs with.
//!
//! The memory file's format (versioned, a checksum per case, atomic
//! appends) is in [`crate::io::memory_file`]. Pure: no files here.

pub mod acceptance;
pub mod adaptation;
pub mod case;
pub mod ilc;
pub mod memory;

pub use acceptance::{Decline, LearningScore};
pub use adaptation::{adapt, retrieve, AdaptError, Adaptation, Advice, EndStateCache};
pub use case::{
    model_base, Case, CaseConditions, CaseLearning, CaseModel, CaseOutcome, LearntEffect,
    RIVAL_EFFECTS,
};
pub use ilc::{learn_commands, IlcData, IlcUpdate};
pub use memory::{CaseMemory, FeatureScales, Neighbour};
