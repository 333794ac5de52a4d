//! The simulator's SLAM front end (notes §1, §2, §8): turns the measured odometry, the IMU
//! attitude, the camera's landmark observations and the sensor clouds into keyframes for the
//! [`GraphSlam`] back end, and gives the mission its pose estimate, 6×6 covariance, landmark map
//! and the keyframe clouds to re-register the traversability map after a loop closure.
//!
//! **Keyframes.** A keyframe is taken when the odometry says the robot moved
//! `keyframe_every_m` (0.5 m) or turned `keyframe_every_rad` (0.5 rad) since the last one (never
//! while standing still). The first keyframe is the start pose (the map frame, fixed: the gauge).
//!
//! **Odometry in SE(3), integrated in the body frame** (notes §8). Each control tick the wheels
//! measure the distance driven `d` (along the body's x axis) and the gyro the body-frame rotation
//! increment `δφ` (roll and pitch with σ_g² dt per axis, σ_g = `tilt_gyro_sigma_per_sqrt_s`;
//! yaw with the odometry's own noise, [`super::odometry`]). The motion since the latest keyframe
//! is composed from those increments, `T_rel ← T_rel · ΔT`, `ΔT = (Exp(δφ), Exp(δφ/2) (d, 0, 0))`
//! (the chord of the tick's arc), so the odometry factor between keyframes a, b holds only the
//! noise of the ticks between them, as a real gyro's relative rotation does. (Integrating an
//! *absolute* odometry attitude and differencing two of them lets the absolute tilt drift leak
//! into every relative rotation when the robot turns; unmodelled, that made the gravity factors
//! and the odometry disagree: BENCHMARKS, SLAM backend.) Its covariance, in `T_rel`'s right
//! tangent (ξ = (δt, δφ)), is propagated per tick: `Σ ← Ad(ΔT⁻¹) Σ Ad(ΔT⁻¹)ᵀ + J Q Jᵀ` with
//! `Q = diag(σ_d², σ_z² |d|, σ_roll², σ_pitch², σ_yaw²)` (σ_z = `z_sigma_per_sqrt_m`: the
//! terrain's curvature under the chord) and `J` the tick's noise Jacobian
//! ([`propagate_relative`]). A floor of 10⁻⁸ on the diagonal keeps it invertible when standing
//! still or turning in place.
//!
//! **Landmark factors.** At each keyframe the camera observes; each observation is the landmark
//! in the robot frame with the camera model's covariance (bearing σ_b across the line of
//! sight, σ_d = k d² along it; [`super::camera`]). Correspondences are the landmark ids (known
//! data association). At most `max_observations_per_keyframe` are used: landmarks already in the
//! map first (they link keyframes and close loops), then new ones nearest first.
//!
//! **Between keyframes** the estimate is `T = T_k ⊕ (T_o(k)⁻¹ T_o(now))` and its covariance the
//! keyframe's marginal compounded with the odometry since: `Σ = Ad(T_rel⁻¹) Σ_k Ad(T_rel⁻¹)ᵀ +
//! Σ_rel` (right perturbations). **Keyframe marginals**: the exact 6×6 marginal of the full
//! problem (one sparse Cholesky) after every loop closure and every `marginal_every_keyframes`
//! keyframes; at the other keyframes the compounded covariance above is kept (it ignores the
//! landmark information since the last exact marginal, so it over-estimates; the exact one drops
//! back). Landmark covariances for the planner: at a decision, when `landmark_refresh_keyframes`
//! keyframes were added since the last refresh, the exact marginals (3 solves each) of the
//! landmarks seen since the last refresh; older landmarks keep their last exact covariance (a
//! later loop closure lowers the true one: theirs is then conservative); a landmark added since
//! the last refresh gets `R C Rᵀ + G Σ_k Gᵀ` (its observation's covariance
//! plus its keyframe's pose covariance through `G = R [I, −[p]×]`, correlations ignored).
//!
//! **Re-registration.** Every sensor cloud (LiDAR, depth camera, footprint) is stored in the body
//! frame of the latest keyframe (`p_k = T_o(k)⁻¹ T_o(now) p_body`), one point per
//! `cloud_voxel_m` 3D voxel per keyframe, as f32. When a full optimisation moves some keyframe
//! by more than `reregister_shift_m` (|Δt| + `reregister_lever_m` · |Δφ|, the lever standing for
//! a typical point range) from the pose its clouds were registered with, the traversability map
//! is rebuilt from every keyframe cloud with the new poses ([`reregister`]). Points forgotten by a
//! trapped robot's recovery ([`SlamFrontend::forget_disc`]) stay out of every later rebuild.
//!
//! Cost per tick O(1); per keyframe one window optimisation (O(window)), plus one full sparse
//! Cholesky every `marginal_every_keyframes`; per stored point O(1) (a hash-set lookup); a
//! re-registration O(stored points + cells × disc).

use std::collections::{BTreeMap, HashSet};

use nalgebra::{Matrix3, Matrix6, Point3, Vector3};
use serde::{Deserialize, Serialize};

use super::camera::CameraObservation;
use crate::cloud::PointCloud;
use crate::grid::GridGeometry;
use crate::math;
use crate::slam::lie::{hat, so3_exp, so3_log};
use crate::slam::optimizer::OptimizerParams;
use crate::slam::{GraphSlam, GraphSlamParams, Gravity, LandmarkObservation, Odometry, Se3, SlamBackend, SlamError};
use crate::traversability::TraversabilityMap;

/// Diagonal floor of an odometry factor's covariance (m², rad²).
const COV_FLOOR: f64 = 1e-8;

/// Parameters of the SLAM front end (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlamParams {
    /// New keyframe after this distance, metres. Default 0.5.
    pub keyframe_every_m: f64,
    /// … or this rotation, radians. Default 0.5.
    pub keyframe_every_rad: f64,
    /// Gyro roll/pitch rate noise σ_g, rad/√s (a random walk on the tilt). Default 2·10⁻⁴
    /// (0.7°/√h, a consumer MEMS gyro; the odometry's yaw uses its own, noisier figure).
    pub tilt_gyro_sigma_per_sqrt_s: f64,
    /// Noise σ_z of the motion across the body's x–y plane per √metre driven (the wheels do not
    /// see the terrain's curvature under a tick's chord). Default 0.01.
    pub z_sigma_per_sqrt_m: f64,
    /// The IMU accelerometer's absolute tilt noise σ, radians, for a gravity factor at every
    /// keyframe; 0 disables it. Default 0.003 (≈ 0.17°, a calibrated MEMS IMU at rover speeds).
    pub gravity_sigma_rad: f64,
    /// Landmark observations used per keyframe. Default 30.
    pub max_observations_per_keyframe: usize,
    /// Exact pose marginal every this many keyframes (and at every loop closure). Default 20.
    pub marginal_every_keyframes: usize,
    /// At a decision, when this many keyframes were added since the last refresh, exact
    /// marginals for the landmarks seen since then. Default 20.
    pub landmark_refresh_keyframes: usize,
    /// Keyframe clouds keep one point per voxel of this edge, metres. Default 0.05.
    pub cloud_voxel_m: f64,
    /// Re-register the map when a keyframe moved more than this, metres. Default 0.025 (half a
    /// 5 cm cell).
    pub reregister_shift_m: f64,
    /// Lever arm turning a keyframe's rotation change into a shift, metres. Default 2.
    pub reregister_lever_m: f64,
    pub graph: GraphSlamParams,
}

impl Default for SlamParams {
    fn default() -> Self {
        Self {
            keyframe_every_m: 0.5,
            keyframe_every_rad: 0.5,
            tilt_gyro_sigma_per_sqrt_s: 2e-4,
            z_sigma_per_sqrt_m: 0.01,
            gravity_sigma_rad: 0.003,
            max_observations_per_keyframe: 30,
            marginal_every_keyframes: 20,
            landmark_refresh_keyframes: 20,
            cloud_voxel_m: 0.05,
            reregister_shift_m: 0.025,
            reregister_lever_m: 2.0,
            graph: GraphSlamParams {
                full_cooldown_keyframes: 20,
                optimizer: OptimizerParams { max_iterations: 10, relative_tolerance: 1e-6, ..OptimizerParams::default() },
                ..GraphSlamParams::default()
            },
        }
    }
}

impl SlamParams {
    /// Checks ranges; returns a message naming the first bad field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| crate::params::check_positive(&format!("slam.{name}"), v);
        let nonneg = |name: &str, v: f64| crate::params::check_non_negative(&format!("slam.{name}"), v);
        pos("keyframe_every_m", self.keyframe_every_m)?;
        pos("keyframe_every_rad", self.keyframe_every_rad)?;
        nonneg("z_sigma_per_sqrt_m", self.z_sigma_per_sqrt_m)?;
        nonneg("gravity_sigma_rad", self.gravity_sigma_rad)?;
        pos("tilt_gyro_sigma_per_sqrt_s", self.tilt_gyro_sigma_per_sqrt_s)?;
        pos("cloud_voxel_m", self.cloud_voxel_m)?;
        nonneg("reregister_shift_m", self.reregister_shift_m)?;
        nonneg("reregister_lever_m", self.reregister_lever_m)?;
        let at_least_one = |name: &str, v: usize| {
            if v >= 1 { Ok(()) } else { Err(format!("slam.{name} must be ≥ 1 (got {v})")) }
        };
        at_least_one("marginal_every_keyframes", self.marginal_every_keyframes)?;
        at_least_one("landmark_refresh_keyframes", self.landmark_refresh_keyframes)?;
        at_least_one("graph.window_keyframes", self.graph.window_keyframes)?;
        // The back end's optimiser has no check of its own: a NaN tolerance never stops it, a
        // λ₀ of 0 (absolute in the GTSAM schedule) never grows, an infinite λ_max never gives up.
        let o = &self.graph.optimizer;
        at_least_one("graph.optimizer.max_iterations", o.max_iterations)?;
        nonneg("graph.optimizer.relative_tolerance", o.relative_tolerance)?;
        nonneg("graph.optimizer.absolute_tolerance", o.absolute_tolerance)?;
        pos("graph.optimizer.lambda_initial_factor", o.lambda_initial_factor)?;
        pos("graph.optimizer.lambda_max", o.lambda_max)?;
        Ok(())
    }
}

/// Sensor points of every keyframe, in that keyframe's body frame (f32, flat), one per voxel
/// per keyframe.
#[derive(Clone, Debug)]
pub struct KeyframeClouds {
    voxel_m: f64,
    points: Vec<[f32; 3]>,
    /// Keyframe k's points are `starts[k]..starts[k + 1]` (the last one runs to the end).
    starts: Vec<usize>,
    /// Keyframe k's roll/pitch variance, rad² (for the points' height noise at re-registration).
    tilt_var_rad2: Vec<f64>,
    /// Voxels already holding a point of the latest keyframe (membership only, never iterated).
    occupied: HashSet<[i32; 3]>,
    /// Discs whose points stored before them [`reregister`] leaves out ([`Self::forget_disc`]).
    forgotten: Vec<ForgottenDisc>,
}

/// Points stored before `before` whose map cell's centre lies within `radius_m` of `centre_m`
/// (world frame) are forgotten.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ForgottenDisc {
    centre_m: [f64; 2],
    radius_m: f64,
    before: usize,
}

impl KeyframeClouds {
    /// No keyframe yet.
    pub fn new(voxel_m: f64) -> Self {
        Self { voxel_m, points: Vec::new(), starts: Vec::new(), tilt_var_rad2: Vec::new(), occupied: HashSet::new(), forgotten: Vec::new() }
    }

    /// Forgets, for every later [`reregister`], the points stored so far that it would put in a
    /// map cell whose centre lies within `radius_m` of (`x_m`, `y_m`), world frame (as
    /// [`TraversabilityMap::forget_disc`] does to the map itself). Points stored later are kept.
    pub fn forget_disc(&mut self, x_m: f64, y_m: f64, radius_m: f64) {
        self.forgotten.push(ForgottenDisc { centre_m: [x_m, y_m], radius_m, before: self.points.len() });
    }

    /// Whether the stored point `index`, registered at world (`x_m`, `y_m`), is forgotten on the
    /// grid `g`.
    fn is_forgotten(&self, index: usize, x_m: f64, y_m: f64, g: &GridGeometry) -> bool {
        // Most points (every one before the first recovery) are older than no disc: no cell lookup.
        if !self.forgotten.iter().any(|f| index < f.before) {
            return false;
        }
        let Some(c) = g.cell_of(x_m, y_m) else { return false };
        let (cx, cy) = g.center_of(c);
        self.forgotten.iter().any(|f| index < f.before && math::hypot(cx - f.centre_m[0], cy - f.centre_m[1]) <= f.radius_m)
    }

    /// Starts the cloud of a new keyframe (later points belong to it) whose roll/pitch variance
    /// is `tilt_var_rad2`.
    pub fn start_keyframe(&mut self, tilt_var_rad2: f64) {
        self.starts.push(self.points.len());
        self.tilt_var_rad2.push(tilt_var_rad2);
        self.occupied.clear();
    }

    /// Stores a point of the latest keyframe (its body frame) unless its voxel already has one
    /// or there is no keyframe; returns whether it was stored.
    pub fn push(&mut self, point_in_keyframe: &Vector3<f64>) -> bool {
        if self.starts.is_empty() || !point_in_keyframe.iter().all(|v| v.is_finite()) {
            return false;
        }
        let key = point_in_keyframe.map(|v| (v / self.voxel_m).floor().clamp(i32::MIN as f64, i32::MAX as f64) as i32);
        if !self.occupied.insert([key.x, key.y, key.z]) {
            return false;
        }
        self.points.push([point_in_keyframe.x as f32, point_in_keyframe.y as f32, point_in_keyframe.z as f32]);
        true
    }

    pub fn keyframes(&self) -> usize {
        self.starts.len()
    }

    /// Points stored over all keyframes.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Keyframe `k`'s points (empty when out of range).
    pub fn points_of(&self, k: usize) -> &[[f32; 3]] {
        let Some(&a) = self.starts.get(k) else { return &[] };
        let b = self.starts.get(k + 1).copied().unwrap_or(self.points.len());
        &self.points[a..b]
    }
}

/// Rebuilds `map` from every keyframe cloud registered with `world_from_keyframe`, less the
/// forgotten points ([`KeyframeClouds::forget_disc`]) (keyframes
/// beyond the shorter of the two are skipped), each point with its height noise
/// ([`height_variance`]); the next `update` recomputes every cell. Returns the number of points
/// inserted. O(points).
pub fn reregister(map: &mut TraversabilityMap, clouds: &KeyframeClouds, world_from_keyframe: &[Se3]) -> usize {
    map.clear();
    let mut n = 0;
    let g = map.geometry();
    for (k, pose) in world_from_keyframe.iter().enumerate().take(clouds.keyframes()) {
        let r = pose.rotation_matrix();
        let t = pose.translation;
        let tilt_var = clouds.tilt_var_rad2[k];
        let start = clouds.starts[k];
        let pts = clouds.points_of(k).iter().enumerate().filter_map(|(j, p)| {
            let q = Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            let w = r * q + t;
            (!clouds.is_forgotten(start + j, w.x, w.y, &g)).then(|| (Point3::from(w), height_variance(tilt_var, &q)))
        });
        n += map.insert_points_with_variance(pts).inserted;
    }
    n
}

/// Variance of a registered point's height from the pose's tilt uncertainty, m²: a small roll /
/// pitch error δφ moves the point `b` (body frame) by δφ × b, whose vertical part has variance
/// σ_t²·(b_x² + b_y²) for isotropic roll/pitch variance σ_t². (The pose's own height error is
/// common to the whole scan and left out: it shifts a scan, it does not make it rough.)
pub fn height_variance(tilt_var_rad2: f64, point_in_body: &Vector3<f64>) -> f64 {
    tilt_var_rad2 * (point_in_body.x * point_in_body.x + point_in_body.y * point_in_body.y)
}

/// Mean roll/pitch variance of a 6×6 body-frame covariance (ξ = (δt, δφ)), rad².
fn tilt_variance(cov: &Matrix6<f64>) -> f64 {
    (0.5 * (cov[(3, 3)] + cov[(4, 4)])).max(0.0)
}

/// One odometry tick measured in the body frame: distance driven along the body's x axis and
/// the gyro's rotation increment, with their noise variances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyIncrement {
    /// Distance driven, metres (negative when reversing).
    pub distance_m: f64,
    /// Rotation increment (roll, pitch, yaw axes of the body), radians.
    pub rotation_rad: Vector3<f64>,
    /// Variance of the distance, m².
    pub var_distance_m2: f64,
    /// Variance of the motion across the body's x–y plane (the wheels do not measure the
    /// terrain's curvature under the chord), m².
    pub var_vertical_m2: f64,
    /// Variance of the rotation increment per body axis (roll, pitch, yaw), rad².
    pub var_rotation_rad2: Vector3<f64>,
}

impl BodyIncrement {
    /// The tick's motion `ΔT = (Exp(δφ), Exp(δφ/2) (d, 0, 0))`.
    pub fn motion(&self) -> Se3 {
        let t = so3_exp(&(0.5 * self.rotation_rad)) * Vector3::new(self.distance_m, 0.0, 0.0);
        Se3::new(so3_exp(&self.rotation_rad), t)
    }
}

/// `T_rel · ΔT` and its covariance in the right tangent (ξ = (δt, δφ)) from `T_rel`'s
/// `covariance` and the tick's noise: `Σ' = Ad(ΔT⁻¹) Σ Ad(ΔT⁻¹)ᵀ + J Q Jᵀ`, where a noise
/// `n = (n_d, n_z, n_φ)` perturbs `ΔT` by `ρ = A (n_d e_x + n_z e_z − (d/2) [e_x]× n_φ)`,
/// `A = Exp(−δφ/2)`, and `φ = n_φ` (first order; the half-rotation puts half the tick's turn
/// noise on its lever).
pub fn propagate_relative(relative: &Se3, covariance: &Matrix6<f64>, step: &BodyIncrement) -> (Se3, Matrix6<f64>) {
    let motion = step.motion();
    let a = so3_exp(&(-0.5 * step.rotation_rad)).to_rotation_matrix().into_inner();
    let mut j = nalgebra::Matrix6x5::zeros();
    j.fixed_view_mut::<3, 1>(0, 0).copy_from(&a.column(0));
    j.fixed_view_mut::<3, 1>(0, 1).copy_from(&a.column(2));
    j.fixed_view_mut::<3, 3>(0, 2).copy_from(&(-0.5 * step.distance_m * a * hat(&Vector3::x())));
    j.fixed_view_mut::<3, 3>(3, 2).copy_from(&Matrix3::identity());
    let v = step.var_rotation_rad2;
    let q = nalgebra::Matrix5::from_diagonal(&nalgebra::Vector5::new(step.var_distance_m2, step.var_vertical_m2, v.x, v.y, v.z));
    let cov = compound_covariance(covariance, &motion, &(j * q * j.transpose()));
    (*relative * motion, cov)
}

/// `covariance` plus the diagonal floor (an odometry factor must be invertible).
fn with_floor(covariance: &Matrix6<f64>) -> Matrix6<f64> {
    covariance + Matrix6::identity() * COV_FLOOR
}

/// Covariance of `T_k · T_rel` (right perturbations) from the keyframe's `Σ_k` and the
/// relative motion's `Σ_rel`, independent: `Ad(T_rel⁻¹) Σ_k Ad(T_rel⁻¹)ᵀ + Σ_rel`.
pub fn compound_covariance(keyframe: &Matrix6<f64>, keyframe_from_current: &Se3, relative: &Matrix6<f64>) -> Matrix6<f64> {
    let ad = keyframe_from_current.inverse().adjoint();
    let s = ad * keyframe * ad.transpose() + relative;
    (s + s.transpose()) * 0.5
}

/// A landmark's world covariance from one observation: `R C Rᵀ + G Σ Gᵀ`, `G = R [I, −[p]×]`
/// (first-order, pose and observation independent).
pub fn anchored_landmark_covariance(
    world_from_robot: &Se3,
    pose_covariance: &Matrix6<f64>,
    point_in_robot: &Vector3<f64>,
    observation: &Matrix3<f64>,
) -> Matrix3<f64> {
    let r = world_from_robot.rotation_matrix();
    let mut g = nalgebra::Matrix3x6::zeros();
    g.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    g.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-r * hat(point_in_robot)));
    let q = r * observation * r.transpose() + g * pose_covariance * g.transpose();
    (q + q.transpose()) * 0.5
}

/// What one keyframe did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KeyframeOutcome {
    /// The update optimised the whole graph (a loop closure).
    pub loop_closure: bool,
    /// The traversability map must be rebuilt ([`SlamFrontend::reregister_map`]).
    pub reregister: bool,
}

/// The front end and its [`GraphSlam`]; see the module doc.
#[derive(Debug)]
pub struct SlamFrontend {
    params: SlamParams,
    slam: GraphSlam,
    /// Odometry since the latest keyframe, `T_rel`, and its covariance (right tangent).
    keyframe_from_current: Se3,
    relative_cov: Matrix6<f64>,
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
    /// observations.
    pub fn new(params: SlamParams, world_from_start: Se3, observations: &[CameraObservation]) -> Result<Self, SlamError> {
        let mut scratch = Vec::new();
        select_observations(observations, |_| false, params.max_observations_per_keyframe, &mut scratch);
        let slam = GraphSlam::new(params.graph.clone(), world_from_start, &scratch)?;
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

    pub fn params(&self) -> &SlamParams {
        &self.params
    }

    pub fn backend(&self) -> &GraphSlam {
        &self.slam
    }

    pub fn clouds(&self) -> &KeyframeClouds {
        &self.clouds
    }

    /// Full optimisations triggered by loop closures so far.
    pub fn loop_closures(&self) -> u64 {
        self.loop_closures
    }

    /// Traversability rebuilds requested so far.
    pub fn reregistrations(&self) -> u64 {
        self.reregistrations
    }

    /// One control tick of odometry measured in the body frame ([`propagate_relative`]). O(1).
    pub fn odometry_step(&mut self, step: &BodyIncrement) {
        (self.keyframe_from_current, self.relative_cov) = propagate_relative(&self.keyframe_from_current, &self.relative_cov, step);
    }

    /// `T_rel`: the odometry since the latest keyframe.
    pub fn keyframe_from_current(&self) -> Se3 {
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
    pub fn keyframe_due(&self) -> bool {
        let rel = &self.keyframe_from_current;
        let moved = rel.translation.norm();
        let turned = so3_log(&rel.rotation).norm();
        moved >= self.params.keyframe_every_m || turned >= self.params.keyframe_every_rad
    }

    /// Adds a keyframe at the current odometry pose with the camera's observations and the IMU's
    /// measured up direction in the body frame (used when `gravity_sigma_rad > 0`), updates the
    /// graph and the covariances, and decides on re-registration.
    pub fn add_keyframe(
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
        let slam = &self.slam;
        select_observations(observations, |id| slam.has_landmark(id), self.params.max_observations_per_keyframe, &mut scratch);
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
        let exact_due = update.full || self.keyframes_since_marginal >= self.params.marginal_every_keyframes;
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
            let lever = self.params.reregister_lever_m;
            let moved = poses.iter().zip(&self.registered).any(|(now, then)| {
                let d = then.between(now);
                d.translation.norm() + lever * so3_log(&d.rotation).norm() > self.params.reregister_shift_m
            });
            if moved {
                self.registered = poses;
                self.reregistrations += 1;
                out.reregister = true;
            }
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
    pub fn register_points(&mut self, points_in_body: &[Vector3<f64>], world_out: &mut Vec<(Point3<f64>, f64)>) {
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

    /// Rebuilds `map` from the keyframe clouds with the current keyframe poses.
    pub fn reregister_map(&self, map: &mut TraversabilityMap) -> usize {
        reregister(map, &self.clouds, &self.registered)
    }

    /// When `landmark_refresh_keyframes` keyframes were added since the last refresh, recomputes
    /// the exact marginals of the landmarks seen since. Returns whether it did.
    pub fn refresh_landmark_covariances(&mut self) -> bool {
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

/// The observations to use: landmarks already mapped first (by id), then new ones nearest first,
/// at most `cap`, returned by increasing id.
fn select_observations(observations: &[CameraObservation], known: impl Fn(u64) -> bool, cap: usize, out: &mut Vec<LandmarkObservation>) {
    out.clear();
    let mut order: Vec<(bool, u64, usize)> = observations
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let k = known(o.landmark_id);
            // Known: by id; new: by squared distance (as integer micrometres², ties by id).
            let key = if k { o.landmark_id } else { (o.point_in_robot.norm_squared() * 1e6) as u64 };
            (!k, key, i)
        })
        .collect();
    order.sort_unstable();
    order.truncate(cap);
    order.sort_unstable_by_key(|&(_, _, i)| observations[i].landmark_id);
    out.extend(order.iter().map(|&(_, _, i)| {
        let o = &observations[i];
        LandmarkObservation { landmark_id: o.landmark_id, point_in_robot: o.point_in_robot, covariance: o.covariance }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;
    use crate::pose::{Pose2, wrap_pi};
    use crate::sim::odometry::OdometryNoise;
    use crate::slam::CovarianceTraces;
    use nalgebra::UnitQuaternion;

    #[test]
    fn keyframe_clouds_keep_one_point_per_voxel_per_keyframe() {
        let mut c = KeyframeClouds::new(0.05);
        assert!(!c.push(&Vector3::new(0.01, 0.01, 0.0)), "no keyframe yet");
        c.start_keyframe(0.0);
        assert!(c.push(&Vector3::new(0.01, 0.01, 0.0)));
        assert!(!c.push(&Vector3::new(0.04, 0.02, 0.03)), "same 5 cm voxel");
        assert!(c.push(&Vector3::new(0.06, 0.01, 0.0)));
        assert!(!c.push(&Vector3::new(f64::NAN, 0.0, 0.0)));
        c.start_keyframe(0.0);
        assert!(c.push(&Vector3::new(0.01, 0.01, 0.0)), "a new keyframe has its own voxels");
        assert_eq!((c.keyframes(), c.len()), (2, 3));
        assert_eq!(c.points_of(0).len(), 2);
        assert_eq!(c.points_of(1), &[[0.01f32, 0.01, 0.0]]);
        assert!(c.points_of(2).is_empty());
    }

    /// Cells of `map` holding at least one point.
    fn occupied(map: &TraversabilityMap) -> Vec<usize> {
        map.moments().iter().enumerate().filter(|(_, m)| m.count > 0).map(|(i, _)| i).collect()
    }

    #[test]
    fn reregistration_moves_the_map_with_the_keyframes() {
        let g = GridGeometry::new(0.0, 0.0, 0.05, 80, 80);
        let mut map = TraversabilityMap::new(g).unwrap();
        let mut clouds = KeyframeClouds::new(0.05);
        // Two keyframes, each a 0.2 m × 0.2 m flat patch centred on it (body frame).
        for k in 0..2 {
            clouds.start_keyframe(if k == 0 { 0.0 } else { 1e-6 });
            for i in 0..4 {
                for j in 0..4 {
                    clouds.push(&Vector3::new(-0.075 + 0.05 * i as f64, -0.075 + 0.05 * j as f64, 0.0));
                }
            }
        }
        let at = |x: f64, y: f64, yaw: f64| Se3::new(UnitQuaternion::from_euler_angles(0.0, 0.0, yaw), Vector3::new(x, y, 0.0));
        let cell = |x: f64, y: f64| g.index(g.cell_of(x, y).unwrap()).unwrap();
        assert_eq!(reregister(&mut map, &clouds, &[at(1.0, 1.0, 0.0), at(3.0, 1.0, 0.0)]), 32);
        let before = occupied(&map);
        assert_eq!(before.len(), 32, "16 cells per patch");
        assert!(before.contains(&cell(1.0, 1.0)) && before.contains(&cell(3.0, 1.0)) && !before.contains(&cell(2.0, 2.0)));
        // The second keyframe moved by 1 m in y (and turned): its cells move, the first's stay.
        assert_eq!(reregister(&mut map, &clouds, &[at(1.0, 1.0, 0.0), at(3.0, 2.0, 0.3)]), 32);
        let after = occupied(&map);
        assert!(after.contains(&cell(1.0, 1.0)) && after.contains(&cell(3.0, 2.0)));
        assert!(!after.contains(&cell(3.0, 1.0)), "the old registration is gone");
        assert_eq!(map.point_count(), 32);
        // Heights carry the keyframe's tilt noise: 1e-6 rad² × (x² + y²) summed over the second
        // patch's 16 points, x, y ∈ {±0.025, ±0.075}: Σ(x² + y²) = 2 · 4 · 2 · (0.025² + 0.075²) = 0.1.
        let var_sum: f64 = map.moments().iter().map(|m| m.var_sum_m2).sum();
        assert!((var_sum - 1e-6 * 0.1).abs() < 1e-12, "{var_sum}"); // points stored as f32
        // Fewer poses than clouds: the unposed keyframe is skipped.
        assert_eq!(reregister(&mut map, &clouds, &[at(1.0, 1.0, 0.0)]), 16);
    }

    #[test]
    fn forgotten_points_stay_out_of_every_later_reregistration() {
        let g = GridGeometry::new(0.0, 0.0, 0.05, 80, 80);
        let mut map = TraversabilityMap::new(g).unwrap();
        let mut clouds = KeyframeClouds::new(0.05);
        // Keyframe 0 at (1, 1): a 4 × 4 patch of 5 cm cells, points at ±0.025 / ±0.075 m.
        let patch = |clouds: &mut KeyframeClouds| {
            for i in 0..4 {
                for j in 0..4 {
                    clouds.push(&Vector3::new(-0.075 + 0.05 * i as f64, -0.075 + 0.05 * j as f64, 0.0));
                }
            }
        };
        clouds.start_keyframe(0.0);
        patch(&mut clouds);
        let at = |x: f64, y: f64| Se3::new(UnitQuaternion::identity(), Vector3::new(x, y, 0.0));
        // Forget around (1.0, 0.95) with 0.06 m: the cells centred at (0.975|1.025, 0.925|0.975)
        // are within √(0.025² + 0.025²) ≈ 0.035 m, the next ones ≥ √(0.075² + 0.025²) ≈ 0.079 m.
        clouds.forget_disc(1.0, 0.95, 0.06);
        assert_eq!(reregister(&mut map, &clouds, &[at(1.0, 1.0)]), 12);
        // Points stored after the forget are kept, even in the disc: a second keyframe's patch
        // registered on top of the first.
        clouds.start_keyframe(0.0);
        patch(&mut clouds);
        assert_eq!(reregister(&mut map, &clouds, &[at(1.0, 1.0), at(1.0, 1.0)]), 28);
        // The disc is in the world: keyframe 0 moved 1 m in x no longer has points in it.
        assert_eq!(reregister(&mut map, &clouds, &[at(2.0, 1.0), at(1.0, 1.0)]), 32);
    }

    #[test]
    fn height_variance_grows_with_the_horizontal_range() {
        // σ_t = 1 mrad, a point 3 m ahead and 4 m left, 1 m up: σ_z² = 1e-6 · 25 = 2.5e-5 m² (5 mm).
        assert_eq!(height_variance(1e-6, &Vector3::new(3.0, 4.0, 1.0)), 1e-6 * 25.0);
        let mut cov = Matrix6::zeros();
        cov[(3, 3)] = 4e-6;
        cov[(4, 4)] = 2e-6;
        cov[(5, 5)] = 1.0; // yaw does not move heights
        assert_eq!(tilt_variance(&cov), 3e-6);
    }

    #[test]
    fn yaw_noise_on_a_straight_drive_has_the_closed_form_lateral_variance() {
        // n ticks of d straight ahead, yaw noise q per tick only. Tick k's noise turns the
        // second half of its own chord and the n − k ticks after it: lateral error
        // Σ n_k d (n − k + ½), variance q d² Σ_{j<n} (j + ½)² = q d² (n³/3 − n/12); yaw n q;
        // their covariance q d Σ (j + ½) = q d n²/2. (Heading 0: body = world axes.)
        let (n, d, q) = (40usize, 0.05, 1e-6);
        let step = BodyIncrement {
            distance_m: d,
            rotation_rad: Vector3::zeros(),
            var_distance_m2: 0.0,
            var_vertical_m2: 0.0,
            var_rotation_rad2: Vector3::new(0.0, 0.0, q),
        };
        let (mut rel, mut cov) = (Se3::identity(), Matrix6::zeros());
        for _ in 0..n {
            (rel, cov) = propagate_relative(&rel, &cov, &step);
        }
        let nf = n as f64;
        assert!((rel.translation - Vector3::new(nf * d, 0.0, 0.0)).norm() < 1e-12);
        let lateral = q * d * d * (nf.powi(3) / 3.0 - nf / 12.0);
        assert!((cov[(1, 1)] - lateral).abs() < 1e-9 * lateral, "{} vs {lateral}", cov[(1, 1)]);
        assert!((cov[(5, 5)] - nf * q).abs() < 1e-15);
        assert!((cov[(1, 5)] - q * d * nf * nf / 2.0).abs() < 1e-15);
        assert!(cov[(0, 0)].abs() < 1e-18 && cov[(2, 2)].abs() < 1e-18, "no along-track or height error without their noise");
    }

    #[test]
    fn relative_motion_holds_only_the_noise_of_its_own_ticks() {
        // Tilt noise on the way to a keyframe does not enter the next relative motion: after a
        // keyframe T_rel restarts from the identity with zero covariance, whatever came before.
        let mut fe = SlamFrontend::new(SlamParams::default(), Se3::identity(), &[]).unwrap();
        let tilt = BodyIncrement {
            distance_m: 0.05,
            rotation_rad: Vector3::new(0.01, -0.02, 0.1),
            var_distance_m2: 1e-6,
            var_vertical_m2: 1e-6,
            var_rotation_rad2: Vector3::new(4e-8, 4e-8, 1e-6),
        };
        while !fe.keyframe_due() {
            fe.odometry_step(&tilt);
        }
        assert!(fe.relative_cov[(3, 3)] > 0.0);
        fe.add_keyframe(&[], None).unwrap();
        assert_eq!(fe.keyframe_from_current(), Se3::identity());
        assert_eq!(fe.relative_cov, Matrix6::zeros());
        // A pure turn in place: the relative rotation is the gyro's increments, composed in the
        // body frame (here about one axis: their sum), whatever the absolute attitude.
        let turn = BodyIncrement { distance_m: 0.0, rotation_rad: Vector3::new(0.0, 0.0, 0.05), ..tilt };
        for _ in 0..4 {
            fe.odometry_step(&turn);
        }
        let angle = so3_log(&fe.keyframe_from_current().rotation);
        assert!((angle - Vector3::new(0.0, 0.0, 0.2)).norm() < 1e-12, "{angle}");
        assert!((fe.relative_cov[(3, 3)] - 4.0 * 4e-8).abs() < 1e-18, "four ticks of roll noise");
        // The factor's covariance is invertible; standing still (no noise at all) only the floor
        // keeps it so.
        assert!(with_floor(&fe.relative_cov).cholesky().is_some());
        assert!(with_floor(&Matrix6::zeros()).cholesky().is_some());
    }

    #[test]
    fn compounding_adds_the_yaw_lever_arm() {
        // Keyframe yaw variance σ² only; 2 m straight ahead: the lateral variance is (2σ)².
        let sigma2 = 1e-4;
        let mut k = Matrix6::zeros();
        k[(5, 5)] = sigma2;
        let rel = Se3::new(UnitQuaternion::identity(), Vector3::new(2.0, 0.0, 0.0));
        let c = compound_covariance(&k, &rel, &Matrix6::zeros());
        assert!((c[(1, 1)] - 4.0 * sigma2).abs() < 1e-15 && c[(0, 0)].abs() < 1e-15 && (c[(5, 5)] - sigma2).abs() < 1e-15);
        assert!((c[(1, 5)] - 2.0 * sigma2).abs() < 1e-15, "lateral error and yaw are correlated");
    }

    /// A scripted loop: a circle of radius 2 m driven in 5 cm steps, landmarks only near the
    /// start, noise-free measurements with the model's covariances.
    #[test]
    fn covariance_grows_while_driving_and_drops_at_the_loop_closure() {
        let radius = 2.0;
        let landmarks: Vec<Vector3<f64>> =
            (0..12).map(|i| Vector3::new(1.0 + 0.3 * i as f64, if i % 2 == 0 { -1.2 } else { 1.2 }, 0.2)).collect();
        // Robot at angle a on the circle centred (0, radius), heading tangent (start at origin, yaw 0).
        let pose_at = |a: f64| Pose2 { x_m: radius * a.sin(), y_m: radius - radius * a.cos(), yaw_rad: wrap_pi(a) };
        let se3 = |p: Pose2| Se3::new(UnitQuaternion::from_euler_angles(0.0, 0.0, p.yaw_rad), Vector3::new(p.x_m, p.y_m, 0.0));
        let observe = |p: Pose2| -> Vec<CameraObservation> {
            let t = se3(p);
            landmarks
                .iter()
                .enumerate()
                .filter_map(|(i, m)| {
                    let v = t.inverse_transform_point(m);
                    (v.x > 0.3 && v.x < 3.0 && v.y.abs() < v.x).then(|| CameraObservation {
                        landmark_id: i as u64,
                        point_in_robot: v,
                        covariance: Matrix3::identity() * 1e-4,
                    })
                })
                .collect()
        };
        let noise = OdometryNoise::default();
        let start = pose_at(0.0);
        let mut fe = SlamFrontend::new(SlamParams::default(), se3(start), &observe(start)).unwrap();
        assert!(fe.backend().landmark_count() > 0);
        let (ds, dt) = (0.05, 0.125);
        let dth = ds / radius;
        let steps = (std::f64::consts::TAU * radius / ds).round() as usize + 20;
        let mut traces = Vec::new(); // (keyframe, trace before, trace after, loop closure)
        for k in 1..=steps {
            let (vs, vt) = noise.variances(ds, dth, dt);
            let step = BodyIncrement {
                distance_m: ds,
                rotation_rad: Vector3::new(0.0, 0.0, dth),
                var_distance_m2: vs,
                var_vertical_m2: 0.0,
                var_rotation_rad2: Vector3::new(0.0, 0.0, vt),
            };
            fe.odometry_step(&step);
            if fe.keyframe_due() {
                let before = CovarianceTraces::of(&fe.covariance()).cov_trace;
                let o = fe.add_keyframe(&observe(pose_at(k as f64 * dth)), None).unwrap();
                let after = CovarianceTraces::of(&fe.covariance()).cov_trace;
                traces.push((fe.backend().keyframe_count() - 1, before, after, o.loop_closure));
            }
        }
        let closing = traces.iter().position(|t| t.3).expect("returning to the start closes the loop");
        assert_eq!(fe.loop_closures(), 1, "the cool-down keeps it to one full optimisation");
        // 0.5 m per keyframe: about 25 keyframes per lap; the landmarks ahead of the start come
        // into view a few keyframes before it (gap ≥ 20 keyframes).
        assert!((20..=27).contains(&traces[closing].0), "{:?}", traces[closing]);
        // Growing while away from the landmarks (keyframes 6‥18, before the periodic exact
        // marginal at keyframe 20, which is lower: it holds the landmark information)…
        assert!(closing > 18);
        let far: Vec<f64> = traces[5..18].iter().map(|t| t.2).collect();
        assert!(far.windows(2).all(|w| w[1] >= w[0] * 0.999), "{far:?}");
        assert!(far[far.len() - 1] > 3.0 * far[0], "{far:?}");
        // …and dropping at the closure (the exact marginal, pulled back by the old landmarks).
        let (_, before, after, _) = traces[closing];
        assert!(after < 0.5 * before, "{before} → {after}");
        // The estimate is back at the truth (noise-free measurements).
        let truth = pose_at(steps as f64 * dth);
        let err = (fe.estimate().translation - Vector3::new(truth.x_m, truth.y_m, 0.0)).norm();
        assert!(err < 1e-3, "{err}"); // the arc integrated in chords: sub-millimetre
    }
}
