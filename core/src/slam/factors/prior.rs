//! Prior factors on a pose: `e = Local(z, x)`, the GTSAM `PriorFactor` error.
//!
//! SE(2): `e = Log(z⁻¹ x)` with Jacobian `J_r⁻¹(e)` under `x · Exp(ξ)` (default, GTSAM 4.3),
//! or with [`Se2Residual::Vector`] `e = (x, y, θ)` of `z⁻¹ x` with Jacobian
//! `[[R_zᵀ R_x, 0], [0, 1]]`. SE(3): `e = Log(z⁻¹ x)`, Jacobian `J_r⁻¹(e)`. All O(1).

use super::{Factor, FactorError, GaussianNoise, Jacobian, MAX_FACTOR_KEYS, Residual, Se2Residual, fetch};
use crate::slam::lie::{Se2, Se3, se2_right_jacobian_inv, se3_right_jacobian_inv};
use crate::slam::values::{Values, VarId};

/// Prior on an SE(2) pose.
#[derive(Clone, Debug)]
pub struct PriorSe2 {
    keys: [VarId; 1],
    prior: Se2,
    noise: GaussianNoise,
    residual: Se2Residual,
}

impl PriorSe2 {
    /// `noise` must be 3-dimensional, ordered (x, y, θ).
    pub fn new(key: VarId, prior: Se2, noise: GaussianNoise) -> Self {
        Self { keys: [key], prior, noise, residual: Se2Residual::Log }
    }

    /// Chooses the residual (default [`Se2Residual::Log`]).
    pub fn with_residual(mut self, residual: Se2Residual) -> Self {
        self.residual = residual;
        self
    }

    /// The pose the variable is pulled towards.
    pub fn prior(&self) -> &Se2 {
        &self.prior
    }

    fn eval(&self, x: &Se2) -> Residual {
        let d = self.prior.between(x);
        let e = match self.residual {
            Se2Residual::Log => d.log(),
            Se2Residual::Vector => d.to_vector(),
        };
        Residual::new(e.x, e.y, e.z, 0.0, 0.0, 0.0)
    }
}

impl Factor for PriorSe2 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        Ok(self.eval(&fetch!(values, self.keys[0], se2, "SE2")))
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let x = fetch!(values, self.keys[0], se2, "SE2");
        let e = self.eval(&x);
        let j = &mut jac[0];
        j.fill(0.0);
        match self.residual {
            Se2Residual::Log => {
                let jr = se2_right_jacobian_inv(&e.fixed_rows::<3>(0).into_owned());
                j.fixed_view_mut::<3, 3>(0, 0).copy_from(&jr);
            }
            Se2Residual::Vector => {
                let r = self.prior.rotation_matrix().transpose() * x.rotation_matrix();
                j.fixed_view_mut::<2, 2>(0, 0).copy_from(&r);
                j[(2, 2)] = 1.0;
            }
        }
        Ok(e)
    }
}

/// Prior on an SE(3) pose.
#[derive(Clone, Debug)]
pub struct PriorSe3 {
    keys: [VarId; 1],
    prior: Se3,
    noise: GaussianNoise,
}

impl PriorSe3 {
    /// `noise` must be 6-dimensional, ordered (δt, δφ).
    pub fn new(key: VarId, prior: Se3, noise: GaussianNoise) -> Self {
        Self { keys: [key], prior, noise }
    }

    /// The pose the variable is pulled towards.
    pub fn prior(&self) -> &Se3 {
        &self.prior
    }
}

impl Factor for PriorSe3 {
    fn keys(&self) -> &[VarId] {
        &self.keys
    }

    fn noise(&self) -> &GaussianNoise {
        &self.noise
    }

    fn error(&self, values: &Values) -> Result<Residual, FactorError> {
        Ok(self.prior.local(&fetch!(values, self.keys[0], se3, "SE3")))
    }

    fn linearize(&self, values: &Values, jac: &mut [Jacobian; MAX_FACTOR_KEYS]) -> Result<Residual, FactorError> {
        let e = self.prior.local(&fetch!(values, self.keys[0], se3, "SE3"));
        jac[0] = se3_right_jacobian_inv(&e);
        Ok(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::values::Variable;

    #[test]
    fn se2_prior_error_hand_value() {
        // z = (1, 0, π/2), x = (1, 2, π/2 + 0.1): z⁻¹x = (2, 0, 0.1) (R_zᵀ (0, 2) = (2, 0)).
        let mut values = Values::new();
        let k = values.push(Variable::Se2(Se2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2 + 0.1)));
        let noise = GaussianNoise::from_sigmas(&[1.0, 1.0, 0.1]).unwrap();
        let f = PriorSe2::new(k, Se2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2), noise).with_residual(Se2Residual::Vector);
        let e = f.error(&values).unwrap();
        assert!((e.x - 2.0).abs() < 1e-12 && e.y.abs() < 1e-12 && (e.z - 0.1).abs() < 1e-12);
        // χ² = 4 + (0.1/0.1)² = 5.
        assert!((f.chi2(&values).unwrap() - 5.0).abs() < 1e-9);
        // Log residual: V(0.1)⁻¹ (2, 0) with a = sin 0.1/0.1, b = (1 − cos 0.1)/0.1.
        let g = PriorSe2::new(k, Se2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2), noise);
        let (a, b) = (0.1f64.sin() / 0.1, (1.0 - 0.1f64.cos()) / 0.1);
        let e = g.error(&values).unwrap();
        let det = a * a + b * b;
        assert!((e.x - 2.0 * a / det).abs() < 1e-12 && (e.y + 2.0 * b / det).abs() < 1e-12);
    }
}
