//! Gaussian noise models: the square-root information `R` (Ω = RᵀR) that whitens a residual,
//! `r = R e`, so that χ² = ‖r‖² = eᵀ Ω e. Construction is a d×d Cholesky, O(d³), d ≤ 6.

use nalgebra::{Matrix6, SMatrix, Vector6};
use thiserror::Error;

use super::MAX_RESIDUAL_DIM;

#[derive(Clone, Debug, Error, PartialEq)]
pub enum NoiseError {
    #[error("noise model dimension {0} is not in 1..=6")]
    BadDimension(usize),
    #[error("noise matrix has a non-finite entry")]
    NonFinite,
    #[error("noise matrix is not symmetric (|M − Mᵀ| = {0:e})")]
    NotSymmetric(f64),
    #[error("noise matrix is not positive definite (pivot {0})")]
    NotPositiveDefinite(usize),
}

/// A Gaussian noise model of dimension `dim` ≤ 6.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianNoise {
    dim: usize,
    /// Top-left `dim × dim` block used; Ω = RᵀR.
    sqrt_info: Matrix6<f64>,
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
        Ok(Self { dim: D, sqrt_info: l.transpose() })
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
        Ok(Self { dim: D, sqrt_info: inv })
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
        Ok(Self { dim: d, sqrt_info: r })
    }

    /// `dim` independent components with standard deviation `sigma`.
    pub fn isotropic(dim: usize, sigma: f64) -> Result<Self, NoiseError> {
        if dim == 0 || dim > MAX_RESIDUAL_DIM {
            return Err(NoiseError::BadDimension(dim));
        }
        Self::from_sigmas(&[sigma; MAX_RESIDUAL_DIM][..dim])
    }

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

    /// Whitened residual `R e`.
    pub fn whiten(&self, error: &Vector6<f64>) -> Vector6<f64> {
        self.sqrt_info * error
    }

    /// eᵀ Ω e.
    pub fn chi2(&self, error: &Vector6<f64>) -> f64 {
        self.whiten(error).norm_squared()
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
    fn rejects_bad_matrices() {
        assert_eq!(GaussianNoise::from_information(&Matrix2::new(1.0, 2.0, 2.0, 1.0)), Err(NoiseError::NotPositiveDefinite(1)));
        assert!(matches!(GaussianNoise::from_information(&Matrix2::new(1.0, 0.5, 0.0, 1.0)), Err(NoiseError::NotSymmetric(_))));
        assert_eq!(GaussianNoise::from_sigmas(&[1.0, f64::NAN]), Err(NoiseError::NonFinite));
        assert_eq!(GaussianNoise::isotropic(7, 1.0), Err(NoiseError::BadDimension(7)));
    }
}
