//! The N×N cable net of the peer benchmark (`scripts/peer-benchmark/`):
//! a square grid of tension-only cables pinned on its perimeter, a load
//! on every free node. Its stiffness is that of a membrane, so the
//! tangent is sparse (five nodes per row) where the bridge's halves are
//! dense: the structure that tells the sparse and dense factorisations,
//! and Newton and DR, apart.

use nalgebra::Vector3;

use crate::model::{Member, MemberKind, Node, Structure, StructureError};

/// The net's parameters; the defaults are the peer benchmark's.
#[derive(Debug, Clone, PartialEq)]
pub struct SquareNetParameters {
    /// Nodes per side (the perimeter's are pinned). Default 7.
    pub nodes_per_side: usize,
    /// Grid spacing, m. Default 1.
    pub spacing_m: f64,
    /// Axial stiffness of every cable, N. Default 1 256 636 N: π·(2 mm)²
    /// at 100 GPa, the peer benchmark's.
    pub ea_n: f64,
    /// Rest length over the grid spacing, 1. Default 0.998: prestressed
    /// when flat, so the flat tangent is positive definite.
    pub rest_length_ratio: f64,
    /// Vertical load on every free node, N (negative: down). Default
    /// −1000 N.
    pub free_node_load_n: f64,
}

impl Default for SquareNetParameters {
    fn default() -> Self {
        SquareNetParameters {
            nodes_per_side: 7,
            spacing_m: 1.0,
            ea_n: 1_256_636.0,
            rest_length_ratio: 0.998,
            free_node_load_n: -1000.0,
        }
    }
}

/// The flat net of `p`: node `i + n·j` at `(i, j, 0)·spacing`, cables
/// between grid neighbours, in row order.
pub fn square_net(p: &SquareNetParameters) -> Result<Structure, StructureError> {
    let n = p.nodes_per_side;
    let mut nodes = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let edge = i == 0 || j == 0 || i + 1 == n || j + 1 == n;
            nodes.push(Node {
                id: format!("n{i}_{j}"),
                position_m: Vector3::new(i as f64, j as f64, 0.0) * p.spacing_m,
                mass_kg: 0.0,
                fixed: [edge; 3],
                load_n: Vector3::new(0.0, 0.0, if edge { 0.0 } else { p.free_node_load_n }),
            });
        }
    }
    let mut members = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let k = j * n + i;
            for (other, exists) in [(k + 1, i + 1 < n), (k + n, j + 1 < n)] {
                if exists {
                    members.push(Member {
                        id: format!("c{}", members.len()),
                        kind: MemberKind::Cable { ea_n: p.ea_n },
                        nodes: [k, other],
                        rest_length_m: p.rest_length_ratio * p.spacing_m,
                    });
                }
            }
        }
    }
    Structure::new(
        format!("cable net {n}x{n}"),
        nodes,
        members,
        vec![],
        Vector3::zeros(),
        vec![],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An N×N grid has 2·N·(N − 1) cables and (N − 2)² free nodes.
    #[test]
    fn the_net_has_the_grids_counts() {
        for n in [3, 5, 11] {
            let s = square_net(&SquareNetParameters {
                nodes_per_side: n,
                ..Default::default()
            })
            .unwrap();
            assert_eq!(s.members.len(), 2 * n * (n - 1));
            let free = s.nodes.iter().filter(|node| !node.fixed[0]).count();
            assert_eq!(free, (n - 2) * (n - 2));
        }
    }
}
