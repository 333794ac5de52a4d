//! The keyframe SLAM front end (see the module doc).

use nalgebra::{Matrix3, Matrix6, Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use super::clouds::tilt_variance;
use super::odometry::with_floor;
use super::*;
use crate::cloud::PointCloud;
use crate::slam::lie::so3_log;
use crate::slam::{GraphSlam, Gravity, LandmarkObservation, Odometry, PoseGraphSlam, Se3, SlamBackend, SlamError};
use crate::traversability::TraversabilityMap;

/// A landmark observed by the camera: its id (known data association), the measured point in the
/// robot frame (x forward, y left, z up), metres, and its covariance, m².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraObservation {
    /// The landmark's id.
    pub landmark_id: u64,
    /// The landmark in the robot frame, metres.
    pub point_in_robot: Vector3<f64>,
    /// Covariance of `point_in_robot`, m².
    pub covariance: Matrix3<f64>,
}

/// What one keyframe did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct KeyframeOutcome {
    /// The update optimised the whole graph (a loop closure).
    pub loop_closure: bool,
    /// The traversability map must be rebuilt ([`SlamFrontend::reregister_map`]).
    pub reregister: bool,
}

/// Which SLAM model the front end feeds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlamModel {
    /// [`GraphSlam`]: keyframes and landmarks as variables (a full bundle adjustment,
    /// ORB-SLAM's class).
    #[default]
    LandmarkSmoother,
    /// [`PoseGraphSlam`]: keyframes only, landmarks anchored in them (RTAB-Map's class).
    PoseGraph,
}

/// The front end and its back end; see the module doc.
#[derive(Debug)]
pub struct SlamFrontend {
    params: SlamParams,
    slam: Box<dyn SlamBackend>,
    /// Odometry since the latest keyframe, `T_rel`, and its covariance (right tangent).
    keyframe_from_current: Se3,
    pub(super) relative_cov: Matrix6<f64>,
    keyframe_pose: Se3,
    keyframe_cov: Matrix6<f64>,
    keyframes_since_marginal: usize,
    clouds: KeyframeClouds,
    /// The pose each keyframe's clouds were last registered with.
    registered: Vec<Se3>,
    loop_closures: u64,
    reregistrations: u64,
    landmark_cov: BTreeMap<u64, Matrix3<f64>>,
    landmark_refreshed_at: usize,
    scratch: Vec<LandmarkObservation>,
}

impl SlamFrontend {
    /// Starts at `world_from_start` (the first keyframe, fixed) with the camera's first
    /// observations, feeding the landmark smoother.
    pub fn new(params: SlamParams, world_from_start: Se3, observations: &[CameraObservation]) -> Result<Self, SlamError> {
        Self::with_model(params, SlamModel::LandmarkSmoother, world_from_start, observations, 0)
    }

    /// … feeding `model`; `seed` drives the pose graph's aliased loop closures.
    pub fn with_model(
        params: SlamParams,
        model: SlamModel,
        world_from_start: Se3,
        observations: &[CameraObservation],
        seed: u64,
    ) -> Result<Self, SlamError> {
        let mut scratch = Vec::new();
        to_landmark_observations(observations, &mut scratch);
        let slam: Box<dyn SlamBackend> = match model {
            SlamModel::LandmarkSmoother => Box::new(GraphSlam::new(params.graph.clone(), world_from_start, &scratch)?),
            SlamModel::PoseGraph => Box::new(PoseGraphSlam::new(params.pose_graph.clone(), world_from_start, &scratch, seed)?),
        };
        let mut clouds = KeyframeClouds::new(params.cloud_voxel_m);
        clouds.start_keyframe(0.0);
        let mut me = Self {
            slam,
            keyframe_from_current: Se3::identity(),
            relative_cov: Matrix6::zeros(),
            keyframe_pose: world_from_start,
            keyframe_cov: Matrix6::zeros(),
            keyframes_since_marginal: 0,
            clouds,
            registered: vec![world_from_start],
            loop_closures: 0,
            reregistrations: 0,
            landmark_cov: BTreeMap::new(),
            landmark_refreshed_at: 0,
            scratch: Vec::new(),
            params,
        };
        me.anchor_new_landmarks(&scratch);
        Ok(me)
    }

    /// Its parameters.
    pub fn params(&self) -> &SlamParams {
        &self.params
    }

    /// The back end it feeds.
    pub fn backend(&self) -> &dyn SlamBackend {
        self.slam.as_ref()
    }

    /// The sensor points of every keyframe.
    pub fn clouds(&self) -> &KeyframeClouds {
        &self.clouds
    }

    /// Full optimisations triggered by loop closures so far.
    pub fn loop_closures(&self) -> u64 {
        self.loop_closures
    }

    /// Re-registrations of the map done so far.
    pub(crate) fn reregistrations(&self) -> u64 {
        self.reregistrations
    }

    /// One control tick of odometry measured in the body frame ([`propagate_relative`]). O(1).
    pub(crate) fn odometry_step(&mut self, step: &BodyIncrement) {
        (self.keyframe_from_current, self.relative_cov) = propagate_relative(&self.keyframe_from_current, &self.relative_cov, step);
    }

    /// `T_rel`: the odometry since the latest keyframe.
    pub(crate) fn keyframe_from_current(&self) -> Se3 {
        self.keyframe_from_current
    }

    /// `world_from_robot` estimate: the latest keyframe ⊕ odometry since.
    pub fn estimate(&self) -> Se3 {
        self.keyframe_pose * self.keyframe_from_current()
    }

    /// 6×6 covariance of [`Self::estimate`] (ξ = (δt, δφ), body frame).
    pub fn covariance(&self) -> Matrix6<f64> {
        compound_covariance(&self.keyframe_cov, &self.keyframe_from_current, &with_floor(&self.relative_cov))
    }

    /// Whether the robot moved or turned enough for a new keyframe.
    pub(crate) fn keyframe_due(&self) -> bool {
        let rel = &self.keyframe_from_current;
        let moved = rel.translation.norm();
        let turned = so3_log(&rel.rotation).norm();
        moved >= self.params.keyframe_every_m || turned >= self.params.keyframe_every_rad
    }

    /// Adds a keyframe at the current odometry pose with the camera's observations and the IMU's
    /// measured up direction in the body frame (used when `gravity_sigma_rad > 0`), updates the
    /// graph and the covariances, and decides on re-registration.
    pub(crate) fn add_keyframe(
        &mut self,
        observations: &[CameraObservation],
        up_in_body: Option<Vector3<f64>>,
    ) -> Result<KeyframeOutcome, SlamError> {
        let rel = self.keyframe_from_current;
        let gravity = up_in_body
            .filter(|_| self.params.gravity_sigma_rad > 0.0)
            .map(|up_in_body| Gravity { up_in_body, sigma_rad: self.params.gravity_sigma_rad });
        let odometry = Odometry { previous_from_current: rel, covariance: with_floor(&self.relative_cov), gravity };
        let compounded = self.covariance();
        let mut scratch = std::mem::take(&mut self.scratch);
        to_landmark_observations(observations, &mut scratch);
        let update = self.slam.add_keyframe(&odometry, &scratch);
        let update = match update {
            Ok(u) => u,
            Err(e) => {
                self.scratch = scratch;
                return Err(e);
            }
        };
        self.keyframe_pose = self.slam.current_pose();
        self.keyframe_from_current = Se3::identity();
        self.relative_cov = Matrix6::zeros();
        self.keyframes_since_marginal += 1;
        self.keyframe_cov = compounded;
        let exact_due = self.slam.exact_marginal_every_keyframe()
            || update.full
            || self.keyframes_since_marginal >= self.params.marginal_every_keyframes;
        if let Some(c) = exact_due.then(|| self.slam.current_pose_covariance().ok()).flatten() {
            self.keyframe_cov = c;
            self.keyframes_since_marginal = 0;
        }
        self.anchor_new_landmarks(&scratch);
        self.scratch = scratch;
        self.clouds.start_keyframe(tilt_variance(&self.keyframe_cov));
        self.registered.push(self.keyframe_pose);
        let mut out = KeyframeOutcome { loop_closure: update.full, reregister: false };
        if update.full {
            self.loop_closures += 1;
            let poses = self.slam.keyframe_poses();
            out.reregister = poses.iter().zip(&self.registered).any(|(now, then)| moved(&self.params, then, now));
        }
        Ok(out)
    }

    /// Anchored covariances for landmarks first seen in `observations` (from the latest keyframe).
    fn anchor_new_landmarks(&mut self, observations: &[LandmarkObservation]) {
        for o in observations {
            self.landmark_cov
                .entry(o.landmark_id)
                .or_insert_with(|| anchored_landmark_covariance(&self.keyframe_pose, &self.keyframe_cov, &o.point_in_robot, &o.covariance));
        }
    }

    /// Stores body-frame points `points_in_body` (taken now) in the latest keyframe's cloud and
    /// appends them, registered with the current estimate, to `world_out`, with their height
    /// variance from the estimate's tilt uncertainty ([`height_variance`]).
    pub(crate) fn register_points(&mut self, points_in_body: &[Vector3<f64>], world_out: &mut Vec<(Point3<f64>, f64)>) {
        let rel = self.keyframe_from_current();
        let est = self.keyframe_pose * rel;
        let tilt_var = tilt_variance(&self.covariance());
        for p in points_in_body {
            self.clouds.push(&rel.transform_point(p));
            world_out.push((Point3::from(est.transform_point(p)), height_variance(tilt_var, p)));
        }
    }

    /// Forgets the points within `radius_m` of (`x_m`, `y_m`) in `map` and in the keyframe clouds
    /// stored so far ([`TraversabilityMap::forget_disc`], [`KeyframeClouds::forget_disc`]), so
    /// that a later re-registration does not bring them back. Returns the map's forgotten points.
    pub fn forget_disc(&mut self, map: &mut TraversabilityMap, x_m: f64, y_m: f64, radius_m: f64) -> u64 {
        self.clouds.forget_disc(x_m, y_m, radius_m);
        map.forget_disc(x_m, y_m, radius_m)
    }

    /// Re-registers in `map` the keyframes that moved since their points were registered
    /// ([`reregister_moved`]); returns how many did.
    pub(crate) fn reregister_map(&mut self, map: &mut TraversabilityMap) -> usize {
        let poses = self.slam.keyframe_poses();
        let params = &self.params;
        let n = reregister_moved(map, &mut self.clouds, &mut self.registered, &poses, |then, now| moved(params, then, now));
        self.reregistrations += u64::from(n > 0);
        n
    }

    /// Rebuilds the whole of `map` from the keyframe clouds at their registered poses.
    #[cfg(test)]
    pub(crate) fn rebuild_map(&self, map: &mut TraversabilityMap) -> usize {
        super::reregister(map, &self.clouds, &self.registered)
    }

    /// When `landmark_refresh_keyframes` keyframes were added since the last refresh, recomputes
    /// the exact marginals of the landmarks seen since. Returns whether it did.
    pub(crate) fn refresh_landmark_covariances(&mut self) -> bool {
        let k = self.slam.keyframe_count();
        if k < self.landmark_refreshed_at + self.params.landmark_refresh_keyframes {
            return false;
        }
        if self.slam.keyframe_count() < 2 {
            return false;
        }
        let Ok(lms) = self.slam.recent_landmarks(self.landmark_refreshed_at) else { return false };
        for l in lms {
            self.landmark_cov.insert(l.landmark_id, l.covariance);
        }
        self.landmark_refreshed_at = k;
        true
    }

    /// The landmark map: current positions by increasing id, with the cached covariances.
    pub fn landmark_map(&self) -> PointCloud {
        let lms = self.slam.landmark_positions();
        let mut points = Vec::with_capacity(lms.len());
        let mut covs = Vec::with_capacity(lms.len());
        for (id, p) in lms {
            points.push(Point3::from(p));
            covs.push(self.landmark_cov.get(&id).copied().unwrap_or_else(Matrix3::zeros));
        }
        PointCloud { points, covariances: Some(covs), classification: None }
    }
}

/// Whether a keyframe registered at `then` and now at `now` moved enough to re-register its
/// points: |Δt| + `reregister_lever_m` · |Δφ| > `reregister_shift_m`.
fn moved(params: &SlamParams, then: &Se3, now: &Se3) -> bool {
    let d = then.between(now);
    d.translation.norm() + params.reregister_lever_m * so3_log(&d.rotation).norm() > params.reregister_shift_m
}

/// The observations in the back end's form, by increasing id.
fn to_landmark_observations(observations: &[CameraObservation], out: &mut Vec<LandmarkObservation>) {
    out.clear();
    out.extend(observations.iter().map(|o| LandmarkObservation {
        landmark_id: o.landmark_id,
        point_in_robot: o.point_in_robot,
        covariance: o.covariance,
    }));
    out.sort_by_key(|o| o.landmark_id);
}
