//! Numerical building blocks with no knowledge of structures: quadratic
//! programs and the one Clarabel adapter ([`qp`]), free-DOF numbering
//! ([`dofs`]), labels users give settings ([`label`]), block matrices to assemble tangents into ([`block_matrix`]) and their
//! factorisation ([`block_lu`]), dense or sparse ([`sparse_block`]).

pub mod block_lu;
pub mod block_matrix;
pub mod dofs;
pub mod label;
pub mod qp;
pub mod range;
pub mod sparse_block;

pub use block_lu::BlockLu;
pub use block_matrix::{BlockLayout, BlockMatrix, MatrixAssembly};
pub use dofs::FreeDofs;
pub use label::{check_label, MAX_LABEL_CHARS};
pub use range::{check_ranges, FieldError, NumberRange, Ranged};
pub use sparse_block::BlockPattern;
