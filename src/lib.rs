#![warn(missing_docs)]
// `!(a <= b)` is how this crate treats NaN as a failure; keep it.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Loops over the three axes index positions, forces and fixity masks of
// one node together; an iterator over one of them reads worse.
#![allow(clippy::needless_range_loop)]
//! # tensegrity-deploy
//!
//! Deployment planning and learning for a deployable "hollow-rope"
//! tensegrity footbridge whose continuous cables stick and slip over joints.
//!
//! ## Pipeline
//! ```text
//!  structure + friction ─► model::ForwardModel (Newton + DR equilibrium)
//!                                 │
//!      command sequences ─► apply_payout in increments ─► states, forces
//!                                 │
//!  plan: responses d(gap, force)/d(payout) ─► QP step ─► confirming trial
//!                                 │                  (trust region)
//!  control: send u/(1+ŝ) to the truth (sim::Plant) ─► measure ─►
//!      payout scale ŝ (Kalman) · gap offsets · filtered force offsets
//!                                 │
//!  studies::cycles: deploy ─► fold back ─► case memory (ILC on commands)
//!      └─► studies::model_learning: diagnose the last cycles' log ─►
//!          the next cycle plans on what explains it (held out, trusted)
//!                                 │
//!  studies::evaluation: policies × seeded scenarios (shards, McNemar)
//! ```
//! The measurement tools ([`measure`]: compare, diagnose, calibrate) read
//! the same model.
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
//! - QP step: `min Σ w_p‖g_p + G⁺u⁺ − G⁻u⁻‖² + ρ‖u‖² + κΣ(u⁺ + u⁻)` over
//!   `u± ≥ 0` within the trust region, stroke and step limits and the
//!   linearised force limits `F + A⁺u⁺ − A⁻u⁻ ∈ [F_min + m, F_max − m]`.
//! - Payout scale per bridge half: `Δy − g = ε·g + noise`, `ε̂ = (Σ g r/R) /
//!   (1/P + Σ g²/R)` (see [`control::estimation`]).
//!
//! ## Layout
//! Layers, each depending only on those above it in this list (a test,
//! `tests/layers.rs`, fails if a `use crate::…` line points the other way):
//! - [`numerics`]: QPs and the one Clarabel adapter, DOF numbering, block
//!   factorisation. Knows nothing of structures.
//! - [`model`]: structure, state, joint friction, effects, the equilibrium
//!   solver. Pure.
//! - [`design`]: the reference bridge, form finding, the friction rig.
//! - [`sim`]: a model with effects ([`sim::EffectModel`], the one way it
//!   becomes a forward model), the plant stepped one command at a time,
//!   sensors, schedule runs.
//! - [`measure`]: logs in memory, the synthetic lab, compare, diagnose,
//!   calibrate.
//! - [`plan`]: the deployment planner on a model alone: problem, limits,
//!   responses, QP step, sequence search, baselines, policies, open-loop
//!   plans.
//! - [`control`]: what runs against a plant: the controller, the closed
//!   loop, the estimation and the measurement corrections, and the online
//!   session (the controller one command at a time, driven by a rig or an
//!   operator outside the process, with interlocks).
//! - [`learn`]: the case memory of past deployment cycles.
//! - [`studies`]: what the experiments, `cycles` (with the model learnt
//!   between cycles) and `evaluate` compute.
//! - [`io`]: file formats and every writer of the commands' outputs: the
//!   only code that touches files (the CLI calls it).
//! - [`report`]: SVG drawings and figures.

pub mod control;
pub mod design;
pub mod io;
pub mod learn;
pub mod measure;
pub mod model;
pub mod numerics;
pub mod plan;
pub mod report;
pub mod sim;
pub mod studies;
