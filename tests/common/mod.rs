//! Helpers shared by the integration tests; every test file that needs one
//! declares `mod common;` (each file is its own crate and uses a part, so
//! unused items are allowed here).
//!
//! - [`cli`]: running the `tdeploy` binary (in a folder, with a thread
//!   count or a hang guard) and checking how it ended;
//! - [`files`]: reading what a run wrote: every file of a folder, JSON,
//!   CSV by column;
//! - [`fixtures`]: inputs several tests build the same way: small
//!   structure, command and model files, a folder with a small lab log,
//!   the reference bridge and its standard lab log;
//! - [`cable_net`]: the 7×7 cable-net reference (also read by
//!   `benches/relaxation.rs`, through `#[path]`).
//!
//! Paths into the repository (policies, experiments, test data) come from
//! [`repo_path`]: tests do not depend on the folder they run in.

#![allow(dead_code)]

pub mod cable_net;
pub mod cli;
pub mod files;
pub mod fixtures;

use std::path::{Path, PathBuf};

/// The repository's root (the package's manifest folder).
pub fn repo_root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `path` (relative to the repository's root) as an absolute path.
pub fn repo_path(path: &str) -> PathBuf {
    repo_root().join(path)
}

/// [`repo_path`] as a command-line argument.
pub fn repo_arg(path: &str) -> String {
    repo_path(path).display().to_string()
}

/// The text of the repository's file `path`.
pub fn repo_text(path: &str) -> String {
    std::fs::read_to_string(repo_path(path)).unwrap()
}
