//! Odometry in SE(3) between keyframes: increments, their covariance, compounding.

use nalgebra::{Matrix3, Matrix6, Vector3};

use crate::slam::Se3;
use crate::slam::lie::{hat, so3_exp};
use crate::slam::propagation::compound_covariance;

/// Diagonal floor of an odometry factor's covariance (m², rad²).
const COV_FLOOR: f64 = 1e-8;

/// One odometry tick measured in the body frame: distance driven along the body's x axis and
/// the gyro's rotation increment, with their noise variances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BodyIncrement {
    /// Distance driven, metres (negative when reversing).
    pub distance_m: f64,
    /// Rotation increment (roll, pitch, yaw axes of the body), radians.
    pub rotation_rad: Vector3<f64>,
    /// Variance of the distance, m².
    pub var_distance_m2: f64,
    /// Variance of the motion across the body's x–y plane (the wheels do not measure the
    /// terrain's curvature under the chord), m².
    pub var_vertical_m2: f64,
    /// Variance of the rotation increment per body axis (roll, pitch, yaw), rad².
    pub var_rotation_rad2: Vector3<f64>,
}

impl BodyIncrement {
    /// The tick's motion `ΔT = (Exp(δφ), Exp(δφ/2) (d, 0, 0))`.
    pub fn motion(&self) -> Se3 {
        let t = so3_exp(&(0.5 * self.rotation_rad)) * Vector3::new(self.distance_m, 0.0, 0.0);
        Se3::new(so3_exp(&self.rotation_rad), t)
    }
}

/// `T_rel · ΔT` and its covariance in the right tangent (ξ = (δt, δφ)) from `T_rel`'s
/// `covariance` and the tick's noise: `Σ' = Ad(ΔT⁻¹) Σ Ad(ΔT⁻¹)ᵀ + J Q Jᵀ`, where a noise
/// `n = (n_d, n_z, n_φ)` perturbs `ΔT` by `ρ = A (n_d e_x + n_z e_z − (d/2) [e_x]× n_φ)`,
/// `A = Exp(−δφ/2)`, and `φ = n_φ` (first order; the half-rotation puts half the tick's turn
/// noise on its lever).
pub(crate) fn propagate_relative(relative: &Se3, covariance: &Matrix6<f64>, step: &BodyIncrement) -> (Se3, Matrix6<f64>) {
    let motion = step.motion();
    let a = so3_exp(&(-0.5 * step.rotation_rad)).to_rotation_matrix().into_inner();
    let mut j = nalgebra::Matrix6x5::zeros();
    j.fixed_view_mut::<3, 1>(0, 0).copy_from(&a.column(0));
    j.fixed_view_mut::<3, 1>(0, 1).copy_from(&a.column(2));
    j.fixed_view_mut::<3, 3>(0, 2).copy_from(&(-0.5 * step.distance_m * a * hat(&Vector3::x())));
    j.fixed_view_mut::<3, 3>(3, 2).copy_from(&Matrix3::identity());
    let v = step.var_rotation_rad2;
    let q = nalgebra::Matrix5::from_diagonal(&nalgebra::Vector5::new(step.var_distance_m2, step.var_vertical_m2, v.x, v.y, v.z));
    let cov = compound_covariance(covariance, &motion, &(j * q * j.transpose()));
    (*relative * motion, cov)
}

/// `covariance` plus the diagonal floor (an odometry factor must be invertible).
pub(super) fn with_floor(covariance: &Matrix6<f64>) -> Matrix6<f64> {
    covariance + Matrix6::identity() * COV_FLOOR
}
