//! The world simulator (notes §8): the robot's true motion with the bumper, and what its sensors
//! measure — the LiDAR sweep, the depth camera's ground rays and the body's footprint (points in
//! the true world frame), the camera's landmark observations, the wheels and the gyro, the
//! accelerometer's up direction. Nothing here knows the robot's estimate: localisation
//! ([`super::localisation`]) turns these measurements into one.
//!
//! One seeded RNG drives every sensor's noise, drawn in the order the mission asks for
//! measurements, so a seed gives one run.
//!
//! Cost: O(1) per motion step; per scan O(rays × march); per camera frame O(landmarks in the
//! frustum's buckets).

use super::camera::{CameraObservation, CameraPose, LandmarkIndex, LandmarkScene, depth_ground_hits, observe_landmarks};
use super::lidar::{RayCaster, gaussian, scan};
use super::params::MissionParams;
use super::robot::{Twist, body_on_terrain, footprint_points, integrate};
use super::vision::{FrameCounts, FrameView, landmark_normals, select_features};
use super::world::World;
use crate::params::{CameraParams, Params};
use crate::pose::{Pose2, wrap_pi};
use crate::slam::Se3;
use crate::slam::keyframes::{BodyIncrement, SlamParams};
use crate::slam::lie::so3_log;
use nalgebra::{Point3, Rotation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// A body position on the terrain and its attitude.
pub(crate) type BodyPose = (Point3<f64>, Rotation3<f64>);

/// What one motion step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Distance driven (signed), metres.
    pub ds_m: f64,
    /// Heading change, radians.
    pub dtheta_rad: f64,
    /// The bumper stopped the robot before ground-truth untraversable terrain.
    pub bumped: bool,
}

/// The true robot in its world, and its sensors.
pub struct WorldSim {
    world: World,
    sensors: MissionParams,
    camera: CameraParams,
    camera_height_m: f64,
    /// Body reach judged by the bumper and the violation count: robot radius − disc radius.
    reach_m: f64,
    caster: RayCaster,
    landmark_index: LandmarkIndex,
    /// Surface normal under each landmark ([`landmark_normals`]).
    landmark_normals: Vec<Option<Vector3<f64>>>,
    /// Landmark ids in the frustum at the last camera frame (a wrong match's candidates).
    frustum: Vec<usize>,
    rng: ChaCha8Rng,
    gt: Pose2,
    /// True `world_from_body` at the previous wheel-and-gyro measurement.
    last_body: Se3,
    distance_m: f64,
    violations: u64,
    safety_stops: u64,
    scans: u64,
    points: Vec<Point3<f64>>,
    observations: Vec<CameraObservation>,
}

impl WorldSim {
    /// The robot at `world.start`, with the sensors of `mission` and the camera of `params`, its
    /// noise seeded with `seed`.
    pub fn new(world: World, mission: &MissionParams, params: &Params, seed: u64) -> Self {
        let g = world.field.geometry;
        let gt = world.start;
        let (gp, gr) = body_on_terrain(&world.field, gt, mission.drive.body_half_m);
        Self {
            caster: RayCaster::new(&world.field),
            landmark_index: LandmarkIndex::new(&world.landmarks, g.bounds_m(), 1.0),
            landmark_normals: landmark_normals(&world.field, &world.landmarks),
            frustum: Vec::new(),
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_51A1),
            sensors: mission.clone(),
            camera: params.camera.clone(),
            camera_height_m: params.robot.camera_height_m,
            reach_m: (params.robot.radius_m - params.traversability.disc_radius_m).max(0.0),
            gt,
            last_body: Se3::new(UnitQuaternion::from_rotation_matrix(&gr), gp.coords),
            distance_m: 0.0,
            violations: 0,
            safety_stops: 0,
            scans: 0,
            points: Vec::new(),
            observations: Vec::new(),
            world,
        }
    }

    /// The ground truth it simulates.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The true planar pose.
    pub fn pose(&self) -> Pose2 {
        self.gt
    }

    /// The true body pose on the terrain.
    pub fn body_pose(&self) -> BodyPose {
        body_on_terrain(&self.world.field, self.gt, self.sensors.drive.body_half_m)
    }

    /// The body pose on the terrain under a planar pose (the estimate's, without a 3D one).
    pub(crate) fn body_pose_at(&self, pose: Pose2) -> BodyPose {
        body_on_terrain(&self.world.field, pose, self.sensors.drive.body_half_m)
    }

    /// Distance driven, metres.
    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    /// Times the body entered ground-truth untraversable terrain (the bumper off, or turning).
    pub fn violations(&self) -> u64 {
        self.violations
    }

    /// Times the bumper stopped the robot.
    pub fn safety_stops(&self) -> u64 {
        self.safety_stops
    }

    /// The wheel odometry's noise model.
    pub(crate) fn odometry_noise(&self) -> &super::odometry::OdometryNoise {
        &self.sensors.odometry
    }

    /// The observations of the last camera frame ([`Self::observe_landmarks`]).
    pub(crate) fn last_observations(&self) -> &[CameraObservation] {
        &self.observations
    }

    /// Scans taken ([`Self::scan`]).
    pub fn scans(&self) -> u64 {
        self.scans
    }

    /// Drives by `cmd` for `dt_s`, unless the body would enter ground-truth untraversable terrain
    /// with the bumper on ([`MissionParams::safety_stop`]): then it stays.
    pub fn drive(&mut self, cmd: Twist, dt_s: f64) -> Motion {
        let next = integrate(self.gt, cmd, dt_s);
        let (world, reach_m) = (&self.world, self.reach_m);
        let touches = |p: Pose2| world.gt_touches_lethal(p.x_m, p.y_m, reach_m);
        let entering = touches(next) && !touches(self.gt);
        let bumped = entering && self.sensors.safety_stop && cmd.v_mps > 0.0;
        let (next, cmd) = if bumped {
            self.safety_stops += 1;
            (self.gt, Twist { v_mps: 0.0, omega_radps: 0.0 })
        } else {
            if entering {
                self.violations += 1;
            }
            (next, cmd)
        };
        let ds_m = cmd.v_mps * dt_s;
        let dtheta_rad = wrap_pi(next.yaw_rad - self.gt.yaw_rad);
        self.gt = next;
        self.distance_m += ds_m.abs();
        Motion { ds_m, dtheta_rad, bumped }
    }

    /// Terrain slope under the robot, radians (wheel slip grows with it).
    fn slope_rad(&self) -> f64 {
        self.world.field.slope_at(self.gt.x_m, self.gt.y_m).unwrap_or(0.0)
    }

    /// Planar wheel odometry + IMU yaw of a motion step: the measured (distance, heading
    /// change) with the odometry's noise and slip ([`super::odometry`]).
    pub(crate) fn planar_odometry(&mut self, motion: &Motion, dt_s: f64) -> (f64, f64) {
        let slope = self.slope_rad();
        self.sensors.odometry.measure(motion.ds_m, motion.dtheta_rad, dt_s, slope, &mut self.rng)
    }

    /// The wheels and the gyro since the last call, in the body frame: the true motion on the
    /// terrain `T_prev⁻¹ T_now`; the wheels measure its length (signed by the direction of
    /// travel) with the odometry's noise and slip, the gyro its rotation with σ_g² dt on roll and
    /// pitch (`slam.tilt_gyro_sigma_per_sqrt_s`) and the odometry's yaw noise. The variances are
    /// the ones `slam` attributes to them.
    pub(crate) fn body_increment(&mut self, dt_s: f64, slam: &SlamParams) -> BodyIncrement {
        let slope = self.slope_rad();
        let (gp, gr) = self.body_pose();
        let now = Se3::new(UnitQuaternion::from_rotation_matrix(&gr), gp.coords);
        let truth = self.last_body.between(&now);
        self.last_body = now;
        let distance = truth.translation.norm().copysign(truth.translation.x);
        let rotation = so3_log(&truth.rotation);
        let odometry = &self.sensors.odometry;
        let (md, myaw) = odometry.measure(distance, rotation.z, dt_s, slope, &mut self.rng);
        let (vd, vyaw) = odometry.variances(distance, rotation.z, dt_s);
        let var_tilt = slam.tilt_gyro_sigma_per_sqrt_s.powi(2) * dt_s;
        let sg = var_tilt.sqrt();
        BodyIncrement {
            distance_m: md,
            rotation_rad: Vector3::new(rotation.x + sg * gaussian(&mut self.rng), rotation.y + sg * gaussian(&mut self.rng), myaw),
            var_distance_m2: vd,
            var_vertical_m2: slam.z_sigma_per_sqrt_m.powi(2) * distance.abs(),
            var_rotation_rad2: Vector3::new(var_tilt, var_tilt, vyaw),
        }
    }

    /// The accelerometer's up direction in the body frame, with tilt noise `sigma_rad` per axis.
    pub(crate) fn gravity_up(&mut self, sigma_rad: f64) -> Vector3<f64> {
        let (_, gr) = self.body_pose();
        let up_true = gr.inverse() * Vector3::z();
        up_true + Vector3::new(sigma_rad * gaussian(&mut self.rng), sigma_rad * gaussian(&mut self.rng), 0.0)
    }

    /// The camera's landmark observations from the true pose.
    pub fn observe_landmarks(&mut self) -> &[CameraObservation] {
        let (gp, gr) = self.body_pose();
        let cam = gp + gr * Vector3::new(0.0, 0.0, self.camera_height_m);
        let scene = LandmarkScene { field: &self.world.field, landmarks: &self.world.landmarks, index: &self.landmark_index };
        observe_landmarks(
            &scene,
            &CameraPose { camera_m: cam, body_m: gp, world_from_body: gr },
            &self.camera,
            &self.sensors.camera_noise,
            &mut self.rng,
            &mut self.observations,
            &mut self.frustum,
        );
        &self.observations
    }

    pub(crate) fn vision_params(&self) -> &super::vision::VisionParams {
        &self.sensors.vision
    }

    /// What the visual front end reports from the true pose ([`super::vision`]): the landmarks
    /// in view ([`Self::observe_landmarks`]) detected, cut to the budget, some matched to the
    /// wrong landmark ([`Self::last_observations`] after the call).
    pub(crate) fn observe_features(&mut self) -> FrameCounts {
        self.observe_landmarks();
        let (gp, gr) = self.body_pose();
        let cam_in_body = Vector3::new(0.0, 0.0, self.camera_height_m);
        let cam = gp + gr * cam_in_body;
        let view = FrameView {
            landmarks: &self.world.landmarks,
            normals: &self.landmark_normals,
            camera_m: cam,
            camera: &self.camera,
            camera_in_body: cam_in_body,
        };
        select_features(&mut self.observations, &self.frustum, &view, &self.sensors.vision, &mut self.rng)
    }

    /// The LiDAR sweep, the depth camera's ground points (depth noise ∝ d²) and the ground under
    /// the wheels (the footprint, every 5 cm), in the true world frame ([`Self::scan_points`]).
    pub fn scan(&mut self) {
        let (gp, gr) = self.body_pose();
        self.points.clear();
        let s = &self.sensors;
        let sensor = gp + gr * Vector3::new(0.0, 0.0, s.lidar.mount_height_m);
        scan(&self.world.field, &self.caster, sensor, &gr, &s.lidar, &mut self.rng, &mut self.points);
        let cam = gp + gr * Vector3::new(0.0, 0.0, self.camera_height_m);
        let (points, rng, sigma) = (&mut self.points, &mut self.rng, s.camera_noise.depth_sigma_coeff);
        depth_ground_hits(&self.world.field, &self.caster, cam, &gr, &self.camera, s.depth_rays, |dir, d| {
            points.push(cam + dir * (d + sigma * d * d * gaussian(rng)));
        });
        footprint_points(&self.world.field, gp, &gr, s.drive.body_half_m, 0.05, &mut self.points);
        self.scans += 1;
    }

    /// The points of the last scan, true world frame.
    pub fn scan_points(&self) -> &[Point3<f64>] {
        &self.points
    }

    /// Replaces the last scan's points with `points_m` (true world frame), as a sensing glitch
    /// would (tests).
    #[cfg(test)]
    pub(crate) fn replace_scan(&mut self, points_m: impl IntoIterator<Item = Point3<f64>>) {
        self.points.clear();
        self.points.extend(points_m);
    }
}
