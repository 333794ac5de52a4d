//! Ground-truth localisation: the estimate is the true pose, its covariance 0.

use super::{LandmarkAverages, Localisation, LocalisationStats, Localiser, PoseCovariance, register_planar};
use crate::PointCloud;
use crate::pose::Pose2;
use crate::sim::world_sim::{Motion, WorldSim};
use crate::traversability::TraversabilityMap;
use nalgebra::Point3;

/// The true pose (no SLAM).
pub(crate) struct GroundTruth {
    est: Pose2,
    landmarks: LandmarkAverages,
}

impl GroundTruth {
    /// Starts at the simulated robot's true pose.
    pub fn new(sim: &WorldSim) -> Self {
        Self { est: sim.pose(), landmarks: LandmarkAverages::default() }
    }
}

impl Localiser for GroundTruth {
    fn kind(&self) -> Localisation {
        Localisation::GroundTruth
    }

    fn propagate(&mut self, sim: &mut WorldSim, motion: &Motion, dt_s: f64) {
        // The wheels still measure (the sensor noise stream is the same in every mode).
        let _ = sim.planar_odometry(motion, dt_s);
        self.est = sim.pose();
    }

    fn pose(&self) -> Pose2 {
        self.est
    }

    fn covariance(&self) -> PoseCovariance {
        PoseCovariance::default()
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
