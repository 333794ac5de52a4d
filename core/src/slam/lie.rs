//! Lie groups SO(3), SE(2) and SE(3): exp/log, composition, adjoints and the Jacobians of
//! `log` that the factors need (notes §1).
//!
//! **Perturbation convention (right / body frame):** `x ⊕ ξ = x · Exp(ξ)`.
//! **Tangent ordering: translation first, rotation second:** ξ = (δt, δφ), i.e. (ρx, ρy, φ) on
//! SE(2) and (ρx, ρy, ρz, φx, φy, φz) on SE(3). This is g2o's ordering of `EDGE_SE3:QUAT`
//! information matrices; GTSAM's `Pose3` tangent is (rotation, translation), so a GTSAM 6×6
//! covariance is ours with the two 3×3 halves swapped. A covariance in this tangent is expressed
//! in the body frame (as GTSAM's).
//!
//! Formulas (Barfoot, *State Estimation for Robotics*, §7.1; Solà et al. 2018, "A micro Lie
//! theory"): `Exp(ρ, φ) = (Exp(φ), J_l(φ) ρ)`, `Log` its inverse, `Ad_T = [[R, [t]× R], [0, R]]`,
//! and the SE(3) left Jacobian `[[J_l(φ), Q(ρ, φ)], [0, J_l(φ)]]`; `J_r(ξ) = J_l(−ξ)`. Every
//! function is O(1); small angles use Taylor series (|θ| below [`SMALL_ANGLE_RAD`]).

use nalgebra::{Matrix2, Matrix3, Matrix6, Quaternion, UnitQuaternion, Vector2, Vector3, Vector6};
use serde::{Deserialize, Serialize};
use std::ops::Mul;

use crate::math;
use crate::pose::wrap_pi;

/// Below this rotation angle the closed forms switch to Taylor series, radians.
pub const SMALL_ANGLE_RAD: f64 = 1e-4;

/// `[v]×`, the skew-symmetric matrix with `[v]× w = v × w`.
pub fn hat(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// SO(3) exponential of a rotation vector, as a unit quaternion.
pub fn so3_exp(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    let theta2 = phi.norm_squared();
    let theta = theta2.sqrt();
    // q = (cos θ/2, sin(θ/2)/θ · φ)
    let (w, k) = if theta < SMALL_ANGLE_RAD {
        (1.0 - theta2 / 8.0, 0.5 - theta2 / 48.0)
    } else {
        (math::cos(0.5 * theta), math::sin(0.5 * theta) / theta)
    };
    UnitQuaternion::new_normalize(Quaternion::new(w, k * phi.x, k * phi.y, k * phi.z))
}

/// SO(3) logarithm: the rotation vector φ with |φ| ≤ π and `so3_exp(φ) = q`.
pub fn so3_log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    // q and −q are the same rotation: take w ≥ 0 so that θ = 2·atan2(|v|, w) ∈ [0, π].
    let (w, v) = if q.w < 0.0 { (-q.w, -q.imag()) } else { (q.w, q.imag()) };
    let s = v.norm();
    if s < 1e-12 {
        // θ ≈ 2 s / w; φ = θ/s · v ≈ 2 v / w (1 − s²/(3 w²))
        v * (2.0 / w) * (1.0 - s * s / (3.0 * w * w))
    } else {
        v * (2.0 * math::atan2(s, w) / s)
    }
}

/// Coefficients (a, b) of `J_l(φ) = I + a [φ]× + b [φ]×²` with a = (1 − cos θ)/θ²,
/// b = (θ − sin θ)/θ³.
fn so3_jl_coefficients(theta: f64) -> (f64, f64) {
    let t2 = theta * theta;
    if theta < SMALL_ANGLE_RAD {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        ((1.0 - math::cos(theta)) / t2, (theta - math::sin(theta)) / (t2 * theta))
    }
}

/// SO(3) left Jacobian `J_l(φ)` (= `V` in `Exp(ρ, φ)`); the right Jacobian is `J_l(−φ)`.
pub fn so3_left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let (a, b) = so3_jl_coefficients(phi.norm());
    let h = hat(phi);
    Matrix3::identity() + h * a + h * h * b
}

/// Inverse of the SO(3) left Jacobian: `I − ½[φ]× + (1/θ² − (1 + cos θ)/(2 θ sin θ)) [φ]×²`.
pub fn so3_left_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let t2 = theta * theta;
    let c = if theta < SMALL_ANGLE_RAD {
        1.0 / 12.0 + t2 / 720.0
    } else {
        1.0 / t2 - (1.0 + math::cos(theta)) / (2.0 * theta * math::sin(theta))
    };
    let h = hat(phi);
    Matrix3::identity() - h * 0.5 + h * h * c
}

/// The `Q(ρ, φ)` block of the SE(3) left Jacobian (Barfoot eq. 7.86).
fn se3_q(rho: &Vector3<f64>, phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let t2 = theta * theta;
    let (c1, c2, c3) = if theta < SMALL_ANGLE_RAD {
        (1.0 / 6.0 - t2 / 120.0, 1.0 / 24.0 - t2 / 720.0, 1.0 / 120.0 - t2 / 2520.0)
    } else {
        let (s, c) = math::sin_cos(theta);
        let t3 = t2 * theta;
        ((theta - s) / t3, (t2 + 2.0 * c - 2.0) / (2.0 * t2 * t2), (2.0 * theta - 3.0 * s + theta * c) / (2.0 * t2 * t3))
    };
    let p = hat(phi);
    let r = hat(rho);
    let pr = p * r;
    let rp = r * p;
    let prp = pr * p;
    r * 0.5 + (pr + rp + prp) * c1 + (p * p * r + rp * p - prp * 3.0) * c2 + (prp * p + p * prp) * c3
}

/// A rigid transform in 3D, `parent_from_child`: `p_parent = rotation · p_child + translation`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Se3 {
    /// Rotation taking child-frame vectors to the parent frame.
    pub rotation: UnitQuaternion<f64>,
    /// The child frame's origin in the parent frame, metres.
    pub translation: Vector3<f64>,
}

impl Default for Se3 {
    fn default() -> Self {
        Self::identity()
    }
}

impl Se3 {
    /// The identity transform.
    pub fn identity() -> Self {
        Self { rotation: UnitQuaternion::identity(), translation: Vector3::zeros() }
    }

    /// A transform from its rotation and translation (metres).
    pub fn new(rotation: UnitQuaternion<f64>, translation: Vector3<f64>) -> Self {
        Self { rotation, translation }
    }

    /// Exp(ξ), ξ = (ρ, φ): `(Exp(φ), J_l(φ) ρ)`.
    pub fn exp(xi: &Vector6<f64>) -> Self {
        let rho = xi.fixed_rows::<3>(0).into_owned();
        let phi = xi.fixed_rows::<3>(3).into_owned();
        Self { rotation: so3_exp(&phi), translation: so3_left_jacobian(&phi) * rho }
    }

    /// Log(T) = (J_l(φ)⁻¹ t, φ) with φ = Log(R), |φ| ≤ π.
    pub fn log(&self) -> Vector6<f64> {
        let phi = so3_log(&self.rotation);
        let rho = so3_left_jacobian_inv(&phi) * self.translation;
        Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z)
    }

    /// `child_from_parent`.
    pub fn inverse(&self) -> Self {
        let r_inv = self.rotation.inverse();
        Self { rotation: r_inv, translation: -(r_inv * self.translation) }
    }

    /// `self⁻¹ · other`: `other` expressed in `self`'s frame.
    pub fn between(&self, other: &Self) -> Self {
        self.inverse() * *other
    }

    /// `self ⊕ ξ = self · Exp(ξ)` (right perturbation).
    pub fn retract(&self, xi: &Vector6<f64>) -> Self {
        *self * Self::exp(xi)
    }

    /// `Log(self⁻¹ · other)`, so that `self.retract(self.local(other)) = other`.
    pub fn local(&self, other: &Self) -> Vector6<f64> {
        self.between(other).log()
    }

    /// A child-frame point in the parent frame.
    pub fn transform_point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p + self.translation
    }

    /// A parent-frame point in the child frame.
    pub fn inverse_transform_point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.inverse() * (p - self.translation)
    }

    /// The rotation as a 3×3 matrix.
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        self.rotation.to_rotation_matrix().into_inner()
    }

    /// `Ad_T` with `T · Exp(ξ) · T⁻¹ = Exp(Ad_T ξ)`: `[[R, [t]× R], [0, R]]`.
    pub fn adjoint(&self) -> Matrix6<f64> {
        let r = self.rotation_matrix();
        let mut ad = Matrix6::zeros();
        ad.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        ad.fixed_view_mut::<3, 3>(0, 3).copy_from(&(hat(&self.translation) * r));
        ad.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
        ad
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.translation.iter().all(|v| v.is_finite()) && self.rotation.coords.iter().all(|v| v.is_finite())
    }
}

impl Mul for Se3 {
    type Output = Se3;
    fn mul(self, rhs: Se3) -> Se3 {
        Se3 { rotation: self.rotation * rhs.rotation, translation: self.rotation * rhs.translation + self.translation }
    }
}

/// SE(3) left Jacobian `J_l(ξ)`, ξ = (ρ, φ).
pub fn se3_left_jacobian(xi: &Vector6<f64>) -> Matrix6<f64> {
    let rho = xi.fixed_rows::<3>(0).into_owned();
    let phi = xi.fixed_rows::<3>(3).into_owned();
    let jl = so3_left_jacobian(&phi);
    let mut j = Matrix6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&jl);
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&se3_q(&rho, &phi));
    j.fixed_view_mut::<3, 3>(3, 3).copy_from(&jl);
    j
}

/// SE(3) inverse left Jacobian: `[[J⁻¹, −J⁻¹ Q J⁻¹], [0, J⁻¹]]` with `J = J_l(φ)`.
pub fn se3_left_jacobian_inv(xi: &Vector6<f64>) -> Matrix6<f64> {
    let rho = xi.fixed_rows::<3>(0).into_owned();
    let phi = xi.fixed_rows::<3>(3).into_owned();
    let jinv = so3_left_jacobian_inv(&phi);
    let mut j = Matrix6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&jinv);
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-(jinv * se3_q(&rho, &phi) * jinv)));
    j.fixed_view_mut::<3, 3>(3, 3).copy_from(&jinv);
    j
}

/// SE(3) inverse right Jacobian, `J_r⁻¹(ξ) = J_l⁻¹(−ξ)`: `Log(Exp(ξ) Exp(δ)) ≈ ξ + J_r⁻¹(ξ) δ`.
pub fn se3_right_jacobian_inv(xi: &Vector6<f64>) -> Matrix6<f64> {
    se3_left_jacobian_inv(&(-xi))
}

/// A rigid transform in the plane, `parent_from_child`, yaw wrapped to (−π, π].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Se2 {
    /// The child frame's origin along the parent's x axis, metres.
    pub x_m: f64,
    /// The child frame's origin along the parent's y axis, metres.
    pub y_m: f64,
    /// Angle from the parent's x axis to the child's, counter-clockwise, radians.
    pub yaw_rad: f64,
}

impl Default for Se2 {
    fn default() -> Self {
        Self::identity()
    }
}

/// (a, b) with `V(θ) = [[a, −b], [b, a]]`, a = sin θ / θ, b = (1 − cos θ)/θ.
fn se2_v_coefficients(theta: f64) -> (f64, f64) {
    if theta.abs() < SMALL_ANGLE_RAD {
        let t2 = theta * theta;
        (1.0 - t2 / 6.0, theta * (0.5 - t2 / 24.0))
    } else {
        (math::sin(theta) / theta, (1.0 - math::cos(theta)) / theta)
    }
}

impl Se2 {
    /// A pose; the yaw is wrapped to (−π, π].
    pub fn new(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        Self { x_m, y_m, yaw_rad: wrap_pi(yaw_rad) }
    }

    /// The identity transform.
    pub fn identity() -> Self {
        Self { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }
    }

    /// `(x_m, y_m)`.
    pub fn translation(&self) -> Vector2<f64> {
        Vector2::new(self.x_m, self.y_m)
    }

    /// The rotation by `yaw_rad` as a 2×2 matrix.
    pub fn rotation_matrix(&self) -> Matrix2<f64> {
        let (s, c) = math::sin_cos(self.yaw_rad);
        Matrix2::new(c, -s, s, c)
    }

    /// Exp(ξ), ξ = (ρx, ρy, φ): `(V(φ) ρ, φ)`.
    pub fn exp(xi: &Vector3<f64>) -> Self {
        let (a, b) = se2_v_coefficients(xi.z);
        Self::new(a * xi.x - b * xi.y, b * xi.x + a * xi.y, xi.z)
    }

    /// Log(T) = (V(θ)⁻¹ t, θ), θ ∈ (−π, π].
    pub fn log(&self) -> Vector3<f64> {
        let theta = self.yaw_rad;
        let (a, b) = se2_v_coefficients(theta);
        let det = a * a + b * b;
        let (x, y) = (self.x_m, self.y_m);
        Vector3::new((a * x + b * y) / det, (-b * x + a * y) / det, theta)
    }

    /// `(x, y, θ)`: g2o's `toVector`, GTSAM's default `Pose2` chart (not the Lie log).
    pub fn to_vector(&self) -> Vector3<f64> {
        Vector3::new(self.x_m, self.y_m, self.yaw_rad)
    }

    /// `child_from_parent` (yaw wrapped).
    pub fn inverse(&self) -> Self {
        let (s, c) = math::sin_cos(self.yaw_rad);
        Self::new(-(c * self.x_m + s * self.y_m), s * self.x_m - c * self.y_m, -self.yaw_rad)
    }

    /// `self⁻¹ · other`.
    pub fn between(&self, other: &Self) -> Self {
        self.inverse() * *other
    }

    /// `self ⊕ ξ = self · Exp(ξ)`.
    pub fn retract(&self, xi: &Vector3<f64>) -> Self {
        *self * Self::exp(xi)
    }

    /// A child-frame point in the parent frame.
    pub fn transform_point(&self, p: &Vector2<f64>) -> Vector2<f64> {
        self.rotation_matrix() * p + self.translation()
    }

    /// A parent-frame point in the child frame.
    pub fn inverse_transform_point(&self, p: &Vector2<f64>) -> Vector2<f64> {
        self.rotation_matrix().transpose() * (p - self.translation())
    }

    /// Whether x, y and yaw are all finite.
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.yaw_rad.is_finite()
    }

    /// `Log(self⁻¹ · other)`.
    pub fn local(&self, other: &Self) -> Vector3<f64> {
        self.between(other).log()
    }

    /// `Ad_T = [[R, (y, −x)ᵀ], [0, 1]]`, with `T · Exp(ξ) · T⁻¹ = Exp(Ad_T ξ)`.
    pub fn adjoint(&self) -> Matrix3<f64> {
        let r = self.rotation_matrix();
        Matrix3::new(r[(0, 0)], r[(0, 1)], self.y_m, r[(1, 0)], r[(1, 1)], -self.x_m, 0.0, 0.0, 1.0)
    }
}

/// SE(2) right Jacobian `J_r(ξ)`, ξ = (ρ1, ρ2, θ) (Solà et al. 2018, eq. 163):
/// `Log(Exp(ξ + δ)) ≈ ...`, `Exp(ξ + δ) ≈ Exp(ξ) Exp(J_r(ξ) δ)`.
pub fn se2_right_jacobian(xi: &Vector3<f64>) -> Matrix3<f64> {
    let (r1, r2, t) = (xi.x, xi.y, xi.z);
    // a = sin θ/θ, b = (1 − cos θ)/θ, c = (θ − sin θ)/θ², d = (1 − cos θ)/θ²
    let (a, b, c, d) = if t.abs() < SMALL_ANGLE_RAD {
        let t2 = t * t;
        (1.0 - t2 / 6.0, t * (0.5 - t2 / 24.0), t * (1.0 / 6.0 - t2 / 120.0), 0.5 - t2 / 24.0)
    } else {
        let (s, co) = math::sin_cos(t);
        (s / t, (1.0 - co) / t, (t - s) / (t * t), (1.0 - co) / (t * t))
    };
    Matrix3::new(a, b, r1 * c - r2 * d, -b, a, r1 * d + r2 * c, 0.0, 0.0, 1.0)
}

/// SE(2) inverse right Jacobian: `Log(Exp(ξ) Exp(δ)) ≈ ξ + J_r⁻¹(ξ) δ`. The 2×2 block
/// `[[a, b], [−b, a]]` is inverted in closed form (det = a² + b² > 0 for |θ| < 2π).
pub fn se2_right_jacobian_inv(xi: &Vector3<f64>) -> Matrix3<f64> {
    let j = se2_right_jacobian(xi);
    let (a, b) = (j[(0, 0)], j[(0, 1)]);
    let det = a * a + b * b;
    let inv2 = Matrix2::new(a, -b, b, a) / det;
    let top = -(inv2 * Vector2::new(j[(0, 2)], j[(1, 2)]));
    Matrix3::new(inv2[(0, 0)], inv2[(0, 1)], top.x, inv2[(1, 0)], inv2[(1, 1)], top.y, 0.0, 0.0, 1.0)
}

impl Mul for Se2 {
    type Output = Se2;
    fn mul(self, rhs: Se2) -> Se2 {
        let t = self.rotation_matrix() * rhs.translation() + self.translation();
        Se2::new(t.x, t.y, self.yaw_rad + rhs.yaw_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vec6(v: [f64; 6]) -> Vector6<f64> {
        Vector6::from_row_slice(&v)
    }

    fn se3_close(a: &Se3, b: &Se3, tol: f64) -> bool {
        (a.translation - b.translation).norm() < tol && a.rotation.angle_to(&b.rotation) < tol
    }

    #[test]
    fn hat_is_cross_product() {
        let a = Vector3::new(1.0, -2.0, 0.5);
        let b = Vector3::new(0.3, 4.0, -1.0);
        assert!((hat(&a) * b - a.cross(&b)).norm() < 1e-15);
    }

    #[test]
    fn so3_exp_of_quarter_turn_about_z() {
        // Hand-derived: Exp((0, 0, π/2)) maps x to y.
        let q = so3_exp(&Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
        assert!((q * Vector3::x() - Vector3::y()).norm() < 1e-15);
    }

    #[test]
    fn se3_exp_pure_translation_and_screw() {
        // φ = 0: Exp = (I, ρ).
        let t = Se3::exp(&vec6([1.0, 2.0, 3.0, 0.0, 0.0, 0.0]));
        assert!((t.translation - Vector3::new(1.0, 2.0, 3.0)).norm() < 1e-15);
        // ρ = (1, 0, 0), φ = (0, 0, π/2): J_l ρ = (sin θ/θ, (1 − cos θ)/θ, 0) = (2/π, 2/π, 0).
        let t = Se3::exp(&vec6([1.0, 0.0, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2]));
        let k = 2.0 / std::f64::consts::PI;
        assert!((t.translation - Vector3::new(k, k, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn se2_exp_matches_hand_derivation() {
        // ρ = (1, 0), φ = π/2 → t = (sin θ/θ, (1 − cos θ)/θ) = (2/π, 2/π).
        let t = Se2::exp(&Vector3::new(1.0, 0.0, std::f64::consts::FRAC_PI_2));
        let k = 2.0 / std::f64::consts::PI;
        assert!((t.x_m - k).abs() < 1e-15 && (t.y_m - k).abs() < 1e-15);
    }

    #[test]
    fn se2_composition_and_inverse() {
        let a = Se2::new(1.0, 2.0, 0.5);
        let b = Se2::new(-0.3, 0.7, 2.9);
        let c = a * b;
        // Hand check of the translation: R(0.5)·(−0.3, 0.7) + (1, 2).
        let (s, co) = 0.5f64.sin_cos();
        assert!((c.x_m - (co * -0.3 - s * 0.7 + 1.0)).abs() < 1e-15);
        assert!((c.yaw_rad - wrap_pi(3.4)).abs() < 1e-15);
        let id = a * a.inverse();
        assert!(id.x_m.abs() < 1e-15 && id.y_m.abs() < 1e-15 && id.yaw_rad.abs() < 1e-15);
    }

    #[test]
    fn adjoint_conjugates_exp() {
        let t = Se3::exp(&vec6([0.3, -1.0, 2.0, 0.4, -0.2, 1.1]));
        let xi = vec6([0.1, 0.2, -0.3, 0.05, 0.3, -0.2]);
        let lhs = t * Se3::exp(&xi) * t.inverse();
        let rhs = Se3::exp(&(t.adjoint() * xi));
        assert!(se3_close(&lhs, &rhs, 1e-12));
    }

    /// Finite-difference check of `Log(Exp(ξ) Exp(δ)) ≈ ξ + J_r⁻¹(ξ) δ`, also near zero angle.
    #[test]
    fn right_jacobian_inverse_matches_finite_differences() {
        for xi in [vec6([0.3, -1.0, 2.0, 0.4, -0.2, 1.1]), vec6([1.0, 2.0, -0.5, 1e-6, -2e-6, 5e-7]), vec6([0.2, 0.1, 0.3, 0.0, 0.0, 2.9])]
        {
            let jinv = se3_right_jacobian_inv(&xi);
            let x = Se3::exp(&xi);
            let h = 1e-6;
            for k in 0..6 {
                let mut d = Vector6::zeros();
                d[k] = h;
                let plus = (x * Se3::exp(&d)).log();
                d[k] = -h;
                let minus = (x * Se3::exp(&d)).log();
                let col = (plus - minus) / (2.0 * h);
                assert!((col - jinv.column(k)).norm() < 1e-7, "column {k} of J_r⁻¹({xi:?})");
            }
            // J_l and J_l⁻¹ are inverses.
            let prod = se3_left_jacobian(&xi) * se3_left_jacobian_inv(&xi);
            assert!((prod - Matrix6::identity()).norm() < 1e-12);
        }
    }

    #[test]
    fn se2_adjoint_and_right_jacobian_inverse() {
        let t = Se2::new(0.3, -1.0, 2.0);
        let xi = Vector3::new(0.1, -0.4, 0.7);
        let lhs = t * Se2::exp(&xi) * t.inverse();
        let rhs = Se2::exp(&(t.adjoint() * xi));
        assert!((lhs.to_vector() - rhs.to_vector()).norm() < 1e-12);
        for xi in [Vector3::new(0.3, -1.0, 2.0), Vector3::new(1.0, 2.0, 1e-6), Vector3::new(-0.5, 0.2, -2.8)] {
            let jinv = se2_right_jacobian_inv(&xi);
            let x = Se2::exp(&xi);
            let h = 1e-6;
            for k in 0..3 {
                let mut d = Vector3::zeros();
                d[k] = h;
                let plus = (x * Se2::exp(&d)).log();
                d[k] = -h;
                let minus = (x * Se2::exp(&d)).log();
                let col = (plus - minus) / (2.0 * h);
                assert!((col - jinv.column(k)).norm() < 1e-7, "column {k} of J_r⁻¹({xi:?})");
            }
        }
    }

    fn arb_vec6(max_angle: f64) -> impl Strategy<Value = Vector6<f64>> {
        (prop::array::uniform3(-10.0..10.0f64), prop::array::uniform3(-1.0..1.0f64), 0.0..max_angle).prop_map(|(t, axis, angle)| {
            let a = Vector3::from_row_slice(&axis);
            let n = a.norm();
            let phi = if n < 1e-9 { Vector3::zeros() } else { a * (angle / n) };
            Vector6::new(t[0], t[1], t[2], phi.x, phi.y, phi.z)
        })
    }

    proptest! {
        #[test]
        fn se3_exp_log_roundtrip(xi in arb_vec6(3.1)) {
            // log(exp(ξ)) = ξ for |φ| < π, and exp(log(x)) = x.
            let x = Se3::exp(&xi);
            prop_assert!((x.log() - xi).norm() < 1e-9 * (1.0 + xi.norm()));
            prop_assert!(se3_close(&Se3::exp(&x.log()), &x, 1e-9));
        }

        #[test]
        fn se3_small_angle_roundtrip(xi in arb_vec6(1e-3)) {
            let x = Se3::exp(&xi);
            prop_assert!((x.log() - xi).norm() < 1e-12 * (1.0 + xi.norm()));
        }

        #[test]
        fn se2_exp_log_roundtrip(x in -10.0..10.0f64, y in -10.0..10.0f64, th in -3.1..3.1f64) {
            let xi = Vector3::new(x, y, th);
            let t = Se2::exp(&xi);
            prop_assert!((t.log() - xi).norm() < 1e-9 * (1.0 + xi.norm()));
            let p = Se2::new(x, y, th);
            let back = Se2::exp(&p.log());
            prop_assert!((back.x_m - p.x_m).abs() < 1e-9 && (back.y_m - p.y_m).abs() < 1e-9);
            prop_assert!((back.yaw_rad - p.yaw_rad).abs() < 1e-12);
        }

        #[test]
        fn se3_local_inverts_retract(a in arb_vec6(3.0), d in arb_vec6(2.0)) {
            let x = Se3::exp(&a);
            let y = x.retract(&d);
            prop_assert!((x.local(&y) - d).norm() < 1e-8 * (1.0 + d.norm()));
        }
    }
}
