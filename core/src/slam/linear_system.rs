//! The sparse normal equations `H δ = −g` (H = Σ Jᵀ Ω J, g = Σ Jᵀ Ω e over the factors that
//! touch a free variable) in compressed-column form, upper triangle only, and their sparse
//! Cholesky solution with faer (AMD ordering; simplicial or supernodal, see [`Factorisation`]).
//!
//! The block structure and faer's symbolic factorisation are computed once per structure
//! (factor list + fixed flags) in O(nnz log nnz); every linearisation then writes into the same
//! value array without allocating (O(Σ_k (d_k · dim)²)), and every solve is one numeric
//! factorisation with the cached symbolic one.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{CholeskySymbolicParams, LltRef, SymbolicCholesky, factorize_symbolic_cholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Side};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::factors::{FactorError, Jacobian, MAX_FACTOR_KEYS};
use super::graph::FactorGraph;
use super::values::{Values, VarId};

/// Why the linearised system `H δ = −g` could not be solved (optimisers and marginals).
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SolveError {
    /// Every variable is fixed: there is nothing to solve for.
    #[error("the problem has no free variable")]
    NoFreeVariables,
    /// The Cholesky factorisation met a non-positive pivot: the problem has a gauge freedom (no
    /// variable fixed or anchored) or a variable no factor constrains enough.
    #[error("the normal equations are not positive definite (a gauge freedom or an unobserved variable?)")]
    NotPositiveDefinite,
    /// faer's sparse factorisation or solve failed for another reason (its message, e.g. out of
    /// memory for its workspace).
    #[error("sparse factorisation failed: {0}")]
    Faer(String),
    /// A marginal asked for a variable the problem does not have.
    #[error("variable {0:?} does not exist")]
    UnknownVariable(VarId),
}

const NONE: usize = usize::MAX;

/// Which of faer's two sparse Cholesky factorisations runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Factorisation {
    /// faer's choice by flop count: supernodal (dense blocks through SIMD kernels) when the
    /// fronts are large, simplicial otherwise. The fastest on large graphs, but the dense kernels
    /// pick SIMD width and FMA at run time, so the last bits of the factor depend on the CPU and
    /// differ in wasm.
    #[default]
    Fastest,
    /// Always simplicial: faer's up-looking factorisation and its solves are scalar arithmetic in
    /// a fixed order (Rust never contracts to FMA), so the factor and everything computed from it
    /// are the same bits on every CPU and in wasm. Slower on large graphs (docs/benchmarks.md, Mission;
    /// docs/decisions/0006).
    Reproducible,
}

/// Normal equations of one graph structure, reused across iterations.
#[derive(Debug)]
pub(crate) struct LinearSystem {
    generation: u64,
    fixed: Vec<bool>,
    dims: Vec<usize>,
    /// First scalar column of each variable, `NONE` when fixed.
    col_of_var: Vec<usize>,
    n: usize,
    /// Factors with at least one free key.
    active: Vec<usize>,
    /// Per active factor, per (p, q) key pair with col(p) ≤ col(q): row offset of block p inside
    /// the column block of q, or `NONE`.
    block_rowoff: Vec<[[usize; MAX_FACTOR_KEYS]; MAX_FACTOR_KEYS]>,
    symbolic: SymbolicSparseColMat<usize>,
    /// Index of each diagonal entry in `values`.
    diag_pos: Vec<usize>,
    /// faer's symbolic Cholesky of H (AMD ordering; simplicial or supernodal, [`Factorisation`]).
    cholesky: SymbolicCholesky<usize>,
    /// The numeric factor L of the last [`LinearSystem::factorize`], in `cholesky`'s layout.
    l_values: Vec<f64>,
    /// H (upper triangle), in `symbolic`'s layout.
    h: Vec<f64>,
    /// g = Jᵀ Ω e.
    g: Vec<f64>,
    scratch: Vec<f64>,
}

impl LinearSystem {
    /// Builds the structure for the current factors and fixed flags.
    pub fn new(graph: &FactorGraph, values: &Values, factorisation: Factorisation) -> Result<Self, SolveError> {
        let nv = values.len();
        let fixed = values.fixed_flags().to_vec();
        let dims: Vec<usize> = values.iter().map(|(_, v)| v.dim()).collect();
        let mut col_of_var = vec![NONE; nv];
        let mut n = 0;
        for v in 0..nv {
            if !fixed[v] {
                col_of_var[v] = n;
                n += dims[v];
            }
        }
        if n == 0 {
            return Err(SolveError::NoFreeVariables);
        }
        // Block pairs (column var, row var) with row ≤ column, including every diagonal.
        let mut pairs: Vec<(usize, usize)> = (0..nv).filter(|&v| !fixed[v]).map(|v| (v, v)).collect();
        let mut active = Vec::new();
        for fi in 0..graph.len() {
            let keys = graph.keys_of(fi);
            for k in keys {
                if k.0 >= nv {
                    return Err(SolveError::UnknownVariable(*k));
                }
            }
            // The factor's free variables, in a fixed-size buffer (the graph caps the keys).
            let mut free = [0usize; MAX_FACTOR_KEYS];
            let mut n_free = 0;
            for k in keys.iter().filter(|k| !fixed[k.0]) {
                free[n_free] = k.0;
                n_free += 1;
            }
            if n_free == 0 {
                continue;
            }
            active.push(fi);
            let free = &free[..n_free];
            for &a in free {
                for &b in free {
                    if a < b {
                        pairs.push((b, a));
                    }
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        // Row blocks of each column block (sorted by var, hence by column offset).
        let mut start = vec![0usize; nv + 1];
        for &(b, _) in &pairs {
            start[b + 1] += 1;
        }
        for v in 0..nv {
            start[v + 1] += start[v];
        }
        let rows_of = |b: usize| &pairs[start[b]..start[b + 1]];
        let rowoff = |a: usize, b: usize| -> usize {
            let list = rows_of(b);
            let idx = list.partition_point(|&(_, r)| r < a);
            list[..idx].iter().map(|&(_, r)| dims[r]).sum()
        };
        // Scalar CSC, upper triangle.
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut diag_pos = Vec::with_capacity(n);
        col_ptr.push(0usize);
        for b in 0..nv {
            if fixed[b] {
                continue;
            }
            for j in 0..dims[b] {
                for &(_, a) in rows_of(b) {
                    let ca = col_of_var[a];
                    let len = if a == b { j + 1 } else { dims[a] };
                    row_idx.extend(ca..ca + len);
                }
                diag_pos.push(row_idx.len() - 1);
                col_ptr.push(row_idx.len());
            }
        }
        let mut block_rowoff = Vec::with_capacity(active.len());
        for &fi in &active {
            let keys = graph.keys_of(fi);
            let mut table = [[NONE; MAX_FACTOR_KEYS]; MAX_FACTOR_KEYS];
            for (p, kp) in keys.iter().enumerate() {
                for (q, kq) in keys.iter().enumerate() {
                    let (a, b) = (kp.0, kq.0);
                    if !fixed[a] && !fixed[b] && a <= b {
                        table[p][q] = rowoff(a, b);
                    }
                }
            }
            block_rowoff.push(table);
        }
        let nnz = row_idx.len();
        let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let params = match factorisation {
            Factorisation::Fastest => CholeskySymbolicParams::default(),
            Factorisation::Reproducible => {
                CholeskySymbolicParams { supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL, ..Default::default() }
            }
        };
        let cholesky = factorize_symbolic_cholesky(symbolic.as_ref(), Side::Upper, Default::default(), params)
            .map_err(|e| SolveError::Faer(format!("{e:?}")))?;
        Ok(Self {
            generation: graph.generation(),
            fixed,
            dims,
            col_of_var,
            n,
            active,
            block_rowoff,
            symbolic,
            diag_pos,
            l_values: vec![0.0; cholesky.len_val()],
            cholesky,
            h: vec![0.0; nnz],
            g: vec![0.0; n],
            scratch: vec![0.0; nnz],
        })
    }

    /// Whether this structure is still the graph's and the values' (factors, variables, fixed).
    pub fn matches(&self, graph: &FactorGraph, values: &Values) -> bool {
        self.generation == graph.generation()
            && self.fixed.as_slice() == values.fixed_flags()
            && self.dims.len() == values.len()
            && values.iter().all(|(id, v)| self.dims[id.0] == v.dim())
    }

    /// Number of scalar unknowns.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// First scalar column of a free variable.
    pub(crate) fn column_of(&self, id: VarId) -> Option<usize> {
        self.col_of_var.get(id.0).copied().filter(|&c| c != NONE)
    }

    /// The diagonal of H.
    pub fn diagonal(&self) -> impl Iterator<Item = f64> + '_ {
        self.diag_pos.iter().map(|&p| self.h[p])
    }

    /// g = Jᵀ Ω e of the last linearisation.
    pub(crate) fn gradient(&self) -> &[f64] {
        &self.g
    }

    /// χ² over the active factors (those touching a free variable): the optimised cost.
    pub fn cost(&self, graph: &FactorGraph, values: &Values) -> Result<f64, FactorError> {
        let factors = graph.factors();
        self.active.iter().map(|&fi| factors[fi].chi2(values)).sum()
    }

    /// Fills H and g at `values`; returns the active χ².
    pub(crate) fn linearize(&mut self, graph: &FactorGraph, values: &Values) -> Result<f64, FactorError> {
        self.h.fill(0.0);
        self.g.fill(0.0);
        let factors = graph.factors();
        let mut jac = [Jacobian::zeros(); MAX_FACTOR_KEYS];
        let mut wj = [Jacobian::zeros(); MAX_FACTOR_KEYS];
        let mut chi2 = 0.0;
        let col_ptr = self.symbolic.col_ptr();
        for (slot, &fi) in self.active.iter().enumerate() {
            let f = &factors[fi];
            let e = f.linearize(values, &mut jac)?;
            let noise = f.noise();
            let d = noise.dim();
            let (r, row_scale, cost) = noise.linearized(&e);
            chi2 += cost;
            let keys = f.keys();
            for k in 0..keys.len() {
                wj[k] = noise.sqrt_information() * jac[k] * row_scale;
            }
            for (p, kp) in keys.iter().enumerate() {
                let ca = self.col_of_var[kp.0];
                if ca == NONE {
                    continue;
                }
                let da = self.dims[kp.0];
                for i in 0..da {
                    let mut s = 0.0;
                    for row in 0..d {
                        s += wj[p][(row, i)] * r[row];
                    }
                    self.g[ca + i] += s;
                }
                for (q, kq) in keys.iter().enumerate() {
                    let off = self.block_rowoff[slot][p][q];
                    if off == NONE {
                        continue;
                    }
                    let cb = self.col_of_var[kq.0];
                    let db = self.dims[kq.0];
                    let diag = kp == kq;
                    for j in 0..db {
                        let base = col_ptr[cb + j] + off;
                        let imax = if diag { j + 1 } else { da };
                        for i in 0..imax {
                            let mut s = 0.0;
                            for row in 0..d {
                                s += wj[p][(row, i)] * wj[q][(row, j)];
                            }
                            self.h[base + i] += s;
                        }
                    }
                }
            }
        }
        Ok(chi2)
    }

    /// Numeric Cholesky of `H + λ I` with the cached symbolic factorisation, kept for
    /// [`LinearSystem::factor_parts`] and the solves (the same faer calls as its high-level `Llt`).
    pub(crate) fn factorize(&mut self, lambda: f64) -> Result<(), SolveError> {
        self.scratch.copy_from_slice(&self.h);
        if lambda != 0.0 {
            for &p in &self.diag_pos {
                self.scratch[p] += lambda;
            }
        }
        let mat = SparseColMatRef::new(self.symbolic.as_ref(), &self.scratch);
        let par = faer::get_global_parallelism();
        let mut stack = MemBuffer::try_new(self.cholesky.factorize_numeric_llt_scratch::<f64>(par, Default::default()))
            .map_err(|e| SolveError::Faer(format!("{e:?}")))?;
        self.l_values.fill(0.0);
        self.cholesky
            .factorize_numeric_llt(
                &mut self.l_values,
                mat,
                Side::Upper,
                Default::default(),
                par,
                MemStack::new(&mut stack),
                Default::default(),
            )
            .map(|_| ())
            // The only error here is a non-positive pivot.
            .map_err(|_| SolveError::NotPositiveDefinite)
    }

    /// The factor of the last successful [`LinearSystem::factorize`].
    fn factor(&self) -> LltRef<'_, usize, f64> {
        LltRef::new(&self.cholesky, &self.l_values)
    }

    /// The factor of the last successful [`LinearSystem::factorize`]: faer's symbolic structure
    /// and the numeric values in its layout.
    pub(crate) fn factor_parts(&self) -> (&SymbolicCholesky<usize>, &[f64]) {
        (&self.cholesky, &self.l_values)
    }

    /// Solves `(H + λ I) δ = −g` into `delta` (length [`LinearSystem::dim`]).
    pub(crate) fn solve_step(&mut self, lambda: f64, delta: &mut Vec<f64>) -> Result<(), SolveError> {
        self.factorize(lambda)?;
        delta.clear();
        delta.extend(self.g.iter().map(|v| -v));
        let par = faer::get_global_parallelism();
        let mut stack =
            MemBuffer::try_new(self.cholesky.solve_in_place_scratch::<f64>(1, par)).map_err(|e| SolveError::Faer(format!("{e:?}")))?;
        self.factor().solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(delta.as_mut_slice(), self.n, 1),
            par,
            MemStack::new(&mut stack),
        );
        if delta.iter().any(|v| !v.is_finite()) {
            return Err(SolveError::NotPositiveDefinite);
        }
        Ok(())
    }

    /// `values ⊕ δ` for every free variable, written into `out` (which is overwritten).
    pub(crate) fn retract_into(&self, values: &Values, delta: &[f64], out: &mut Values) {
        out.clone_from(values);
        for (v, &c) in self.col_of_var.iter().enumerate() {
            if c != NONE {
                out.retract_in_place(VarId(v), &delta[c..c + self.dims[v]]);
            }
        }
    }

    /// H as a dense symmetric matrix (tests and small problems only).
    pub(crate) fn dense_hessian(&self) -> nalgebra::DMatrix<f64> {
        let mut m = nalgebra::DMatrix::zeros(self.n, self.n);
        let col_ptr = self.symbolic.col_ptr();
        let rows = self.symbolic.row_idx();
        for c in 0..self.n {
            for p in col_ptr[c]..col_ptr[c + 1] {
                m[(rows[p], c)] = self.h[p];
                m[(c, rows[p])] = self.h[p];
            }
        }
        m
    }
}
