//! The keyframe SLAM's parameters.

use serde::{Deserialize, Serialize};

use crate::slam::optimizer::OptimizerParams;
use crate::slam::{GraphSlamParams, PoseGraphParams};

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
    /// Batch solver: exact pose marginal every this many keyframes (and at every loop closure;
    /// compounded from odometry in between). The incremental solver gives the exact one at
    /// every keyframe. Default 20.
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
    /// The landmark smoother's parameters (solver, loop closures, observation kernel, optimiser).
    pub graph: GraphSlamParams,
    /// The pose graph's parameters (visual odometry, place recognition, closure rejection).
    pub pose_graph: PoseGraphParams,
}

impl Default for SlamParams {
    fn default() -> Self {
        Self {
            keyframe_every_m: 0.5,
            keyframe_every_rad: 0.5,
            tilt_gyro_sigma_per_sqrt_s: 2e-4,
            z_sigma_per_sqrt_m: 0.01,
            gravity_sigma_rad: 0.003,
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
            pose_graph: PoseGraphParams::default(),
        }
    }
}

impl SlamParams {
    /// Checks ranges; the error names the first bad field.
    pub fn validate(&self) -> Result<(), crate::params::InvalidParam> {
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
            if v >= 1 { Ok(()) } else { Err(crate::params::InvalidParam::new(format!("slam.{name}"), format!("must be ≥ 1 (got {v})"))) }
        };
        at_least_one("marginal_every_keyframes", self.marginal_every_keyframes)?;
        at_least_one("landmark_refresh_keyframes", self.landmark_refresh_keyframes)?;
        at_least_one("graph.window_keyframes", self.graph.window_keyframes)?;
        nonneg("graph.isam2.relinearize_threshold", self.graph.isam2.relinearize_threshold)?;
        nonneg("graph.isam2.wildfire_threshold", self.graph.isam2.wildfire_threshold)?;
        if let Some(k) = self.graph.observation_kernel.threshold() {
            pos("graph.observation_kernel.k", k)?;
        }
        // The back end's optimiser has no check of its own: a NaN tolerance never stops it, a
        // λ₀ of 0 (absolute in the GTSAM schedule) never grows, an infinite λ_max never gives up.
        let o = &self.graph.optimizer;
        at_least_one("graph.optimizer.max_iterations", o.max_iterations)?;
        nonneg("graph.optimizer.relative_tolerance", o.relative_tolerance)?;
        nonneg("graph.optimizer.absolute_tolerance", o.absolute_tolerance)?;
        pos("graph.optimizer.lambda_initial_factor", o.lambda_initial_factor)?;
        pos("graph.optimizer.lambda_max", o.lambda_max)?;
        self.pose_graph.validate()
    }
}
