//! Marginal covariances at the current linearisation (notes §1): the block of `H⁻¹`
//! (H = JᵀΩJ over the free variables) for a variable, by forward solves for a few variables and
//! from the selected inverse for many.
//!
//! With faer's fill-reducing permutation P and factor P H Pᵀ = L Lᵀ,
//! `H⁻¹ = Pᵀ L⁻ᵀ L⁻¹ P`, so the block of the variable with columns c..c+d is the Gram matrix
//! `Σ_ab = y_aᵀ y_b` of `y_a = L⁻¹ P e_(c+a)`: forward solves only. And `L⁻¹` applied to a unit
//! vector is nonzero only on the elimination-tree path from its column to the root, so each
//! forward solve visits only the (super)nodes of that path, not all of L (Gilbert–Peierls
//! reach). faer's simplicial factor is the special case of one-column nodes.
//!
//! Cost: one numeric factorisation, then per variable O(d · Σ over its path of the nodes'
//! entries), typically far below the O(d · nnz(L)) of a full solve. Many variables (all the
//! landmarks, say) share most of their paths: then Σ on the pattern of L, computed once from the
//! root down (Takahashi's recursion, see `Marginals::selected_inverse`), is cheaper, and
//! [`Marginals::covariances`] picks by counting both methods' multiply-adds. Covariances are in the
//! variable's tangent (poses: body frame, ξ = (δt, δφ)); fixed variables have zero covariance
//! (they are the gauge anchor). Symmetric by construction.

use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
use nalgebra::DMatrix;

use super::factors::FactorError;
use super::graph::FactorGraph;
use super::linear_system::{Factorisation, LinearSystem, SolveError};
use super::values::{Values, VarId};

/// Why marginal covariances could not be computed.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum MarginalError {
    /// A factor could not be linearised at the values.
    #[error(transparent)]
    Factor(#[from] FactorError),
    /// The information matrix could not be factorised (e.g. not positive definite), or a
    /// variable asked for does not exist.
    #[error(transparent)]
    Solve(#[from] SolveError),
}

/// Per multiply-add, the selected inverse (with its gathers of Σ_RR) took 2–4× the time of the
/// forward solves on the real graphs (docs/benchmarks.md, SLAM backend): it is chosen when it needs
/// fewer than a third of their multiply-adds.
const SELECTED_INVERSE_WEIGHT: usize = 3;

/// Most right-hand sides one variable brings (its dimension: 6 for an SE(3) pose).
const MAX_RHS: usize = 6;

/// Variables whose forward solves share each pass through L (fewer than 64: a bit each in a
/// `u64`, with room for the all-set mask).
const SOLVE_BATCH: usize = 8;
const _: () = assert!(SOLVE_BATCH < 64);

/// Most right-hand sides of one pass.
const MAX_LANES: usize = SOLVE_BATCH * MAX_RHS;

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
    /// Where `values` starts in the factor's value array.
    offset: usize,
}

/// Size and work of one Cholesky factor of the information matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorStats {
    /// Scalar unknowns.
    pub dim: usize,
    /// Values the factor stores (its nonzeros, with the dense blocks of a supernodal layout).
    pub factor_entries: usize,
    /// Floating-point operations of one numeric factorisation with this structure: per node of k
    /// columns and m rows below them, k³/3 (its diagonal block) + m k² (the panel's triangular
    /// solve) + m² k (its update of the ancestors). Machine-independent: a factorisation with
    /// this structure (this elimination order) takes at least this divided by the machine's
    /// dense rate.
    pub flops: f64,
    /// Whether faer chose the supernodal layout.
    pub supernodal: bool,
}

/// The factorised information matrix of a problem, ready for covariance queries.
pub struct Marginals {
    system: LinearSystem,
    dims: Vec<usize>,
    /// Per permuted column, its node.
    node_of: Vec<usize>,
    /// Per node, its parent in the elimination tree (`usize::MAX` at a root).
    parent: Vec<usize>,
    /// Whether every node's pattern is in increasing row order, as the selected inverse's
    /// lookups need (faer's are; otherwise only the path solves are used).
    sorted_patterns: bool,
}

impl core::fmt::Debug for Marginals {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Marginals").field("n", &self.system.dim()).finish()
    }
}

impl Marginals {
    /// Linearises `graph` at `values` (fixed flags respected) and factorises H.
    pub fn new(graph: &FactorGraph, values: &Values, factorisation: Factorisation) -> Result<Self, MarginalError> {
        let mut system = LinearSystem::new(graph, values, factorisation)?;
        system.linearize(graph, values)?;
        system.factorize(0.0)?;
        let dims = values.iter().map(|(_, v)| v.dim()).collect();
        let mut m = Self { system, dims, node_of: Vec::new(), parent: Vec::new(), sorted_patterns: false };
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
        m.sorted_patterns = (0..count).all(|s| m.node(s).pattern.is_sorted());
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
                let offset = range.start;
                Node { start: s, size: 1, pattern: &l.row_idx()[range.start + 1..range.end], values: &values[range], offset }
            }
            SymbolicCholeskyRaw::Supernodal(sym) => {
                let (start, end) = (sym.supernode_begin()[s], sym.supernode_end()[s]);
                let rows = sym.col_ptr_for_row_idx()[s];
                let pattern = &sym.row_idx()[rows..rows + sym.nnz_per_super()[s]];
                let vals = sym.col_ptr_for_val()[s]..sym.col_ptr_for_val()[s + 1];
                let offset = vals.start;
                Node { start, size: end - start, pattern, values: &values[vals], offset }
            }
        }
    }

    /// Size and work of the factor ([`FactorStats`]).
    pub fn factor_stats(&self) -> FactorStats {
        let (symbolic, values) = self.system.factor_parts();
        let flops = (0..self.node_count())
            .map(|s| {
                let node = self.node(s);
                let (k, m) = (node.size as f64, node.pattern.len() as f64);
                k * k * k / 3.0 + m * k * k + m * m * k
            })
            .sum();
        let supernodal = matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_));
        FactorStats { dim: self.system.dim(), factor_entries: values.len(), flops, supernodal }
    }

    /// Where the first column of variable `id` lies in the factor's elimination order (faer's
    /// fill-reducing permutation); `None` for a fixed or unknown variable.
    pub fn elimination_position(&self, id: VarId) -> Option<usize> {
        let c = self.system.column_of(id)?;
        Some(self.system.factor_parts().0.perm().map_or(c, |p| p.arrays().1[c]))
    }

    /// The information matrix as dense (small problems and tests only).
    pub fn dense_information(&self) -> DMatrix<f64> {
        self.system.dense_hessian()
    }

    /// The d×d marginal covariance of one variable.
    pub fn covariance(&self, id: VarId) -> Result<DMatrix<f64>, MarginalError> {
        Ok(self.covariances(&[id])?.pop().unwrap_or_else(|| DMatrix::zeros(0, 0)))
    }

    /// Marginal covariances of several variables (each its own d×d block): by forward solves
    /// along each variable's elimination-tree path, or from the selected inverse when the
    /// solves would need more than `SELECTED_INVERSE_WEIGHT` (3) times its multiply-adds (many
    /// variables: every landmark of a map, say).
    pub fn covariances(&self, ids: &[VarId]) -> Result<Vec<DMatrix<f64>>, MarginalError> {
        if self.sorted_patterns && self.solve_cost(ids)? > SELECTED_INVERSE_WEIGHT * self.selected_inverse_cost() {
            self.covariances_from_selected_inverse(ids)
        } else {
            self.covariances_by_solves(ids)
        }
    }

    /// Multiply-adds of [`Self::covariances_by_solves`] for `ids`: per variable, d × the
    /// entries of the nodes on its path.
    fn solve_cost(&self, ids: &[VarId]) -> Result<usize, MarginalError> {
        let inv = self.system.factor_parts().0.perm().map(|p| p.arrays().1);
        let mut on_path = vec![false; self.parent.len()];
        let mut path = Vec::new();
        let mut cost = 0;
        for id in ids {
            let d = *self.dims.get(id.0).ok_or(SolveError::UnknownVariable(*id))?;
            let Some(c) = self.system.column_of(*id) else { continue };
            self.collect_path((0..d).map(|a| inv.map_or(c + a, |inv| inv[c + a])), &mut on_path, &mut path);
            for &s in &path {
                let node = self.node(s);
                cost += d * node.size * (node.size + node.pattern.len());
                on_path[s] = false;
            }
        }
        Ok(cost)
    }

    /// Multiply-adds of [`Self::selected_inverse`]: per node with k columns and m pattern rows,
    /// m²k for Σ_RJ, mk² for U and Σ_JJ, k³ for L_JJ⁻¹.
    fn selected_inverse_cost(&self) -> usize {
        (0..self.node_count())
            .map(|s| {
                let node = self.node(s);
                let (k, m) = (node.size, node.pattern.len());
                m * m * k + 2 * m * k * k + k * k * k
            })
            .sum()
    }

    /// The elimination-tree nodes of the permuted columns `columns` and all their ancestors,
    /// children before parents, flagged in `on_path` (the caller clears the flags).
    fn collect_path(&self, columns: impl Iterator<Item = usize>, on_path: &mut [bool], path: &mut Vec<usize>) {
        path.clear();
        for k in columns {
            let mut s = self.node_of[k];
            while s != usize::MAX && !on_path[s] {
                on_path[s] = true;
                path.push(s);
                s = self.parent[s];
            }
        }
        // Node indices are a topological order of the tree.
        path.sort_unstable();
    }

    /// The solves of up to [`SOLVE_BATCH`] variables at a time: their columns are interleaved
    /// (row r of column a at r · stride + a, `stride` their total dimension) and each node of L
    /// on the union of their paths is read once for the variables whose path holds it (all of
    /// them near the root). Every column sees the operations of its own solve in the same
    /// order, so the blocks do not depend on the batching.
    fn covariances_by_solves(&self, ids: &[VarId]) -> Result<Vec<DMatrix<f64>>, MarginalError> {
        let n = self.system.dim();
        let inv = self.system.factor_parts().0.perm().map(|p| p.arrays().1);
        let max_d = self.dims.iter().copied().max().unwrap_or(0);
        // Workspace, zero outside the current union of paths.
        let mut x = vec![0.0; n * max_d * SOLVE_BATCH.min(ids.len())];
        // Per node, which of the batch's variables have it on their path.
        let mut on_paths = vec![0u64; self.parent.len()];
        let mut union = Vec::new();
        let mut out = Vec::with_capacity(ids.len());
        for batch in ids.chunks(SOLVE_BATCH) {
            // (first column, dimension, first lane) of each variable with free columns.
            let mut members = Vec::with_capacity(batch.len());
            let mut stride = 0;
            for id in batch {
                let d = *self.dims.get(id.0).ok_or(SolveError::UnknownVariable(*id))?;
                if let Some(c) = self.system.column_of(*id) {
                    members.push((c, d, stride));
                    stride += d;
                }
            }
            // y_a = L⁻¹ P e_(c+a): the unit entry sits at the permuted position of c + a.
            for (m, &(c, d, lane)) in members.iter().enumerate() {
                let bit = 1u64 << m;
                for a in 0..d {
                    let k = inv.map_or(c + a, |inv| inv[c + a]);
                    x[k * stride + lane + a] = 1.0;
                    let mut s = self.node_of[k];
                    while s != usize::MAX && on_paths[s] & bit == 0 {
                        if on_paths[s] == 0 {
                            union.push(s);
                        }
                        on_paths[s] |= bit;
                        s = self.parent[s];
                    }
                }
            }
            // Node indices are a topological order of the tree: children before parents.
            union.sort_unstable();
            let everyone = (1u64 << members.len()) - 1;
            for &s in &union {
                let node = self.node(s);
                if on_paths[s] == everyone {
                    forward_node(&node, &mut x, 0..stride, stride);
                } else {
                    for (m, &(_, d, lane)) in members.iter().enumerate() {
                        if on_paths[s] & (1 << m) != 0 {
                            forward_node(&node, &mut x, lane..lane + d, stride);
                        }
                    }
                }
            }
            let mut covs: Vec<DMatrix<f64>> = members.iter().map(|&(_, d, _)| DMatrix::zeros(d, d)).collect();
            for &s in &union {
                let node = self.node(s);
                for r in node.start..node.start + node.size {
                    let xr = &mut x[r * stride..(r + 1) * stride];
                    for (m, (&(_, d, lane), cov)) in members.iter().zip(&mut covs).enumerate() {
                        if on_paths[s] & (1 << m) == 0 {
                            continue;
                        }
                        let xm = &xr[lane..lane + d];
                        for a in 0..d {
                            if xm[a] != 0.0 {
                                for b in 0..=a {
                                    cov[(a, b)] += xm[a] * xm[b];
                                }
                            }
                        }
                    }
                    xr.fill(0.0);
                }
                on_paths[s] = 0;
            }
            union.clear();
            let mut covs = covs.into_iter();
            for id in batch {
                let cov = if self.system.column_of(*id).is_some() { covs.next() } else { None };
                out.push(cov.map_or_else(
                    || DMatrix::zeros(self.dims[id.0], self.dims[id.0]),
                    |mut cov| {
                        for a in 0..cov.nrows() {
                            for b in 0..a {
                                cov[(b, a)] = cov[(a, b)];
                            }
                        }
                        cov
                    },
                ));
            }
        }
        Ok(out)
    }

    /// The covariance blocks of `ids` read from the selected inverse.
    fn covariances_from_selected_inverse(&self, ids: &[VarId]) -> Result<Vec<DMatrix<f64>>, MarginalError> {
        let inv = self.system.factor_parts().0.perm().map(|p| p.arrays().1);
        let sigma = self.selected_inverse();
        let mut out = Vec::with_capacity(ids.len());
        for id in ids {
            let d = *self.dims.get(id.0).ok_or(SolveError::UnknownVariable(*id))?;
            let mut cov = DMatrix::zeros(d, d);
            if let Some(c) = self.system.column_of(*id) {
                let permuted = |a: usize| inv.map_or(c + a, |inv| inv[c + a]);
                for a in 0..d {
                    for b in 0..=a {
                        // A variable's own block is dense in H, hence in the pattern of L.
                        let v = self.sigma_at(&sigma, permuted(a), permuted(b)).unwrap_or(f64::NAN);
                        cov[(a, b)] = v;
                        cov[(b, a)] = v;
                    }
                }
            }
            out.push(cov);
        }
        Ok(out)
    }

    /// Σ = (P H Pᵀ)⁻¹ on the pattern of L (the selected inverse, Takahashi, Fagan & Chen 1973),
    /// in the factor's own value layout, node by node from the root: for the node's columns J and
    /// pattern rows R, with U = L_RJ L_JJ⁻¹,
    ///   Σ_RJ = −Σ_RR U,   Σ_JJ = L_JJ⁻ᵀ L_JJ⁻¹ − Σ_RJᵀ U
    /// (from Σ L = L⁻ᵀ, upper triangular); Σ_RR lies in the ancestors' part, already computed.
    /// Both triangles of each Σ_JJ are stored. O(Σ over nodes of m²k + mk² + k³).
    fn selected_inverse(&self) -> Vec<f64> {
        let (_, values) = self.system.factor_parts();
        let mut sigma = vec![0.0; values.len()];
        let (mut u, mut srr, mut linv) = (Vec::new(), Vec::new(), Vec::new());
        for s in (0..self.node_count()).rev() {
            let node = self.node(s);
            let (k, m, l) = (node.size, node.pattern.len(), node.values);
            let rows = k + m;
            // L_JJ⁻¹ (k × k, column-major, lower).
            linv.clear();
            linv.resize(k * k, 0.0);
            for j in 0..k {
                linv[j * k + j] = 1.0 / l[j * rows + j];
                for i in j + 1..k {
                    let mut v = 0.0;
                    for t in j..i {
                        v -= l[t * rows + i] * linv[j * k + t];
                    }
                    linv[j * k + i] = v / l[i * rows + i];
                }
            }
            // U = L_RJ L_JJ⁻¹ (m × k, column-major).
            u.clear();
            u.resize(m * k, 0.0);
            for j in 0..k {
                for t in j..k {
                    let w = linv[j * k + t];
                    for r in 0..m {
                        u[j * m + r] += l[t * rows + k + r] * w;
                    }
                }
            }
            // Σ_RR (m × m, column-major, both triangles) from the ancestors.
            srr.clear();
            srr.resize(m * m, 0.0);
            for c in 0..m {
                // Column pattern[c] of Σ lives in its node t; the rows pattern[c..] are among t's
                // rows (its own columns, then its pattern), both sorted: one merge walk.
                let jc = node.pattern[c];
                let t = self.node(self.node_of[jc]);
                let t_rows = t.size + t.pattern.len();
                let col = &sigma[t.offset + (jc - t.start) * t_rows..][..t_rows];
                let mut pos = 0;
                for r in c..m {
                    let i = node.pattern[r];
                    let v = if i < t.start + t.size {
                        col[i - t.start]
                    } else {
                        while pos < t.pattern.len() && t.pattern[pos] < i {
                            pos += 1;
                        }
                        if pos < t.pattern.len() && t.pattern[pos] == i { col[t.size + pos] } else { 0.0 }
                    };
                    srr[c * m + r] = v;
                    srr[r * m + c] = v;
                }
            }
            let base = node.offset;
            // Σ_RJ = −Σ_RR U (Σ_RR symmetric: its column r is its row r, contiguous).
            for j in 0..k {
                let uj = &u[j * m..(j + 1) * m];
                for r in 0..m {
                    let v: f64 = srr[r * m..(r + 1) * m].iter().zip(uj).map(|(a, b)| a * b).sum();
                    sigma[base + j * rows + k + r] = -v;
                }
            }
            // Σ_JJ = L_JJ⁻ᵀ L_JJ⁻¹ − Σ_RJᵀ U.
            for j in 0..k {
                for i in j..k {
                    let mut v = 0.0;
                    for t in i..k {
                        v += linv[i * k + t] * linv[j * k + t];
                    }
                    for r in 0..m {
                        v -= sigma[base + i * rows + k + r] * u[j * m + r];
                    }
                    sigma[base + j * rows + i] = v;
                    sigma[base + i * rows + j] = v;
                }
            }
        }
        sigma
    }

    /// Σ(i, j) from the selected inverse (permuted indices), if (i, j) is in the pattern of L.
    fn sigma_at(&self, sigma: &[f64], i: usize, j: usize) -> Option<f64> {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        let node = self.node(self.node_of[j]);
        let rows = node.size + node.pattern.len();
        let r = if i < node.start + node.size { i - node.start } else { node.size + node.pattern.binary_search(&i).ok()? };
        Some(sigma[node.offset + (j - node.start) * rows + r])
    }
}

/// One node's part of the forward solves `L y_a = b_a` for the right-hand sides in `lanes`,
/// stored interleaved in `y` (row r of y_a at r · `stride` + a): solves the node's
/// lower-triangular top block for its rows, then subtracts their contribution from the pattern
/// rows. A column whose entries are all zero is skipped. Within a column, a zero entry still
/// subtracts `l · 0 = ±0`, which leaves every value as it was (no value here is ever −0: the
/// right-hand sides are units and zeros, L's diagonal is positive, and x − x rounds to +0), so
/// each y_a is bit for bit what a solve of its own, skipping its zeros, gives; the node's values
/// and pattern are read once for all of them.
fn forward_node(node: &Node, y: &mut [f64], lanes: std::ops::Range<usize>, stride: usize) {
    debug_assert!(lanes.end <= stride && lanes.len() <= MAX_LANES);
    match lanes.len() {
        3 => forward_node_fixed::<3>(node, y, lanes.start, stride),
        6 => forward_node_fixed::<6>(node, y, lanes.start, stride),
        _ => forward_node_any(node, y, lanes, stride),
    }
}

/// [`forward_node`] for `D` lanes from `lane`, `D` known at compile time: for one variable's
/// columns the unrolled loop beat [`forward_node_any`] (paper SLAM mission, the marginals' perf
/// samples 437 / 431 / 430 against 504 / 495 / 489, alternating).
fn forward_node_fixed<const D: usize>(node: &Node, y: &mut [f64], lane: usize, stride: usize) {
    let (start, size) = (node.start, node.size);
    let rows = size + node.pattern.len();
    for j in 0..size {
        let col = &node.values[j * rows..(j + 1) * rows];
        let at = (start + j) * stride + lane;
        let mut yj = [0.0; D];
        for (a, v) in yj.iter_mut().enumerate() {
            *v = y[at + a] / col[j];
            y[at + a] = *v;
        }
        if yj == [0.0; D] {
            continue;
        }
        let targets = (start + j + 1..start + size).chain(node.pattern.iter().copied());
        for (&l, row) in col[j + 1..].iter().zip(targets) {
            for (t, y) in y[row * stride + lane..][..D].iter_mut().zip(&yj) {
                *t -= l * y;
            }
        }
    }
}

/// [`forward_node`] for any number of lanes.
fn forward_node_any(node: &Node, y: &mut [f64], lanes: std::ops::Range<usize>, stride: usize) {
    let (start, size) = (node.start, node.size);
    let rows = size + node.pattern.len();
    let width = lanes.len();
    let mut yj = [0.0; MAX_LANES];
    let yj = &mut yj[..width];
    for j in 0..size {
        let col = &node.values[j * rows..(j + 1) * rows];
        let at = (start + j) * stride + lanes.start;
        for (v, t) in yj.iter_mut().zip(&mut y[at..at + width]) {
            *v = *t / col[j];
            *t = *v;
        }
        if yj.iter().all(|&v| v == 0.0) {
            continue;
        }
        let targets = (start + j + 1..start + size).chain(node.pattern.iter().copied());
        for (&l, row) in col[j + 1..].iter().zip(targets) {
            for (t, &v) in y[row * stride + lanes.start..][..width].iter_mut().zip(yj.iter()) {
                *t -= l * v;
            }
        }
    }
}

#[cfg(test)]
mod tests;
