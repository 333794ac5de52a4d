//! The SLAM back end as the simulator and the robot see it ([`SlamBackend`]): keyframes in
//! (odometry, gravity, landmark observations), the keyframe poses, the landmarks with their
//! marginal covariances and the current pose's covariance out. Two models implement it: the
//! landmark smoother [`super::GraphSlam`] (keyframes and landmarks as variables) and the pose
//! graph [`super::PoseGraphSlam`] (keyframes only, landmarks anchored in them).

use nalgebra::{Matrix3, Matrix6, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::factors::NoiseError;
use super::g2o::G2oFile;
use super::graph::{FactorGraph, GraphError};
use super::incremental::IncrementalError;
use super::lie::Se3;
use super::marginals::{MarginalError, Marginals};
use super::optimizer::{OptError, Summary};
use super::values::{Values, VarId};

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

/// What a pose graph's links were so far (zeros for a model without such links).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkStats {
    /// Keyframes linked to the previous one by visual odometry (and the wheels).
    pub visual_links: u64,
    /// Keyframes linked to the previous one by the wheels alone (visual tracking lost, or no
    /// view shared with the previous keyframe).
    pub wheel_links: u64,
    /// Loop closures verified and accepted.
    pub closures_accepted: u64,
    /// Loop closures (verified or aliased) rejected by the gate.
    pub closures_rejected: u64,
    /// Wrong closures place recognition proposed (aliasing).
    pub false_closures: u64,
    /// … of which the gate let through.
    pub false_closures_accepted: u64,
}

/// A SLAM back end as the simulator and the robot see it.
pub trait SlamBackend: std::fmt::Debug + Send {
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
    /// Number of keyframes, the first included.
    fn keyframe_count(&self) -> usize;
    /// `world_from_robot` of the latest keyframe.
    fn current_pose(&self) -> Se3;
    /// Number of landmarks in the map.
    fn landmark_count(&self) -> usize;
    /// Whether landmark `landmark_id` is in the map.
    fn has_landmark(&self, landmark_id: u64) -> bool;
    /// Landmark positions by increasing id, without covariances. O(landmarks).
    fn landmark_positions(&self) -> Vec<(u64, Vector3<f64>)>;
    /// Landmarks last seen at keyframe `since_keyframe` or later, by increasing id, with their
    /// marginal covariances.
    fn recent_landmarks(&self, since_keyframe: usize) -> Result<Vec<LandmarkEstimate>, SlamError>;
    /// Whether [`Self::current_pose_covariance`] is cheap enough to ask at every keyframe (an
    /// incremental solver's root); otherwise the front end compounds odometry in between.
    fn exact_marginal_every_keyframe(&self) -> bool;
    /// Every factor (for inspection, export and tests).
    fn graph(&self) -> &FactorGraph;
    /// The current estimate of every variable, only the first keyframe fixed.
    fn estimate(&self) -> Values;
    /// Where the marginals are taken, only the first keyframe fixed (an incremental solver's
    /// linearisation point θ, the estimate being θ ⊕ Δ; a batch solver's estimate).
    fn linearization_point(&self) -> Values;
    /// The variable of the latest keyframe.
    fn current_variable(&self) -> VarId;
    /// Marginals of the full problem at the current estimate (one sparse factorisation of the
    /// whole graph: the reference for the incremental solvers' own).
    fn marginals(&self) -> Result<Marginals, SlamError>;
    /// The graph as a g2o file and how many factors have no g2o form (left out).
    fn to_g2o(&self) -> (G2oFile, usize);
    /// What its links were (a pose graph's; zeros by default).
    fn link_stats(&self) -> LinkStats {
        LinkStats::default()
    }
}
