//! The simulator's parameters ([`MissionParams`]; the planner's are [`Params`], the exploration
//! policy's [`ExploreParams`], nested here as `explore`).

use super::camera::CameraNoise;
use super::lidar::LidarParams;
use super::odometry::OdometryNoise;
use super::robot::DriveParams;
use super::vision::VisionParams;
use crate::explore::{EXPLORE_KEYS, ExploreParams};
use crate::params::{InvalidParam, Num, ParamsError, Valid, Validate, check_non_negative as nonneg, check_positive as pos};
use crate::slam::keyframes::SlamParams;
use serde::{Deserialize, Serialize};

#[cfg(doc)]
use crate::params::Params;

/// Simulator parameters.
///
/// # Examples
///
/// ```
/// use fitslam_core::params::ParamsError;
/// use fitslam_core::MissionParams;
///
/// let sim = MissionParams::from_toml("dt_s = 0.05\n[explore]\ntrapped_radius_m = 0.0\n", "sim.toml")?;
/// assert_eq!(sim.dt_s, 0.05);
/// assert_eq!(sim.explore().trapped_radius_m, 0.0);
/// assert_eq!(sim.replan_period_s, MissionParams::default().replan_period_s);
///
/// // An exploration key outside `[explore]`, where older files had it, is named with its new place.
/// match MissionParams::from_toml("trapped_radius_m = 0.0\n", "sim.toml") {
///     Err(ParamsError::Moved { moved_to, .. }) => assert_eq!(moved_to, "[explore] trapped_radius_m"),
///     other => panic!("expected Moved, got {other:?}"),
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MissionParams {
    /// Control period, seconds, from 0.001 to 1. Default 0.1.
    pub dt_s: f64,
    /// Drive limits and controller gains.
    pub drive: DriveParams,
    /// LiDAR geometry and noise.
    pub lidar: LidarParams,
    /// Camera observation noise.
    pub camera_noise: CameraNoise,
    /// The visual front end between the camera and the SLAM ([`super::Localisation::Slam`]
    /// only).
    pub vision: VisionParams,
    /// Wheel odometry and gyro noise.
    pub odometry: OdometryNoise,
    /// Scan when the robot has moved this far since the last scan, metres, > 0. Default 0.25.
    pub scan_every_m: f64,
    /// … or turned this much, radians, > 0. Default 0.5.
    pub scan_every_rad: f64,
    /// … or this much time has passed, seconds, > 0. Default 2.
    pub scan_every_s: f64,
    /// Depth-camera ground rays per frame: columns × rows, at most 2²⁰ in
    /// all; 0 columns or rows turns the depth camera off. Default 24 × 12.
    pub depth_rays: [usize; 2],
    /// Landmark observation period, seconds, > 0. Default 1.
    pub camera_every_s: f64,
    /// Periodic replanning, seconds, > 0. Default 15.
    pub replan_period_s: f64,
    /// A goal not reached within factor × (ρ / v_max) + extra seconds has failed; factor > 0,
    /// extra ≥ 0. Defaults 3, 20.
    pub goal_timeout_factor: f64,
    /// The extra of the goal timeout, seconds (see `goal_timeout_factor`).
    pub goal_timeout_extra_s: f64,
    /// One metrics row (and trajectory pose) every this many seconds, > 0. Default 1.
    pub metrics_period_s: f64,
    /// Stop before the robot's body touches ground-truth untraversable terrain (a bumper;
    /// `gt_touches_lethal`). Default true.
    pub safety_stop: bool,
    /// Overrides the world's time limit, seconds, > 0 and finite.
    pub time_limit_s: Option<f64>,
    /// The exploration policy ([`crate::explore`]).
    pub explore: ExploreParams,
    /// The SLAM front end and back end ([`super::Localisation::Slam`] only).
    pub slam: SlamParams,
}

/// Smallest simulation step, seconds: a finer one only multiplies the steps of a mission.
pub(crate) const MIN_DT_S: f64 = 1e-3;
/// Largest simulation step, seconds: a control period longer than this is not a control loop
/// (at the default 0.4 m/s the robot would drive 0.4 m blind between two commands).
pub(crate) const MAX_DT_S: f64 = 1.0;
/// Most rays in one LiDAR scan or one depth frame (a VLP-16 at 0.2° casts 28,800).
pub(crate) const MAX_RAYS_PER_SENSING: usize = 1 << 20;
/// Largest [`DriveParams::goal_tolerance_m`], metres: a robot that counts a goal reached from
/// farther away stops metres short of every frontier it chose, so a larger value is a typo.
pub(crate) const MAX_GOAL_TOLERANCE_M: f64 = 5.0;
/// Largest [`DriveParams::body_half_m`], metres (a 10 m body): the footprint adds
/// (2 · body_half_m / 5 cm + 1)² points to every scan.
pub(crate) const MAX_BODY_HALF_M: f64 = 5.0;

impl Default for MissionParams {
    fn default() -> Self {
        Self {
            dt_s: 0.1,
            drive: DriveParams::default(),
            lidar: LidarParams::default(),
            camera_noise: CameraNoise::default(),
            vision: VisionParams::default(),
            odometry: OdometryNoise::default(),
            scan_every_m: 0.25,
            scan_every_rad: 0.5,
            scan_every_s: 2.0,
            depth_rays: [24, 12],
            camera_every_s: 1.0,
            replan_period_s: 15.0,
            goal_timeout_factor: 3.0,
            goal_timeout_extra_s: 20.0,
            metrics_period_s: 1.0,
            safety_stop: true,
            time_limit_s: None,
            explore: ExploreParams::default(),
            slam: SlamParams::default(),
        }
    }
}

impl MissionParams {
    /// Parses TOML (unknown keys rejected; keys left out keep [`MissionParams::default`]'s
    /// values at every depth, `from_toml_over_default`) and validates; `name` is
    /// quoted in errors, with the line of a TOML error. A key of [`ExploreParams`] at the top
    /// level (where it was before the `[explore]` table) is named with where it moved.
    pub fn from_toml(text: &str, name: &str) -> Result<Valid<Self>, ParamsError> {
        let text = crate::io::without_bom_str(text);
        if let Ok(table) = toml::from_str::<toml::Table>(text)
            && let Some(key) = EXPLORE_KEYS.iter().find(|k| table.contains_key(**k))
        {
            return Err(ParamsError::Moved { source_name: name.into(), key: (*key).into(), moved_to: format!("[explore] {key}") });
        }
        let p: Self = crate::params::from_toml_over_default(text).map_err(|e| ParamsError::toml(text, name, &e))?;
        Valid::new(p).map_err(|error| ParamsError::Invalid { source_name: name.into(), error })
    }
}

impl Valid<MissionParams> {
    /// The exploration policy's part (valid as part of a valid whole).
    pub fn explore(&self) -> Valid<ExploreParams> {
        Valid::part_of_valid(self.explore.clone())
    }
}

impl Validate for MissionParams {
    /// Checks every numeric field, nested ones included: finite and in its documented range;
    /// the error names the first bad field by its key path (`odometry.gyro_sigma_per_sqrt_s`).
    fn validate(&self) -> Result<(), InvalidParam> {
        use std::f64::consts::{FRAC_PI_2, PI, TAU};
        fn at_most(name: &str, v: f64, max: f64, unit: &str) -> Result<(), InvalidParam> {
            if v <= max { Ok(()) } else { Err(InvalidParam::new(name, format!("must be ≤ {max}{unit} (got {})", Num(v)))) }
        }
        pos("dt_s", self.dt_s)?;
        // Bounds on the work of one step, scan and frame (far beyond any useful setting).
        if self.dt_s < MIN_DT_S {
            return Err(InvalidParam::new("dt_s", format!("must be ≥ {MIN_DT_S} s (got {})", Num(self.dt_s))));
        }
        at_most("dt_s", self.dt_s, MAX_DT_S, " s")?;
        let d = &self.drive;
        pos("drive.max_speed_mps", d.max_speed_mps)?;
        pos("drive.max_turn_rate_radps", d.max_turn_rate_radps)?;
        pos("drive.lookahead_m", d.lookahead_m)?;
        pos("drive.turn_in_place_rad", d.turn_in_place_rad)?;
        at_most("drive.turn_in_place_rad", d.turn_in_place_rad, PI, " rad (π)")?;
        pos("drive.heading_gain", d.heading_gain)?;
        pos("drive.goal_tolerance_m", d.goal_tolerance_m)?;
        at_most("drive.goal_tolerance_m", d.goal_tolerance_m, MAX_GOAL_TOLERANCE_M, " m")?;
        pos("drive.body_half_m", d.body_half_m)?;
        at_most("drive.body_half_m", d.body_half_m, MAX_BODY_HALF_M, " m")?;
        let l = &self.lidar;
        if l.rings == 0 || l.rings > 256 {
            return Err(InvalidParam::new("lidar.rings", format!("must be in 1..=256 (got {})", l.rings)));
        }
        nonneg("lidar.half_vfov_rad", l.half_vfov_rad)?;
        at_most("lidar.half_vfov_rad", l.half_vfov_rad, FRAC_PI_2, " rad (π/2)")?;
        pos("lidar.azimuth_step_rad", l.azimuth_step_rad)?;
        at_most("lidar.azimuth_step_rad", l.azimuth_step_rad, TAU, " rad (2π)")?;
        pos("lidar.max_range_m", l.max_range_m)?;
        nonneg("lidar.min_range_m", l.min_range_m)?;
        if l.min_range_m >= l.max_range_m {
            let reason = format!("({}) must be < lidar.max_range_m ({})", Num(l.min_range_m), Num(l.max_range_m));
            return Err(InvalidParam::new("lidar.min_range_m", reason));
        }
        nonneg("lidar.range_sigma_m", l.range_sigma_m)?;
        nonneg("lidar.mount_height_m", l.mount_height_m)?;
        let scan_rays = l.rings as f64 * (TAU / l.azimuth_step_rad).ceil();
        if scan_rays > MAX_RAYS_PER_SENSING as f64 {
            let reason = format!(
                "({}) gives {scan_rays:.3e} rays per scan (rings × 2π / azimuth_step_rad), over the limit of {MAX_RAYS_PER_SENSING}",
                Num(l.azimuth_step_rad)
            );
            return Err(InvalidParam::new("lidar.azimuth_step_rad", reason));
        }
        nonneg("camera_noise.bearing_sigma_rad", self.camera_noise.bearing_sigma_rad)?;
        nonneg("camera_noise.depth_sigma_coeff", self.camera_noise.depth_sigma_coeff)?;
        let o = &self.odometry;
        nonneg("odometry.distance_sigma_per_sqrt_m", o.distance_sigma_per_sqrt_m)?;
        nonneg("odometry.rotation_sigma_per_sqrt_rad", o.rotation_sigma_per_sqrt_rad)?;
        nonneg("odometry.rotation_sigma_per_sqrt_m", o.rotation_sigma_per_sqrt_m)?;
        nonneg("odometry.slip_per_rad", o.slip_per_rad)?;
        nonneg("odometry.gyro_sigma_per_sqrt_s", o.gyro_sigma_per_sqrt_s)?;
        pos("scan_every_m", self.scan_every_m)?;
        pos("scan_every_rad", self.scan_every_rad)?;
        pos("scan_every_s", self.scan_every_s)?;
        // 0 columns or rows is allowed: no depth-camera ground rays (the loops run 0 times).
        if self.depth_rays[0].saturating_mul(self.depth_rays[1]) > MAX_RAYS_PER_SENSING {
            let [c, r] = self.depth_rays;
            return Err(InvalidParam::new("depth_rays", format!("{c} × {r} rays per frame, over the limit of {MAX_RAYS_PER_SENSING}")));
        }
        pos("camera_every_s", self.camera_every_s)?;
        pos("replan_period_s", self.replan_period_s)?;
        pos("goal_timeout_factor", self.goal_timeout_factor)?;
        nonneg("goal_timeout_extra_s", self.goal_timeout_extra_s)?;
        pos("metrics_period_s", self.metrics_period_s)?;
        if let Some(t) = self.time_limit_s {
            pos("time_limit_s", t)?;
        }
        self.explore.validate().map_err(|e| e.under("explore."))?;
        self.vision.validate()?;
        self.slam.validate()
    }
}
