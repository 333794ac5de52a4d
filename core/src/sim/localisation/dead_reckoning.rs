//! Dead reckoning: wheel odometry + IMU yaw integrated from the start, its (x, y, θ) covariance
//! propagated to first order (no loop closures, so it only grows).
//!
//! Per tick with measured distance d and heading change δθ at mid-heading θ_m = θ + δθ/2:
//! x' = x + d cos θ_m, y' = y + d sin θ_m, θ' = θ + δθ; Σ' = F Σ Fᵀ + L Q Lᵀ with
//! F = ∂(x', y', θ')/∂(x, y, θ), L = ∂(x', y', θ')/∂(d, δθ), Q = diag(σ_d², σ_θ²) from the
//! odometry's noise model (`crate::sim::odometry`).

use super::{LandmarkAverages, Localisation, LocalisationStats, Localiser, PoseCovariance, register_planar};
use crate::PointCloud;
use crate::math;
use crate::pose::{Pose2, wrap_pi};
use crate::sim::odometry::OdometryNoise;
use crate::sim::world_sim::{Motion, WorldSim};
use crate::traversability::TraversabilityMap;
use nalgebra::{Matrix2, Matrix3, Matrix3x2, Point3};

/// Dead-reckoned odometry.
pub(crate) struct DeadReckoning {
    est: Pose2,
    cov: Matrix3<f64>,
    noise: OdometryNoise,
    landmarks: LandmarkAverages,
}

impl DeadReckoning {
    pub fn new(sim: &WorldSim) -> Self {
        Self { est: sim.pose(), cov: Matrix3::zeros(), noise: sim.odometry_noise().clone(), landmarks: LandmarkAverages::default() }
    }
}

impl Localiser for DeadReckoning {
    fn kind(&self) -> Localisation {
        Localisation::Odometry
    }

    fn propagate(&mut self, sim: &mut WorldSim, motion: &Motion, dt_s: f64) {
        let (ms, mth) = sim.planar_odometry(motion, dt_s);
        let th = self.est.yaw_rad + 0.5 * mth;
        let (c, s) = (math::cos(th), math::sin(th));
        self.est = Pose2 { x_m: self.est.x_m + ms * c, y_m: self.est.y_m + ms * s, yaw_rad: wrap_pi(self.est.yaw_rad + mth) };
        let f = Matrix3::new(1.0, 0.0, -ms * s, 0.0, 1.0, ms * c, 0.0, 0.0, 1.0);
        let (vs, vt) = self.noise.variances(motion.ds_m, motion.dtheta_rad, dt_s);
        let l = Matrix3x2::new(c, -0.5 * ms * s, s, 0.5 * ms * c, 0.0, 1.0);
        let q = Matrix2::new(vs, 0.0, 0.0, vt);
        self.cov = f * self.cov * f.transpose() + l * q * l.transpose();
    }

    fn pose(&self) -> Pose2 {
        self.est
    }

    fn covariance(&self) -> PoseCovariance {
        let c = &self.cov;
        PoseCovariance { xy_yaw: *c, pos_trace: c[(0, 0)] + c[(1, 1)], rot_trace: c[(2, 2)], full6: None }
    }

    fn register(&mut self, sim: &WorldSim, points: &[Point3<f64>], map: &mut TraversabilityMap) {
        register_planar(sim, self.est, points, map);
    }

    fn observe(&mut self, sim: &mut WorldSim) {
        let est = self.body_pose(sim);
        self.landmarks.observe(sim, est);
    }

    fn landmark_map(&self, sigma_landmark_m: f64) -> PointCloud {
        self.landmarks.cloud(sigma_landmark_m)
    }

    fn stats(&self) -> LocalisationStats {
        LocalisationStats { landmarks_mapped: self.landmarks.len(), ..LocalisationStats::default() }
    }
}
