//! A 2D landmark observed from an SE(2) pose as bearing and range (GTSAM
//! `BearingRangeFactor<Pose2, Point2>`, which GTSAM's `load2D` builds from Victoria Park's
//! `LANDMARK` lines). With `d = Rᵀ(m − t) = (dx, dy)`, `r = ‖d‖`:
//! `e = (wrap(atan2(dy, dx) − z_b), r − z_r)`, ordered (bearing, range) like GTSAM.
//! Jacobians under `x · Exp(ξ)`: `∂d/∂ρ = −I₂`, `∂d/∂φ = (dy, −dx)`, `∂d/∂m = Rᵀ`, then
//! `∂b/∂d = (−dy, dx)/r²`, `∂r/∂d = (dx, dy)/r`. O(1).

use nalgebra::{Matrix2, RowVector2, Vector2};

use super::{Factor, FactorError, GaussianNoise, Jacobian, MAX_FACTOR_KEYS, Residual, fetch};
use crate::math;
use crate::pose::wrap_pi;
use crate::slam::values::{Values, VarId};

/// A 2D landmark seen from an SE(2) pose as bearing and range (see the module doc).
#[derive(Clone, Debug)]
pub struct BearingRange2 {
    keys: [VarId; 2],
    bearing_rad: f64,
    range_m: f64,
    noise: GaussianNoise,
}

impl BearingRange2 {
    /// `noise` 2-dimensional, ordered (bearing, range).
    pub fn new(pose: VarId, landmark: VarId, bearing_rad: f64, range_m: f64, noise: GaussianNoise) -> Self {
        Self { keys: [pose, landmark], bearing_rad, range_m, noise }
    }

    /// The measured bearing from the robot's +x, counter-clockwise, radians.
    pub fn bearing_rad(&self) -> f64 {
        self.bearing_rad
    }

    /// The measured range, metres.
    pub fn range_m(&self) -> f64 {
        self.range_m
    }

    fn relative(&self, values: &Values) -> Result<(Vector2<f64>, Matrix2<f64>), FactorError> {
        let x = fetch!(values, self.keys[0], se2, "SE2");
        let m = fetch!(values, self.keys[1], point2, "Point2");
        let rt = x.rotation_matrix().transpose();
        let d = rt * (m - x.translation());
        if d.norm_squared() == 0.0 {
            return Err(FactorError::Degenerate("landmark at the robot's position"));
        }
        Ok((d, rt))
    }

    fn eval(&self, d: &Vector2<f64>) -> Residual {
        let b = wrap_pi(math::atan2(d.y, d.x) - self.bearing_rad);
        Residual::new(b, d.norm() - self.range_m, 0.0, 0.0, 0.0, 0.0)
    }
}

impl Factor for BearingRange2 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        Ok(self.eval(&self.relative(values)?.0))
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let (d, rt) = self.relative(values)?;
        let r2 = d.norm_squared();
        let r = r2.sqrt();
        // Rows: ∂(b, r)/∂d.
        let db = RowVector2::new(-d.y, d.x) / r2;
        let dr = RowVector2::new(d.x, d.y) / r;
        let d_dphi = Vector2::new(d.y, -d.x);
        let [jx, jm] = jac;
        jx.fill(0.0);
        jx.fixed_view_mut::<1, 2>(0, 0).copy_from(&(-db));
        jx[(0, 2)] = (db * d_dphi)[0];
        jx.fixed_view_mut::<1, 2>(1, 0).copy_from(&(-dr));
        jx[(1, 2)] = (dr * d_dphi)[0];
        jm.fill(0.0);
        jm.fixed_view_mut::<1, 2>(0, 0).copy_from(&(db * rt));
        jm.fixed_view_mut::<1, 2>(1, 0).copy_from(&(dr * rt));
        Ok(self.eval(&d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::lie::Se2;
    use crate::slam::values::Variable;

    #[test]
    fn error_hand_value_and_wrap() {
        // Robot at origin facing +y; landmark at (−3, 4): in the robot frame d = (4, 3),
        // bearing atan2(3, 4), range 5.
        let mut values = Values::new();
        let x = values.push(Variable::Se2(Se2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2)));
        let m = values.push(Variable::Point2(Vector2::new(-3.0, 4.0)));
        let noise = GaussianNoise::from_sigmas(&[0.1, 1.0]).unwrap();
        let f = BearingRange2::new(x, m, 0.5, 4.0, noise);
        let e = f.error(&values).unwrap();
        assert!((e.x - (3.0f64.atan2(4.0) - 0.5)).abs() < 1e-12 && (e.y - 1.0).abs() < 1e-12);
        // A measured bearing of +3.1 against a predicted bearing near −3.1 wraps to a small error.
        // Landmark at (0.4, −10): d = (−10, −0.4), predicted bearing ≈ −3.1016, error ≈ 0.082.
        let m2 = values.push(Variable::Point2(Vector2::new(0.4, -10.0)));
        let g = BearingRange2::new(x, m2, 3.1, 10.0, noise);
        let expected = (-0.4f64).atan2(-10.0) - 3.1 + std::f64::consts::TAU;
        assert!((g.error(&values).unwrap().x - expected).abs() < 1e-12);
    }

    #[test]
    fn landmark_on_robot_is_degenerate() {
        let mut values = Values::new();
        let x = values.push(Variable::Se2(Se2::new(1.0, 1.0, 0.0)));
        let m = values.push(Variable::Point2(Vector2::new(1.0, 1.0)));
        let f = BearingRange2::new(x, m, 0.0, 1.0, GaussianNoise::isotropic(2, 1.0).unwrap());
        assert!(matches!(f.error(&values), Err(FactorError::Degenerate(_))));
    }
}
