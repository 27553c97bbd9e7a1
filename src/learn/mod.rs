//! Learning from past deployment cycles: the case memory.
//!
//! - [`case`]: one deployment cycle as a case: its conditions, the
//!   commands sent, the measured response, the model's prediction error
//!   per command and the outcome;
//! - [`memory`]: the cases of many cycles and the retrieval of the nearest
//!   by scaled features of their conditions.
//!
//! The memory file's format (versioned, a checksum per case, atomic
//! appends) is in [`crate::io::memory_file`]. Pure: no files here.

pub mod case;
pub mod memory;

pub use case::{Case, CaseConditions, CaseOutcome};
pub use memory::{CaseMemory, FeatureScales, Neighbour};
