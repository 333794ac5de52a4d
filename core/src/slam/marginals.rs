//! Marginal covariances at the current linearisation (notes §1): the block of `H⁻¹`
//! (H = JᵀΩJ over the free variables) for a variable, without a selected inverse.
//!
//! With faer's fill-reducing permutation P and factor P H Pᵀ = L Lᵀ,
//! `H⁻¹ = Pᵀ L⁻ᵀ L⁻¹ P`, so the block of the variable with columns c..c+d is the Gram matrix
//! `Σ_ab = y_aᵀ y_b` of `y_a = L⁻¹ P e_(c+a)`: forward solves only. And `L⁻¹` applied to a unit
//! vector is nonzero only on the elimination-tree path from its column to the root, so each
//! forward solve visits only the (super)nodes of that path, not all of L (Gilbert–Peierls
//! reach). faer's simplicial factor is the special case of one-column nodes.
//!
//! Cost: one numeric factorisation, then per variable O(d · Σ over its path of the nodes'
//! entries), typically far below the O(d · nnz(L)) of a full solve. Covariances are in the
//! variable's tangent (poses: body frame, ξ = (δt, δφ)); fixed variables have zero covariance
//! (they are the gauge anchor). Symmetric by construction.

use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
use nalgebra::DMatrix;

use super::factors::FactorError;
use super::graph::FactorGraph;
use super::linear_system::{LinearSystem, SolveError};
use super::values::{Values, VarId};

#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum MarginalError {
    #[error(transparent)]
    Factor(#[from] FactorError),
    #[error(transparent)]
    Solve(#[from] SolveError),
}

/// One node of the factor: columns `start..start + size` of L (one column when simplicial, a
/// supernode otherwise), their rows below the node (`pattern`, in the permuted order) and the
/// values, column-major `(size + pattern.len()) × size` (the lower-triangular top block, then the
/// pattern rows).
#[derive(Clone, Copy)]
struct Node<'a> {
    start: usize,
    size: usize,
    pattern: &'a [usize],
    values: &'a [f64],
}

/// The factorised information matrix of a problem, ready for covariance queries.
pub struct Marginals {
    system: LinearSystem,
    dims: Vec<usize>,
    /// Per permuted column, its node.
    node_of: Vec<usize>,
    /// Per node, its parent in the elimination tree (`usize::MAX` at a root).
    parent: Vec<usize>,
}

impl core::fmt::Debug for Marginals {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Marginals").field("n", &self.system.dim()).finish()
    }
}

impl Marginals {
    /// Linearises `graph` at `values` (fixed flags respected) and factorises H.
    pub fn new(graph: &FactorGraph, values: &Values) -> Result<Self, MarginalError> {
        let mut system = LinearSystem::new(graph, values)?;
        system.linearize(graph, values)?;
        system.factorize(0.0)?;
        let dims = values.iter().map(|(_, v)| v.dim()).collect();
        let mut m = Self { system, dims, node_of: Vec::new(), parent: Vec::new() };
        let count = m.node_count();
        let mut node_of = vec![0; m.system.dim()];
        let mut parent = vec![usize::MAX; count];
        for s in 0..count {
            let node = m.node(s);
            node_of[node.start..node.start + node.size].fill(s);
        }
        for (s, p) in parent.iter_mut().enumerate() {
            // The parent holds the node's first pattern row (patterns list the rows above in
            // the tree, so their smallest belongs to the parent).
            if let Some(&row) = m.node(s).pattern.iter().min() {
                *p = node_of[row];
            }
        }
        (m.node_of, m.parent) = (node_of, parent);
        Ok(m)
    }

    /// Whether faer chose its supernodal factor (tests cover both layouts).
    #[cfg(test)]
    fn is_supernodal(&self) -> bool {
        matches!(self.system.factor_parts().0.raw(), SymbolicCholeskyRaw::Supernodal(_))
    }

    fn node_count(&self) -> usize {
        match self.system.factor_parts().0.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => s.ncols(),
            SymbolicCholeskyRaw::Supernodal(s) => s.n_supernodes(),
        }
    }

    fn node(&self, s: usize) -> Node<'_> {
        let (symbolic, values) = self.system.factor_parts();
        match symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(sym) => {
                // Column s: the diagonal first, then the rows below it.
                let l = sym.factor();
                let range = l.col_ptr()[s]..l.col_ptr()[s + 1];
                Node { start: s, size: 1, pattern: &l.row_idx()[range.start + 1..range.end], values: &values[range] }
            }
            SymbolicCholeskyRaw::Supernodal(sym) => {
                let (start, end) = (sym.supernode_begin()[s], sym.supernode_end()[s]);
                let rows = sym.col_ptr_for_row_idx()[s];
                let pattern = &sym.row_idx()[rows..rows + sym.nnz_per_super()[s]];
                let vals = sym.col_ptr_for_val()[s]..sym.col_ptr_for_val()[s + 1];
                Node { start, size: end - start, pattern, values: &values[vals] }
            }
        }
    }

    /// The information matrix as dense (small problems and tests only).
    pub fn dense_information(&self) -> DMatrix<f64> {
        self.system.dense_hessian()
    }

    /// The d×d marginal covariance of one variable.
    pub fn covariance(&self, id: VarId) -> Result<DMatrix<f64>, MarginalError> {
        Ok(self.covariances(&[id])?.pop().unwrap_or_else(|| DMatrix::zeros(0, 0)))
    }

    /// Marginal covariances of several variables (each its own d×d block).
    pub fn covariances(&self, ids: &[VarId]) -> Result<Vec<DMatrix<f64>>, MarginalError> {
        let n = self.system.dim();
        let inv = self.system.factor_parts().0.perm().map(|p| p.arrays().1);
        let max_d = self.dims.iter().copied().max().unwrap_or(0);
        // Workspace: max_d right-hand sides of length n, zero outside the current path.
        let mut x = vec![0.0; n * max_d];
        let mut on_path = vec![false; self.parent.len()];
        let mut path = Vec::new();
        let mut out = Vec::with_capacity(ids.len());
        for id in ids {
            let d = *self.dims.get(id.0).ok_or(SolveError::UnknownVariable(*id))?;
            let mut cov = DMatrix::zeros(d, d);
            let Some(c) = self.system.column_of(*id) else {
                out.push(cov);
                continue;
            };
            // y_a = L⁻¹ P e_(c+a): the unit entry sits at the permuted position of c + a.
            path.clear();
            for a in 0..d {
                let k = inv.map_or(c + a, |inv| inv[c + a]);
                x[a * n + k] = 1.0;
                let mut s = self.node_of[k];
                while s != usize::MAX && !on_path[s] {
                    on_path[s] = true;
                    path.push(s);
                    s = self.parent[s];
                }
            }
            // Children before parents: node indices are a topological order of the tree.
            path.sort_unstable();
            for &s in &path {
                let node = self.node(s);
                for y in x.chunks_exact_mut(n).take(d) {
                    forward_node(&node, y);
                }
            }
            for &s in &path {
                let node = self.node(s);
                for r in node.start..node.start + node.size {
                    for a in 0..d {
                        let xa = x[a * n + r];
                        if xa != 0.0 {
                            for b in 0..=a {
                                cov[(a, b)] += xa * x[b * n + r];
                            }
                        }
                    }
                    for a in 0..d {
                        x[a * n + r] = 0.0;
                    }
                }
                on_path[s] = false;
            }
            for a in 0..d {
                for b in 0..a {
                    cov[(b, a)] = cov[(a, b)];
                }
            }
            out.push(cov);
        }
        Ok(out)
    }
}

/// One node's part of the forward solve `L y = b`: solves the node's lower-triangular top block
/// for its rows of `y`, then subtracts their contribution from the pattern rows.
fn forward_node(node: &Node, y: &mut [f64]) {
    let (start, size) = (node.start, node.size);
    let rows = size + node.pattern.len();
    for j in 0..size {
        let col = &node.values[j * rows..(j + 1) * rows];
        let yj = y[start + j] / col[j];
        y[start + j] = yj;
        if yj == 0.0 {
            continue;
        }
        for i in j + 1..size {
            y[start + i] -= col[i] * yj;
        }
        for (p, &row) in node.pattern.iter().enumerate() {
            y[row] -= col[size + p] * yj;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::factors::fixtures::se3;
    use crate::slam::factors::{BetweenSe2, BetweenSe3, GaussianNoise, PointObservation3, PriorSe3};
    use crate::slam::lie::{Se2, Se3};
    use crate::slam::values::Variable;
    use nalgebra::{Matrix6, Vector3};

    /// Checks every block against the dense inverse; returns whether the factor was supernodal.
    fn assert_matches_dense_inverse(graph: &FactorGraph, values: &Values, ids: &[VarId]) -> bool {
        let marginals = Marginals::new(graph, values).unwrap();
        let h = marginals.dense_information();
        let inv = h.clone().try_inverse().unwrap();
        let covs = marginals.covariances(ids).unwrap();
        let mut col = 0;
        let mut offsets = Vec::new();
        for (id, v) in values.iter() {
            offsets.push(if values.is_fixed(id) { usize::MAX } else { col });
            if !values.is_fixed(id) {
                col += v.dim();
            }
        }
        for (id, cov) in ids.iter().zip(&covs) {
            let d = cov.nrows();
            if offsets[id.0] == usize::MAX {
                assert_eq!(cov.amax(), 0.0, "fixed variable has zero covariance");
                continue;
            }
            let block = inv.view((offsets[id.0], offsets[id.0]), (d, d));
            let rel = (cov - block).amax() / block.amax();
            assert!(rel < 1e-9, "{id:?}: relative difference {rel:e}");
        }
        marginals.is_supernodal()
    }

    #[test]
    fn se2_chain_with_loop_matches_dense_inverse() {
        // A square loop of 6 poses, odometry plus one loop closure, first pose fixed.
        let mut values = Values::new();
        let mut graph = FactorGraph::new();
        let info = nalgebra::Matrix3::new(50.0, 5.0, 1.0, 5.0, 30.0, 2.0, 1.0, 2.0, 200.0);
        let noise = GaussianNoise::from_information(&info).unwrap();
        let ids: Vec<VarId> =
            (0..6).map(|k| values.push(Variable::Se2(Se2::new(k as f64 * 0.9, 0.1 * k as f64, 0.2 * k as f64)))).collect();
        for k in 0..5 {
            graph.add(BetweenSe2::new(ids[k], ids[k + 1], Se2::new(1.0, 0.0, 0.3), noise)).unwrap();
        }
        graph.add(BetweenSe2::new(ids[0], ids[5], Se2::new(3.0, 2.0, 1.4), noise)).unwrap();
        values.set_fixed(ids[0], true);
        assert!(!assert_matches_dense_inverse(&graph, &values, &ids), "simplicial factor");
    }

    /// SE(3) poses on a prior-anchored odometry chain, point landmarks, and an observation of
    /// landmark j from pose k wherever `sees(k, j)`; `info6` is the odometry and prior information.
    fn pose_chain_with_landmarks(
        poses: &[Se3],
        landmarks: &[Vector3<f64>],
        info6: Matrix6<f64>,
        sigma_point_m: f64,
        sees: impl Fn(usize, usize) -> bool,
    ) -> (FactorGraph, Values, Vec<VarId>, Vec<VarId>) {
        let mut values = Values::new();
        let mut graph = FactorGraph::new();
        let noise6 = GaussianNoise::from_information(&info6).unwrap();
        let noise3 = GaussianNoise::isotropic(3, sigma_point_m).unwrap();
        let pose_ids: Vec<VarId> = poses.iter().map(|&p| values.push(Variable::Se3(p))).collect();
        let lm_ids: Vec<VarId> = landmarks.iter().map(|&l| values.push(Variable::Point3(l))).collect();
        graph.add(PriorSe3::new(pose_ids[0], se3([0.0; 3], [0.0; 3]), noise6)).unwrap();
        for k in 1..poses.len() {
            let step = se3([1.0, 0.1 * k as f64, 0.1], [0.0, 0.0, 0.3]);
            graph.add(BetweenSe3::new(pose_ids[k - 1], pose_ids[k], step, noise6)).unwrap();
        }
        for (k, &p) in pose_ids.iter().enumerate() {
            for (j, &l) in lm_ids.iter().enumerate() {
                if sees(k, j) {
                    let z = Vector3::new(1.0 + 0.1 * j as f64, 2.0 - 0.05 * k as f64, 0.5);
                    graph.add(PointObservation3::new(p, l, z, noise3)).unwrap();
                }
            }
        }
        (graph, values, pose_ids, lm_ids)
    }

    #[test]
    fn se3_poses_and_landmarks_match_dense_inverse() {
        let a = Matrix6::from_fn(|i, j| ((i * 5 + j) as f64).sin());
        let poses: Vec<Se3> = (0..4).map(|k| se3([k as f64, 0.2, 0.0], [0.0, 0.1, 0.3 * k as f64])).collect();
        let lms: Vec<Vector3<f64>> = (0..3).map(|k| Vector3::new(k as f64, 3.0, 1.0)).collect();
        let info6 = a * a.transpose() + Matrix6::identity() * 5.0;
        let (graph, mut values, poses, lms) = pose_chain_with_landmarks(&poses, &lms, info6, 0.2, |k, j| (k + j) % 2 == 0 || k == 3);
        let all: Vec<VarId> = poses.iter().chain(&lms).copied().collect();
        assert!(!assert_matches_dense_inverse(&graph, &values, &all), "simplicial factor");
        // Anchored instead of prior: the first pose is fixed, its covariance zero.
        values.set_fixed(poses[0], true);
        assert!(!assert_matches_dense_inverse(&graph, &values, &all), "simplicial factor");
    }

    #[test]
    fn supernodal_factor_matches_dense_inverse() {
        // 40 SE(3) poses on a chain with a loop, 30 landmarks each seen from most poses: dense
        // enough that faer factorises supernodally (asserted), with several supernodes.
        let a = Matrix6::from_fn(|i, j| ((i * 7 + j) as f64).cos());
        let poses: Vec<Se3> = (0..40).map(|k| se3([0.3 * k as f64, (0.2 * k as f64).sin(), 0.0], [0.0, 0.05, 0.1 * k as f64])).collect();
        let lms: Vec<Vector3<f64>> = (0..30).map(|j| Vector3::new(0.4 * j as f64, 3.0 + (j % 3) as f64, 1.0)).collect();
        let info6 = a * a.transpose() + Matrix6::identity() * 3.0;
        let (mut graph, values, poses, lms) = pose_chain_with_landmarks(&poses, &lms, info6, 0.3, |k, j| (k * 7 + j * 3) % 5 != 0);
        let noise6 = GaussianNoise::from_information(&info6).unwrap();
        graph.add(BetweenSe3::new(poses[0], poses[39], se3([11.0, 0.5, 0.0], [0.0, 0.0, 3.9]), noise6)).unwrap();
        let all: Vec<VarId> = poses.iter().chain(&lms).copied().collect();
        assert!(assert_matches_dense_inverse(&graph, &values, &all), "supernodal factor");
        let m = Marginals::new(&graph, &values).unwrap();
        assert!(m.node_count() > 1, "several supernodes: {}", m.node_count());
    }
}
