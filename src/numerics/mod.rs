//! Numerical building blocks with no knowledge of structures: quadratic
//! programs and the one Clarabel adapter ([`qp`]), free-DOF numbering
//! ([`dofs`]) and block factorisation ([`block_lu`]).

pub mod block_lu;
pub mod dofs;
pub mod qp;

pub use block_lu::BlockLu;
pub use dofs::FreeDofs;
