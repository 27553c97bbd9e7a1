#![warn(missing_docs)]
// `!(a <= b)` is how this crate treats NaN as a failure; keep it.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
//! # tensegrity-deploy
//!
//! Deployment planning and learning for a deployable "hollow-rope"
//! tensegrity footbridge whose continuous cables stick and slip over joints.
//!
//! ## Pipeline
//! ```text
//!  structure + friction ─► model::ForwardModel (DR equilibrium)
//!                                 │
//!      command sequences ─► apply_payout in increments ─► states, forces
//! ```
//! (The planner, case memory and measurement tools build on this model.)
//!
//! ## Equations
//! - Members: `T = k·(L − L0)` (struts both signs; cables and springs
//!   tension only); continuous-cable segment `i`: `T_i = EA·(L_i − s_i)/s_i`
//!   with `s_i` the rest length of material in it.
//! - Joint friction (capstan): a joint sticks while
//!   `e^(−μα) ≤ T_b/T_a ≤ e^(μα)`, `α = π − θ` (wrap angle, default) or `θ`.
//! - Dynamic relaxation: `v += Δt·R/m`, `x += Δt·v`, kinetic damping,
//!   Gershgorin fictitious masses; sliding relaxed by return mapping.
//! - Convergence: `max |R_free| ≤ tol` and capstan violation `≤ tol`, with
//!   `tol = tol_force_rel · max |T|`.
//!
//! ## Layout
//! - [`model`]: structure, friction, DR solver, reference bridge. Pure.
//! - [`qp`]: quadratic programs and the only Clarabel adapter.
//! - [`analysis`]: studies that compare model runs (friction effect).
//! - [`measure`]: models with effects run through logged cycles; the
//!   synthetic lab.
//! - [`io`]: file formats; the only module that touches files.

pub mod analysis;
pub mod io;
pub mod measure;
pub mod model;
pub mod qp;
