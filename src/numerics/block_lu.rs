//! Factors of a matrix block by block: free DOFs that no chain of members
//! joins (the two halves of the bridge, parted by their supports) never
//! couple, so each block is factorised on its own, which for two equal
//! halves quarters the work. The one place in the crate that factorises a
//! tangent.
//!
//! Each block is factorised by faer's dense kernels (SIMD, blocked; 2–5×
//! faster than nalgebra's LU on the 60 to 250 rows of the structures here):
//! Cholesky `LLᵀ` where the block is symmetric and positive definite (a
//! tangent without sliding friction joints, at a stable state; half the
//! flops of LU and no pivoting), LU with partial pivoting otherwise.
//! Symmetry is tested numerically, to `SYMMETRY_TOL` of the largest
//! entry (a frictionless cable's tangent is symmetric only to rounding);
//! the Cholesky factors are those of the symmetric part.
//!
//! Sparse blocks (large ones, see [`super::BlockLayout::new`]) are
//! factorised the same two ways by faer's sparse kernels
//! ([`super::sparse_block`]), on the symbolic analysis their pattern
//! keeps, so only the numeric factorisation is repeated from one tangent
//! to the next.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_unit_lower_triangular_in_place,
    solve_upper_triangular_in_place,
};
use faer::{Mat, Par};
use nalgebra::{DMatrix, DVector};

use super::block_matrix::{Block, BlockMatrix, DenseBlock};
use super::sparse_block::SparseBlock;

/// Largest `|a_ij − a_ji|`, relative to the block's largest entry, of a
/// block treated as symmetric. Rounding in the assembly of a symmetric
/// tangent leaves ~1e-15; the Cholesky solve of the symmetric part then
/// differs from the LU solve of the matrix by about this much relative,
/// far below any solver tolerance (1e-6 of the member forces by default).
const SYMMETRY_TOL: f64 = 1e-10;

/// How one block was factorised.
#[derive(Debug, Clone)]
enum Factors {
    /// `A = L·Lᵀ`, `L` in the lower triangle.
    Cholesky,
    /// `P·A = L·U` (`L` unit lower, `U` upper, in place); `perm[i]` is the
    /// row of `A` that is row `i` of `P·A`.
    Lu { perm: Vec<usize> },
}

#[derive(Debug, Clone)]
enum FactorBlock {
    Dense {
        block: DenseBlock,
        factors: Factors,
    },
    /// Holds its own factors.
    Sparse(SparseBlock),
}

/// Block-diagonal factors of a square matrix.
#[derive(Debug, Clone)]
pub struct BlockLu {
    blocks: Vec<FactorBlock>,
    /// The matrix's row placement, kept to hand the storage back.
    shape: BlockMatrix,
}

impl BlockLu {
    /// Factorises `k` on the given blocks of rows (which must cover every
    /// row that couples; see [`super::FreeDofs::blocks`]); `None` if a block
    /// is singular.
    pub fn new(k: &DMatrix<f64>, blocks: &[Vec<usize>]) -> Option<Self> {
        BlockLu::factorise(BlockMatrix::from_dense(k, blocks))
    }

    /// Factorises an assembled block matrix in place (its storage becomes
    /// the factors'; [`BlockLu::into_storage`] hands it back); `None` if a
    /// block is singular (a zero or non-finite pivot).
    pub fn factorise(mut matrix: BlockMatrix) -> Option<Self> {
        let blocks = std::mem::take(&mut matrix.blocks);
        let mut factored = Vec::with_capacity(blocks.len());
        for block in blocks {
            factored.push(match block {
                Block::Dense(mut block) => {
                    let factors = factorise_block(&mut block)?;
                    FactorBlock::Dense { block, factors }
                }
                Block::Sparse(mut block) => {
                    if !block.factorise(SYMMETRY_TOL) {
                        return None;
                    }
                    FactorBlock::Sparse(block)
                }
            });
        }
        Some(BlockLu {
            blocks: factored,
            shape: matrix,
        })
    }

    /// The storage back, as a zero matrix of the same blocks, to assemble
    /// the next matrix into without allocating.
    pub fn into_storage(self) -> BlockMatrix {
        let mut m = self.shape;
        m.blocks = self
            .blocks
            .into_iter()
            .map(|b| match b {
                FactorBlock::Dense { block, .. } => Block::Dense(block),
                FactorBlock::Sparse(block) => Block::Sparse(block),
            })
            .collect();
        m.clear();
        m
    }

    /// Solves `K·x = rhs`.
    pub fn solve(&self, rhs: &DVector<f64>) -> DVector<f64> {
        let mut x = DVector::zeros(self.shape.size());
        let mut col = Mat::<f64>::zeros(0, 1);
        for factor_block in &self.blocks {
            let (block, factors) = match factor_block {
                FactorBlock::Dense { block, factors } => (block, factors),
                FactorBlock::Sparse(block) => {
                    col.resize_with(block.rows.len(), 1, |_, _| 0.0);
                    for (i, &r) in block.rows.iter().enumerate() {
                        col[(i, 0)] = rhs[r];
                    }
                    block.solve_in_place(col.as_mut());
                    for (i, &r) in block.rows.iter().enumerate() {
                        x[r] = col[(i, 0)];
                    }
                    continue;
                }
            };
            let n = block.dim();
            col.resize_with(n, 1, |_, _| 0.0);
            match factors {
                Factors::Cholesky => {
                    for (i, &r) in block.rows.iter().enumerate() {
                        col[(i, 0)] = rhs[r];
                    }
                    let l = block.as_ref();
                    solve_lower_triangular_in_place(l, col.as_mut(), Par::Seq);
                    solve_upper_triangular_in_place(l.transpose(), col.as_mut(), Par::Seq);
                }
                Factors::Lu { perm } => {
                    for (i, &p) in perm.iter().enumerate() {
                        col[(i, 0)] = rhs[block.rows[p]];
                    }
                    let lu = block.as_ref();
                    solve_unit_lower_triangular_in_place(lu, col.as_mut(), Par::Seq);
                    solve_upper_triangular_in_place(lu, col.as_mut(), Par::Seq);
                }
            }
            for (i, &r) in block.rows.iter().enumerate() {
                x[r] = col[(i, 0)];
            }
        }
        x
    }

    /// Whether every block was factorised by Cholesky (symmetric positive
    /// definite), for tests of which kernel runs.
    pub fn is_cholesky(&self) -> bool {
        self.blocks.iter().all(|b| match b {
            FactorBlock::Dense { factors, .. } => matches!(factors, Factors::Cholesky),
            FactorBlock::Sparse(block) => block.is_cholesky(),
        })
    }
}

/// Factorises one dense block in place: Cholesky if it is symmetric (to
/// [`SYMMETRY_TOL`]) and positive definite, else LU with partial pivoting;
/// `None` if singular.
fn factorise_block(block: &mut DenseBlock) -> Option<Factors> {
    let n = block.dim();
    if n == 0 {
        return Some(Factors::Cholesky);
    }
    let ld = block.stride;
    let a = &mut block.values;
    // The largest entry of the lower triangle and whether all are finite,
    // column by column in four independent lanes: a single running
    // `f64::max` is a chain of dependent instructions, and this scan was
    // 8 % of `evaluate`.
    let (mut lanes, mut finite) = ([0.0f64; 4], [true; 4]);
    for j in 0..n {
        let column = &a[j * ld + j..j * ld + n];
        let mut fold = |lane: usize, value: f64| {
            let m = value.abs();
            lanes[lane] = if m > lanes[lane] { m } else { lanes[lane] };
            finite[lane] &= m <= f64::MAX;
        };
        let chunks = column.chunks_exact(4);
        let tail = chunks.remainder();
        for chunk in chunks {
            for lane in 0..4 {
                fold(lane, chunk[lane]);
            }
        }
        for (lane, value) in tail.iter().enumerate() {
            fold(lane, *value);
        }
    }
    let largest = lanes.iter().fold(0.0f64, |l, m| l.max(*m));
    if finite.contains(&false) || largest == 0.0 {
        return None;
    }
    // Symmetric to the tolerance? Column j below the diagonal against row
    // j right of it, stopping at the first pair that differs (a sliding
    // joint makes the tangent unsymmetric in its first columns).
    let allowed = SYMMETRY_TOL * largest;
    let symmetric = 'check: {
        for j in 0..n {
            for i in j + 1..n {
                if !((a[i + j * ld] - a[j + i * ld]).abs() <= allowed) {
                    break 'check false;
                }
            }
        }
        true
    };
    let diagonal_ok = |a: &[f64], positive: bool| {
        (0..n).all(|i| {
            let d = a[i + i * ld];
            d.is_finite() && if positive { d > 0.0 } else { d != 0.0 }
        })
    };
    if symmetric {
        // The lower triangle becomes the symmetric part; the upper one is
        // left as it was, so a failed Cholesky (indefinite) can restore the
        // lower triangle from it for LU.
        for j in 0..n {
            for i in j + 1..n {
                let mean = 0.5 * (a[i + j * ld] + a[j + i * ld]);
                a[i + j * ld] = mean;
            }
        }
        let mut buf = MemBuffer::new(cholesky_in_place_scratch::<f64>(
            n,
            Par::Seq,
            Default::default(),
        ));
        let llt = cholesky_in_place(
            block.as_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut buf),
            Default::default(),
        );
        if llt.is_ok() && diagonal_ok(&block.values, true) {
            return Some(Factors::Cholesky);
        }
        let a = &mut block.values;
        for j in 0..n {
            for i in j..n {
                a[i + j * ld] = a[j + i * ld];
            }
        }
    }
    let mut perm = vec![0usize; n];
    let mut perm_inv = vec![0usize; n];
    let mut buf = MemBuffer::new(lu_in_place_scratch::<usize, f64>(
        n,
        n,
        Par::Seq,
        Default::default(),
    ));
    lu_in_place(
        block.as_mut(),
        &mut perm,
        &mut perm_inv,
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    );
    if !diagonal_ok(&block.values, false) {
        return None;
    }
    Some(Factors::Lu { perm })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::block_matrix::MatrixAssembly;

    /// A reproducible dense matrix with entries in [−1, 1] (a linear
    /// congruential sequence; no test should depend on `rand`'s stream).
    fn pseudo_random(n: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed;
        DMatrix::from_fn(n, n, |_, _| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        })
    }

    #[test]
    fn block_solve_matches_a_dense_solve() {
        let k = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 2.0, 3.0, 0.0, 0.0, 0.0, 5.0]);
        let lu = BlockLu::new(&k, &[vec![0, 1], vec![2]]).unwrap();
        let rhs = DVector::from_vec(vec![1.0, 2.0, 10.0]);
        let x = lu.solve(&rhs);
        assert!((&k * &x - rhs).amax() < 1e-12);
        assert!(!lu.is_cholesky());
        assert!(BlockLu::new(&DMatrix::zeros(2, 2), &[vec![0, 1]]).is_none());
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
        assert!(BlockLu::new(&singular, &[vec![0, 1]]).is_none());
    }

    /// Every kernel against nalgebra's LU (an independent implementation)
    /// on 60-row blocks like the bridge's halves, interleaved rows: general
    /// (LU), symmetric positive definite (Cholesky), symmetric indefinite
    /// (Cholesky fails, LU from the restored matrix). Residuals to 1e-10
    /// relative: these are well-conditioned (condition numbers ~1e2–1e3),
    /// so rounding leaves ~1e-13.
    #[test]
    fn each_kernel_solves_like_nalgebra() {
        let n = 120;
        let blocks: Vec<Vec<usize>> =
            vec![(0..n).step_by(2).collect(), (1..n).step_by(2).collect()];
        let a = pseudo_random(n, 7);
        let general = DMatrix::from_fn(n, n, |i, j| {
            if i % 2 != j % 2 {
                0.0
            } else if i == j {
                a[(i, j)] + 8.0
            } else {
                a[(i, j)]
            }
        });
        let spd = general.transpose() * &general;
        let mut indefinite = &general + general.transpose();
        for i in 0..4 {
            indefinite[(2 * i, 2 * i)] -= 40.0;
        }
        let rhs = DVector::from_fn(n, |i, _| (i as f64 * 0.37).sin());
        for (name, k, cholesky) in [
            ("general", &general, false),
            ("spd", &spd, true),
            ("indefinite", &indefinite, false),
        ] {
            let lu = BlockLu::new(k, &blocks).unwrap();
            assert_eq!(lu.is_cholesky(), cholesky, "{name}");
            let x = lu.solve(&rhs);
            let reference = k.clone().lu().solve(&rhs).unwrap();
            let err = (&x - &reference).amax() / reference.amax();
            assert!(err < 1e-10, "{name}: {err}");
            assert!(
                (k * &x - &rhs).amax() < 1e-10 * k.amax() * x.amax(),
                "{name}"
            );
        }
    }

    #[test]
    fn assembled_blocks_factorise_and_the_storage_comes_back_zeroed() {
        let blocks = vec![vec![1, 2], vec![0]];
        let mut m = BlockMatrix::zeros(3, &blocks);
        let dense = DMatrix::from_row_slice(3, 3, &[2.0, 0.0, 0.0, 0.0, 4.0, 1.0, 0.0, 1.0, 3.0]);
        for r in 0..3 {
            for c in 0..3 {
                m.add(r, c, dense[(r, c)]);
            }
        }
        let lu = BlockLu::factorise(m).unwrap();
        assert!(lu.is_cholesky());
        let rhs = DVector::from_vec(vec![2.0, 5.0, 4.0]);
        assert!((&dense * lu.solve(&rhs) - &rhs).amax() < 1e-14);
        let back = lu.into_storage();
        assert!(back.has_layout(3, &blocks));
        assert_eq!(back.get(1, 1), 0.0);
    }
}
