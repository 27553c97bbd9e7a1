//! LU factors of a matrix block by block: free DOFs that no chain of
//! members joins (the two halves of the bridge, parted by their supports)
//! never couple, so each block is factorised on its own, which for two
//! equal halves quarters the work.

use nalgebra::{DMatrix, DVector, Dyn, LU};

/// Block-diagonal LU factors of a square matrix.
#[derive(Debug, Clone)]
pub struct BlockLu {
    blocks: Vec<(Vec<usize>, LU<f64, Dyn, Dyn>)>,
    size: usize,
}

impl BlockLu {
    /// Factorises `k` on the given blocks of rows (which must cover every
    /// row that couples; see [`super::FreeDofs::blocks`]); `None` if a block
    /// is singular.
    pub fn new(k: &DMatrix<f64>, blocks: &[Vec<usize>]) -> Option<Self> {
        let mut factors = Vec::with_capacity(blocks.len());
        for members in blocks {
            let sub = DMatrix::from_fn(members.len(), members.len(), |i, j| {
                k[(members[i], members[j])]
            });
            let lu = sub.lu();
            if !lu.is_invertible() {
                return None;
            }
            factors.push((members.clone(), lu));
        }
        Some(BlockLu {
            blocks: factors,
            size: k.nrows(),
        })
    }

    /// Solves `K·x = rhs`.
    pub fn solve(&self, rhs: &DVector<f64>) -> DVector<f64> {
        let mut x = DVector::zeros(self.size);
        for (members, lu) in &self.blocks {
            let b = DVector::from_iterator(members.len(), members.iter().map(|&i| rhs[i]));
            if let Some(y) = lu.solve(&b) {
                for (i, v) in members.iter().zip(y.iter()) {
                    x[*i] = *v;
                }
            }
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_solve_matches_a_dense_solve() {
        let k = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 2.0, 3.0, 0.0, 0.0, 0.0, 5.0]);
        let lu = BlockLu::new(&k, &[vec![0, 1], vec![2]]).unwrap();
        let rhs = DVector::from_vec(vec![1.0, 2.0, 10.0]);
        let x = lu.solve(&rhs);
        assert!((&k * &x - rhs).amax() < 1e-12);
        assert!(BlockLu::new(&DMatrix::zeros(2, 2), &[vec![0, 1]]).is_none());
    }
}
