//! Gaussian noise models: the square-root information `R` (Ω = RᵀR) that whitens a residual,
//! `r = R e`, so that χ² = ‖r‖² = eᵀ Ω e. Construction is a d×d Cholesky, O(d³), d ≤ 6.
//!
//! A model may carry a robust kernel (an M-estimator on s = ‖r‖, [`RobustKernel`]): the cost is
//! then 2ρ(s) instead of s², and a linearisation scales the whitened residual and Jacobians by
//! √w(s), w = ρ′(s)/s (iteratively reweighted least squares, as GTSAM's `noiseModel::Robust`).

use nalgebra::{Matrix6, SMatrix, Vector6};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::MAX_RESIDUAL_DIM;

/// Why a covariance, information matrix or set of sigmas cannot make a [`GaussianNoise`].
#[derive(Clone, Debug, Error, PartialEq)]
pub enum NoiseError {
    /// The dimension (given) is not in 1..=6.
    #[error("noise model dimension {0} is not in 1..=6")]
    BadDimension(usize),
    /// An entry is NaN or infinite.
    #[error("noise matrix has a non-finite entry")]
    NonFinite,
    /// The matrix is not symmetric (the largest |M − Mᵀ| entry).
    #[error("noise matrix is not symmetric (|M − Mᵀ| = {0:e})")]
    NotSymmetric(f64),
    /// The matrix is not positive definite, or a sigma is ≤ 0 (the 0-based pivot or sigma index).
    #[error("noise matrix is not positive definite (pivot {0})")]
    NotPositiveDefinite(usize),
}

/// An M-estimator on the whitened residual's norm s (Zhang 1997; GTSAM's `mEstimator`), with
/// its threshold k in units of σ. Cost ρ(s) and weight w(s) = ρ′(s)/s:
/// - Huber: ρ = s²/2 for s ≤ k, k s − k²/2 beyond; w = min(1, k/s) (bounded influence);
/// - Cauchy: ρ = k²/2 · ln(1 + s²/k²); w = 1 / (1 + s²/k²) (influence falls to 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum RobustKernel {
    /// Least squares: ρ = s²/2.
    #[default]
    None,
    /// Huber: quadratic up to `k` σ, linear beyond.
    Huber {
        /// Threshold, in units of σ (> 0).
        k: f64,
    },
    /// Cauchy: the weight of a residual falls towards 0 as it grows past `k` σ.
    Cauchy {
        /// Threshold, in units of σ (> 0).
        k: f64,
    },
}

impl RobustKernel {
    /// 2ρ(s): the factor's share of χ² (s² without a kernel).
    pub fn cost(self, s: f64) -> f64 {
        match self {
            RobustKernel::None => s * s,
            RobustKernel::Huber { k } if s <= k => s * s,
            RobustKernel::Huber { k } => 2.0 * k * s - k * k,
            RobustKernel::Cauchy { k } => k * k * crate::math::ln_1p(s * s / (k * k)),
        }
    }

    /// The IRLS weight w(s) = ρ′(s)/s, in (0, 1].
    pub fn weight(self, s: f64) -> f64 {
        match self {
            RobustKernel::None => 1.0,
            RobustKernel::Huber { k } => {
                if s <= k {
                    1.0
                } else {
                    k / s
                }
            }
            RobustKernel::Cauchy { k } => 1.0 / (1.0 + s * s / (k * k)),
        }
    }

    /// The threshold, when there is one.
    pub fn threshold(self) -> Option<f64> {
        match self {
            RobustKernel::None => None,
            RobustKernel::Huber { k } | RobustKernel::Cauchy { k } => Some(k),
        }
    }
}

/// A Gaussian noise model of dimension `dim` ≤ 6, optionally robust.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianNoise {
    dim: usize,
    /// Top-left `dim × dim` block used; Ω = RᵀR.
    sqrt_info: Matrix6<f64>,
    kernel: RobustKernel,
}

/// Lower Cholesky factor of the top-left d×d block of `m`: `m = L Lᵀ`.
fn cholesky_lower(m: &Matrix6<f64>, d: usize) -> Result<Matrix6<f64>, NoiseError> {
    let mut l = Matrix6::zeros();
    for j in 0..d {
        let mut diag = m[(j, j)];
        for k in 0..j {
            diag -= l[(j, k)] * l[(j, k)];
        }
        if diag.is_nan() || diag <= 0.0 {
            return Err(NoiseError::NotPositiveDefinite(j));
        }
        let ljj = diag.sqrt();
        l[(j, j)] = ljj;
        for i in (j + 1)..d {
            let mut s = m[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / ljj;
        }
    }
    Ok(l)
}

/// Checks finiteness and symmetry (relative to the largest entry) and copies into a 6×6.
fn checked_copy<const D: usize>(m: &SMatrix<f64, D, D>) -> Result<Matrix6<f64>, NoiseError> {
    if D == 0 || D > MAX_RESIDUAL_DIM {
        return Err(NoiseError::BadDimension(D));
    }
    if m.iter().any(|v| !v.is_finite()) {
        return Err(NoiseError::NonFinite);
    }
    let scale = m.amax().max(f64::MIN_POSITIVE);
    let asym = (m - m.transpose()).amax();
    if asym > 1e-9 * scale {
        return Err(NoiseError::NotSymmetric(asym));
    }
    let mut out = Matrix6::zeros();
    for i in 0..D {
        for j in 0..D {
            // Symmetrise exactly.
            out[(i, j)] = 0.5 * (m[(i, j)] + m[(j, i)]);
        }
    }
    Ok(out)
}

impl GaussianNoise {
    /// From an information matrix Ω (the inverse covariance), as stored in g2o files.
    pub fn from_information<const D: usize>(information: &SMatrix<f64, D, D>) -> Result<Self, NoiseError> {
        let m = checked_copy(information)?;
        let l = cholesky_lower(&m, D)?;
        // Ω = L Lᵀ → R = Lᵀ.
        Ok(Self { dim: D, sqrt_info: l.transpose(), kernel: RobustKernel::None })
    }

    /// From a covariance Σ: Σ = L Lᵀ → Ω = L⁻ᵀ L⁻¹ → R = L⁻¹.
    pub fn from_covariance<const D: usize>(covariance: &SMatrix<f64, D, D>) -> Result<Self, NoiseError> {
        let m = checked_copy(covariance)?;
        let l = cholesky_lower(&m, D)?;
        // Forward substitution for L⁻¹ (lower triangular), column by column.
        let mut inv = Matrix6::zeros();
        for c in 0..D {
            for i in c..D {
                let mut s = if i == c { 1.0 } else { 0.0 };
                for k in c..i {
                    s -= l[(i, k)] * inv[(k, c)];
                }
                inv[(i, c)] = s / l[(i, i)];
            }
        }
        Ok(Self { dim: D, sqrt_info: inv, kernel: RobustKernel::None })
    }

    /// Independent components with standard deviations `sigmas` (1 to 6 of them, all > 0).
    pub fn from_sigmas(sigmas: &[f64]) -> Result<Self, NoiseError> {
        let d = sigmas.len();
        if d == 0 || d > MAX_RESIDUAL_DIM {
            return Err(NoiseError::BadDimension(d));
        }
        let mut r = Matrix6::zeros();
        for (i, &s) in sigmas.iter().enumerate() {
            if !s.is_finite() {
                return Err(NoiseError::NonFinite);
            }
            if s <= 0.0 {
                return Err(NoiseError::NotPositiveDefinite(i));
            }
            r[(i, i)] = 1.0 / s;
        }
        Ok(Self { dim: d, sqrt_info: r, kernel: RobustKernel::None })
    }

    /// `dim` independent components with standard deviation `sigma`.
    pub fn isotropic(dim: usize, sigma: f64) -> Result<Self, NoiseError> {
        if dim == 0 || dim > MAX_RESIDUAL_DIM {
            return Err(NoiseError::BadDimension(dim));
        }
        Self::from_sigmas(&[sigma; MAX_RESIDUAL_DIM][..dim])
    }

    /// Dimension of the residual it weighs, 1 to 6.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// R with Ω = RᵀR (top-left `dim × dim` block; the rest is zero).
    pub fn sqrt_information(&self) -> &Matrix6<f64> {
        &self.sqrt_info
    }

    /// Ω = RᵀR (top-left `dim × dim` block).
    pub fn information(&self) -> Matrix6<f64> {
        self.sqrt_info.transpose() * self.sqrt_info
    }

    /// The same model with the robust kernel `kernel`.
    pub fn with_kernel(self, kernel: RobustKernel) -> Self {
        Self { kernel, ..self }
    }

    /// Its robust kernel ([`RobustKernel::None`] unless set by [`Self::with_kernel`]).
    pub fn kernel(&self) -> RobustKernel {
        self.kernel
    }

    /// Whitened residual `R e` (without the kernel's weight).
    pub fn whiten(&self, error: &Vector6<f64>) -> Vector6<f64> {
        self.sqrt_info * error
    }

    /// The factor's share of χ²: eᵀ Ω e, or 2ρ(‖R e‖) with a kernel.
    pub fn chi2(&self, error: &Vector6<f64>) -> f64 {
        self.kernel.cost(self.whiten(error).norm())
    }

    /// For a linearisation at `error`: the weighted whitened residual √w R e, the row scale √w
    /// for the whitened Jacobians R J, and the factor's χ² share (as [`Self::chi2`]).
    pub fn linearized(&self, error: &Vector6<f64>) -> (Vector6<f64>, f64, f64) {
        let r = self.whiten(error);
        if self.kernel == RobustKernel::None {
            let c = r.norm_squared();
            return (r, 1.0, c);
        }
        let s = r.norm();
        let sw = self.kernel.weight(s).sqrt();
        (r * sw, sw, self.kernel.cost(s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Matrix3};

    #[test]
    fn information_and_covariance_agree() {
        let cov = Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0);
        let info = cov.try_inverse().unwrap_or_else(Matrix3::zeros);
        let a = GaussianNoise::from_covariance(&cov).unwrap_or_else(|e| panic!("{e}"));
        let b = GaussianNoise::from_information(&info).unwrap_or_else(|e| panic!("{e}"));
        let e = Vector6::new(0.3, -1.0, 2.0, 0.0, 0.0, 0.0);
        let expected = (e.fixed_rows::<3>(0).transpose() * info * e.fixed_rows::<3>(0))[(0, 0)];
        assert!((a.chi2(&e) - expected).abs() < 1e-12 * expected);
        assert!((b.chi2(&e) - expected).abs() < 1e-12 * expected);
        assert!((a.information().fixed_view::<3, 3>(0, 0) - info).amax() < 1e-12);
    }

    #[test]
    fn sigmas_hand_value() {
        // σ = (2, 0.5): e = (1, 1) → χ² = 1/4 + 4.
        let n = GaussianNoise::from_sigmas(&[2.0, 0.5]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(n.chi2(&Vector6::new(1.0, 1.0, 0.0, 0.0, 0.0, 0.0)), 4.25);
    }

    #[test]
    fn robust_costs_and_weights_hand_values() {
        let huber = RobustKernel::Huber { k: 2.0 };
        // Inside: s². Outside, s = 4: 2·2·4 − 4 = 12; w = 2/4.
        assert_eq!((huber.cost(1.5), huber.weight(1.5)), (2.25, 1.0));
        assert_eq!((huber.cost(4.0), huber.weight(4.0)), (12.0, 0.5));
        // Cauchy, k = 1, s = 1: ln 2; w = 1/2.
        let cauchy = RobustKernel::Cauchy { k: 1.0 };
        assert!((cauchy.cost(1.0) - std::f64::consts::LN_2).abs() < 1e-15);
        assert_eq!(cauchy.weight(1.0), 0.5);
        // A noise model applies it to the whitened norm: σ = 0.5, e = (3, 0) → s = 6.
        let n = GaussianNoise::from_sigmas(&[0.5, 0.5]).unwrap_or_else(|e| panic!("{e}")).with_kernel(huber);
        let e = Vector6::new(3.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(n.chi2(&e), 2.0 * 2.0 * 6.0 - 4.0);
        let (r, sw, c) = n.linearized(&e);
        assert_eq!((sw * sw, c), (2.0 / 6.0, 20.0));
        assert!((r[0] - 6.0 * (2.0f64 / 6.0).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn robust_cost_is_continuous_and_its_weight_is_its_slope() {
        // ρ′(s) = w(s)·s, checked by central differences of ρ = cost/2 at s across both kernels.
        for kernel in [RobustKernel::Huber { k: 1.345 }, RobustKernel::Cauchy { k: 2.3849 }] {
            for i in 1..60 {
                let s = 0.1 * f64::from(i);
                let h = 1e-6;
                let slope = (kernel.cost(s + h) - kernel.cost(s - h)) / (4.0 * h);
                assert!((slope - kernel.weight(s) * s).abs() < 1e-6, "{kernel:?} at {s}: {slope}");
                assert!(kernel.cost(s) <= s * s + 1e-12, "a kernel never costs more than least squares");
            }
        }
    }

    #[test]
    fn rejects_bad_matrices() {
        assert_eq!(GaussianNoise::from_information(&Matrix2::new(1.0, 2.0, 2.0, 1.0)), Err(NoiseError::NotPositiveDefinite(1)));
        assert!(matches!(GaussianNoise::from_information(&Matrix2::new(1.0, 0.5, 0.0, 1.0)), Err(NoiseError::NotSymmetric(_))));
        assert_eq!(GaussianNoise::from_sigmas(&[1.0, f64::NAN]), Err(NoiseError::NonFinite));
        assert_eq!(GaussianNoise::isotropic(7, 1.0), Err(NoiseError::BadDimension(7)));
    }
}
