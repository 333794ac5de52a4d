//! Between (odometry / loop-closure) factors: measurement `z ≈ x_i⁻¹ x_j` (g2o `EDGE_SE2`,
//! `EDGE_SE3:QUAT`; GTSAM `BetweenFactor`). O(1).
//!
//! SE(2), `D = x_i⁻¹ x_j`: by default `e = Log(z⁻¹ D)` (GTSAM 4.3's error: its `Pose2` chart
//! is the Lie log), `∂e/∂ξ_j = J_r⁻¹(e)`, `∂e/∂ξ_i = −J_r⁻¹(e) Ad(D⁻¹)`. With
//! [`Se2Residual::Vector`], g2o's `EdgeSE2` error `e = toVector(z⁻¹ D) = (R_zᵀ(t_D − t_z),
//! θ_D − θ_z)`, `∂e/∂ξ_j = [[R_zᵀ R_D, 0], [0, 1]]`, `∂e/∂ξ_i = [[−R_zᵀ, −R_zᵀ J t_D], [0, −1]]`
//! with `J = [[0, −1], [1, 0]]`. The two agree to first order; their χ² at a minimum differ
//! slightly, so compare χ² only between solvers using the same residual.
//!
//! SE(3): `e = Log(z⁻¹ x_i⁻¹ x_j)` (GTSAM's error with `Pose3` expmap, its default), with
//! `∂e/∂ξ_j = J_r⁻¹(e)`, `∂e/∂ξ_i = −J_r⁻¹(e) Ad(D⁻¹)`. g2o's own `EdgeSE3` uses
//! `(t, q_xyz)` of the same relative pose instead of `Log`; the two agree to first order in
//! translation and differ by a factor 2 in the rotation part (q_xyz ≈ φ/2), so χ² values from
//! g2o itself are not comparable with ours or GTSAM's on 3D files. The information matrix is
//! read in g2o's (t, R) order, which is our tangent order.

use nalgebra::Matrix2;

use super::{Factor, FactorError, GaussianNoise, Jacobian, MAX_FACTOR_KEYS, Measurement, Residual, Se2Residual, fetch};
use crate::slam::lie::{Se2, Se3, se2_right_jacobian_inv, se3_right_jacobian_inv};
use crate::slam::values::{Values, VarId};

/// Relative SE(2) pose measurement between `x_i` and `x_j`.
#[derive(Clone, Debug)]
pub struct BetweenSe2 {
    keys: [VarId; 2],
    measured: Se2,
    noise: GaussianNoise,
    residual: Se2Residual,
}

impl BetweenSe2 {
    /// `measured` = `i_from_j`; `noise` 3-dimensional, ordered (x, y, θ).
    pub fn new(i: VarId, j: VarId, measured: Se2, noise: GaussianNoise) -> Self {
        Self { keys: [i, j], measured, noise, residual: Se2Residual::Log }
    }

    /// Chooses the residual (default [`Se2Residual::Log`]).
    pub fn with_residual(mut self, residual: Se2Residual) -> Self {
        self.residual = residual;
        self
    }

    /// The measured `i_from_j`.
    pub fn measured(&self) -> &Se2 {
        &self.measured
    }

    fn eval(&self, xi: &Se2, xj: &Se2) -> (Residual, Se2) {
        let d = xi.between(xj);
        let zd = self.measured.between(&d);
        let e = match self.residual {
            Se2Residual::Log => zd.log(),
            Se2Residual::Vector => zd.to_vector(),
        };
        (Residual::new(e.x, e.y, e.z, 0.0, 0.0, 0.0), d)
    }
}

impl Factor for BetweenSe2 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        let xi = fetch!(values, self.keys[0], se2, "SE2");
        let xj = fetch!(values, self.keys[1], se2, "SE2");
        Ok(self.eval(&xi, &xj).0)
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let xi = fetch!(values, self.keys[0], se2, "SE2");
        let xj = fetch!(values, self.keys[1], se2, "SE2");
        let (e, d) = self.eval(&xi, &xj);
        if self.residual == Se2Residual::Log {
            let jr_inv = se2_right_jacobian_inv(&e.fixed_rows::<3>(0).into_owned());
            let [ji, jj] = jac;
            ji.fill(0.0);
            jj.fill(0.0);
            ji.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-(jr_inv * d.inverse().adjoint())));
            jj.fixed_view_mut::<3, 3>(0, 0).copy_from(&jr_inv);
            return Ok(e);
        }
        let rzt = self.measured.rotation_matrix().transpose();
        let j_t = Matrix2::new(0.0, -1.0, 1.0, 0.0) * d.translation();
        let [ji, jj] = jac;
        ji.fill(0.0);
        ji.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-rzt));
        ji.fixed_view_mut::<2, 1>(0, 2).copy_from(&(-(rzt * j_t)));
        ji[(2, 2)] = -1.0;
        jj.fill(0.0);
        jj.fixed_view_mut::<2, 2>(0, 0).copy_from(&(rzt * d.rotation_matrix()));
        jj[(2, 2)] = 1.0;
        Ok(e)
    }
}

/// Relative SE(3) pose measurement between `x_i` and `x_j`.
#[derive(Clone, Debug)]
pub struct BetweenSe3 {
    keys: [VarId; 2],
    measured: Se3,
    noise: GaussianNoise,
}

impl BetweenSe3 {
    /// `measured` = `i_from_j`; `noise` 6-dimensional, ordered (δt, δφ).
    pub fn new(i: VarId, j: VarId, measured: Se3, noise: GaussianNoise) -> Self {
        Self { keys: [i, j], measured, noise }
    }

    /// The measured `i_from_j`.
    pub fn measured(&self) -> &Se3 {
        &self.measured
    }
}

impl Factor for BetweenSe3 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn measurement(&self) -> Option<Measurement> {
        let [from, to] = self.keys;
        Some(Measurement::Se3Between { from, to, z: self.measured, information: self.noise.information() })
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        let xi = fetch!(values, self.keys[0], se3, "SE3");
        let xj = fetch!(values, self.keys[1], se3, "SE3");
        Ok(self.measured.local(&xi.between(&xj)))
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let xi = fetch!(values, self.keys[0], se3, "SE3");
        let xj = fetch!(values, self.keys[1], se3, "SE3");
        let d = xi.between(&xj);
        let e = self.measured.local(&d);
        let jr_inv = se3_right_jacobian_inv(&e);
        jac[0] = -(jr_inv * d.inverse().adjoint());
        jac[1] = jr_inv;
        Ok(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::values::Variable;

    #[test]
    fn se2_between_error_hand_value() {
        // x_i = (0, 0, π/2), x_j = (0, 1, π/2): D = (1, 0, 0). z = (0.9, 0, 0.1):
        // z⁻¹ D = (R(−0.1)·(0.1, 0), −0.1) = (0.1 cos 0.1, −0.1 sin 0.1, −0.1).
        let mut values = Values::new();
        let a = values.push(Variable::Se2(Se2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2)));
        let b = values.push(Variable::Se2(Se2::new(0.0, 1.0, std::f64::consts::FRAC_PI_2)));
        let noise = GaussianNoise::isotropic(3, 1.0).unwrap();
        let f = BetweenSe2::new(a, b, Se2::new(0.9, 0.0, 0.1), noise).with_residual(Se2Residual::Vector);
        let e = f.error(&values).unwrap();
        let expected = [0.1 * 0.1f64.cos(), -0.1 * 0.1f64.sin(), -0.1];
        for k in 0..3 {
            assert!((e[k] - expected[k]).abs() < 1e-12, "{e:?}");
        }
    }

    #[test]
    fn se3_between_is_zero_at_the_measurement() {
        let mut values = Values::new();
        let xi = super::super::fixtures::se3([1.0, -2.0, 0.5], [0.3, 0.2, -1.0]);
        let z = super::super::fixtures::se3([0.4, 0.1, -0.2], [0.0, 0.5, 0.1]);
        let a = values.push(Variable::Se3(xi));
        let b = values.push(Variable::Se3(xi * z));
        let f = BetweenSe3::new(a, b, z, GaussianNoise::isotropic(6, 1.0).unwrap());
        assert!(f.error(&values).unwrap().norm() < 1e-12);
    }
}
