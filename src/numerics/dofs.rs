//! Numbering of free degrees of freedom, and their grouping into blocks
//! that no element couples. Shared by the solver's tangent, the planner's
//! sensitivities and form finding, so that a row means the same DOF
//! everywhere.

use nalgebra::{DVector, Vector3};

/// Numbering of the free degrees of freedom: `index[node][axis]` is the
/// row of that DOF, `None` where the axis is fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeDofs {
    /// Row of each node's axis, or `None` for a supported axis.
    pub index: Vec<[Option<usize>; 3]>,
    /// Number of free DOFs.
    pub count: usize,
}

impl FreeDofs {
    /// Numbers the free DOFs node by node, x, y, z; `fixed[node][axis]`
    /// says which axes are supported.
    pub fn from_fixed<'a>(fixed: impl IntoIterator<Item = &'a [bool; 3]>) -> Self {
        let mut count = 0;
        let index = fixed
            .into_iter()
            .map(|f| {
                let mut row = [None; 3];
                for (a, slot) in row.iter_mut().enumerate() {
                    if !f[a] {
                        *slot = Some(count);
                        count += 1;
                    }
                }
                row
            })
            .collect();
        FreeDofs { index, count }
    }

    /// The free-DOF entries of per-node vectors.
    pub fn gather(&self, per_node: &[Vector3<f64>]) -> DVector<f64> {
        let mut v = DVector::zeros(self.count);
        for (i, rows) in self.index.iter().enumerate() {
            for (a, row) in rows.iter().enumerate() {
                if let Some(r) = row {
                    v[*r] = per_node[i][a];
                }
            }
        }
        v
    }

    /// `per_node += scale·v` on the free DOFs.
    pub fn scatter_add(&self, per_node: &mut [Vector3<f64>], v: &DVector<f64>, scale: f64) {
        for (i, rows) in self.index.iter().enumerate() {
            for (a, row) in rows.iter().enumerate() {
                if let Some(r) = row {
                    per_node[i][a] += scale * v[*r];
                }
            }
        }
    }

    /// Free DOFs grouped into blocks that no element couples: connected
    /// components of the free nodes joined by `edges` (node pairs; a node
    /// with no free DOF joins nothing), each block its nodes' free DOFs in
    /// order.
    pub fn blocks(&self, edges: impl IntoIterator<Item = [usize; 2]>) -> Vec<Vec<usize>> {
        let n = self.index.len();
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let free = |i: usize| self.index[i].iter().any(Option::is_some);
        for [a, b] in edges {
            if free(a) && free(b) {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                parent[ra] = rb;
            }
        }
        let mut block_of_root = vec![usize::MAX; n];
        let mut blocks: Vec<Vec<usize>> = Vec::new();
        for (i, rows) in self.index.iter().enumerate() {
            for row in rows.iter().flatten() {
                let r = root(&mut parent, i);
                if block_of_root[r] == usize::MAX {
                    block_of_root[r] = blocks.len();
                    blocks.push(Vec::new());
                }
                blocks[block_of_root[r]].push(*row);
            }
        }
        blocks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbering_skips_fixed_axes_and_blocks_split_at_supports() {
        // 0 fixed, 1 free, 2 fixed, 3 free: chain 1–2–3 is cut at node 2.
        let fixed = [[true; 3], [false; 3], [true; 3], [false, true, false]];
        let dofs = FreeDofs::from_fixed(&fixed);
        assert_eq!(dofs.count, 5);
        assert_eq!(dofs.index[3], [Some(3), None, Some(4)]);
        let blocks = dofs.blocks([[0, 1], [1, 2], [2, 3]]);
        assert_eq!(blocks, vec![vec![0, 1, 2], vec![3, 4]]);
        let mut x = vec![Vector3::zeros(); 4];
        dofs.scatter_add(&mut x, &DVector::from_vec(vec![1., 2., 3., 4., 5.]), 2.0);
        assert_eq!(
            dofs.gather(&x),
            DVector::from_vec(vec![2., 4., 6., 8., 10.])
        );
    }
}
