#![warn(missing_docs)]
//! tensegrity-deploy
pub mod model;
