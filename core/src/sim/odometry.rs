//! Wheel odometry with an IMU yaw (notes §8). Over one control step the robot moves δs along its
//! heading and turns δθ (ground truth). Measured:
//! - δs_m = δs · (1 + slip) + n_s, slip = `slip_per_rad` · slope (wheels spin more than the
//!   body moves on a slope), n_s ~ N(0, σ_s² |δs|) with σ_s = `distance_sigma_per_sqrt_m`;
//! - δθ_m = δθ + n_θ, n_θ ~ N(0, σ_r² |δθ| + σ_rd² |δs|) (wheels), or with `use_imu_yaw`
//!   n_θ ~ N(0, σ_g² dt) (gyro integration).
//!
//! So the variance grows linearly with distance travelled and angle turned (a random walk).
//! O(1) per step.

use super::lidar::gaussian;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Odometry noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OdometryNoise {
    /// σ_s, m/√m, ≥ 0: distance noise. Default 0.02 (2 cm RMS after 1 m).
    pub distance_sigma_per_sqrt_m: f64,
    /// σ_r, rad/√rad, ≥ 0: wheel heading noise per angle turned. Default 0.03.
    pub rotation_sigma_per_sqrt_rad: f64,
    /// σ_rd, rad/√m, ≥ 0: wheel heading noise per distance. Default 0.01.
    pub rotation_sigma_per_sqrt_m: f64,
    /// Slip fraction per radian of slope, ≥ 0. Default 0.1.
    pub slip_per_rad: f64,
    /// Use the gyro for δθ instead of the wheels. Default true.
    pub use_imu_yaw: bool,
    /// Gyro angle random walk σ_g, rad/√s, ≥ 0. Default 0.002.
    pub gyro_sigma_per_sqrt_s: f64,
}

impl Default for OdometryNoise {
    fn default() -> Self {
        Self {
            distance_sigma_per_sqrt_m: 0.02,
            rotation_sigma_per_sqrt_rad: 0.03,
            rotation_sigma_per_sqrt_m: 0.01,
            slip_per_rad: 0.1,
            use_imu_yaw: true,
            gyro_sigma_per_sqrt_s: 0.002,
        }
    }
}

impl OdometryNoise {
    /// Variances (δs, δθ) of one step's measurement noise (slip excluded).
    pub fn variances(&self, ds_m: f64, dtheta_rad: f64, dt_s: f64) -> (f64, f64) {
        let vs = self.distance_sigma_per_sqrt_m.powi(2) * ds_m.abs();
        let vt = if self.use_imu_yaw {
            self.gyro_sigma_per_sqrt_s.powi(2) * dt_s
        } else {
            self.rotation_sigma_per_sqrt_rad.powi(2) * dtheta_rad.abs() + self.rotation_sigma_per_sqrt_m.powi(2) * ds_m.abs()
        };
        (vs, vt)
    }

    /// A measured (δs, δθ) for a true step on a slope of `slope_rad`.
    pub(crate) fn measure(&self, ds_m: f64, dtheta_rad: f64, dt_s: f64, slope_rad: f64, rng: &mut ChaCha8Rng) -> (f64, f64) {
        let (vs, vt) = self.variances(ds_m, dtheta_rad, dt_s);
        let slip = self.slip_per_rad * slope_rad.abs();
        (ds_m * (1.0 + slip) + vs.sqrt() * gaussian(rng), dtheta_rad + vt.sqrt() * gaussian(rng))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn distance_noise_variance_grows_linearly_and_slip_biases() {
        let noise = OdometryNoise::default();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        // 10 m in 0.04 m steps, 2000 trials: final error variance = σ_s² · 10 m = 0.004 m².
        let trials = 2000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..trials {
            let mut s = 0.0;
            for _ in 0..250 {
                s += noise.measure(0.04, 0.0, 0.1, 0.0, &mut rng).0;
            }
            sum += s - 10.0;
            sum2 += (s - 10.0).powi(2);
        }
        let mean = sum / trials as f64;
        let var = sum2 / trials as f64 - mean * mean;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 0.004).abs() < 0.0006, "{var}"); // ±15 % (sampling σ ≈ 3 %)
        // On a 0.2 rad slope: +2 % distance.
        let mut s = 0.0;
        for _ in 0..250 {
            s += noise.measure(0.04, 0.0, 0.1, 0.2, &mut rng).0;
        }
        assert!((s - 10.2).abs() < 0.25, "{s}");
    }

    #[test]
    fn gyro_yaw_noise_is_a_random_walk_in_time() {
        let noise = OdometryNoise::default();
        let (_, vt) = noise.variances(0.04, 0.1, 0.1);
        assert!((vt - 0.002f64.powi(2) * 0.1).abs() < 1e-15);
        let wheels = OdometryNoise { use_imu_yaw: false, ..OdometryNoise::default() };
        let (_, vt) = wheels.variances(0.04, 0.1, 0.1);
        assert!((vt - (0.03f64.powi(2) * 0.1 + 0.01f64.powi(2) * 0.04)).abs() < 1e-15);
    }
}
