//! A landmark observed from a pose as a point in the robot frame (notes §1; g2o's
//! `EdgeSE3PointXYZ` and `EdgeSE2PointXY`): `e = x⁻¹ m − z = Rᵀ(m − t) − z`. With
//! `p = Rᵀ(m − t)`, the Jacobians under `x · Exp(ξ)`, ξ = (δt, δφ), are
//! - 3D: `∂e/∂ξ = [−I₃, [p]×]` (the same form as notes §6), `∂e/∂m = Rᵀ`;
//! - 2D: `∂e/∂ξ = [−I₂, (p_y, −p_x)ᵀ]`, `∂e/∂m = Rᵀ`.
//!
//! O(1).

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

use super::{Factor, FactorError, GaussianNoise, Jacobian, MAX_FACTOR_KEYS, Measurement, Residual, fetch};
use crate::slam::lie::hat;
use crate::slam::values::{Values, VarId};

/// A 3D landmark seen from an SE(3) pose as a point in the robot frame (see the module doc).
#[derive(Clone, Debug)]
pub struct PointObservation3 {
    keys: [VarId; 2],
    point_in_robot: Vector3<f64>,
    noise: GaussianNoise,
}

impl PointObservation3 {
    /// `noise` 3-dimensional, in the robot frame.
    pub fn new(pose: VarId, landmark: VarId, point_in_robot: Vector3<f64>, noise: GaussianNoise) -> Self {
        Self { keys: [pose, landmark], point_in_robot, noise }
    }

    /// The measured point in the robot frame, metres.
    pub fn point_in_robot(&self) -> &Vector3<f64> {
        &self.point_in_robot
    }
}

impl Factor for PointObservation3 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn measurement(&self) -> Option<Measurement> {
        let [pose, point] = self.keys;
        let information = self.noise.information().fixed_view::<3, 3>(0, 0).into_owned();
        Some(Measurement::Point3InSe3 { pose, point, point_in_pose: self.point_in_robot, information })
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        let x = fetch!(values, self.keys[0], se3, "SE3");
        let m = fetch!(values, self.keys[1], point3, "Point3");
        let e = x.inverse_transform_point(&m) - self.point_in_robot;
        Ok(Residual::new(e.x, e.y, e.z, 0.0, 0.0, 0.0))
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let x = fetch!(values, self.keys[0], se3, "SE3");
        let m = fetch!(values, self.keys[1], point3, "Point3");
        let p = x.inverse_transform_point(&m);
        let [jx, jm] = jac;
        jx.fill(0.0);
        jx.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-Matrix3::identity()));
        jx.fixed_view_mut::<3, 3>(0, 3).copy_from(&hat(&p));
        jm.fill(0.0);
        jm.fixed_view_mut::<3, 3>(0, 0).copy_from(&x.rotation_matrix().transpose());
        let e = p - self.point_in_robot;
        Ok(Residual::new(e.x, e.y, e.z, 0.0, 0.0, 0.0))
    }
}

/// The 2D form: an SE(2) pose and a 2D landmark.
#[derive(Clone, Debug)]
pub struct PointObservation2 {
    keys: [VarId; 2],
    point_in_robot: Vector2<f64>,
    noise: GaussianNoise,
}

impl PointObservation2 {
    /// `noise` 2-dimensional, in the robot frame.
    pub fn new(pose: VarId, landmark: VarId, point_in_robot: Vector2<f64>, noise: GaussianNoise) -> Self {
        Self { keys: [pose, landmark], point_in_robot, noise }
    }

    /// The measured point in the robot frame, metres.
    pub fn point_in_robot(&self) -> &Vector2<f64> {
        &self.point_in_robot
    }
}

impl Factor for PointObservation2 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        let x = fetch!(values, self.keys[0], se2, "SE2");
        let m = fetch!(values, self.keys[1], point2, "Point2");
        let e = x.inverse_transform_point(&m) - self.point_in_robot;
        Ok(Residual::new(e.x, e.y, 0.0, 0.0, 0.0, 0.0))
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let x = fetch!(values, self.keys[0], se2, "SE2");
        let m = fetch!(values, self.keys[1], point2, "Point2");
        let p = x.inverse_transform_point(&m);
        let [jx, jm] = jac;
        jx.fill(0.0);
        jx.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-Matrix2::identity()));
        jx[(0, 2)] = p.y;
        jx[(1, 2)] = -p.x;
        jm.fill(0.0);
        jm.fixed_view_mut::<2, 2>(0, 0).copy_from(&x.rotation_matrix().transpose());
        let e = p - self.point_in_robot;
        Ok(Residual::new(e.x, e.y, 0.0, 0.0, 0.0, 0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::lie::{Se3, so3_exp};
    use crate::slam::values::Variable;

    #[test]
    fn error_hand_value() {
        // Robot at (1, 0, 0) turned π/2 about z; landmark at (1, 2, 0) is 2 m ahead: p = (2, 0, 0).
        let mut values = Values::new();
        let pose = Se3::new(so3_exp(&Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2)), Vector3::new(1.0, 0.0, 0.0));
        let x = values.push(Variable::Se3(pose));
        let m = values.push(Variable::Point3(Vector3::new(1.0, 2.0, 0.0)));
        let f = PointObservation3::new(x, m, Vector3::new(2.0, 0.5, 0.0), GaussianNoise::isotropic(3, 0.5).unwrap());
        let e = f.error(&values).unwrap();
        assert!((e - Residual::new(0.0, -0.5, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-12);
        // χ² = (0.5/0.5)² = 1.
        assert!((f.chi2(&values).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn error_hand_value_2d() {
        // Robot at (1, 0) facing +y; landmark at (1, 3) is 3 m ahead: p = (3, 0).
        use crate::slam::lie::Se2;
        let mut values = Values::new();
        let x = values.push(Variable::Se2(Se2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2)));
        let m = values.push(Variable::Point2(Vector2::new(1.0, 3.0)));
        let f = PointObservation2::new(x, m, Vector2::new(2.5, 0.2), GaussianNoise::from_sigmas(&[0.5, 0.1]).unwrap());
        let e = f.error(&values).unwrap();
        assert!((e - Residual::new(0.5, -0.2, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-12);
        // χ² = (0.5/0.5)² + (0.2/0.1)² = 5.
        assert!((f.chi2(&values).unwrap() - 5.0).abs() < 1e-12);
    }
}
