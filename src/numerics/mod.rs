//! Numerical building blocks with no knowledge of structures: quadratic
//! programs and the one Clarabel adapter ([`qp`]), free-DOF numbering
//! ([`dofs`]), block matrices to assemble tangents into ([`block_matrix`]) and their
//! factorisation ([`block_lu`]).

pub mod block_lu;
pub mod block_matrix;
pub mod dofs;
pub mod qp;

pub use block_lu::BlockLu;
pub use block_matrix::{BlockMatrix, MatrixAssembly};
pub use dofs::FreeDofs;
