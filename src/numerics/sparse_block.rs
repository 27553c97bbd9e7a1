//! Sparse diagonal blocks, for structures too large for dense factors.
//!
//! A net of N×N nodes couples each node to its four neighbours only: its
//! 3(N−2)² free DOFs in one block, a dense factorisation of ⅔·(3N²)³ flops
//! (8·10⁸ at N = 21) where a sparse one with a fill-reducing ordering needs
//! a few hundredths of that. [`BlockPattern`] holds one block's pattern
//! (compressed columns, both triangles, from the structure's topology, so a
//! superset of every tangent's entries: slack members and the joints'
//! slip states change values, never the pattern) with its symbolic
//! analyses, computed once and shared by every matrix on it;
//! `SparseBlock` the values assembled into it and their numeric factors.
//!
//! Kernels (faer's sparse solvers, sequential): Cholesky `LLᵀ` of the
//! symmetric part where the block is symmetric (to [`super::block_lu`]'s
//! tolerance) and positive definite, LU with partial pivoting otherwise,
//! as the dense blocks do.

use std::sync::{Arc, OnceLock};

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, NumericLu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// One block's sparsity pattern (compressed sparse columns, rows sorted,
/// structurally symmetric, every diagonal entry present) and its symbolic
/// factorisations, shared by every matrix assembled on it.
#[derive(Debug)]
pub struct BlockPattern {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Per stored entry `(i, j)`, the index of entry `(j, i)`.
    transpose: Vec<usize>,
    /// Fill-reducing ordering and elimination structure of `LLᵀ`.
    cholesky: SymbolicCholesky<usize>,
    /// That of `LU`, made at the first block that needs it (an unsymmetric
    /// tangent: sliding friction joints); `None` if it failed.
    lu: OnceLock<Option<SymbolicLu<usize>>>,
}

impl BlockPattern {
    /// The pattern of an `n`×`n` block holding the given entries (local
    /// indices below `n`; each is stored with its transpose, and every
    /// diagonal entry is stored); `None` if an index is out of range or
    /// the symbolic analysis fails (the caller then stores the block
    /// densely).
    pub fn new(n: usize, entries: impl IntoIterator<Item = (usize, usize)>) -> Option<Self> {
        let mut columns: Vec<Vec<usize>> = (0..n).map(|j| vec![j]).collect();
        for (i, j) in entries {
            if i >= n || j >= n {
                return None;
            }
            columns[j].push(i);
            columns[i].push(j);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for mut rows in columns {
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend(rows);
            col_ptr.push(row_idx.len());
        }
        let mut transpose = vec![0; row_idx.len()];
        for j in 0..n {
            for k in col_ptr[j]..col_ptr[j + 1] {
                let i = row_idx[k];
                let column = &row_idx[col_ptr[i]..col_ptr[i + 1]];
                transpose[k] = col_ptr[i] + column.binary_search(&j).ok()?;
            }
        }
        let symbolic = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let cholesky = factorize_symbolic_cholesky(
            symbolic,
            Side::Lower,
            Default::default(),
            Default::default(),
        )
        .ok()?;
        Some(BlockPattern {
            col_ptr,
            row_idx,
            transpose,
            cholesky,
            lu: OnceLock::new(),
        })
    }

    /// Number of rows (and columns).
    pub fn dim(&self) -> usize {
        self.col_ptr.len() - 1
    }

    /// Stored entries (both triangles).
    pub fn nonzeros(&self) -> usize {
        self.row_idx.len()
    }

    /// Flops of one numeric Cholesky factorisation on this pattern,
    /// `Σ_j c_j²` over the columns of `L` with `c_j` entries each (exact
    /// for a column-by-column factorisation up to lower-order terms; the
    /// dense equivalent is `n³/3`).
    pub fn cholesky_flops(&self) -> f64 {
        let square = |c: usize| (c as f64) * (c as f64);
        match self.cholesky.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                s.col_ptr().windows(2).map(|w| square(w[1] - w[0])).sum()
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                let (begin, end) = (s.supernode_begin(), s.supernode_end());
                let rows = s.col_ptr_for_row_idx();
                (0..s.n_supernodes())
                    .map(|k| {
                        let below = rows[k + 1] - rows[k];
                        (begin[k]..end[k])
                            .map(|c| square(end[k] - c + below))
                            .sum::<f64>()
                    })
                    .sum()
            }
        }
    }

    /// Index of entry (`i`, `j`) in the values, if stored.
    #[inline]
    pub(super) fn position(&self, i: usize, j: usize) -> Option<usize> {
        let (start, end) = (*self.col_ptr.get(j)?, *self.col_ptr.get(j + 1)?);
        self.row_idx[start..end]
            .binary_search(&i)
            .ok()
            .map(|k| start + k)
    }

    fn symbolic(&self) -> SymbolicSparseColMatRef<'_, usize> {
        let n = self.dim();
        SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx)
    }

    fn lu(&self) -> Option<&SymbolicLu<usize>> {
        self.lu
            .get_or_init(|| factorize_symbolic_lu(self.symbolic(), Default::default()).ok())
            .as_ref()
    }
}

/// Numeric factors of a sparse block.
#[derive(Debug, Clone, Default)]
pub(super) enum SparseFactors {
    /// Not factorised (being assembled).
    #[default]
    None,
    /// `L` of `A = L·Lᵀ` (values on the pattern's symbolic factor).
    Cholesky(Vec<f64>),
    /// `P·A·Q = L·U`.
    Lu(Box<NumericLu<usize, f64>>),
}

/// One sparse diagonal block: global rows, values on a shared pattern, and
/// once factorised its factors.
#[derive(Debug, Clone)]
pub(super) struct SparseBlock {
    pub(super) rows: Vec<usize>,
    pub(super) pattern: Arc<BlockPattern>,
    pub(super) values: Vec<f64>,
    /// Whether an entry outside the pattern was added (a pattern that is
    /// not the superset it must be): the block then refuses to factorise
    /// rather than solve a matrix that lost entries.
    pub(super) missed_entry: bool,
    pub(super) factors: SparseFactors,
}

impl SparseBlock {
    pub(super) fn zeros(rows: &[usize], pattern: Arc<BlockPattern>) -> Self {
        SparseBlock {
            rows: rows.to_vec(),
            values: vec![0.0; pattern.nonzeros()],
            pattern,
            missed_entry: false,
            factors: SparseFactors::None,
        }
    }

    /// Adds `value` to local entry (`i`, `j`).
    #[inline]
    pub(super) fn add(&mut self, i: usize, j: usize, value: f64) {
        match self.pattern.position(i, j) {
            Some(k) => self.values[k] += value,
            None => self.missed_entry |= value != 0.0,
        }
    }

    /// Local entry (`i`, `j`); zero where not stored.
    pub(super) fn get(&self, i: usize, j: usize) -> f64 {
        self.pattern.position(i, j).map_or(0.0, |k| self.values[k])
    }

    /// Zero values, no factors.
    pub(super) fn clear(&mut self) {
        self.values.fill(0.0);
        self.missed_entry = false;
        self.factors = SparseFactors::None;
    }

    /// Factorises the values: Cholesky of the symmetric part if symmetric
    /// to `symmetry_tol` of the largest entry and positive definite, else
    /// LU; `false` if singular (zero or non-finite entries, a zero pivot).
    pub(super) fn factorise(&mut self, symmetry_tol: f64) -> bool {
        self.factors = SparseFactors::None;
        let p = &*self.pattern;
        let n = p.dim();
        if n == 0 {
            self.factors = SparseFactors::Cholesky(Vec::new());
            return true;
        }
        if self.missed_entry {
            return false;
        }
        let (mut largest, mut asymmetry) = (0.0f64, 0.0f64);
        for (k, v) in self.values.iter().enumerate() {
            largest = largest.max(v.abs());
            asymmetry = asymmetry.max((v - self.values[p.transpose[k]]).abs());
        }
        if !largest.is_finite() || largest == 0.0 {
            return false;
        }
        if asymmetry <= symmetry_tol * largest {
            // faer reads the lower triangle only: make it the symmetric part.
            let symmetric: Vec<f64> = self
                .values
                .iter()
                .enumerate()
                .map(|(k, v)| 0.5 * (v + self.values[p.transpose[k]]))
                .collect();
            let mut l = vec![0.0; p.cholesky.len_val()];
            let mut buf = MemBuffer::new(
                p.cholesky
                    .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            );
            let ok = p
                .cholesky
                .factorize_numeric_llt(
                    &mut l,
                    SparseColMatRef::new(p.symbolic(), &symmetric),
                    Side::Lower,
                    LltRegularization::default(),
                    Par::Seq,
                    MemStack::new(&mut buf),
                    Default::default(),
                )
                .is_ok();
            if ok && l.iter().all(|v| v.is_finite()) {
                self.factors = SparseFactors::Cholesky(l);
                return true;
            }
        }
        let Some(symbolic) = p.lu() else {
            return false;
        };
        let mut numeric = Box::new(NumericLu::new());
        let mut buf = MemBuffer::new(
            symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
        );
        if symbolic
            .factorize_numeric_lu(
                &mut numeric,
                SparseColMatRef::new(p.symbolic(), &self.values),
                Par::Seq,
                MemStack::new(&mut buf),
                Default::default(),
            )
            .is_err()
        {
            return false;
        }
        self.factors = SparseFactors::Lu(numeric);
        // A zero pivot that the symbolic structure did not foresee shows as
        // a non-finite solution (faer checks structural singularity only).
        let mut probe = faer::Mat::<f64>::from_fn(n, 1, |i, _| 1.0 + i as f64 / n as f64);
        self.solve_in_place(probe.as_mut());
        if !(0..n).all(|i| probe[(i, 0)].is_finite()) {
            self.factors = SparseFactors::None;
            return false;
        }
        true
    }

    /// Solves in place with the factors (a column of the block's rows).
    pub(super) fn solve_in_place(&self, rhs: MatMut<'_, f64>) {
        let p = &*self.pattern;
        match &self.factors {
            SparseFactors::None => {}
            SparseFactors::Cholesky(l) => {
                let mut buf = MemBuffer::new(p.cholesky.solve_in_place_scratch::<f64>(1, Par::Seq));
                LltRef::new(&p.cholesky, l).solve_in_place_with_conj(
                    Conj::No,
                    rhs,
                    Par::Seq,
                    MemStack::new(&mut buf),
                );
            }
            SparseFactors::Lu(numeric) => {
                let Some(symbolic) = p.lu() else { return };
                let mut buf = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
                LuRef::new_unchecked(symbolic, numeric).solve_in_place_with_conj(
                    Conj::No,
                    rhs,
                    Par::Seq,
                    MemStack::new(&mut buf),
                );
            }
        }
    }

    pub(super) fn is_cholesky(&self) -> bool {
        matches!(self.factors, SparseFactors::Cholesky(_))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use crate::numerics::{BlockLayout, BlockLu, BlockMatrix};

    /// A 1-D Laplacian chain of `n` rows with its pattern (tridiagonal).
    fn chain(n: usize) -> (DMatrix<f64>, Vec<(usize, usize)>) {
        let k = DMatrix::from_fn(n, n, |i, j| match i.abs_diff(j) {
            0 => 2.0,
            1 => -1.0,
            _ => 0.0,
        });
        let pairs = (1..n).map(|i| (i, i - 1)).collect();
        (k, pairs)
    }

    /// Singular blocks are refused (`None`), as the dense ones are: all
    /// zero, exactly rank deficient in value (two equal rows, which no
    /// structural analysis sees), structurally singular (an empty row),
    /// and non-finite. A regular one is solved exactly (the chain's
    /// solution of `K·x = e_0` is `x_i = (n − i)/(n + 1)`).
    #[test]
    fn singular_sparse_blocks_are_refused() {
        let n = 60;
        let (k, pairs) = chain(n);
        let layout = BlockLayout::with_sparse_from(n, &[(0..n).collect()], &pairs, 0);
        let lu = BlockLu::factorise(BlockMatrix::from_dense_on(&k, &layout)).unwrap();
        assert!(lu.is_cholesky());
        let x = lu.solve(&DVector::from_fn(n, |i, _| if i == 0 { 1.0 } else { 0.0 }));
        for (i, v) in x.iter().enumerate() {
            let exact = (n - i) as f64 / (n + 1) as f64;
            assert!((v - exact).abs() < 1e-13, "{i}: {v} against {exact}");
        }
        let refused =
            |m: &DMatrix<f64>| BlockLu::factorise(BlockMatrix::from_dense_on(m, &layout)).is_none();
        assert!(refused(&DMatrix::zeros(n, n)));
        // Rows 0 and 1 equal: [1, 1, 0…] twice (unsymmetric, so LU).
        let mut equal_rows = k.clone();
        for r in 0..2 {
            equal_rows[(r, 0)] = 1.0;
            equal_rows[(r, 1)] = 1.0;
            equal_rows[(r, 2)] = 0.0;
        }
        assert!(refused(&equal_rows));
        let mut empty_row = k.clone();
        for c in 0..n {
            empty_row[(5, c)] = 0.0;
        }
        assert!(refused(&empty_row));
        let mut nan = k.clone();
        nan[(3, 3)] = f64::NAN;
        assert!(refused(&nan));
    }

    /// An entry outside the pattern makes the block refuse to factorise
    /// instead of silently solving a matrix that lost it.
    #[test]
    fn an_entry_outside_the_pattern_is_refused() {
        use crate::numerics::MatrixAssembly;
        let n = 10;
        let (k, pairs) = chain(n);
        let layout = BlockLayout::with_sparse_from(n, &[(0..n).collect()], &pairs, 0);
        let mut m = BlockMatrix::from_dense_on(&k, &layout);
        m.add(0, 5, 1e-3);
        assert!(BlockLu::factorise(m).is_none());
    }
}
