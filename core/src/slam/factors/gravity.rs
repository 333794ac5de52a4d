//! Gravity (IMU accelerometer) factor on an SE(3) pose: the absolute roll and pitch a ground
//! robot's IMU measures, as the direction of "up" in the body frame.
//!
//! `e = (Rᵀ ẑ − u)_{x,y}`, with `R` the pose's rotation (world from body), ẑ the world's up and
//! `u` the measured up direction in the body frame (unit). Under `R · Exp(δφ)`,
//! `Exp(δφ)ᵀ Rᵀ ẑ ≈ Rᵀ ẑ + [Rᵀ ẑ]_× δφ`, so `∂e/∂δφ` is the top two rows of `[Rᵀ ẑ]_×` and
//! `∂e/∂δt = 0`. Yaw is unobservable (rotations about up leave `Rᵀ ẑ` unchanged), hence two
//! residual rows; for a near-level robot they are ≈ (−pitch, roll) errors in radians. O(1).

use super::{Factor, FactorError, GaussianNoise, Jacobian, MAX_FACTOR_KEYS, Residual, fetch};
use crate::slam::lie::hat;
use crate::slam::values::{Values, VarId};
use nalgebra::Vector3;

/// Absolute roll/pitch of one SE(3) pose from the measured gravity direction.
#[derive(Clone, Debug)]
pub struct GravitySe3 {
    keys: [VarId; 1],
    up_in_body: Vector3<f64>,
    noise: GaussianNoise,
}

impl GravitySe3 {
    /// `up_in_body` is normalised; `noise` must be 2-dimensional (radians, x and y of the body).
    pub fn new(key: VarId, up_in_body: Vector3<f64>, noise: GaussianNoise) -> Result<Self, FactorError> {
        let n = up_in_body.norm();
        if !(n.is_finite() && n > 1e-9) {
            return Err(FactorError::Degenerate("gravity direction of zero length"));
        }
        Ok(Self { keys: [key], up_in_body: up_in_body / n, noise })
    }

    fn eval(&self, up_predicted: &Vector3<f64>) -> Residual {
        let d = up_predicted - self.up_in_body;
        Residual::new(d.x, d.y, 0.0, 0.0, 0.0, 0.0)
    }
}

impl Factor for GravitySe3 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        let x = fetch!(values, self.keys[0], se3, "SE3");
        Ok(self.eval(&(x.rotation_matrix().transpose() * Vector3::z())))
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let x = fetch!(values, self.keys[0], se3, "SE3");
        let up = x.rotation_matrix().transpose() * Vector3::z();
        let j = &mut jac[0];
        j.fill(0.0);
        j.fixed_view_mut::<2, 3>(0, 3).copy_from(&hat(&up).fixed_rows::<2>(0));
        Ok(self.eval(&up))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::lie::Se3;
    use crate::slam::values::Variable;
    use nalgebra::{Rotation3, UnitQuaternion};

    #[test]
    fn error_is_the_tilt_of_the_pose_against_the_measured_up() {
        // Rx(r): Rᵀ ẑ = (0, sin r, cos r); measured level (ẑ) → e = (0, sin r).
        let r = 0.1_f64;
        let mut values = Values::new();
        let rot = Rotation3::from_euler_angles(r, 0.0, 0.7);
        let k = values.push(Variable::Se3(Se3::new(UnitQuaternion::from_rotation_matrix(&rot), Vector3::new(1.0, 2.0, 3.0))));
        let f = GravitySe3::new(k, Vector3::z(), GaussianNoise::isotropic(2, 0.01).unwrap()).unwrap();
        let e = f.error(&values).unwrap();
        assert!(e.x.abs() < 1e-12 && (e.y - r.sin()).abs() < 1e-12, "{e:?}");
        // Measuring the same tilt gives zero error, whatever the yaw.
        let f = GravitySe3::new(k, Vector3::new(0.0, r.sin(), r.cos()) * 2.0, GaussianNoise::isotropic(2, 0.01).unwrap()).unwrap();
        assert!(f.error(&values).unwrap().norm() < 1e-12);
        assert!(GravitySe3::new(k, Vector3::zeros(), GaussianNoise::isotropic(2, 0.01).unwrap()).is_err());
    }
}
