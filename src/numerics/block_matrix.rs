//! A square matrix stored as dense diagonal blocks, to assemble a tangent
//! straight into the pieces that [`super::BlockLu`] factorises: free DOFs
//! that no chain of members joins (the two halves of the bridge) never
//! couple, so the off-block entries are all zero and are not stored (two
//! 60×60 blocks instead of one 120×120 matrix, and no copying out).

use faer::{MatMut, MatRef};
use nalgebra::{DMatrix, Matrix3};

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

/// A square matrix of dense diagonal blocks over given groups of rows.
#[derive(Debug, Clone)]
pub struct BlockMatrix {
    /// Per global row: its block and its index there (`usize::MAX` for a
    /// row in no block, whose entries are dropped).
    place: Vec<(usize, usize)>,
    pub(super) blocks: Vec<DenseBlock>,
}

impl BlockMatrix {
    /// A zero matrix of `size` rows on the given blocks of rows (disjoint,
    /// each row below `size`; see [`super::FreeDofs::blocks`]). Entries
    /// added between two different blocks, or on a row in no block, are
    /// dropped: the blocks must cover every coupling.
    pub fn zeros(size: usize, blocks: &[Vec<usize>]) -> Self {
        let mut place = vec![(usize::MAX, usize::MAX); size];
        for (b, rows) in blocks.iter().enumerate() {
            for (i, &r) in rows.iter().enumerate() {
                if let Some(p) = place.get_mut(r) {
                    *p = (b, i);
                }
            }
        }
        BlockMatrix {
            place,
            blocks: blocks.iter().map(|rows| DenseBlock::zeros(rows)).collect(),
        }
    }

    /// The blocks of `k` (entries between blocks dropped).
    pub fn from_dense(k: &DMatrix<f64>, blocks: &[Vec<usize>]) -> Self {
        let mut m = BlockMatrix::zeros(k.nrows(), blocks);
        for block in &mut m.blocks {
            for j in 0..block.dim() {
                for i in 0..block.dim() {
                    let at = block.at(i, j);
                    block.values[at] = k[(block.rows[i], block.rows[j])];
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
            b.values.fill(0.0);
        }
    }

    /// Whether the blocks are those of `blocks` over `size` rows (so that
    /// the storage can be reused for them).
    pub fn has_layout(&self, size: usize, blocks: &[Vec<usize>]) -> bool {
        self.size() == size
            && self.blocks.len() == blocks.len()
            && self.blocks.iter().zip(blocks).all(|(b, r)| b.rows == *r)
    }

    /// Entry (`row`, `col`); zero between blocks.
    pub fn get(&self, row: usize, col: usize) -> f64 {
        match (self.place.get(row), self.place.get(col)) {
            (Some(&(br, i)), Some(&(bc, j))) if br == bc && br != usize::MAX => {
                let b = &self.blocks[br];
                b.values[b.at(i, j)]
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
            let b = &mut self.blocks[br];
            let at = b.at(i, j);
            b.values[at] += value;
        }
    }

    fn add_3x3(
        &mut self,
        rows: &[Option<usize>; 3],
        cols: &[Option<usize>; 3],
        block: &Matrix3<f64>,
    ) {
        let cols = cols.map(|c| c.and_then(|c| self.place.get(c).copied()));
        for (a, r) in rows.iter().enumerate() {
            let Some(&(br, i)) = r.and_then(|r| self.place.get(r)) else {
                continue;
            };
            let Some(target) = self.blocks.get_mut(br) else {
                continue;
            };
            for (c, col) in cols.iter().enumerate() {
                if let Some((bc, j)) = col {
                    if *bc == br {
                        let at = target.at(i, *j);
                        target.values[at] += block[(a, c)];
                    }
                }
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
