//! The SLAM back end as the simulator and the robot see it ([`SlamBackend`]): keyframes in
//! (odometry, gravity, landmark observations), the keyframe poses, the landmarks with their
//! marginal covariances and the current pose's covariance out. [`super::GraphSlam`] implements it.

use nalgebra::{Matrix3, Matrix6, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::factors::NoiseError;
use super::graph::GraphError;
use super::incremental::IncrementalError;
use super::lie::Se3;
use super::marginals::MarginalError;
use super::optimizer::{OptError, Summary};

/// Proprioception between consecutive keyframes: the relative motion measured by odometry and,
/// optionally, the IMU's gravity direction at the new keyframe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// The new keyframe's body pose in the previous keyframe's body frame (metres).
    pub previous_from_current: Se3,
    /// Covariance in the tangent of `previous_from_current`, ξ = (δt, δφ), body frame.
    pub covariance: Matrix6<f64>,
    /// Absolute roll/pitch of the new keyframe ([`super::factors::GravitySe3`]); `None`: no IMU
    /// attitude (tilt then drifts with the odometry and is held only by landmarks).
    pub gravity: Option<Gravity>,
}

/// The accelerometer's "up" direction in the body frame and its angular noise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gravity {
    /// The "up" direction in the body frame (normalised by the factor; any non-zero length).
    pub up_in_body: Vector3<f64>,
    /// σ of the tilt, radians (per body axis).
    pub sigma_rad: f64,
}

/// A landmark seen from the current keyframe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LandmarkObservation {
    /// The landmark's id (data association is the caller's).
    pub landmark_id: u64,
    /// The landmark in the current keyframe's body frame, metres.
    pub point_in_robot: Vector3<f64>,
    /// Covariance of `point_in_robot`, m².
    pub covariance: Matrix3<f64>,
}

/// A landmark's estimate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LandmarkEstimate {
    /// The landmark's id, as observed.
    pub landmark_id: u64,
    /// The landmark in the world frame, metres.
    pub position_in_world: Vector3<f64>,
    /// Marginal covariance, m² (world frame).
    pub covariance: Matrix3<f64>,
}

/// What [`SlamBackend::add_keyframe`] did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KeyframeUpdate {
    /// Index of the new keyframe (the first one is 0).
    pub keyframe: usize,
    /// Landmarks that closed a loop.
    pub loop_closures: Vec<u64>,
    /// A loop closure outside the cool-down: the batch solver optimised the whole graph, the
    /// incremental one re-eliminated what the closure touched; old keyframes may have moved.
    pub full: bool,
    /// The batch solver's optimisation (`None` for the incremental one, which does not evaluate
    /// the whole graph's error per update).
    pub summary: Option<Summary>,
}

/// Traces of a 6×6 pose covariance (notes §1 asks to log all three).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CovarianceTraces {
    /// Trace of the whole block (m² + rad², what the paper plots).
    pub cov_trace: f64,
    /// Trace of the position block, m².
    pub pos_cov_trace: f64,
    /// Trace of the rotation block, rad².
    pub rot_cov_trace: f64,
}

impl CovarianceTraces {
    /// The traces of a covariance in (δt, δφ) order.
    pub fn of(covariance: &Matrix6<f64>) -> Self {
        let pos = covariance[(0, 0)] + covariance[(1, 1)] + covariance[(2, 2)];
        let rot = covariance[(3, 3)] + covariance[(4, 4)] + covariance[(5, 5)];
        Self { cov_trace: pos + rot, pos_cov_trace: pos, rot_cov_trace: rot }
    }
}

/// Why a SLAM back end could not take a keyframe or answer a query.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SlamError {
    /// An odometry, gravity or observation covariance cannot make a noise model.
    #[error("odometry or observation covariance: {0}")]
    Noise(#[from] NoiseError),
    /// A factor could not be added to the graph.
    #[error(transparent)]
    Graph(#[from] GraphError),
    /// The estimate holds the best values found.
    #[error("optimisation: {0}")]
    Optimization(#[from] OptError),
    /// The marginal covariances could not be computed.
    #[error("marginals: {0}")]
    Marginal(#[from] MarginalError),
    /// The incremental solver (iSAM2) failed.
    #[error("incremental solver: {0}")]
    Incremental(#[from] IncrementalError),
    /// An odometry, gravity direction or observation has a NaN or infinite entry (or a
    /// gravity direction of zero length).
    #[error("non-finite odometry or observation")]
    NonFinite,
}

/// A SLAM back end as the simulator and the robot see it.
pub trait SlamBackend {
    /// Adds a keyframe reached by `odometry` from the previous one, with what it observes, and
    /// updates the estimate.
    fn add_keyframe(&mut self, odometry: &Odometry, observations: &[LandmarkObservation]) -> Result<KeyframeUpdate, SlamError>;
    /// Optimises the whole graph (first keyframe anchored) to convergence.
    fn optimize_full(&mut self) -> Result<Summary, SlamError>;
    /// `world_from_keyframe` of every keyframe, oldest first.
    fn keyframe_poses(&self) -> Vec<Se3>;
    /// Landmarks by increasing id, with marginal covariances.
    fn landmarks(&self) -> Result<Vec<LandmarkEstimate>, SlamError>;
    /// Marginal covariance of the latest keyframe, ξ = (δt, δφ), body frame, anchored at the
    /// first keyframe.
    fn current_pose_covariance(&self) -> Result<Matrix6<f64>, SlamError>;
}
