//! Finite-element bodies (beams, imported super-elements): full mass and
//! stiffness matrices with a node map, and the rows that express a point of
//! the body (a node plus a rigid offset) in the body's (reduced) DOFs.
#![allow(non_snake_case)]

use super::rigid::offset_map;
use super::sparse::Csc;
use faer::Mat;

/// One FE node: an id, its position (m) and the matrix rows of its DOFs
/// (x, y, z, rx, ry, rz); rotations are `None` for translational-only nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct FeNode {
    pub id: u64,
    pub position: [f64; 3],
    pub dofs: [Option<usize>; 6],
}

/// Full FE matrices of one body, sparse (both triangles stored).
#[derive(Debug, Clone)]
pub struct FeBody {
    pub M: Csc,
    pub K: Csc,
    pub nodes: Vec<FeNode>,
}

impl FeBody {
    /// Number of DOFs (matrix rows).
    pub fn n(&self) -> usize {
        self.M.n
    }

    /// Index in `nodes` of the node with this id.
    pub fn node_index(&self, id: u64) -> Option<usize> {
        self.nodes.iter().position(|n| n.id == id)
    }

    /// Index of the node nearest to `p` (ties: lowest index).
    pub fn nearest_node(&self, p: [f64; 3]) -> usize {
        let mut best = (0, f64::INFINITY);
        for (i, n) in self.nodes.iter().enumerate() {
            let d: f64 = (0..3).map(|k| (n.position[k] - p[k]).powi(2)).sum();
            if d < best.1 {
                best = (i, d);
            }
        }
        best.0
    }

    /// Matrix rows (full DOF numbering) of node `index`.
    pub fn node_dofs(&self, index: usize) -> Vec<usize> {
        self.nodes[index].dofs.iter().flatten().copied().collect()
    }

    /// 6 × n_full rows giving the 6 DOFs of the point at `offset` from node
    /// `index` (u_p = u_n + θ_n × offset). Rotational rows of a
    /// translational-only node are zero.
    pub fn point_rows(&self, index: usize, offset: [f64; 3]) -> Mat<f64> {
        let n = self.n();
        let T = offset_map(offset);
        let dofs = self.nodes[index].dofs;
        Mat::from_fn(6, n, |i, col| {
            (0..6)
                .filter(|&j| dofs[j] == Some(col))
                .map(|j| T[i][j])
                .sum()
        })
    }
}
