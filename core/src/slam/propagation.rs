//! First-order covariance propagation through SE(3) compositions (right perturbations,
//! ξ = (δt, δφ), body frame): a pose compounded with a relative motion, and a point seen from an
//! uncertain pose. Used by the keyframe front end and the pose-graph back end.

use nalgebra::{Matrix3, Matrix6, Vector3};

use super::lie::{Se3, hat};

/// Covariance of `T_k · T_rel` (right perturbations) from the keyframe's `Σ_k` and the
/// relative motion's `Σ_rel`, independent: `Ad(T_rel⁻¹) Σ_k Ad(T_rel⁻¹)ᵀ + Σ_rel`.
pub(crate) fn compound_covariance(keyframe: &Matrix6<f64>, keyframe_from_current: &Se3, relative: &Matrix6<f64>) -> Matrix6<f64> {
    let ad = keyframe_from_current.inverse().adjoint();
    let s = ad * keyframe * ad.transpose() + relative;
    (s + s.transpose()) * 0.5
}

/// A landmark's world covariance from one observation: `R C Rᵀ + G Σ Gᵀ`, `G = R [I, −[p]×]`
/// (first-order, pose and observation independent).
pub(crate) fn anchored_landmark_covariance(
    world_from_robot: &Se3,
    pose_covariance: &Matrix6<f64>,
    point_in_robot: &Vector3<f64>,
    observation: &Matrix3<f64>,
) -> Matrix3<f64> {
    let r = world_from_robot.rotation_matrix();
    let mut g = nalgebra::Matrix3x6::zeros();
    g.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    g.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-r * hat(point_in_robot)));
    let q = r * observation * r.transpose() + g * pose_covariance * g.transpose();
    (q + q.transpose()) * 0.5
}
