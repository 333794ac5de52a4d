//! How the simulated robot knows where it is, behind one trait (`Localiser`): the true pose
//! (`GroundTruth`), dead-reckoned wheel odometry + IMU yaw (`DeadReckoning`), or keyframe
//! SLAM (`KeyframeSlamLocaliser`, notes §1) with either back end: the landmark smoother or the
//! pose graph. Each turns the world simulator's
//! measurements ([`WorldSim`]) into an estimate, registers the sensed points into the robot's map
//! with it, and keeps the landmark map the planner's u2 reads.
//!
//! ATE is the 3D distance between the estimated and the true body positions; without SLAM the
//! estimate's height and attitude are the terrain's under the planar estimate (odometry alone does
//! not estimate them).

mod dead_reckoning;
mod ground_truth;
mod keyframe_slam;
mod tracking;

pub(crate) use dead_reckoning::DeadReckoning;
pub(crate) use ground_truth::GroundTruth;
pub(crate) use keyframe_slam::KeyframeSlamLocaliser;
pub(crate) use tracking::TrackingStats;
pub use tracking::{LOSS_GROUND_RADIUS_M, TRACKING_LOSSES_HEADER, TrackingLoss, tracking_losses_csv};

use super::world_sim::{BodyPose, Motion, WorldSim};
use crate::PointCloud;
use crate::slam::keyframes::SlamFrontend;
use crate::traversability::TraversabilityMap;
use nalgebra::{Matrix3, Matrix6, Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How the robot knows where it is.
///
/// # Examples
///
/// ```
/// use fitslam_core::Localisation;
///
/// let slam: Localisation = "slam".parse()?;
/// assert_eq!(slam, Localisation::Slam);
/// assert_eq!("ground_truth".parse::<Localisation>()?, Localisation::GroundTruth);
/// assert_eq!(Localisation::GroundTruth.to_string(), "ground-truth");
/// let error = "gps".parse::<Localisation>().unwrap_err();
/// assert_eq!(error.expected, "ground-truth, odometry, slam, pose-graph");
/// assert_eq!("pose_graph".parse::<Localisation>()?, Localisation::PoseGraph);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Localisation {
    /// The true pose, covariance 0 (no SLAM).
    GroundTruth,
    /// Dead-reckoned wheel odometry + IMU yaw, covariance propagated (no loop closures).
    Odometry,
    /// Keyframe SLAM with the landmark smoother (odometry + IMU + camera landmarks as
    /// variables, loop closures through re-observed landmarks): 6×6 marginal covariance, map
    /// re-registration.
    Slam,
    /// Keyframe SLAM with the pose graph (RTAB-Map's class: visual-odometry and loop-closure
    /// links between keyframes, landmarks anchored in them): 6×6 marginal covariance, map
    /// re-registration.
    PoseGraph,
}

impl Localisation {
    /// Every variant, in declaration order.
    pub const ALL: [Localisation; 4] = [Localisation::GroundTruth, Localisation::Odometry, Localisation::Slam, Localisation::PoseGraph];

    /// The name used on the command line, in the studio and in file names (`ground-truth`).
    pub fn name(self) -> &'static str {
        match self {
            Localisation::GroundTruth => "ground-truth",
            Localisation::Odometry => "odometry",
            Localisation::Slam => "slam",
            Localisation::PoseGraph => "pose-graph",
        }
    }

    /// Whether a keyframe SLAM localises (either back end).
    pub fn is_slam(self) -> bool {
        matches!(self, Localisation::Slam | Localisation::PoseGraph)
    }
}

impl std::fmt::Display for Localisation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Localisation {
    type Err = crate::params::UnknownName;

    /// `ground-truth` (or `ground_truth`), `odometry`, `slam`, `pose-graph` (or `pose_graph`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.replace('_', "-");
        Self::ALL.into_iter().find(|l| l.name() == s).ok_or_else(|| crate::params::UnknownName::new("localisation", &s, &Self::ALL))
    }
}

/// The uncertainty of an estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseCovariance {
    /// (x, y, yaw) covariance, world axes.
    pub xy_yaw: Matrix3<f64>,
    /// Trace of the position block, m² (SLAM: of the 6×6 marginal; else σx² + σy²).
    pub pos_trace: f64,
    /// Trace of the rotation block, rad² (SLAM: of the 6×6 marginal; else σ_yaw²).
    pub rot_trace: f64,
    /// The body pose's whole 6×6 marginal in the right-perturbation (δt, δφ), SLAM only.
    pub full6: Option<Matrix6<f64>>,
}

/// Counters of the SLAM's work (zeros without SLAM).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LocalisationStats {
    pub loop_closures: u64,
    pub keyframes: usize,
    /// Traversability map rebuilds after loop closures.
    pub reregistrations: u64,
    /// Keyframe updates whose optimisation or covariance failed (the keyframe was kept).
    pub slam_errors: u64,
    pub landmarks_mapped: usize,
    /// Visual tracking losses and recoveries ([`VisualTracking`]).
    pub tracking: TrackingStats,
    /// Features the front end matched to the wrong landmark ([`crate::sim::vision`]).
    pub wrong_associations: u64,
    /// The pose graph's links (zeros for the other localisations).
    pub links: crate::slam::LinkStats,
}

/// A localisation of the simulated robot. The mission calls, per control tick, [`Self::propagate`]
/// then [`Self::keyframe`]; per scan [`Self::register`]; per camera period [`Self::observe`];
/// before a decision [`Self::prepare_decision`] and [`Self::landmark_map`].
pub(crate) trait Localiser {
    /// Which one this is.
    fn kind(&self) -> Localisation;

    /// The robot drove `motion` in `dt_s`: the estimate follows the wheels and the gyro.
    fn propagate(&mut self, sim: &mut WorldSim, motion: &Motion, dt_s: f64);

    /// After a tick's motion: a SLAM takes a keyframe when one is due. Nothing by default.
    fn keyframe(&mut self, _sim: &mut WorldSim) {}

    /// The planar estimate.
    fn pose(&self) -> crate::Pose2;

    /// The estimated 3D body pose (without SLAM: the terrain's under the planar estimate).
    fn body_pose(&self, sim: &WorldSim) -> BodyPose {
        sim.body_pose_at(self.pose())
    }

    fn covariance(&self) -> PoseCovariance;

    /// Registers `points` (sensed now, true world frame) into `map` with the estimate:
    /// p_est = T_est · T_gt⁻¹ · p.
    fn register(&mut self, sim: &WorldSim, points: &[Point3<f64>], map: &mut TraversabilityMap);

    /// The periodic camera frame (without SLAM: averaged into the landmark map; a SLAM uses the
    /// camera at keyframes only). Nothing by default.
    fn observe(&mut self, _sim: &mut WorldSim) {}

    /// Before a decision: a SLAM re-registers in `map` the keyframes its loop closures moved
    /// since the last decision, and brings the landmark covariances up to date. Nothing by
    /// default.
    fn prepare_decision(&mut self, _map: &mut TraversabilityMap) {}

    /// The landmark map (estimated positions in id order, with covariances; `sigma_landmark_m`
    /// where the localisation has none of its own).
    fn landmark_map(&self, sigma_landmark_m: f64) -> PointCloud;

    /// Forgets the map within `radius_m` of (x, y) (a trapped robot's recovery).
    fn forget_disc(&mut self, map: &mut TraversabilityMap, x_m: f64, y_m: f64, radius_m: f64) {
        map.forget_disc(x_m, y_m, radius_m);
    }

    fn stats(&self) -> LocalisationStats;

    /// The tracking losses so far (empty without a visual front end).
    fn tracking_losses(&self) -> &[TrackingLoss] {
        &[]
    }

    /// The SLAM front end and its back end, for inspection.
    fn slam(&self) -> Option<&SlamFrontend> {
        None
    }
}

/// The localiser of `kind` for a robot whose world simulator is `sim`; `seed` drives the pose
/// graph's aliased loop closures.
pub(crate) fn new_localiser(
    kind: Localisation,
    sim: &mut WorldSim,
    slam: &crate::slam::keyframes::SlamParams,
    seed: u64,
) -> Result<Box<dyn Localiser>, crate::slam::SlamError> {
    use crate::slam::keyframes::SlamModel;
    Ok(match kind {
        Localisation::GroundTruth => Box::new(GroundTruth::new(sim)),
        Localisation::Odometry => Box::new(DeadReckoning::new(sim)),
        Localisation::Slam => Box::new(KeyframeSlamLocaliser::new(sim, slam.clone(), SlamModel::LandmarkSmoother, seed)?),
        Localisation::PoseGraph => Box::new(KeyframeSlamLocaliser::new(sim, slam.clone(), SlamModel::PoseGraph, seed)?),
    })
}

/// A landmark map averaged from observations registered with a planar estimate (no SLAM).
#[derive(Clone, Debug, Default)]
struct LandmarkAverages {
    /// id → (sum of world positions, count).
    sums: BTreeMap<u64, (Vector3<f64>, u32)>,
}

impl LandmarkAverages {
    /// One camera frame from the true pose, registered with the estimated body pose `est`.
    fn observe(&mut self, sim: &mut WorldSim, (ep, er): BodyPose) {
        for o in sim.observe_landmarks() {
            let w = ep.coords + er * o.point_in_robot;
            let e = self.sums.entry(o.landmark_id).or_insert((Vector3::zeros(), 0));
            e.0 += w;
            e.1 += 1;
        }
    }

    fn cloud(&self, sigma_landmark_m: f64) -> PointCloud {
        let sigma2 = sigma_landmark_m.powi(2);
        let points: Vec<Point3<f64>> = self.sums.values().map(|(s, n)| Point3::from(*s / f64::from(*n))).collect();
        PointCloud { covariances: Some(vec![Matrix3::identity() * sigma2; points.len()]), points, classification: None }
    }

    fn len(&self) -> usize {
        self.sums.len()
    }
}

/// Registers `points` (true world frame) into `map` with the planar estimate's body pose `est`
/// (its height and attitude the terrain's): unchanged where the estimate is the truth.
fn register_planar(sim: &WorldSim, est: crate::Pose2, points: &[Point3<f64>], map: &mut TraversabilityMap) {
    if est == sim.pose() {
        map.insert_points(points.iter().copied());
        return;
    }
    let ((gp, gr), (ep, er)) = (sim.body_pose(), sim.body_pose_at(est));
    let (gt_inv, gp_c) = (gr.inverse(), gp.coords);
    map.insert_points(points.iter().map(|p| ep + er * (gt_inv * (p.coords - gp_c))));
}
