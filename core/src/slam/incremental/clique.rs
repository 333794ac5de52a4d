//! One clique of the Bayes tree (Kaess et al. 2012, §3): the Gaussian conditional
//! `p(Δ_F | Δ_S)` of its frontal variables F given its separator S, `R Δ_F = d − T Δ_S`, and the
//! marginal factor on S it passes to its parent (the Schur complement of its frontal block).
//!
//! Both live in one matrix in information form: the joint `[H b; bᵀ c]` of the clique's
//! factors and of its children's marginal factors on (F, S), with `H Δ = b`, `b = −Jᵀ Ω e`, is
//! partially Cholesky-factorised over F (lower triangle, column-major): afterwards its F columns
//! hold `L_FF = Rᵀ`, `L_SF = Tᵀ` and, in the last row, `d`; its trailing block holds the marginal
//! factor `H_SS − T ᵀT` and `b_S − Tᵀ d`. Elimination is O(m² · |F|) for m scalar rows, on a
//! dense scratch matrix; the clique keeps only its lower triangle, packed by columns
//! ([`LowerPacked`]), half the memory of the square (the tree's cliques are most of a large
//! SLAM's memory).

use nalgebra::DMatrix;

use super::IncrementalError;
use crate::slam::values::VarId;

/// A clique: frontal variables (in elimination order), separator, tree links, factor.
#[derive(Clone, Debug)]
pub(super) struct Clique {
    pub frontals: Vec<VarId>,
    /// In the order of the matrix's rows (sorted by elimination position when the clique was
    /// made; later re-orderings of its ancestors leave it).
    pub separator: Vec<VarId>,
    pub parent: Option<usize>,
    pub children: Vec<usize>,
    /// Scalar dimension of the frontal variables.
    pub frontal_dim: usize,
    /// The partially factorised joint, `(m + 1) × (m + 1)` with m the scalar size of F ∪ S, its
    /// lower triangle.
    pub factor: LowerPacked,
}

impl Clique {
    /// Scalar size of F ∪ S (the rhs is row and column `m`).
    pub fn dim(&self) -> usize {
        self.factor.n.saturating_sub(1)
    }

    /// The variables of the clique, frontals first.
    pub fn variables(&self) -> impl Iterator<Item = VarId> + '_ {
        self.frontals.iter().chain(self.separator.iter()).copied()
    }
}

/// The lower triangle of an `n × n` matrix packed by columns: column j holds rows j..n, from
/// offset `j·n − j(j−1)/2`.
#[derive(Clone, Debug, Default)]
pub(super) struct LowerPacked {
    /// Rows (and columns) of the matrix.
    pub n: usize,
    data: Vec<f64>,
}

impl LowerPacked {
    /// The lower triangle of the square `a`.
    pub fn from_lower(a: &DMatrix<f64>) -> Self {
        let n = a.nrows();
        let s = a.as_slice();
        let mut data = Vec::with_capacity(n * (n + 1) / 2);
        for j in 0..n {
            data.extend_from_slice(&s[j * n + j..j * n + n]);
        }
        Self { n, data }
    }

    /// Column `j`, rows `j..n` (element `i` of the matrix at index `i − j`).
    #[inline]
    pub fn column(&self, j: usize) -> &[f64] {
        let start = j * self.n - j * j.saturating_sub(1) / 2;
        &self.data[start..start + self.n - j]
    }

    /// Element (`i`, `j`) of the lower triangle, `i ≥ j`.
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.column(j)[i - j]
    }

    /// The `rows × cols` block at (`r0`, `c0`), which must lie in the lower triangle, with the
    /// entries above the diagonal zero when `lower` (a diagonal block's triangle).
    fn block(&self, (r0, c0): (usize, usize), (rows, cols): (usize, usize), lower: bool) -> DMatrix<f64> {
        DMatrix::from_fn(rows, cols, |i, j| if lower && i < j { 0.0 } else { self.at(r0 + i, c0 + j) })
    }
}

/// Partial Cholesky of the lower triangle of `a` over its first `nf` columns (the rhs row is
/// carried along), right-looking in panels of [`PANEL`] columns: a panel is factorised, then
/// every trailing column is updated by the whole panel in one pass (a rank-`PANEL` update, so
/// the trailing matrix is swept `nf / PANEL` times instead of `nf`). Fails on a non-positive or
/// non-finite pivot.
pub(super) fn eliminate_frontals(a: &mut DMatrix<f64>, nf: usize) -> Result<(), IncrementalError> {
    let m = a.nrows();
    let s = a.as_mut_slice();
    let mut k0 = 0;
    while k0 < nf {
        let k1 = (k0 + PANEL).min(nf);
        // The panel's own columns, one after another (left-looking inside the panel).
        for k in k0..k1 {
            for p in k0..k {
                let akp = s[p * m + k];
                if akp == 0.0 {
                    continue;
                }
                let (head, tail) = s.split_at_mut(k * m);
                let col_p = &head[p * m..p * m + m];
                let col_k = &mut tail[..m];
                for i in k..m {
                    col_k[i] -= col_p[i] * akp;
                }
            }
            let piv = s[k * m + k];
            if !(piv > 0.0 && piv.is_finite()) {
                return Err(IncrementalError::NotPositiveDefinite);
            }
            let l = piv.sqrt();
            for i in k..m {
                s[k * m + i] /= l;
            }
        }
        // Every later column j, rows j.., minus the panel's contribution L[j.., P] L[j, P]ᵀ.
        let (head, tail) = s.split_at_mut(k1 * m);
        let panel = &head[k0 * m..k1 * m];
        for (jj, col_j) in tail.chunks_exact_mut(m).enumerate() {
            let j = k1 + jj;
            let mut w = [0.0; PANEL];
            for (p, w) in w.iter_mut().enumerate().take(k1 - k0) {
                *w = panel[p * m + j];
            }
            if w.iter().all(|&x| x == 0.0) {
                continue;
            }
            if k1 - k0 == PANEL {
                let (c0, c1, c2, c3) = (&panel[..m], &panel[m..2 * m], &panel[2 * m..3 * m], &panel[3 * m..4 * m]);
                for i in j..m {
                    col_j[i] -= c0[i] * w[0] + c1[i] * w[1] + c2[i] * w[2] + c3[i] * w[3];
                }
            } else {
                for (p, &wp) in w.iter().enumerate().take(k1 - k0) {
                    let c = &panel[p * m..p * m + m];
                    for i in j..m {
                        col_j[i] -= c[i] * wp;
                    }
                }
            }
        }
        k0 = k1;
    }
    Ok(())
}

/// Columns per panel of [`eliminate_frontals`].
const PANEL: usize = 4;

/// Back-substitution of one conditional: `Δ_F = R⁻¹ (d − T Δ_S)`, with `x_s` the separator's
/// values (scalar order) and the result written into `x_f` (length `nf`).
pub(super) fn solve_conditional(a: &LowerPacked, nf: usize, x_s: &[f64], x_f: &mut [f64]) {
    let m = a.n;
    let ns = m - 1 - nf;
    for k in 0..nf {
        let col = a.column(k);
        let mut r = col[m - 1 - k];
        for i in 0..ns {
            r -= col[nf + i - k] * x_s[i];
        }
        x_f[k] = r;
    }
    for k in (0..nf).rev() {
        let col = a.column(k);
        let mut r = x_f[k];
        for i in k + 1..nf {
            r -= col[i - k] * x_f[i];
        }
        x_f[k] = r / col[0];
    }
}

/// The joint covariance of (F, S) from the separator's covariance `cov_s` (`ns × ns`; empty at a
/// root): `Σ_FF = R⁻¹R⁻ᵀ + K Σ_SS Kᵀ`, `Σ_FS = −K Σ_SS`, `K = R⁻¹ T` (the conditional's
/// mean is linear in Δ_S). O(nf² (nf + ns) + nf ns²). `None` if R is singular.
pub(super) fn joint_covariance(a: &LowerPacked, nf: usize, cov_s: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let m = a.n - 1;
    let ns = m - nf;
    let l_ff = a.block((0, 0), (nf, nf), true);
    let r = l_ff.transpose();
    let mut out = DMatrix::zeros(m, m);
    // R⁻¹ R⁻ᵀ: solve R X = R⁻ᵀ, with R⁻ᵀ = L⁻¹ from the lower factor.
    let mut rinv_t = DMatrix::identity(nf, nf);
    if !l_ff.solve_lower_triangular_mut(&mut rinv_t) {
        return None;
    }
    let mut cov_ff = rinv_t;
    if !r.solve_upper_triangular_mut(&mut cov_ff) {
        return None;
    }
    if ns > 0 {
        let mut k = a.block((nf, 0), (ns, nf), false).transpose();
        if !r.solve_upper_triangular_mut(&mut k) {
            return None;
        }
        let k_cov = &k * cov_s;
        cov_ff += &k_cov * k.transpose();
        out.view_mut((0, nf), (nf, ns)).copy_from(&(-&k_cov));
        out.view_mut((nf, 0), (ns, nf)).copy_from(&(-k_cov.transpose()));
        out.view_mut((nf, nf), (ns, ns)).copy_from(cov_s);
    }
    out.view_mut((0, 0), (nf, nf)).copy_from(&cov_ff);
    Some(out)
}

/// The covariance of the frontal scalars `offset..offset + dim` of a root clique (no separator):
/// columns of `R⁻¹R⁻ᵀ` by two triangular solves, O(nf² · dim).
pub(super) fn root_block_covariance(a: &LowerPacked, nf: usize, offset: usize, dim: usize) -> Option<DMatrix<f64>> {
    let l_ff = a.block((0, 0), (nf, nf), true);
    let mut e = DMatrix::zeros(nf, dim);
    for i in 0..dim {
        e[(offset + i, i)] = 1.0;
    }
    if !l_ff.solve_lower_triangular_mut(&mut e) || !l_ff.tr_solve_lower_triangular_mut(&mut e) {
        return None;
    }
    Some(e.rows(offset, dim).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random SPD joint over 3 frontal and 2 separator scalars, with a rhs.
    fn joint() -> (DMatrix<f64>, nalgebra::DVector<f64>) {
        let j = DMatrix::from_fn(8, 5, |i, k| (((i * 5 + k) as f64) * 0.731).sin());
        let h = j.transpose() * j + DMatrix::identity(5, 5) * 0.1;
        let b = nalgebra::DVector::from_fn(5, |i, _| (i as f64 * 1.3).cos());
        (h, b)
    }

    fn augmented(h: &DMatrix<f64>, b: &nalgebra::DVector<f64>) -> DMatrix<f64> {
        let n = h.nrows();
        let mut a = DMatrix::zeros(n + 1, n + 1);
        a.view_mut((0, 0), (n, n)).copy_from(h);
        for i in 0..n {
            a[(n, i)] = b[i];
            a[(i, n)] = b[i];
        }
        a
    }

    /// Two whole panels and a partial one (9 frontals of 12): the trailing block is the Schur
    /// complement and the factor reproduces the frontal block, as an unblocked Cholesky gives.
    #[test]
    fn panelled_elimination_gives_the_schur_complement() {
        let (n, nf) = (12, 9);
        let j = DMatrix::from_fn(20, n, |i, k| (((i * n + k) as f64) * 0.377).sin());
        let h = j.transpose() * j + DMatrix::identity(n, n) * 0.5;
        let b = nalgebra::DVector::from_fn(n, |i, _| (i as f64 * 0.7).sin());
        let mut a = augmented(&h, &b);
        eliminate_frontals(&mut a, nf).unwrap();
        let hff = h.view((0, 0), (nf, nf)).into_owned();
        let l = hff.clone().cholesky().unwrap().l();
        let schur =
            h.view((nf, nf), (n - nf, n - nf)) - h.view((nf, 0), (n - nf, nf)) * hff.try_inverse().unwrap() * h.view((0, nf), (nf, n - nf));
        for c in 0..nf {
            for r in c..nf {
                assert!((a[(r, c)] - l[(r, c)]).abs() < 1e-12, "L[{r}, {c}]");
            }
        }
        for c in 0..n - nf {
            for r in c..n - nf {
                assert!((a[(nf + r, nf + c)] - schur[(r, c)]).abs() < 1e-10, "S[{r}, {c}]");
            }
        }
    }

    #[test]
    fn elimination_and_back_substitution_solve_the_joint() {
        let (h, b) = joint();
        let mut a = augmented(&h, &b);
        eliminate_frontals(&mut a, 3).unwrap();
        let packed = LowerPacked::from_lower(&a);
        // The trailing block is the Schur complement; its solution is the separator's part.
        let hss = h.view((3, 3), (2, 2)) - h.view((3, 0), (2, 3)) * h.view((0, 0), (3, 3)).try_inverse().unwrap() * h.view((0, 3), (3, 2));
        for i in 0..2 {
            for k in 0..=i {
                assert!((a[(3 + i, 3 + k)] - hss[(i, k)]).abs() < 1e-12);
            }
        }
        let x = h.clone().lu().solve(&b).unwrap();
        let mut xf = [0.0; 3];
        solve_conditional(&packed, 3, &[x[3], x[4]], &mut xf);
        for k in 0..3 {
            assert!((xf[k] - x[k]).abs() < 1e-12);
        }
        let cov = h.clone().try_inverse().unwrap();
        let cov_s = cov.view((3, 3), (2, 2)).into_owned();
        let joint = joint_covariance(&packed, 3, &cov_s).unwrap();
        // Without the separator's uncertainty, a block of R⁻¹R⁻ᵀ.
        let conditional = joint_covariance(&packed, 3, &DMatrix::zeros(2, 2)).unwrap();
        assert!((root_block_covariance(&packed, 3, 1, 2).unwrap() - conditional.view((1, 1), (2, 2))).amax() < 1e-12);
        assert!((joint - cov).amax() < 1e-12);
    }
}
