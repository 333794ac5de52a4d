//! Marginal covariances at the current linearisation (notes §1): the block of `H⁻¹`
//! (H = JᵀΩJ over the free variables) for a variable, obtained without a selected inverse by
//! solving `H X = E` for the variable's unit columns `E` with the sparse Cholesky factor.
//!
//! Cost: one numeric factorisation, then O(nnz(L)) per right-hand-side column. Covariances are
//! in the variable's tangent (poses: body frame, ξ = (δt, δφ)); fixed variables have zero
//! covariance (they are the gauge anchor).

use faer::MatMut;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::Llt;
use nalgebra::DMatrix;

use super::factors::FactorError;
use super::graph::FactorGraph;
use super::linear_system::{LinearSystem, SolveError};
use super::values::{Values, VarId};

/// Right-hand sides solved at once (bounds memory at n × 64 doubles).
const RHS_CHUNK: usize = 64;

#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum MarginalError {
    #[error(transparent)]
    Factor(#[from] FactorError),
    #[error(transparent)]
    Solve(#[from] SolveError),
}

/// The factorised information matrix of a problem, ready for covariance queries.
pub struct Marginals {
    system: LinearSystem,
    llt: Llt<usize, f64>,
    dims: Vec<usize>,
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
        let llt = system.factorize(0.0)?;
        let dims = values.iter().map(|(_, v)| v.dim()).collect();
        Ok(Self { system, llt, dims })
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
        let mut out = Vec::with_capacity(ids.len());
        for id in ids {
            let d = *self.dims.get(id.0).ok_or(SolveError::UnknownVariable(*id))?;
            out.push(DMatrix::zeros(d, d));
        }
        // Columns to solve: (output index, column in H, local column).
        let mut cols: Vec<(usize, usize, usize)> = Vec::new();
        for (k, id) in ids.iter().enumerate() {
            if let Some(c) = self.system.column_of(*id) {
                for j in 0..self.dims[id.0] {
                    cols.push((k, c, j));
                }
            }
        }
        let mut rhs = Vec::new();
        for chunk in cols.chunks(RHS_CHUNK) {
            rhs.clear();
            rhs.resize(n * chunk.len(), 0.0);
            for (m, &(_, c, j)) in chunk.iter().enumerate() {
                rhs[m * n + c + j] = 1.0;
            }
            self.llt.solve_in_place(MatMut::from_column_major_slice_mut(rhs.as_mut_slice(), n, chunk.len()));
            for (m, &(k, c, j)) in chunk.iter().enumerate() {
                let d = out[k].nrows();
                for i in 0..d {
                    out[k][(i, j)] = rhs[m * n + c + i];
                }
            }
        }
        // Symmetrise (the solve is symmetric to rounding).
        for m in &mut out {
            let t = m.transpose();
            *m = (&*m + t) * 0.5;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::factors::fixtures::se3;
    use crate::slam::factors::{BetweenSe2, BetweenSe3, GaussianNoise, PointObservation3, PriorSe3};
    use crate::slam::lie::Se2;
    use crate::slam::values::Variable;
    use nalgebra::{Matrix6, Vector3};

    fn assert_matches_dense_inverse(graph: &FactorGraph, values: &Values, ids: &[VarId]) {
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
        assert_matches_dense_inverse(&graph, &values, &ids);
    }

    #[test]
    fn se3_poses_and_landmarks_match_dense_inverse() {
        let mut values = Values::new();
        let mut graph = FactorGraph::new();
        let a = Matrix6::from_fn(|i, j| ((i * 5 + j) as f64).sin());
        let noise6 = GaussianNoise::from_information(&(a * a.transpose() + Matrix6::identity() * 5.0)).unwrap();
        let noise3 = GaussianNoise::isotropic(3, 0.2).unwrap();
        let poses: Vec<VarId> = (0..4).map(|k| values.push(Variable::Se3(se3([k as f64, 0.2, 0.0], [0.0, 0.1, 0.3 * k as f64])))).collect();
        let lms: Vec<VarId> = (0..3).map(|k| values.push(Variable::Point3(Vector3::new(k as f64, 3.0, 1.0)))).collect();
        graph.add(PriorSe3::new(poses[0], se3([0.0; 3], [0.0; 3]), noise6)).unwrap();
        for k in 0..3 {
            graph.add(BetweenSe3::new(poses[k], poses[k + 1], se3([1.0, 0.0, 0.1], [0.0, 0.0, 0.3]), noise6)).unwrap();
        }
        for (k, &p) in poses.iter().enumerate() {
            for (j, &l) in lms.iter().enumerate() {
                if (k + j) % 2 == 0 || k == 3 {
                    let z = Vector3::new(1.0 + j as f64, 2.0, 0.5 * k as f64);
                    graph.add(PointObservation3::new(p, l, z, noise3)).unwrap();
                }
            }
        }
        let all: Vec<VarId> = poses.iter().chain(&lms).copied().collect();
        assert_matches_dense_inverse(&graph, &values, &all);
        // Anchored instead of prior: the first pose is fixed, its covariance zero.
        values.set_fixed(poses[0], true);
        assert_matches_dense_inverse(&graph, &values, &all);
    }
}
