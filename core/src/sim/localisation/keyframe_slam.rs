//! Keyframe graph SLAM as the simulated robot's localisation ([`crate::slam::keyframes`]):
//! odometry + IMU attitude lifted to SE(3), the visual front end's features at keyframes
//! ([`crate::sim::vision`]) while visual tracking holds ([`VisualTracking`]), an iSAM2 update per
//! keyframe (or the batch solver's window / full optimisation), 6×6 pose covariance, the traversability map re-registered from
//! the keyframe clouds when a loop closure moves the keyframes, the planner's landmark map with
//! SLAM covariances.

use super::tracking::{TrackingLoss, VisualTracking};
use super::{Localisation, LocalisationStats, Localiser, PoseCovariance};
use crate::PointCloud;
use crate::math;
use crate::pose::{Pose2, wrap_pi};
use crate::sim::camera::CameraObservation;
use crate::sim::world_sim::{BodyPose, Motion, WorldSim};
use crate::slam::keyframes::{SlamFrontend, SlamModel, SlamParams};
use crate::slam::{CovarianceTraces, Se3, SlamError};
use crate::traversability::TraversabilityMap;
use nalgebra::{Matrix3, Matrix6, Point3, UnitQuaternion, Vector3};

/// The simulator's SLAM.
pub(crate) struct KeyframeSlamLocaliser {
    kind: Localisation,
    frontend: SlamFrontend,
    params: SlamParams,
    est: Pose2,
    /// 6×6 covariance of the estimate (ξ = (δt, δφ), body frame).
    cov6: Matrix6<f64>,
    /// Its (x, y, yaw) block on world axes.
    xy_yaw: Matrix3<f64>,
    slam_errors: u64,
    tracking: VisualTracking,
    /// The true yaw at the last tick and the true yaw rate over it (the loss log's context).
    true_yaw_rad: f64,
    yaw_rate_radps: f64,
    /// Features matched to the wrong landmark by the front end so far.
    wrong_associations: u64,
    /// A loop closure moved keyframes since the map was last re-registered.
    reregister_pending: bool,
    features: Vec<CameraObservation>,
    /// Buffers for registering a scan.
    body_points: Vec<Vector3<f64>>,
    registered: Vec<(Point3<f64>, f64)>,
}

impl KeyframeSlamLocaliser {
    /// The first keyframe is the start pose (the map frame), with the camera's first view;
    /// `model` is the back end. Fails on a start pose the SLAM cannot take (not finite).
    pub fn new(sim: &mut WorldSim, params: SlamParams, model: SlamModel, seed: u64) -> Result<Self, SlamError> {
        let (gp, gr) = sim.body_pose();
        let counts = sim.observe_features();
        let observations = sim.last_observations().to_vec();
        let start = Se3::new(UnitQuaternion::from_rotation_matrix(&gr), gp.coords);
        let frontend = SlamFrontend::with_model(params.clone(), model, start, &observations, seed)?;
        let kind = match model {
            SlamModel::LandmarkSmoother => Localisation::Slam,
            SlamModel::PoseGraph => Localisation::PoseGraph,
        };
        Ok(Self {
            kind,
            tracking: VisualTracking::new(sim.vision_params()),
            true_yaw_rad: sim.pose().yaw_rad,
            yaw_rate_radps: 0.0,
            wrong_associations: counts.wrong as u64,
            reregister_pending: false,
            features: Vec::new(),
            est: sim.pose(),
            frontend,
            params,
            cov6: Matrix6::zeros(),
            xy_yaw: Matrix3::zeros(),
            slam_errors: 0,
            body_points: Vec::new(),
            registered: Vec::new(),
        })
    }

    /// Refreshes the covariances from the front end.
    fn update_covariance(&mut self) {
        let c = self.frontend.covariance();
        self.cov6 = c;
        // World-axis (x, y, yaw) block: rotate the body-frame position and rotation blocks.
        let r = self.frontend.estimate().rotation_matrix();
        let mut rr = Matrix6::zeros();
        rr.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        rr.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
        let w = rr * c * rr.transpose();
        let idx = [0usize, 1, 5];
        self.xy_yaw = Matrix3::from_fn(|i, j| w[(idx[i], idx[j])]);
    }
}

impl Localiser for KeyframeSlamLocaliser {
    fn kind(&self) -> Localisation {
        self.kind
    }

    fn propagate(&mut self, sim: &mut WorldSim, _motion: &Motion, dt_s: f64) {
        let step = sim.body_increment(dt_s, &self.params);
        self.tracking.tick(dt_s);
        let yaw = sim.pose().yaw_rad;
        self.yaw_rate_radps = if dt_s > 0.0 { wrap_pi(yaw - self.true_yaw_rad) / dt_s } else { 0.0 };
        self.true_yaw_rad = yaw;
        self.frontend.odometry_step(&step);
        self.est = pose2_of(&self.frontend.estimate());
        self.update_covariance();
    }

    /// A keyframe when due: the front end reports features from the true pose, tracking keeps
    /// those the SLAM may use, the accelerometer measures up; a loop closure that moved the
    /// keyframes leaves the map to be re-registered before the next decision (consecutive
    /// closures of one revisit then cost one re-registration).
    fn keyframe(&mut self, sim: &mut WorldSim) {
        if !self.frontend.keyframe_due() {
            return;
        }
        self.wrong_associations += sim.observe_features().wrong as u64;
        self.features.clear();
        self.features.extend_from_slice(sim.last_observations());
        let backend = self.frontend.backend();
        let (p, yaw_rate_radps) = (sim.pose(), self.yaw_rate_radps);
        self.tracking.at_keyframe(
            &mut self.features,
            |id| backend.has_landmark(id),
            |time_s, features, mapped| {
                let context = (time_s, p.x_m, p.y_m, yaw_rate_radps);
                TrackingLoss::at(context, (features, mapped), &sim.world().landmarks, |id| backend.has_landmark(id))
            },
        );
        let up = sim.gravity_up(self.params.gravity_sigma_rad);
        let outcome = self.frontend.add_keyframe(&self.features, Some(up));
        self.est = pose2_of(&self.frontend.estimate());
        match outcome {
            Ok(o) if o.reregister => self.reregister_pending = true,
            Ok(_) => {}
            Err(_) => self.slam_errors += 1,
        }
        self.update_covariance();
    }

    fn pose(&self) -> Pose2 {
        self.est
    }

    fn body_pose(&self, _sim: &WorldSim) -> BodyPose {
        let e = self.frontend.estimate();
        (Point3::from(e.translation), e.rotation.to_rotation_matrix())
    }

    fn covariance(&self) -> PoseCovariance {
        let t = CovarianceTraces::of(&self.cov6);
        PoseCovariance { xy_yaw: self.xy_yaw, pos_trace: t.pos_cov_trace, rot_trace: t.rot_cov_trace, full6: Some(self.cov6) }
    }

    /// Kept in the keyframe's cloud too, for re-registration.
    fn register(&mut self, sim: &WorldSim, points: &[Point3<f64>], map: &mut TraversabilityMap) {
        let (gp, gr) = sim.body_pose();
        let (gt_inv, gp_c) = (gr.inverse(), gp.coords);
        self.body_points.clear();
        self.body_points.extend(points.iter().map(|p| gt_inv * (p.coords - gp_c)));
        self.registered.clear();
        self.frontend.register_points(&self.body_points, &mut self.registered);
        map.insert_points_with_variance(self.registered.iter().copied());
    }

    fn prepare_decision(&mut self, map: &mut TraversabilityMap) {
        if std::mem::take(&mut self.reregister_pending) {
            self.frontend.reregister_map(map);
        }
        self.frontend.refresh_landmark_covariances();
    }

    fn landmark_map(&self, _sigma_landmark_m: f64) -> PointCloud {
        self.frontend.landmark_map()
    }

    /// Forgets the keyframe clouds there too, so that no later re-registration brings it back.
    fn forget_disc(&mut self, map: &mut TraversabilityMap, x_m: f64, y_m: f64, radius_m: f64) {
        self.frontend.forget_disc(map, x_m, y_m, radius_m);
    }

    fn tracking_losses(&self) -> &[TrackingLoss] {
        self.tracking.losses()
    }

    fn stats(&self) -> LocalisationStats {
        let b = self.frontend.backend();
        LocalisationStats {
            loop_closures: self.frontend.loop_closures(),
            keyframes: b.keyframe_count(),
            reregistrations: self.frontend.reregistrations(),
            slam_errors: self.slam_errors,
            landmarks_mapped: b.landmark_count(),
            tracking: self.tracking.stats(),
            wrong_associations: self.wrong_associations,
            links: b.link_stats(),
        }
    }

    fn slam(&self) -> Option<&SlamFrontend> {
        Some(&self.frontend)
    }
}

/// The planar pose (x, y, yaw) of a 3D pose.
fn pose2_of(t: &Se3) -> Pose2 {
    let r = t.rotation_matrix();
    Pose2 { x_m: t.translation.x, y_m: t.translation.y, yaw_rad: math::atan2(r[(1, 0)], r[(0, 0)]) }
}
