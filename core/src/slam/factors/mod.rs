//! Factors: the terms `‖e_k(X)‖²_{Σ_k}` of the SLAM cost (notes §1, paper eq. 1).
//!
//! A [`Factor`] connects at most [`MAX_FACTOR_KEYS`] variables, has a residual of at most
//! [`MAX_RESIDUAL_DIM`] rows and a [`GaussianNoise`]. It returns its *unwhitened* error `e` and
//! the Jacobians `∂e/∂ξ_k` with respect to a right perturbation of each variable
//! (`x_k · Exp(ξ_k)`, ξ = (δt, δφ); points additively), in fixed-size buffers so that
//! linearising a graph allocates nothing. Every implementation is checked against finite
//! differences by [`check_factor_jacobians`] (the conformance test at the bottom of this file
//! runs it on every factor type).

pub mod bearing_range;
pub mod between;
pub mod gravity;
pub mod noise;
pub mod point_observation;
pub mod prior;

pub use bearing_range::BearingRange2;
pub use between::{BetweenSe2, BetweenSe3};
pub use gravity::GravitySe3;
pub use noise::{GaussianNoise, NoiseError, RobustKernel};

pub use point_observation::{PointObservation2, PointObservation3};
pub use prior::{PriorSe2, PriorSe3};

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use thiserror::Error;

use super::lie::Se3;
use super::values::{Values, VarId};

/// How an SE(2) pose difference `D = a⁻¹ b` becomes a residual.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Se2Residual {
    /// `Log(D)` on SE(2) (GTSAM ≥ 4.3, whose `Pose2` chart is the Lie log). Default.
    #[default]
    Log,
    /// `(x, y, θ)` of D (g2o's `EdgeSE2` error, GTSAM < 4.3's default `Pose2` chart).
    Vector,
}

/// Largest residual dimension of any factor.
pub const MAX_RESIDUAL_DIM: usize = 6;
/// Largest number of variables one factor connects.
pub const MAX_FACTOR_KEYS: usize = 2;

/// A factor's error, in the first `residual_dim` rows.
pub type Residual = Vector6<f64>;
/// `∂e/∂ξ_k` in the top-left `residual_dim × dim(x_k)` block.
pub type Jacobian = Matrix6<f64>;

/// Why a factor could not be evaluated.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FactorError {
    /// The factor names a variable that the values do not hold.
    #[error("factor refers to variable {0:?}, which does not exist")]
    MissingVariable(VarId),
    /// A variable of the wrong kind (e.g. a point where the factor needs a pose).
    #[error("variable {key:?} is a {found}, the factor needs a {expected}")]
    WrongVariableType {
        /// The variable.
        key: VarId,
        /// The kind the factor needs.
        expected: &'static str,
        /// The variable's kind.
        found: &'static str,
    },
    /// The measurement is undefined at these values (e.g. a landmark at the robot's
    /// position for a bearing); the detail says which.
    #[error("degenerate measurement geometry: {0}")]
    Degenerate(&'static str),
}

/// One term of the cost.
pub trait Factor: core::fmt::Debug + Send + Sync {
    /// The variables, in the order of the Jacobians.
    fn keys(&self) -> &[VarId];

    /// The noise model (its dimension is the residual dimension).
    fn noise(&self) -> &GaussianNoise;

    /// Unwhitened error `e(X)`; rows past the residual dimension are zero.
    fn error(&self, values: &Values) -> Result<Residual, FactorError>;

    /// Error and Jacobians (one per key, written into `jacobians[k]`).
    fn linearize(&self, values: &Values, jacobians: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError>;

    /// Rows of the residual: the noise model's dimension.
    fn residual_dim(&self) -> usize {
        self.noise().dim()
    }

    /// eᵀ Ω e.
    fn chi2(&self, values: &Values) -> Result<f64, FactorError> {
        Ok(self.noise().chi2(&self.error(values)?))
    }

    /// What this factor measures between its two variables, in terms any graph format can
    /// write ([`Measurement`]); `None` for unary factors (priors, gravity). The robust kernel is
    /// not part of it.
    fn measurement(&self) -> Option<Measurement> {
        None
    }
}

/// A binary factor's measurement and its information Ω (the inverse covariance, in the factor's
/// tangent order), for exporters such as [`super::g2o`].
// Made one at a time while a graph is written; boxing the 6×6 would cost an allocation each.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Measurement {
    /// Relative pose `z ≈ x_from⁻¹ x_to`; Ω over (δt, δφ).
    Se3Between {
        /// The pose the measurement is taken from.
        from: VarId,
        /// The pose measured.
        to: VarId,
        /// Pose of `to` in the frame of `from` (translation in metres).
        z: Se3,
        /// Information matrix over (δt, δφ).
        information: Matrix6<f64>,
    },
    /// The point `point` seen from the pose `pose`, in the pose's frame.
    Point3InSe3 {
        /// The observing pose.
        pose: VarId,
        /// The landmark.
        point: VarId,
        /// The landmark in the pose's frame, metres.
        point_in_pose: Vector3<f64>,
        /// Information matrix of `point_in_pose`, m⁻².
        information: Matrix3<f64>,
    },
}

/// Looks up a variable of a given kind, with the factor errors.
macro_rules! fetch {
    ($values:expr, $key:expr, $getter:ident, $kind:literal) => {
        match $values.$getter($key) {
            Some(v) => v,
            None => {
                return Err(match $values.get($key) {
                    None => $crate::slam::factors::FactorError::MissingVariable($key),
                    Some(other) => {
                        $crate::slam::factors::FactorError::WrongVariableType { key: $key, expected: $kind, found: other.kind() }
                    }
                })
            }
        }
    };
}
pub(crate) use fetch;

/// Largest absolute difference between the analytic Jacobians of `factor` at `values` and
/// central finite differences (step `h`) of its error under `x_k ⊕ (h e_i)`. Both signs of the
/// step must give errors on the same branch (e.g. bearings away from ±π).
pub fn check_factor_jacobians(factor: &dyn Factor, values: &Values, h: f64) -> Result<f64, FactorError> {
    let mut jac = [Jacobian::zeros(); MAX_FACTOR_KEYS];
    factor.linearize(values, &mut jac)?;
    let e0 = factor.error(values)?;
    let d = factor.residual_dim();
    // The error from `linearize` must equal `error`.
    let mut worst = (factor.linearize(values, &mut [Jacobian::zeros(); MAX_FACTOR_KEYS])? - e0).amax();
    for (k, &key) in factor.keys().iter().enumerate() {
        let var = values.get(key).ok_or(FactorError::MissingVariable(key))?;
        for i in 0..var.dim() {
            let mut delta = [0.0; 6];
            delta[i] = h;
            let mut plus = values.clone();
            plus.set(key, var.retract(&delta));
            delta[i] = -h;
            let mut minus = values.clone();
            minus.set(key, var.retract(&delta));
            let col = (factor.error(&plus)? - factor.error(&minus)?) / (2.0 * h);
            for r in 0..d {
                worst = worst.max((col[r] - jac[k][(r, i)]).abs());
            }
        }
    }
    Ok(worst)
}

#[cfg(test)]
pub(crate) mod fixtures {
    //! One instance of every factor type at non-trivial values, for the conformance test.
    use super::*;
    use crate::slam::lie::{Se2, Se3};
    use crate::slam::values::Variable;
    use nalgebra::{Matrix3, Matrix6, Vector2, Vector3};

    pub fn se3(t: [f64; 3], phi: [f64; 3]) -> Se3 {
        Se3::exp(&Vector6::new(t[0], t[1], t[2], phi[0], phi[1], phi[2]))
    }

    /// Every factor type with values for its keys; `seed` varies the geometry.
    pub fn all_factors(seed: f64) -> Vec<(Box<dyn Factor>, Values)> {
        let s = seed;
        let mut out: Vec<(Box<dyn Factor>, Values)> = Vec::new();
        let info6 = {
            let a = Matrix6::from_fn(|i, j| ((i * 7 + j * 3) as f64 * 0.37 + s).sin() * 0.3);
            a * a.transpose() + Matrix6::identity() * 2.0
        };
        let info3 = Matrix3::new(40.0, 3.0, 1.0, 3.0, 25.0, -2.0, 1.0, -2.0, 90.0);

        // SE(2)
        let mut v2 = Values::new();
        let a = v2.push(Variable::Se2(Se2::new(1.0 + s, -2.0, 0.7 + s)));
        let b = v2.push(Variable::Se2(Se2::new(3.0, 0.5 * s, -2.4)));
        let l = v2.push(Variable::Point2(Vector2::new(4.0 - s, 6.0)));
        let z2 = Se2::new(0.3, -0.2, 0.4 * s - 1.0);
        let noise3 = GaussianNoise::from_information(&info3).unwrap_or_else(|e| panic!("{e}"));
        out.push((Box::new(PriorSe2::new(a, z2, noise3)), v2.clone()));
        out.push((Box::new(PriorSe2::new(a, z2, noise3).with_residual(Se2Residual::Vector)), v2.clone()));
        out.push((Box::new(BetweenSe2::new(a, b, z2, noise3)), v2.clone()));
        out.push((Box::new(BetweenSe2::new(a, b, z2, noise3).with_residual(Se2Residual::Vector)), v2.clone()));
        let br = GaussianNoise::from_sigmas(&[0.1, 0.5]).unwrap_or_else(|e| panic!("{e}"));
        out.push((Box::new(BearingRange2::new(b, l, 0.3 + s, 5.0, br)), v2.clone()));
        let info2 = nalgebra::Matrix2::new(30.0, -4.0, -4.0, 12.0);
        let noise2 = GaussianNoise::from_information(&info2).unwrap_or_else(|e| panic!("{e}"));
        out.push((Box::new(PointObservation2::new(a, l, Vector2::new(2.0 * s, -1.0), noise2)), v2));

        // SE(3)
        let mut v3 = Values::new();
        let a = v3.push(Variable::Se3(se3([1.0, 2.0, -s], [0.3, -0.5 + s, 1.2])));
        let b = v3.push(Variable::Se3(se3([-2.0, s, 0.5], [2.0, 0.4, -0.3 * s])));
        let m = v3.push(Variable::Point3(Vector3::new(3.0, -1.0 + s, 2.0)));
        let z3 = se3([0.5, -0.1, 0.2], [0.2 * s, 0.4, -0.8]);
        let noise6 = GaussianNoise::from_information(&info6).unwrap_or_else(|e| panic!("{e}"));
        out.push((Box::new(PriorSe3::new(a, z3, noise6)), v3.clone()));
        out.push((Box::new(BetweenSe3::new(a, b, z3, noise6)), v3.clone()));
        let g2 = GaussianNoise::from_sigmas(&[0.002, 0.003]).unwrap_or_else(|e| panic!("{e}"));
        let up = Vector3::new(0.1 * s, -0.05, 1.0);
        out.push((Box::new(GravitySe3::new(b, up, g2).unwrap_or_else(|e| panic!("{e}"))), v3.clone()));
        out.push((Box::new(PointObservation3::new(b, m, Vector3::new(1.0, 2.0, s), noise3)), v3));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Conformance: every factor type's Jacobians match finite differences (GTSAM's
    /// EXPECT_CORRECT_FACTOR_JACOBIANS), at several geometries.
    #[test]
    fn every_factor_has_correct_jacobians() {
        for seed in [0.0, 0.37, -0.81, 1.3] {
            let all = fixtures::all_factors(seed);
            assert_eq!(all.len(), 10, "one fixture per factor type and residual kind");
            for (factor, values) in &all {
                let worst = check_factor_jacobians(factor.as_ref(), values, 1e-6).unwrap_or_else(|e| panic!("{factor:?}: {e}"));
                assert!(worst < 1e-6, "{factor:?}: Jacobian off by {worst:e} at seed {seed}");
            }
        }
    }

    #[test]
    fn wrong_variable_kind_is_a_typed_error() {
        let all = fixtures::all_factors(0.0);
        // The SE(3) prior evaluated on the SE(2) values: variable 0 is an SE2.
        let (prior3, _) = &all[6];
        let (_, values2) = &all[0];
        assert_eq!(prior3.error(values2), Err(FactorError::WrongVariableType { key: VarId(0), expected: "SE3", found: "SE2" }));
        assert_eq!(prior3.error(&Values::new()), Err(FactorError::MissingVariable(VarId(0))));
    }
}
