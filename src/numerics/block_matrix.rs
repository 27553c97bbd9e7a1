//! A square matrix stored as diagonal blocks, to assemble a tangent
//! straight into the pieces that [`super::BlockLu`] factorises: free DOFs
//! that no chain of members joins (the two halves of the bridge) never
//! couple, so the off-block entries are all zero and are not stored (two
//! 60×60 blocks instead of one 120×120 matrix, and no copying out).
//!
//! A block is dense, or sparse on a shared [`BlockPattern`] where a
//! [`BlockLayout`] gives it one (large blocks: see [`BlockLayout::new`]).

use std::sync::Arc;

use faer::{MatMut, MatRef};
use nalgebra::{DMatrix, Matrix3};

use super::sparse_block::{BlockPattern, SparseBlock};

/// Blocks below this many rows are always dense, without a symbolic
/// analysis to estimate the sparse cost (made once per model, it would be
/// paid by every small model built): a sparse factorisation's fixed costs
/// (ordering, permuting, allocations) outweigh its savings there
/// (measured: the 5×5 net's 27 rows sparse 7 µs, dense 4 µs; the 7×7
/// net's 75 rows 22 µs against 19 µs; the bridge's 60-row halves 80 µs
/// against 35 µs).
pub const MIN_SPARSE_ROWS: usize = 100;

/// Time models of one assembly and factorisation of a block, ns, fitted
/// to `cargo run --release --example factor_timing` (tangents of the
/// bridges with 2 to 16 modules per half and of the 5×5 to 31×31 nets,
/// 2026-11-24, this machine; within a factor 2 of every measurement, and
/// the choice between the two right in every case measured).
pub mod cost {
    use super::BlockPattern;

    /// Dense: per flop of an LU (⅔·b³; faer's blocked kernels, measured
    /// on the Cholesky that symmetric tangents take, 0.009 ns per such
    /// flop on blocks of 250 to 2500 rows), per entry (zeroing,
    /// assembling, the symmetry test: 2 ns), per row (per-column
    /// overheads that dominate small blocks: 100 ns).
    pub fn dense_ns(rows: usize) -> f64 {
        let b = rows as f64;
        0.009 * (2.0 / 3.0) * b * b * b + 2.0 * b * b + 100.0 * b
    }

    /// Sparse: per flop of the Cholesky factor ([`BlockPattern::cholesky_flops`],
    /// 0.06 ns: small supernodes run far below the dense rate) and per
    /// stored entry of the matrix (assembly by binary search in a column,
    /// the symmetric copy and faer's permutation of it: 30 ns).
    pub fn sparse_ns(pattern: &BlockPattern) -> f64 {
        0.06 * pattern.cholesky_flops() + 30.0 * pattern.nonzeros() as f64
    }
}

/// How a matrix is split into diagonal blocks and how each is stored:
/// densely, or sparse on a pattern whose symbolic analysis is shared by
/// every matrix assembled on the layout.
#[derive(Debug, Clone)]
pub struct BlockLayout {
    size: usize,
    blocks: Vec<Vec<usize>>,
    patterns: Vec<Option<Arc<BlockPattern>>>,
}

impl BlockLayout {
    /// Every block dense.
    pub fn dense(size: usize, blocks: &[Vec<usize>]) -> Self {
        BlockLayout {
            size,
            blocks: blocks.to_vec(),
            patterns: vec![None; blocks.len()],
        }
    }

    /// Each block stored the way it is estimated to factorise faster
    /// ([`BlockLayout::factorisation_cost_ns`]): sparse, holding the entries
    /// `coupled` (global row, column pairs; each stored with its transpose,
    /// and every diagonal entry), or dense. Pairs between blocks are
    /// ignored. Blocks under [`MIN_SPARSE_ROWS`] are dense without an
    /// analysis, as is a block whose symbolic analysis fails.
    pub fn new(size: usize, blocks: &[Vec<usize>], coupled: &[(usize, usize)]) -> Self {
        let mut layout = BlockLayout::with_sparse_from(size, blocks, coupled, MIN_SPARSE_ROWS);
        for (b, pattern) in layout.patterns.iter_mut().enumerate() {
            let dense = cost::dense_ns(blocks[b].len());
            if pattern
                .as_ref()
                .is_some_and(|p| cost::sparse_ns(p) >= dense)
            {
                *pattern = None;
            }
        }
        layout
    }

    /// Every block of at least `sparse_from_rows` rows sparse (as in
    /// [`BlockLayout::new`]), whatever it costs: for tests and timings.
    pub fn with_sparse_from(
        size: usize,
        blocks: &[Vec<usize>],
        coupled: &[(usize, usize)],
        sparse_from_rows: usize,
    ) -> Self {
        let mut layout = BlockLayout::dense(size, blocks);
        let sparse = |rows: &Vec<usize>| !rows.is_empty() && rows.len() >= sparse_from_rows;
        if !blocks.iter().any(sparse) {
            return layout;
        }
        let place = placement(size, blocks);
        let mut entries: Vec<Vec<(usize, usize)>> = vec![Vec::new(); blocks.len()];
        for &(r, c) in coupled {
            if let (Some(&(br, i)), Some(&(bc, j))) = (place.get(r), place.get(c)) {
                if br == bc && br != usize::MAX && sparse(&blocks[br]) {
                    entries[br].push((i, j));
                }
            }
        }
        for (b, rows) in blocks.iter().enumerate() {
            if sparse(rows) {
                let local = std::mem::take(&mut entries[b]);
                layout.patterns[b] = BlockPattern::new(rows.len(), local).map(Arc::new);
            }
        }
        layout
    }

    /// Estimated time of assembling and factorising one matrix on this
    /// layout, ns (see [`cost`]): what a Newton iteration that
    /// refactorises costs beyond the residual.
    pub fn factorisation_cost_ns(&self) -> f64 {
        self.blocks
            .iter()
            .zip(&self.patterns)
            .map(|(rows, p)| match p {
                Some(p) => cost::sparse_ns(p),
                None => cost::dense_ns(rows.len()),
            })
            .sum()
    }

    /// Number of rows (and columns).
    pub fn size(&self) -> usize {
        self.size
    }

    /// The blocks of rows.
    pub fn blocks(&self) -> &[Vec<usize>] {
        &self.blocks
    }

    /// The pattern of block `b`, if it is sparse.
    pub fn pattern(&self, b: usize) -> Option<&BlockPattern> {
        self.patterns.get(b).and_then(|p| p.as_deref())
    }
}

/// Per global row: its block and its index there (`usize::MAX` for a row
/// in no block).
fn placement(size: usize, blocks: &[Vec<usize>]) -> Vec<(usize, usize)> {
    let mut place = vec![(usize::MAX, usize::MAX); size];
    for (b, rows) in blocks.iter().enumerate() {
        for (i, &r) in rows.iter().enumerate() {
            if let Some(p) = place.get_mut(r) {
                *p = (b, i);
            }
        }
    }
    place
}

/// Anything a stiffness matrix can be assembled into, entry by entry or
/// three by three (the rows of two nodes).
pub trait MatrixAssembly {
    /// Adds `value` to entry (`row`, `col`).
    fn add(&mut self, row: usize, col: usize, value: f64);

    /// Adds `block[(a, b)]` to entry (`rows[a]`, `cols[b]`) for every
    /// `a`, `b` whose row and column are `Some`.
    fn add_3x3(
        &mut self,
        rows: &[Option<usize>; 3],
        cols: &[Option<usize>; 3],
        block: &Matrix3<f64>,
    ) {
        for (a, r) in rows.iter().enumerate() {
            let Some(r) = r else { continue };
            for (b, c) in cols.iter().enumerate() {
                if let Some(c) = c {
                    self.add(*r, *c, block[(a, b)]);
                }
            }
        }
    }

    /// Adds a two-node element's `block` (the stiffness on `x_b − x_a`):
    /// `+block` on the (a, a) and (b, b) entries, `−block` on (a, b) and
    /// (b, a), where `a` and `b` are the nodes' rows.
    fn add_pair(&mut self, a: &[Option<usize>; 3], b: &[Option<usize>; 3], block: &Matrix3<f64>) {
        self.add_3x3(a, a, block);
        self.add_3x3(b, b, block);
        self.add_3x3(a, b, &-block);
        self.add_3x3(b, a, &-block);
    }
}

impl MatrixAssembly for DMatrix<f64> {
    fn add(&mut self, row: usize, col: usize, value: f64) {
        self[(row, col)] += value;
    }
}

/// One diagonal block: its global rows (in order) and its dense values,
/// column-major with a column stride padded to whole 64-byte lines (so
/// that faer's SIMD kernels see aligned columns).
#[derive(Debug, Clone)]
pub(super) struct DenseBlock {
    pub(super) rows: Vec<usize>,
    pub(super) values: Vec<f64>,
    pub(super) stride: usize,
}

impl DenseBlock {
    fn zeros(rows: &[usize]) -> Self {
        let n = rows.len();
        let stride = n.div_ceil(8) * 8;
        DenseBlock {
            rows: rows.to_vec(),
            values: vec![0.0; stride * n],
            stride,
        }
    }

    /// Number of rows (and columns).
    pub(super) fn dim(&self) -> usize {
        self.rows.len()
    }

    /// Index of entry (`i`, `j`) in `values`.
    #[inline]
    pub(super) fn at(&self, i: usize, j: usize) -> usize {
        i + j * self.stride
    }

    pub(super) fn as_ref(&self) -> MatRef<'_, f64> {
        let n = self.dim();
        MatRef::from_column_major_slice_with_stride(&self.values, n, n, self.stride.max(1))
    }

    pub(super) fn as_mut(&mut self) -> MatMut<'_, f64> {
        let n = self.dim();
        let stride = self.stride.max(1);
        MatMut::from_column_major_slice_with_stride_mut(&mut self.values, n, n, stride)
    }
}

/// One diagonal block, dense or sparse.
#[derive(Debug, Clone)]
pub(super) enum Block {
    Dense(DenseBlock),
    Sparse(SparseBlock),
}

impl Block {
    fn rows(&self) -> &[usize] {
        match self {
            Block::Dense(b) => &b.rows,
            Block::Sparse(b) => &b.rows,
        }
    }

    #[inline]
    fn add(&mut self, i: usize, j: usize, value: f64) {
        match self {
            Block::Dense(b) => {
                let at = b.at(i, j);
                b.values[at] += value;
            }
            Block::Sparse(b) => b.add(i, j, value),
        }
    }
}

/// A square matrix of diagonal blocks over given groups of rows.
#[derive(Debug, Clone)]
pub struct BlockMatrix {
    /// Per global row: its block and its index there (`usize::MAX` for a
    /// row in no block, whose entries are dropped).
    place: Vec<(usize, usize)>,
    pub(super) blocks: Vec<Block>,
}

impl BlockMatrix {
    /// A zero matrix of `size` rows on the given blocks of rows (disjoint,
    /// each row below `size`; see [`super::FreeDofs::blocks`]), all dense.
    /// Entries added between two different blocks, or on a row in no
    /// block, are dropped: the blocks must cover every coupling.
    pub fn zeros(size: usize, blocks: &[Vec<usize>]) -> Self {
        BlockMatrix::zeros_on(&BlockLayout::dense(size, blocks))
    }

    /// A zero matrix on `layout`. Its sparse blocks refuse to factorise
    /// after an entry outside their pattern was added (a pattern must hold
    /// every entry that can be nonzero).
    pub fn zeros_on(layout: &BlockLayout) -> Self {
        BlockMatrix {
            place: placement(layout.size, &layout.blocks),
            blocks: layout
                .blocks
                .iter()
                .zip(&layout.patterns)
                .map(|(rows, pattern)| match pattern {
                    Some(p) => Block::Sparse(SparseBlock::zeros(rows, Arc::clone(p))),
                    None => Block::Dense(DenseBlock::zeros(rows)),
                })
                .collect(),
        }
    }

    /// The blocks of `k` (entries between blocks dropped), all dense.
    pub fn from_dense(k: &DMatrix<f64>, blocks: &[Vec<usize>]) -> Self {
        BlockMatrix::from_dense_on(k, &BlockLayout::dense(k.nrows(), blocks))
    }

    /// The blocks of `k` on `layout` (entries between blocks, and nonzero
    /// entries outside a sparse block's pattern, dropped).
    pub fn from_dense_on(k: &DMatrix<f64>, layout: &BlockLayout) -> Self {
        let mut m = BlockMatrix::zeros_on(layout);
        for block in &mut m.blocks {
            let rows = block.rows().to_vec();
            for (j, &c) in rows.iter().enumerate() {
                for (i, &r) in rows.iter().enumerate() {
                    let v = k[(r, c)];
                    if v != 0.0 {
                        block.add(i, j, v);
                    }
                }
            }
        }
        m
    }

    /// Number of rows (and columns).
    pub fn size(&self) -> usize {
        self.place.len()
    }

    /// Sets every entry to zero, keeping the storage.
    pub fn clear(&mut self) {
        for b in &mut self.blocks {
            match b {
                Block::Dense(b) => b.values.fill(0.0),
                Block::Sparse(b) => b.clear(),
            }
        }
    }

    /// Whether the blocks are those of `blocks` over `size` rows, all
    /// dense (so that the storage can be reused for them).
    pub fn has_layout(&self, size: usize, blocks: &[Vec<usize>]) -> bool {
        self.size() == size
            && self.blocks.len() == blocks.len()
            && self
                .blocks
                .iter()
                .zip(blocks)
                .all(|(b, r)| matches!(b, Block::Dense(d) if d.rows == *r))
    }

    /// Whether the storage is that of `layout` (same blocks, the same
    /// shared patterns), so that it can be reused for it.
    pub fn is_on(&self, layout: &BlockLayout) -> bool {
        self.size() == layout.size
            && self.blocks.len() == layout.blocks.len()
            && self
                .blocks
                .iter()
                .zip(layout.blocks.iter().zip(&layout.patterns))
                .all(|(b, (rows, pattern))| match (b, pattern) {
                    (Block::Dense(d), None) => d.rows == *rows,
                    (Block::Sparse(s), Some(p)) => s.rows == *rows && Arc::ptr_eq(&s.pattern, p),
                    _ => false,
                })
    }

    /// Whether any block is stored sparse.
    pub fn has_sparse_blocks(&self) -> bool {
        self.blocks.iter().any(|b| matches!(b, Block::Sparse(_)))
    }

    /// Entry (`row`, `col`); zero between blocks.
    pub fn get(&self, row: usize, col: usize) -> f64 {
        match (self.place.get(row), self.place.get(col)) {
            (Some(&(br, i)), Some(&(bc, j))) if br == bc && br != usize::MAX => {
                match &self.blocks[br] {
                    Block::Dense(b) => b.values[b.at(i, j)],
                    Block::Sparse(b) => b.get(i, j),
                }
            }
            _ => 0.0,
        }
    }
}

impl MatrixAssembly for BlockMatrix {
    fn add(&mut self, row: usize, col: usize, value: f64) {
        let (Some(&(br, i)), Some(&(bc, j))) = (self.place.get(row), self.place.get(col)) else {
            return;
        };
        if br == bc && br != usize::MAX {
            self.blocks[br].add(i, j, value);
        }
    }

    fn add_3x3(
        &mut self,
        rows: &[Option<usize>; 3],
        cols: &[Option<usize>; 3],
        block: &Matrix3<f64>,
    ) {
        let (rows, cols) = (self.placed(rows), self.placed(cols));
        self.add_placed(&rows, &cols, block, 1.0);
    }

    fn add_pair(&mut self, a: &[Option<usize>; 3], b: &[Option<usize>; 3], block: &Matrix3<f64>) {
        let (a, b) = (self.placed(a), self.placed(b));
        self.add_placed(&a, &a, block, 1.0);
        self.add_placed(&b, &b, block, 1.0);
        self.add_placed(&a, &b, block, -1.0);
        self.add_placed(&b, &a, block, -1.0);
    }
}

/// Where three global rows lie: (block, index in it), `None` for a row
/// not given or in no block.
type PlacedRows = [Option<(usize, usize)>; 3];

impl BlockMatrix {
    fn placed(&self, rows: &[Option<usize>; 3]) -> PlacedRows {
        rows.map(|r| {
            r.and_then(|r| self.place.get(r).copied())
                .filter(|(b, _)| *b != usize::MAX)
        })
    }

    /// Adds `sign·block` at placed rows and columns, within one block
    /// (entries between blocks are dropped).
    fn add_placed(
        &mut self,
        rows: &PlacedRows,
        cols: &PlacedRows,
        block: &Matrix3<f64>,
        sign: f64,
    ) {
        for (a, row) in rows.iter().enumerate() {
            let Some((br, i)) = *row else { continue };
            match self.blocks.get_mut(br) {
                Some(Block::Dense(target)) => {
                    for (c, col) in cols.iter().enumerate() {
                        if let Some((bc, j)) = *col {
                            if bc == br {
                                let at = target.at(i, j);
                                target.values[at] += sign * block[(a, c)];
                            }
                        }
                    }
                }
                Some(Block::Sparse(target)) => {
                    for (c, col) in cols.iter().enumerate() {
                        if let Some((bc, j)) = *col {
                            if bc == br {
                                target.add(i, j, sign * block[(a, c)]);
                            }
                        }
                    }
                }
                None => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assembly_lands_in_the_blocks_and_reads_back_as_dense() {
        let blocks = vec![vec![0, 2], vec![1]];
        let mut m = BlockMatrix::zeros(3, &blocks);
        let mut d = DMatrix::zeros(3, 3);
        for (r, c, v) in [
            (0, 0, 1.0),
            (0, 2, 2.0),
            (2, 0, 3.0),
            (1, 1, 4.0),
            (2, 2, 5.0),
        ] {
            m.add(r, c, v);
            d.add(r, c, v);
        }
        m.add(0, 0, 0.5);
        d.add(0, 0, 0.5);
        // Between blocks: dropped.
        m.add(0, 1, 9.0);
        for r in 0..3 {
            for c in 0..3 {
                assert_eq!(m.get(r, c), d[(r, c)], "({r}, {c})");
            }
        }
        let copy = BlockMatrix::from_dense(&d, &blocks);
        assert_eq!(copy.get(2, 0), 3.0);
        assert!(copy.has_layout(3, &blocks));
        m.clear();
        assert_eq!(m.get(2, 2), 0.0);
        // Three by three, as the dense default does it.
        let block = Matrix3::from_fn(|a, b| (3 * a + b) as f64 + 1.0);
        let (rows, cols) = ([Some(0), None, Some(2)], [Some(2), Some(0), Some(1)]);
        let mut d = DMatrix::zeros(3, 3);
        m.add_3x3(&rows, &cols, &block);
        d.add_3x3(&rows, &cols, &block);
        for r in 0..3 {
            for c in 0..3 {
                let expected = if r == 1 || c == 1 { 0.0 } else { d[(r, c)] };
                assert_eq!(m.get(r, c), expected, "({r}, {c})");
            }
        }
        assert_eq!(d[(0, 2)], 1.0);
    }
}
