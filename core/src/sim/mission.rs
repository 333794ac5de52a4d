//! A whole exploration mission, headless (notes §1, §2, §7, §8): sense → localise → map → decide
//! → move, one control tick per [`Mission::step`]; [`Mission::run`] loops over it.
//!
//! Per tick (`dt_s`): the robot follows its path (carrot controller, GT motion with a safety stop
//! before any ground-truth untraversable cell), odometry integrates the measured motion, and
//! every `scan_every_*` the LiDAR sweep, the depth camera's ground points and the body's footprint
//! are registered with the *estimated* pose into the traversability map (lazily estimated, below);
//! every `camera_every_s` the camera observes landmarks, which build the landmark map. The goal
//! is (re)chosen on arrival (after turning to Θ*), on failure (timeout → blacklist `Failed`),
//! when the path ahead of the robot is blocked (checked after each scan, [`super::corridor`];
//! the part already driven is not checked), and every `replan_period_s` (then the current goal
//! is kept while it is still a reachable frontier candidate). Candidates the selector finds
//! unreachable are blacklisted `NoPath`; a goal re-chosen near any goal reached before is
//! blacklisted `Reselected`. The path the robot drives ends short of unknown ground by its
//! position uncertainty ([`crate::path::set_back`]); the goal stays the candidate. A decision
//! that finds no goal is made again with the cells the robot's centre has driven on open to the
//! planner (and, for that path, to the path check) while its map holds them free (`reuse_trail`),
//! so that lethal cells mapped later beside a doorway it came through cannot shut it in; if it still
//! finds none, again with lethal cells inflated by each of `tight_inflations_m` in turn instead
//! of the robot radius (the path check of a path planned so uses that radius too), for doorways
//! the full inflation shuts. A robot its map walls in ([`crate::frontier::enclosed_within`]) with no candidate left
//! forgets its map around itself and turns a full circle, at most `trap_recoveries` times. The mission ends when no candidate
//! is left (`Decision::chosen == None`; `Trapped` rather than `NoFrontier` if the map still walls
//! the robot in after its recoveries) or at the time limit.
//!
//! Localisation: ground truth (covariance 0), dead-reckoned odometry with a propagated 3×3
//! (x, y, θ) covariance, or keyframe graph SLAM ([`super::slam_frontend`]: odometry + IMU
//! attitude lifted to SE(3), camera landmarks, sliding window / full optimisation on loop
//! closure, 6×6 pose covariance, the traversability map re-registered from the keyframe clouds
//! when a loop closure moves the keyframes, the planner's landmark map with SLAM covariances).
//! ATE is the 3D distance between the estimated and true body positions (for ground truth and
//! odometry the estimate's height is the terrain's under it).
//!
//! The traversability map is estimated lazily: a scan only adds its points (O(disc cells) each);
//! the cells along the path ahead are re-estimated for the blocked-path check, every stale
//! cell at a decision, and the metrics count known cells from flags kept without estimating.
//!
//! Cost per tick: O(path) control; per scan O(rays × march) + O(points × disc cells) + O(path
//! corridor); per decision the selector's cost (one Dijkstra, rays, u2) plus the stale cells'
//! estimates and O(cells) thresholding; per metrics row O(cells whose disc changed).

#![allow(clippy::collapsible_if)] // nested ifs mirror the decision steps

use super::World;
use super::camera::{CameraNoise, CameraObservation, LandmarkIndex, depth_ground_hits, observe_landmarks};
use super::corridor::CorridorCheck;
use super::lidar::{LidarParams, RayCaster, gaussian, scan};
use super::odometry::OdometryNoise;
use super::robot::{DriveParams, PathFollower, Twist, body_on_terrain, footprint_points, integrate};
use super::slam_frontend::{BodyIncrement, SlamFrontend, SlamParams};
use crate::PointCloud;
use crate::frontier::Blacklist;
use crate::frontier::BlacklistReason;
use crate::grid::OccupancyGrid;
use crate::math;
use crate::params::{Num, Params, ParamsError, Strategy};
use crate::path::GoalSetback;
use crate::pose::{Pose2, wrap_pi};
use crate::select::{DecisionInput, DropReason, GoalSelector, SelectError, make_selector};
use crate::slam::lie::so3_log;
use crate::slam::{CovarianceTraces, Se3};
use crate::traversability::{TraversabilityLayers, TraversabilityMap};
use crate::utility::LandmarkVoxels;
use nalgebra::{Matrix3, Matrix6, Point3, Rotation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A body position on the terrain and its attitude.
type BodyPose = (Point3<f64>, Rotation3<f64>);

/// How the robot knows where it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Localisation {
    /// The true pose, covariance 0 (no SLAM).
    GroundTruth,
    /// Dead-reckoned wheel odometry + IMU yaw, covariance propagated (no loop closures).
    Odometry,
    /// Keyframe graph SLAM ([`super::slam_frontend`]): 6×6 marginal covariance, loop closures,
    /// map re-registration.
    Slam,
}

/// Simulator parameters (the planner's are [`Params`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MissionParams {
    /// Control period, seconds, from [`MIN_DT_S`] (0.001) to [`MAX_DT_S`] (1). Default 0.1.
    pub dt_s: f64,
    pub drive: DriveParams,
    pub lidar: LidarParams,
    pub camera_noise: CameraNoise,
    pub odometry: OdometryNoise,
    /// Scan when the robot has moved this far since the last scan, metres, > 0. Default 0.25.
    pub scan_every_m: f64,
    /// … or turned this much, radians, > 0. Default 0.5.
    pub scan_every_rad: f64,
    /// … or this much time has passed, seconds, > 0. Default 2.
    pub scan_every_s: f64,
    /// Depth-camera ground rays per frame: columns × rows, at most [`MAX_RAYS_PER_SENSING`] in
    /// all; 0 columns or rows turns the depth camera off. Default 24 × 12.
    pub depth_rays: [usize; 2],
    /// Landmark observation period, seconds, > 0. Default 1.
    pub camera_every_s: f64,
    /// Periodic replanning, seconds, > 0. Default 15.
    pub replan_period_s: f64,
    /// A goal not reached within factor × (ρ / v_max) + extra seconds has failed; factor > 0,
    /// extra ≥ 0. Defaults 3, 20.
    pub goal_timeout_factor: f64,
    pub goal_timeout_extra_s: f64,
    /// One metrics row (and trajectory pose) every this many seconds, > 0. Default 1.
    pub metrics_period_s: f64,
    /// Stop before the robot's body touches ground-truth untraversable terrain (a bumper;
    /// [`World::gt_touches_lethal`]). Default true.
    pub safety_stop: bool,
    /// Each path ends short of unknown ground by a multiple of the position estimate's standard
    /// deviation ([`crate::path::set_back`]): a robot unsure of its position could otherwise
    /// drive past a frontier goal into ground no sensor has seen. 0 with a ground-truth pose.
    /// Defaults 2 σ, at most 1 m.
    pub goal_setback: GoalSetback,
    /// Footprint clearing, as robot costmaps do, when the planner finds the robot blocked (no
    /// free cell of the inflated grid within its radius plus one cell): the decision is made
    /// again with the cells within that distance of the estimated pose free (the robot stands on
    /// that ground), so registration speckle under the robot cannot block every plan. Only
    /// then: cleared on every decision, a lethal edge just ahead of the robot would be planned
    /// through. Default true.
    pub clear_footprint: bool,
    /// The robot may go back the way it came: when a decision finds no goal, it is made again
    /// with every cell the estimated centre has driven on, while free in the thresholded map,
    /// free in the planner's inflated grid (and in the trap check), and the path check then
    /// ignores lethal cells beside such cells for that path. The robot was there, so the
    /// inflation of lethal cells mapped since (a doorway's jambs, seen better from inside the
    /// room) must not shut it in; cells its map holds lethal themselves stay closed. Only then:
    /// open at every decision, the trail would lead paths along edges the robot once stopped
    /// at (measured on the pit world, session 22). Default true.
    pub reuse_trail: bool,
    /// Squeezing through: when a decision finds no goal even with the trail open, it is made
    /// again with lethal cells inflated by each of these radii in turn, metres, instead of
    /// `robot.radius_m`, until one finds a goal (the path check and trap check of that path then
    /// use that radius too). The robot radius on top of the disc's band of lethal cells along a
    /// wall shuts doorways narrower than about 0.95 m at the defaults; 0.20 m passes ≈ 0.85 m.
    /// A second radius of 0.10 m (radius − disc radius: a cell is lethal when its disc holds a
    /// hazard, so that still keeps the body off ground-truth hazards in a perfect map) passes
    /// 0.7 m, but measured over the assets' worlds it also chases scraps of ground and the bumper
    /// fired in 13 of 320 runs (session 25): add it for indoor maps with narrow doors. Only when nothing else is left: planned this close everywhere,
    /// the body meets drops and walls the map does not show yet (session 23). Each > 0 and
    /// smaller than the one before, at most [`MAX_TIGHT_INFLATIONS`]; radii at least
    /// `robot.radius_m` are skipped; empty turns the retry off. Default [0.20].
    pub tight_inflations_m: Vec<f64>,
    /// Overrides the world's time limit, seconds, > 0 and finite.
    pub time_limit_s: Option<f64>,
    /// Decisions in a row without a plan (each followed by 2 s of looking around) before the
    /// mission ends as [`EndReason::Stuck`], ≥ 1. Default 30.
    pub max_failed_decisions: u32,
    /// A decision with no frontier goal ends the mission as [`EndReason::Trapped`] instead of
    /// [`EndReason::NoFrontier`] when every free cell the robot can reach in its inflated map
    /// lies within this distance, metres (a pocket a few robot lengths wide; a finished map's
    /// reachable space spans what was explored), ≥ 0. 0 turns the distinction off. Default 2.
    pub trapped_radius_m: f64,
    /// Times a trapped robot recovers before the mission ends [`EndReason::Trapped`]: as Nav2's
    /// clear-costmap recovery does, it forgets its map within
    /// [`crate::frontier::recovery_radius_m`] of itself (with SLAM in the keyframe clouds too, so
    /// that no re-registration brings it back) and turns a full circle in place to map it again.
    /// 0: no recovery. Default 2.
    pub trap_recoveries: u32,
    /// The SLAM front end and back end ([`Localisation::Slam`] only).
    pub slam: SlamParams,
}

/// Smallest simulation step, seconds: a finer one only multiplies the steps of a mission.
pub const MIN_DT_S: f64 = 1e-3;
/// Largest simulation step, seconds: a control period longer than this is not a control loop
/// (at the default 0.4 m/s the robot would drive 0.4 m blind between two commands).
pub const MAX_DT_S: f64 = 1.0;
/// Most rays in one LiDAR scan or one depth frame (a VLP-16 at 0.2° casts 28,800).
pub const MAX_RAYS_PER_SENSING: usize = 1 << 20;
/// Largest [`DriveParams::goal_tolerance_m`], metres: a robot that counts a goal reached from
/// farther away stops metres short of every frontier it chose, so a larger value is a typo.
pub const MAX_GOAL_TOLERANCE_M: f64 = 5.0;
/// Most radii in [`MissionParams::tight_inflations_m`]: each is one more decision whenever a
/// decision finds no goal.
pub const MAX_TIGHT_INFLATIONS: usize = 8;
/// Largest [`DriveParams::body_half_m`], metres (a 10 m body): the footprint adds
/// (2 · body_half_m / 5 cm + 1)² points to every scan.
pub const MAX_BODY_HALF_M: f64 = 5.0;

impl Default for MissionParams {
    fn default() -> Self {
        Self {
            dt_s: 0.1,
            drive: DriveParams::default(),
            lidar: LidarParams::default(),
            camera_noise: CameraNoise::default(),
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
            goal_setback: GoalSetback::default(),
            clear_footprint: true,
            reuse_trail: true,
            tight_inflations_m: vec![0.20],
            time_limit_s: None,
            max_failed_decisions: 30,
            trapped_radius_m: 2.0,
            trap_recoveries: 2,
            slam: SlamParams::default(),
        }
    }
}

impl MissionParams {
    /// Parses TOML (unknown keys rejected; keys left out keep [`MissionParams::default`]'s
    /// values at every depth, [`crate::params::from_toml_over_default`]) and validates; `name` is
    /// quoted in errors, with the line of a TOML error.
    pub fn from_toml(text: &str, name: &str) -> Result<Self, ParamsError> {
        let text = crate::io::without_bom_str(text);
        let p: Self = crate::params::from_toml_over_default(text).map_err(|e| ParamsError::toml(text, name, &e))?;
        p.validate().map_err(|message| ParamsError::Invalid { source_name: name.into(), message })?;
        Ok(p)
    }

    /// Checks every numeric field, nested ones included: finite and in its documented range;
    /// returns a message naming the first bad field by its key path (`odometry.gyro_sigma_per_sqrt_s`).
    pub fn validate(&self) -> Result<(), String> {
        use crate::params::{check_non_negative as nonneg, check_positive as pos};
        use std::f64::consts::{FRAC_PI_2, PI, TAU};
        fn at_most(name: &str, v: f64, max: f64, unit: &str) -> Result<(), String> {
            if v <= max { Ok(()) } else { Err(format!("{name} must be ≤ {max}{unit} (got {})", Num(v))) }
        }
        pos("dt_s", self.dt_s)?;
        // Bounds on the work of one step, scan and frame (far beyond any useful setting).
        if self.dt_s < MIN_DT_S {
            return Err(format!("dt_s must be ≥ {MIN_DT_S} s (got {})", Num(self.dt_s)));
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
            return Err(format!("lidar.rings must be in 1..=256 (got {})", l.rings));
        }
        nonneg("lidar.half_vfov_rad", l.half_vfov_rad)?;
        at_most("lidar.half_vfov_rad", l.half_vfov_rad, FRAC_PI_2, " rad (π/2)")?;
        pos("lidar.azimuth_step_rad", l.azimuth_step_rad)?;
        at_most("lidar.azimuth_step_rad", l.azimuth_step_rad, TAU, " rad (2π)")?;
        pos("lidar.max_range_m", l.max_range_m)?;
        nonneg("lidar.min_range_m", l.min_range_m)?;
        if l.min_range_m >= l.max_range_m {
            return Err(format!("lidar.min_range_m ({}) must be < lidar.max_range_m ({})", l.min_range_m, l.max_range_m));
        }
        nonneg("lidar.range_sigma_m", l.range_sigma_m)?;
        nonneg("lidar.mount_height_m", l.mount_height_m)?;
        let scan_rays = l.rings as f64 * (TAU / l.azimuth_step_rad).ceil();
        if scan_rays > MAX_RAYS_PER_SENSING as f64 {
            return Err(format!(
                "lidar: {scan_rays:.3e} rays per scan (rings × 2π / azimuth_step_rad), over the limit of {MAX_RAYS_PER_SENSING}"
            ));
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
            return Err(format!(
                "depth_rays: {} × {} rays per frame, over the limit of {MAX_RAYS_PER_SENSING}",
                self.depth_rays[0], self.depth_rays[1]
            ));
        }
        pos("camera_every_s", self.camera_every_s)?;
        pos("replan_period_s", self.replan_period_s)?;
        pos("goal_timeout_factor", self.goal_timeout_factor)?;
        nonneg("goal_timeout_extra_s", self.goal_timeout_extra_s)?;
        pos("metrics_period_s", self.metrics_period_s)?;
        self.goal_setback.validate("goal_setback")?;
        if let Some(t) = self.time_limit_s {
            pos("time_limit_s", t)?;
        }
        if self.max_failed_decisions == 0 {
            return Err("max_failed_decisions must be ≥ 1".into());
        }
        nonneg("trapped_radius_m", self.trapped_radius_m)?;
        check_tight_inflations("tight_inflations_m", &self.tight_inflations_m)?;
        self.slam.validate()
    }
}

/// `Ok` when `radii` (named `name`) is a valid [`MissionParams::tight_inflations_m`]: at most
/// [`MAX_TIGHT_INFLATIONS`], each finite and > 0, each smaller than the one before.
pub fn check_tight_inflations(name: &str, radii: &[f64]) -> Result<(), String> {
    if radii.len() > MAX_TIGHT_INFLATIONS {
        return Err(format!("{name}: {} radii, over the limit of {MAX_TIGHT_INFLATIONS}", radii.len()));
    }
    for (i, &r) in radii.iter().enumerate() {
        crate::params::check_positive(&format!("{name}[{i}]"), r)?;
        if i > 0 && r >= radii[i - 1] {
            return Err(format!("{name}[{i}] must be smaller than the radius before it ({}; got {})", Num(radii[i - 1]), Num(r)));
        }
    }
    Ok(())
}

/// Why a [`Mission`] could not start.
#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    #[error("planner parameters: {0}")]
    Params(String),
    #[error("simulator parameters: {0}")]
    Simulator(String),
    #[error("traversability map: {0}")]
    Map(#[from] crate::traversability::TraversabilityError),
    #[error("SLAM: {0}")]
    Slam(#[from] crate::slam::SlamError),
}

/// One metrics row (notes §8).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MetricsRow {
    pub time_s: f64,
    /// Explorable cells still unknown in the robot's map, % of the explorable cells.
    pub unexplored_pct: f64,
    pub cov_trace: f64,
    pub pos_cov_trace: f64,
    pub rot_cov_trace: f64,
    /// |estimated − true| position, metres.
    pub ate_m: f64,
    pub distance_m: f64,
    pub loop_closures: u64,
    /// Wall time of the decisions since the previous row, ms (0 without a clock). Not
    /// deterministic: keep it out of byte-compared files.
    pub plan_ms: f64,
}

/// A timestamped 3D pose for TUM trajectories.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StampedPose {
    pub time_s: f64,
    pub position_m: [f64; 3],
    /// Quaternion (x, y, z, w).
    pub quaternion_xyzw: [f64; 4],
}

/// Why a mission ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EndReason {
    /// No non-blacklisted reachable frontier candidate left.
    NoFrontier,
    /// No frontier candidate left, but only because the robot's map walls it in: every free
    /// cell it can reach lies within [`MissionParams::trapped_radius_m`]
    /// ([`crate::frontier::enclosed_within`]; e.g. a ring of registration speckle), still after
    /// [`MissionParams::trap_recoveries`] recoveries.
    Trapped,
    TimeLimit,
    /// `max_failed_decisions` decisions in a row found no plan (e.g. the robot's own cell stayed
    /// untraversable in its map): the robot is stuck.
    Stuck,
}

/// What one [`Mission::step`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepOutcome {
    Running,
    Finished(EndReason),
}

/// Final figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub world: String,
    pub strategy: Strategy,
    pub localisation: Localisation,
    pub seed: u64,
    pub end_reason: Option<EndReason>,
    pub time_s: f64,
    pub unexplored_pct: f64,
    pub explorable_cells: usize,
    pub distance_m: f64,
    pub ate_rmse_m: f64,
    pub final_cov_trace: f64,
    pub loop_closures: u64,
    pub decisions: u64,
    pub goals_reached: u64,
    pub goals_failed: u64,
    pub blacklist_len: usize,
    pub gt_violations: u64,
    pub safety_stops: u64,
    /// Recoveries from a trap ([`MissionParams::trap_recoveries`]).
    pub trap_recoveries: u64,
    /// Paths planned with a tight inflation ([`MissionParams::tight_inflations_m`]): to a new
    /// goal, or to the current one when periodic replanning found it only so.
    pub tight_plans: u64,
    pub planning_errors: u64,
    pub landmarks_mapped: usize,
    pub scans: u64,
    /// SLAM keyframes (0 without SLAM).
    pub keyframes: usize,
    /// Traversability map rebuilds after loop closures.
    pub reregistrations: u64,
    /// Keyframe updates whose optimisation or covariance failed (the keyframe was kept).
    pub slam_errors: u64,
    pub total_plan_ms: f64,
}

#[derive(Clone, Debug)]
enum Phase {
    /// No goal: decide on the next tick.
    Idle,
    Driving,
    /// At the goal position, turning to Θ*.
    Turning(f64),
    /// Turning in place (initial look-around, after a planning error or a trap recovery) until
    /// the time.
    Spinning(f64),
}

/// A running mission.
pub struct Mission {
    pub world: World,
    pub params: Params,
    pub mission: MissionParams,
    pub strategy: Strategy,
    pub seed: u64,
    pub localisation: Localisation,
    selector: Box<dyn GoalSelector>,
    caster: RayCaster,
    landmark_index: LandmarkIndex,
    rng: ChaCha8Rng,
    clock: Option<Box<dyn FnMut() -> f64>>,
    time_limit_s: f64,

    pub time_s: f64,
    pub gt: Pose2,
    pub est: Pose2,
    /// (x, y, θ) covariance of the estimate (world axes).
    pub est_cov: Matrix3<f64>,
    /// 6×6 covariance of the estimate (ξ = (δt, δφ), body frame): SLAM only, else zero.
    pub est_cov6: Matrix6<f64>,
    slam: Option<SlamFrontend>,
    slam_errors: u64,
    /// True `world_from_body` at the previous tick (the wheels and the gyro measure the motion
    /// since, in the body frame): SLAM only.
    last_body_gt: Se3,
    body_points: Vec<Vector3<f64>>,
    tmap: TraversabilityMap,
    /// Estimated lazily: cells are refreshed along the path after each scan and everywhere at
    /// each decision ([`Self::layers`] brings them all up to date).
    layers: TraversabilityLayers,
    corridor: CorridorCheck,
    /// Cells (flat indices) the estimated centre has driven on, in the order first reached
    /// ([`MissionParams::reuse_trail`]).
    trail: Vec<usize>,
    /// Membership of `trail`, per cell.
    on_trail: Vec<bool>,
    /// Whether the path being driven was planned with the trail open.
    path_on_trail: bool,
    /// The inflation radius the path being driven was planned with, metres (`robot.radius_m`,
    /// or one of [`MissionParams::tight_inflations_m`]).
    path_inflation_m: f64,
    /// Landmark map: id → (sum of world positions, count).
    landmark_sums: BTreeMap<u64, (Vector3<f64>, u32)>,
    pub blacklist: Blacklist,
    phase: Phase,
    follower: PathFollower,
    pub goal: Option<Pose2>,
    goal_started_s: f64,
    goal_deadline_s: f64,
    next_replan_s: f64,
    /// The goals reached so far (notes §3: one selected again while still a frontier goal is
    /// blacklisted).
    reached: Vec<[f64; 2]>,
    /// The grid the last decision planned on ([`Self::planning_grid`]).
    planning_grid: Option<OccupancyGrid>,
    last_scan: (Pose2, f64),
    last_camera_s: f64,
    next_metrics_s: f64,
    /// Ground-truth explorable cells that are known in the robot's map (kept by
    /// [`TraversabilityMap::refresh_known`], no estimate needed).
    known_explorable: usize,

    pub distance_m: f64,
    pub rows: Vec<MetricsRow>,
    pub trajectory_gt: Vec<StampedPose>,
    pub trajectory_est: Vec<StampedPose>,
    pending_plan_ms: f64,
    total_plan_ms: f64,
    sq_err_sum: f64,
    decisions: u64,
    goals_reached: u64,
    goals_failed: u64,
    violations: u64,
    safety_stops: u64,
    trap_recoveries: u64,
    tight_plans: u64,
    planning_errors: u64,
    /// Decisions in a row that found no plan.
    failed_decisions: u32,
    scans: u64,
    pub end: Option<EndReason>,
    points: Vec<Point3<f64>>,
    /// SLAM-registered points with their height variance.
    registered: Vec<(Point3<f64>, f64)>,
    observations: Vec<CameraObservation>,
    /// The last decision (for the studio).
    pub last_decision: Option<crate::select::Decision>,
}

impl Mission {
    /// A mission in `world` with planner `params` (its `selector.strategy` and `selector.seed`
    /// are overridden by `strategy` and `seed`), simulator `mission` parameters, sensor seed
    /// `seed`. Fails on invalid parameters, a world too large for a map, or a SLAM that cannot
    /// start (a non-finite start pose).
    pub fn new(
        world: World,
        mut params: Params,
        mission: MissionParams,
        strategy: Strategy,
        seed: u64,
        localisation: Localisation,
    ) -> Result<Self, MissionError> {
        params.validate().map_err(MissionError::Params)?;
        mission.validate().map_err(MissionError::Simulator)?;
        params.selector.strategy = strategy;
        params.selector.seed = seed;
        let selector = make_selector(&params.selector);
        let g = world.field.geometry;
        let tmap = TraversabilityMap::new(g)?;
        let layers = tmap.compute(&params.traversability);
        let caster = RayCaster::new(&world.field);
        let landmark_index = LandmarkIndex::new(&world.landmarks, g.bounds_m(), 1.0);
        let time_limit_s = mission.time_limit_s.unwrap_or(world.spec.time_limit_s);
        let start = world.start;
        let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
        let mut m = Self {
            selector,
            caster,
            landmark_index,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_51A1),
            clock: None,
            time_limit_s,
            time_s: 0.0,
            gt: start,
            est: start,
            est_cov: Matrix3::zeros(),
            est_cov6: Matrix6::zeros(),
            slam: None,
            slam_errors: 0,
            last_body_gt: Se3::identity(),
            body_points: Vec::new(),
            tmap,
            layers,
            corridor: CorridorCheck::default(),
            trail: Vec::new(),
            on_trail: vec![false; g.len()],
            path_on_trail: false,
            path_inflation_m: params.robot.radius_m,
            landmark_sums: BTreeMap::new(),
            blacklist,
            // A full turn in place first: the LiDAR is blind within ~1.1 m, the camera sees it.
            phase: Phase::Spinning(std::f64::consts::TAU / mission.drive.max_turn_rate_radps),
            follower: PathFollower::default(),
            goal: None,
            goal_started_s: 0.0,
            goal_deadline_s: 0.0,
            next_replan_s: 0.0,
            reached: Vec::new(),
            planning_grid: None,
            last_scan: (start, 0.0),
            last_camera_s: f64::NEG_INFINITY,
            next_metrics_s: 0.0,
            known_explorable: 0,
            distance_m: 0.0,
            rows: Vec::new(),
            trajectory_gt: Vec::new(),
            trajectory_est: Vec::new(),
            pending_plan_ms: 0.0,
            total_plan_ms: 0.0,
            sq_err_sum: 0.0,
            decisions: 0,
            goals_reached: 0,
            goals_failed: 0,
            violations: 0,
            safety_stops: 0,
            trap_recoveries: 0,
            tight_plans: 0,
            planning_errors: 0,
            failed_decisions: 0,
            scans: 0,
            end: None,
            points: Vec::new(),
            registered: Vec::new(),
            observations: Vec::new(),
            last_decision: None,
            world,
            params,
            mission,
            strategy,
            seed,
            localisation,
        };
        if localisation == Localisation::Slam {
            // The first keyframe: the start pose (the map frame), with the camera's first view.
            let (gp, gr) = body_on_terrain(&m.world.field, m.gt, m.mission.drive.body_half_m);
            m.observe_camera(gp, &gr);
            let start = Se3::new(UnitQuaternion::from_rotation_matrix(&gr), gp.coords);
            m.last_body_gt = start;
            let fe = SlamFrontend::new(m.mission.slam.clone(), start, &m.observations)?;
            m.slam = Some(fe);
            m.last_camera_s = 0.0;
        }
        m.sense_geometry();
        m.sense_landmarks();
        m.record_metrics();
        Ok(m)
    }

    /// Registers `points_m` (true world frame) as if sensed now, as a sensing glitch would.
    #[cfg(test)]
    pub(crate) fn plant_points(&mut self, points_m: impl IntoIterator<Item = Point3<f64>>) {
        self.points.clear();
        self.points.extend(points_m);
        let poses = self.body_poses();
        self.register_sensed_points(poses);
    }

    /// Rebuilds the map from the keyframe clouds now, as a loop closure would (no-op without SLAM).
    #[cfg(test)]
    pub(crate) fn reregister_now(&mut self) {
        if let Some(fe) = &self.slam {
            fe.reregister_map(&mut self.tmap);
        }
    }

    /// A wall clock in milliseconds used only to fill `plan_ms` (core has no clock).
    pub fn set_clock(&mut self, clock: Box<dyn FnMut() -> f64>) {
        self.clock = Some(clock);
    }

    /// The robot's map: thresholded traversability (0 free, 100 lethal, −1 unknown).
    pub fn occupancy(&mut self) -> OccupancyGrid {
        let tau = self.params.traversability.tau;
        self.layers().to_occupancy(tau)
    }

    /// The robot's traversability layers, brought up to date (O(cells changed since the last
    /// decision)).
    pub fn layers(&mut self) -> &TraversabilityLayers {
        self.tmap.update(&self.params.traversability, &mut self.layers);
        &self.layers
    }

    /// The landmark map (estimated positions, in id order; with SLAM: the graph's landmarks and
    /// their covariances, see [`super::slam_frontend`]).
    pub fn landmark_map(&self) -> PointCloud {
        if let Some(fe) = &self.slam {
            return fe.landmark_map();
        }
        let sigma2 = self.params.u2.sigma_landmark_m.powi(2);
        let points: Vec<Point3<f64>> = self.landmark_sums.values().map(|(s, n)| Point3::from(*s / f64::from(*n))).collect();
        PointCloud { covariances: Some(vec![Matrix3::identity() * sigma2; points.len()]), points, classification: None }
    }

    /// Runs to the end and returns the summary.
    pub fn run(&mut self) -> Summary {
        while self.step() == StepOutcome::Running {}
        self.summary()
    }

    /// One control tick.
    pub fn step(&mut self) -> StepOutcome {
        if let Some(r) = self.end {
            return StepOutcome::Finished(r);
        }
        if self.time_s >= self.time_limit_s - 1e-9 {
            return self.finish(EndReason::TimeLimit);
        }
        let replan_due = self.time_s >= self.next_replan_s;
        match self.phase {
            Phase::Idle => {
                if let Some(r) = self.decide(false) {
                    return self.finish(r);
                }
            }
            Phase::Driving if replan_due => {
                if let Some(r) = self.decide(true) {
                    return self.finish(r);
                }
            }
            _ => {}
        }
        let dt = self.mission.dt_s;
        let cmd = match self.phase {
            Phase::Idle => Twist { v_mps: 0.0, omega_radps: 0.0 },
            Phase::Driving => self.follower.command(self.est, &self.mission.drive),
            Phase::Turning(yaw) => {
                let err = wrap_pi(yaw - self.est.yaw_rad);
                let w = self.mission.drive.max_turn_rate_radps;
                Twist { v_mps: 0.0, omega_radps: (err / dt).clamp(-w, w) }
            }
            Phase::Spinning(_) => Twist { v_mps: 0.0, omega_radps: self.mission.drive.max_turn_rate_radps },
        };
        // Ground-truth motion with the safety stop.
        let next = integrate(self.gt, cmd, dt);
        let reach_m = (self.params.robot.radius_m - self.params.traversability.disc_radius_m).max(0.0);
        let touches = |p: Pose2| self.world.gt_touches_lethal(p.x_m, p.y_m, reach_m);
        let entering = touches(next) && !touches(self.gt);
        let (next, cmd) = if entering && self.mission.safety_stop && cmd.v_mps > 0.0 {
            self.safety_stops += 1;
            self.fail_goal();
            (self.gt, Twist { v_mps: 0.0, omega_radps: 0.0 })
        } else {
            if entering {
                self.violations += 1;
            }
            (next, cmd)
        };
        let ds = cmd.v_mps * dt;
        let dth = wrap_pi(next.yaw_rad - self.gt.yaw_rad);
        self.gt = next;
        self.distance_m += ds.abs();
        self.time_s = ((self.time_s + dt) * 1e6).round() / 1e6;
        let before = self.est;
        self.localise(ds, dth, dt);
        self.mark_trail(before);

        // Phase transitions.
        match self.phase {
            Phase::Driving => {
                if self.follower.arrived(self.est, self.mission.drive.goal_tolerance_m) {
                    let yaw = self.goal.map(|g| g.yaw_rad).unwrap_or(self.est.yaw_rad);
                    self.phase = Phase::Turning(yaw);
                } else if self.time_s > self.goal_deadline_s {
                    self.fail_goal();
                }
            }
            Phase::Turning(yaw) => {
                if wrap_pi(yaw - self.est.yaw_rad).abs() < 0.05 {
                    self.goals_reached += 1;
                    self.reached.extend(self.goal.map(|g| [g.x_m, g.y_m]));
                    self.goal = None;
                    self.phase = Phase::Idle;
                }
            }
            Phase::Spinning(until) => {
                if self.time_s >= until {
                    self.phase = Phase::Idle;
                }
            }
            Phase::Idle => {}
        }

        // Sensing. A SLAM keyframe first, so that this tick's scan belongs to it.
        if self.slam.as_ref().is_some_and(|f| f.keyframe_due()) {
            self.slam_keyframe();
        }
        let (p, t) = self.last_scan;
        let moved = math::hypot(self.est.x_m - p.x_m, self.est.y_m - p.y_m);
        let turned = wrap_pi(self.est.yaw_rad - p.yaw_rad).abs();
        if moved >= self.mission.scan_every_m || turned >= self.mission.scan_every_rad || self.time_s - t >= self.mission.scan_every_s {
            self.sense_geometry();
            if matches!(self.phase, Phase::Driving) && self.path_blocked() {
                self.next_replan_s = self.time_s;
            }
        }
        if self.time_s - self.last_camera_s >= self.mission.camera_every_s - 1e-9 {
            self.sense_landmarks();
        }
        if self.time_s >= self.next_metrics_s - 1e-9 {
            self.record_metrics();
        }
        StepOutcome::Running
    }

    fn finish(&mut self, reason: EndReason) -> StepOutcome {
        self.end = Some(reason);
        if self.rows.last().map(|r| r.time_s) != Some(self.time_s) {
            self.record_metrics();
        }
        StepOutcome::Finished(reason)
    }

    fn fail_goal(&mut self) {
        if let Some(g) = self.goal.take() {
            self.blacklist.add(g.x_m, g.y_m, BlacklistReason::Failed);
            self.goals_failed += 1;
        }
        self.phase = Phase::Idle;
    }

    /// Updates the estimate from the odometry of one tick.
    fn localise(&mut self, ds: f64, dth: f64, dt: f64) {
        let slope = self.world.field.slope_at(self.gt.x_m, self.gt.y_m).unwrap_or(0.0);
        if self.localisation == Localisation::Slam {
            self.localise_slam(dt, slope);
            return;
        }
        let (ms, mth) = self.mission.odometry.measure(ds, dth, dt, slope, &mut self.rng);
        if self.localisation == Localisation::GroundTruth {
            self.est = self.gt;
            return;
        }
        let th = self.est.yaw_rad + 0.5 * mth;
        let (c, s) = (math::cos(th), math::sin(th));
        self.est = Pose2 { x_m: self.est.x_m + ms * c, y_m: self.est.y_m + ms * s, yaw_rad: wrap_pi(self.est.yaw_rad + mth) };
        let f = Matrix3::new(1.0, 0.0, -ms * s, 0.0, 1.0, ms * c, 0.0, 0.0, 1.0);
        let (vs, vt) = self.mission.odometry.variances(ds, dth, dt);
        let l = nalgebra::Matrix3x2::new(c, -0.5 * ms * s, s, 0.5 * ms * c, 0.0, 1.0);
        let q = nalgebra::Matrix2::new(vs, 0.0, 0.0, vt);
        self.est_cov = f * self.est_cov * f.transpose() + l * q * l.transpose();
    }

    /// The SLAM front end's odometry tick, measured in the body frame: the true motion since
    /// the last tick on the terrain, `T_prev⁻¹ T_now`; the wheels measure its length (signed by
    /// the direction of travel) with the odometry's noise and slip, the gyro its rotation with
    /// σ_g² dt on roll and pitch and the odometry's yaw noise.
    fn localise_slam(&mut self, dt: f64, slope: f64) {
        let (gp, gr) = body_on_terrain(&self.world.field, self.gt, self.mission.drive.body_half_m);
        let now = Se3::new(UnitQuaternion::from_rotation_matrix(&gr), gp.coords);
        let truth = self.last_body_gt.between(&now);
        self.last_body_gt = now;
        let distance = truth.translation.norm().copysign(truth.translation.x);
        let rotation = so3_log(&truth.rotation);
        let odometry = &self.mission.odometry;
        let (md, myaw) = odometry.measure(distance, rotation.z, dt, slope, &mut self.rng);
        let (vd, vyaw) = odometry.variances(distance, rotation.z, dt);
        let var_tilt = self.mission.slam.tilt_gyro_sigma_per_sqrt_s.powi(2) * dt;
        let sg = var_tilt.sqrt();
        let step = BodyIncrement {
            distance_m: md,
            rotation_rad: Vector3::new(rotation.x + sg * gaussian(&mut self.rng), rotation.y + sg * gaussian(&mut self.rng), myaw),
            var_distance_m2: vd,
            var_vertical_m2: self.mission.slam.z_sigma_per_sqrt_m.powi(2) * distance.abs(),
            var_rotation_rad2: Vector3::new(var_tilt, var_tilt, vyaw),
        };
        if let Some(fe) = self.slam.as_mut() {
            fe.odometry_step(&step);
            self.est = pose2_of(&fe.estimate());
        }
        self.update_slam_covariance();
    }

    /// Refreshes `est_cov6` and `est_cov` from the SLAM front end.
    fn update_slam_covariance(&mut self) {
        let Some(fe) = &self.slam else { return };
        let c = fe.covariance();
        self.est_cov6 = c;
        // World-axis (x, y, yaw) block: rotate the body-frame position and rotation blocks.
        let r = fe.estimate().rotation_matrix();
        let mut rr = Matrix6::zeros();
        rr.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        rr.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
        let w = rr * c * rr.transpose();
        let idx = [0usize, 1, 5];
        self.est_cov = Matrix3::from_fn(|i, j| w[(idx[i], idx[j])]);
    }

    /// A SLAM keyframe: the camera observes from the true pose, the front end adds the keyframe
    /// and, after a loop closure that moved the keyframes, the map is rebuilt from the keyframe
    /// clouds.
    fn slam_keyframe(&mut self) {
        let (gp, gr) = body_on_terrain(&self.world.field, self.gt, self.mission.drive.body_half_m);
        self.observe_camera(gp, &gr);
        // The accelerometer's up direction in the body frame, with the IMU's tilt noise.
        let sg = self.mission.slam.gravity_sigma_rad;
        let up_true = gr.inverse() * Vector3::z();
        let up_measured = up_true + Vector3::new(sg * gaussian(&mut self.rng), sg * gaussian(&mut self.rng), 0.0);
        let Some(fe) = self.slam.as_mut() else { return };
        let outcome = fe.add_keyframe(&self.observations, Some(up_measured));
        self.est = pose2_of(&fe.estimate());
        match outcome {
            Ok(o) if o.reregister => {
                fe.reregister_map(&mut self.tmap);
            }
            Ok(_) => {}
            Err(_) => self.slam_errors += 1,
        }
        self.update_slam_covariance();
    }

    /// Camera observations from the true body pose into `self.observations`.
    fn observe_camera(&mut self, gp: Point3<f64>, gr: &Rotation3<f64>) {
        let cam = gp + gr * Vector3::new(0.0, 0.0, self.params.robot.camera_height_m);
        observe_landmarks(
            &self.world.field,
            &self.world.landmarks,
            &self.landmark_index,
            cam,
            gp,
            gr,
            &self.params.camera,
            &self.mission.camera_noise,
            &mut self.rng,
            &mut self.observations,
        );
    }

    /// The true and estimated 3D body poses.
    fn body_poses(&self) -> (BodyPose, BodyPose) {
        let b = self.mission.drive.body_half_m;
        let gt = body_on_terrain(&self.world.field, self.gt, b);
        // Without SLAM the estimate's height and attitude are the terrain's under the estimate
        // (odometry alone does not estimate them); the SLAM estimates all six.
        let est = match &self.slam {
            Some(fe) => {
                let e = fe.estimate();
                (Point3::from(e.translation), e.rotation.to_rotation_matrix())
            }
            None => body_on_terrain(&self.world.field, self.est, b),
        };
        (gt, est)
    }

    /// LiDAR sweep + depth-camera ground rays + footprint, registered with the estimate.
    fn sense_geometry(&mut self) {
        let poses = self.body_poses();
        let (gp, gr) = poses.0;
        self.points.clear();
        let sensor = gp + gr * Vector3::new(0.0, 0.0, self.mission.lidar.mount_height_m);
        scan(&self.world.field, &self.caster, sensor, &gr, &self.mission.lidar, &mut self.rng, &mut self.points);
        // Depth camera ground points, with depth noise ∝ d².
        let cam = gp + gr * Vector3::new(0.0, 0.0, self.params.robot.camera_height_m);
        let (points, rng, sigma) = (&mut self.points, &mut self.rng, self.mission.camera_noise.depth_sigma_coeff);
        depth_ground_hits(&self.world.field, &self.caster, cam, &gr, &self.params.camera, self.mission.depth_rays, |dir, d| {
            points.push(cam + dir * (d + sigma * d * d * gaussian(rng)));
        });
        // The ground under the wheels (proprioceptive): the footprint, every 5 cm.
        footprint_points(&self.world.field, gp, &gr, self.mission.drive.body_half_m, 0.05, &mut self.points);
        self.register_sensed_points(poses);
        self.last_scan = (self.est, self.time_s);
        self.scans += 1;
    }

    /// Registers `self.points` (sensed now, true world frame) with the estimate into the map:
    /// p_est = T_est · T_gt⁻¹ · p, with ([`Self::body_poses`]) the true and estimated body poses
    /// now; with SLAM, kept in the keyframe's cloud too.
    fn register_sensed_points(&mut self, ((gp, gr), (ep, er)): (BodyPose, BodyPose)) {
        let (gt_inv, gp_c) = (gr.inverse(), gp.coords);
        if let Some(fe) = self.slam.as_mut() {
            // Kept in the keyframe's cloud too, for re-registration.
            self.body_points.clear();
            self.body_points.extend(self.points.iter().map(|p| gt_inv * (p.coords - gp_c)));
            self.registered.clear();
            fe.register_points(&self.body_points, &mut self.registered);
            self.tmap.insert_points_with_variance(self.registered.iter().copied());
        } else {
            let same = self.est == self.gt;
            let pts = self.points.iter().map(|p| if same { *p } else { ep + er * (gt_inv * (p.coords - gp_c)) });
            self.tmap.insert_points(pts);
        }
    }

    /// Periodic landmark observations (without SLAM: averaged into the landmark map; with SLAM
    /// the camera is used at keyframes only).
    fn sense_landmarks(&mut self) {
        if self.slam.is_some() {
            self.last_camera_s = self.time_s;
            return;
        }
        let ((gp, gr), (ep, er)) = self.body_poses();
        self.observe_camera(gp, &gr);
        for o in &self.observations {
            let w = ep.coords + er * o.point_in_robot;
            let e = self.landmark_sums.entry(o.landmark_id).or_insert((Vector3::zeros(), 0));
            e.0 += w;
            e.1 += 1;
        }
        self.last_camera_s = self.time_s;
    }

    /// Whether the path ahead crosses a lethal cell of the current map within the robot radius
    /// ([`CorridorCheck`]), refreshing the estimates of the cells it reads.
    fn path_blocked(&mut self) -> bool {
        let g = self.layers.geometry();
        let (tmap, layers, params) = (&mut self.tmap, &mut self.layers, &self.params);
        let ahead = self.follower.remaining(self.est);
        let robot_m = [self.est.x_m, self.est.y_m];
        let on_trail: &[bool] = if self.path_on_trail { &self.on_trail } else { &[] };
        self.corridor.blocked(&g, ahead, robot_m, self.path_inflation_m, params.traversability.tau as f32, on_trail, |i| {
            tmap.refresh_cells([i], &params.traversability, layers);
            layers.score.data[i]
        })
    }

    /// Chooses a goal. `keep_current`: periodic replanning keeps the current goal while it is
    /// still a reachable candidate. Returns `Some(NoFrontier)` (or `Some(Trapped)`, once the
    /// recoveries are spent) at the end of the mission.
    fn decide(&mut self, keep_current: bool) -> Option<EndReason> {
        let mut grid = self.occupancy();
        let end = self.decide_on(&mut grid, keep_current);
        self.planning_grid = Some(grid);
        end
    }

    /// [`Self::decide`] on `grid`, the robot's map (its footprint cleared here if the robot is
    /// blocked in it).
    fn decide_on(&mut self, grid: &mut OccupancyGrid, keep_current: bool) -> Option<EndReason> {
        let (mut cleared, mut use_trail) = (false, false);
        // The planner's parameters with a tight inflation, once a retry needs them, and the
        // number of tight radii already considered.
        let (mut tight_params, mut tight_tried): (Option<Params>, usize) = (None, 0);
        if let Some(fe) = self.slam.as_mut() {
            fe.refresh_landmark_covariances();
        }
        let cloud = self.landmark_map();
        let voxels = match LandmarkVoxels::new(&cloud, self.params.u2.voxel_m, self.params.u2.sigma_landmark_m) {
            Ok(v) => v,
            Err(_) => LandmarkVoxels::empty(self.params.u2.voxel_m),
        };
        // The camera's ground for u2: the estimated body's height (with SLAM its estimate, without
        // it the terrain under the estimated position, as in `body_poses`).
        let ground_z_m = self.body_poses().1.0.z;
        // At most: footprint clearing, trail, each tight inflation, and a few goals re-chosen.
        for _attempt in 0..5 + self.mission.tight_inflations_m.len() {
            let tight = tight_params.is_some();
            let params = tight_params.as_ref().unwrap_or(&self.params);
            let t0 = self.clock.as_mut().map(|c| c());
            let input = DecisionInput {
                grid,
                landmarks: &voxels,
                robot: self.est,
                boundary: Some(&self.world.boundary),
                blacklist: &self.blacklist,
                ground_z_m,
                traversed: if use_trail { &self.trail } else { &[] },
            };
            let result = self.selector.select(&input, params);
            if let (Some(t0), Some(c)) = (t0, self.clock.as_mut()) {
                let ms = c() - t0;
                self.pending_plan_ms += ms;
                self.total_plan_ms += ms;
            }
            self.decisions += 1;
            let decision = match result {
                Ok(d) => d,
                // Blocked in its own map (speckle under the robot): plan again on its footprint.
                Err(SelectError::RobotBlocked { .. }) if self.mission.clear_footprint && !cleared => {
                    self.clear_footprint(grid);
                    cleared = true;
                    continue;
                }
                Err(_) => {
                    // Typically the robot's cell is not free in its own map yet: look around.
                    self.planning_errors += 1;
                    self.failed_decisions += 1;
                    if self.failed_decisions >= self.mission.max_failed_decisions {
                        return Some(EndReason::Stuck);
                    }
                    self.goal = None;
                    self.phase = Phase::Spinning(self.time_s + 2.0);
                    self.next_replan_s = self.time_s + 2.0;
                    return None;
                }
            };
            for c in &decision.candidates {
                if c.dropped == Some(DropReason::NoPath) {
                    self.blacklist.add(c.x_m, c.y_m, BlacklistReason::NoPath);
                }
            }
            // Keep the current goal if it is still a reachable candidate.
            if keep_current {
                if let Some(goal) = self.goal {
                    let r = self.blacklist.radius_m();
                    let same = decision
                        .candidates
                        .iter()
                        .filter(|c| c.rho_m.is_some() && c.dropped.is_none_or(|d| d == DropReason::NotInTopN))
                        .min_by(|a, b| {
                            let da = math::hypot(a.x_m - goal.x_m, a.y_m - goal.y_m);
                            let db = math::hypot(b.x_m - goal.x_m, b.y_m - goal.y_m);
                            da.total_cmp(&db)
                        })
                        .filter(|c| math::hypot(c.x_m - goal.x_m, c.y_m - goal.y_m) <= r);
                    if let Some(c) = same {
                        self.failed_decisions = 0;
                        self.path_inflation_m = params.robot.radius_m;
                        self.tight_plans += u64::from(tight);
                        self.follow(&c.path_m, grid, use_trail);
                        self.next_replan_s = self.time_s + self.mission.replan_period_s;
                        self.last_decision = Some(decision);
                        return None;
                    }
                }
            }
            let Some(chosen) = decision.chosen else {
                // No goal: plan again with the cells the robot drove on open.
                if self.mission.reuse_trail && !use_trail && !self.trail.is_empty() {
                    use_trail = true;
                    continue;
                }
                // Then with each tight inflation smaller than the last radius tried (the trail
                // still open).
                let inflation_m = params.robot.radius_m;
                let radii = &self.mission.tight_inflations_m;
                if let Some(k) = (tight_tried..radii.len()).find(|&k| radii[k] < inflation_m) {
                    (tight_params, tight_tried) = (Some(self.params.with_robot_radius_m(radii[k])), k + 1);
                    continue;
                }
                let start = decision.robot_cell;
                self.last_decision = Some(decision);
                if !self.trapped(grid, start, inflation_m) {
                    return Some(EndReason::NoFrontier);
                }
                if self.trap_recoveries >= u64::from(self.mission.trap_recoveries) {
                    return Some(EndReason::Trapped);
                }
                self.recover_from_trap();
                return None;
            };
            let c = &decision.candidates[chosen];
            // A goal chosen again where the robot already went: blacklist and retry.
            let near = |p: &[f64; 2]| math::hypot(c.x_m - p[0], c.y_m - p[1]) <= self.blacklist.radius_m();
            if let Some(k) = self.reached.iter().position(near) {
                let [x, y] = self.reached.remove(k);
                self.blacklist.add(x, y, BlacklistReason::Reselected);
                continue;
            }
            let goal = decision.goal.unwrap_or(Pose2 { x_m: c.x_m, y_m: c.y_m, yaw_rad: self.est.yaw_rad });
            let rho = c.rho_m.unwrap_or(0.0);
            // The goal stays the candidate (blacklisting and re-selection compare candidates);
            // only the path the robot drives is set back.
            self.path_inflation_m = params.robot.radius_m;
            self.tight_plans += u64::from(tight);
            self.follow(&c.path_m, grid, use_trail);
            self.goal = Some(goal);
            self.goal_started_s = self.time_s;
            self.goal_deadline_s =
                self.time_s + self.mission.goal_timeout_factor * rho / self.mission.drive.max_speed_mps + self.mission.goal_timeout_extra_s;
            self.next_replan_s = self.time_s + self.mission.replan_period_s;
            self.phase = Phase::Driving;
            self.failed_decisions = 0;
            self.last_decision = Some(decision);
            return None;
        }
        // Every retry re-chose a reached goal: treat as a failure and look around.
        self.failed_decisions += 1;
        if self.failed_decisions >= self.mission.max_failed_decisions {
            return Some(EndReason::Stuck);
        }
        self.phase = Phase::Spinning(self.time_s + 2.0);
        self.next_replan_s = self.time_s + 2.0;
        None
    }

    /// The grid the last decision planned on: the robot's map, thresholded, with its footprint
    /// cleared if the robot was blocked in it ([`MissionParams::clear_footprint`]); `None`
    /// before the first decision.
    pub fn planning_grid(&self) -> Option<&OccupancyGrid> {
        self.planning_grid.as_ref()
    }

    /// Frees the cells of `grid` within the robot radius plus one cell of the estimated pose
    /// ([`MissionParams::clear_footprint`]): the robot's own cell is then never inflated.
    fn clear_footprint(&self, grid: &mut OccupancyGrid) {
        let clear_m = self.params.robot.radius_m + grid.geometry.resolution_m;
        crate::grid::fill_disc(grid, self.est.x_m, self.est.y_m, clear_m, crate::grid::FREE);
    }

    /// The SLAM front end and its back end ([`Localisation::Slam`] only), for inspection.
    pub fn slam_frontend(&self) -> Option<&SlamFrontend> {
        self.slam.as_ref()
    }

    /// The cells (flat indices into the map) the estimated centre has driven on, in the order
    /// first reached ([`MissionParams::reuse_trail`]; empty when it is off).
    pub fn trail(&self) -> &[usize] {
        &self.trail
    }

    /// The path being driven: the chosen candidate's, set back ([`Self::goal_setback_m`]).
    pub fn driven_path_m(&self) -> &[[f64; 2]] {
        &self.follower.path_m
    }

    /// How far a path planned now ends short of unknown ground, metres
    /// ([`MissionParams::goal_setback`] of the estimate's covariance).
    pub fn goal_setback_m(&self) -> f64 {
        self.mission.goal_setback.margin_m(self.est_cov[(0, 0)], self.est_cov[(1, 1)])
    }

    /// Whether the robot is walled in by `grid` inflated by `inflation_m` (as the planner's last
    /// attempt inflated it): every free cell it reaches from `start` (the planner's start cell)
    /// lies within [`MissionParams::trapped_radius_m`].
    fn trapped(&self, grid: &OccupancyGrid, start: crate::grid::Cell, inflation_m: f64) -> bool {
        let r = self.mission.trapped_radius_m;
        if r <= 0.0 {
            return false;
        }
        let mut inflated = crate::grid::inflate_lethal(grid, inflation_m);
        crate::grid::free_traversed(grid, &self.trail, &mut inflated);
        crate::frontier::enclosed_within(&inflated, start, r)
    }

    /// Adds to the trail ([`MissionParams::reuse_trail`]) the cells of the segment from the
    /// previous tick's estimated centre to this one's ([`crate::grid::segment_cells`]).
    fn mark_trail(&mut self, from: Pose2) {
        if !self.mission.reuse_trail {
            return;
        }
        let g = self.layers.geometry();
        crate::grid::segment_cells(&g, [from.x_m, from.y_m], [self.est.x_m, self.est.y_m], |c| {
            if let Some(i) = g.index(c)
                && !self.on_trail[i]
            {
                self.on_trail[i] = true;
                self.trail.push(i);
            }
        });
    }

    /// Forgets the map around the robot (in the keyframe clouds too) and the `NoPath` blacklist
    /// entries judged on it, and turns a full circle to map it again
    /// ([`MissionParams::trap_recoveries`]).
    fn recover_from_trap(&mut self) {
        self.trap_recoveries += 1;
        let r = crate::frontier::recovery_radius_m(self.mission.trapped_radius_m, &self.params);
        let (x, y) = (self.est.x_m, self.est.y_m);
        match self.slam.as_mut() {
            Some(fe) => fe.forget_disc(&mut self.tmap, x, y, r),
            None => self.tmap.forget_disc(x, y, r),
        };
        // "No path" was judged on the map just forgotten.
        self.blacklist.remove_reason(BlacklistReason::NoPath);
        self.goal = None;
        let full_turn_s = std::f64::consts::TAU / self.mission.drive.max_turn_rate_radps;
        self.phase = Phase::Spinning(self.time_s + full_turn_s);
        self.next_replan_s = self.time_s + full_turn_s;
    }

    /// Drives `path_m`, set back ([`Self::set_back`]); `on_trail`: it was planned with the trail
    /// open, so the path check lets it pass beside trail cells.
    fn follow(&mut self, path_m: &[[f64; 2]], grid: &OccupancyGrid, on_trail: bool) {
        self.follower = PathFollower::new(self.set_back(path_m, grid));
        self.path_on_trail = on_trail;
    }

    /// `path_m` ended [`Self::goal_setback_m`] short of unknown ground.
    fn set_back(&self, path_m: &[[f64; 2]], grid: &OccupancyGrid) -> Vec<[f64; 2]> {
        crate::path::set_back(path_m, grid, self.goal_setback_m())
    }

    fn unexplored_pct(&mut self) -> f64 {
        let (explorable, known) = (&self.world.explorable, &mut self.known_explorable);
        self.tmap.refresh_known(&self.params.traversability, |i, k| {
            if explorable[i] {
                if k {
                    *known += 1;
                } else {
                    *known -= 1;
                }
            }
        });
        let n = self.world.explorable_count;
        if n == 0 { 0.0 } else { 100.0 * (n - self.known_explorable) as f64 / n as f64 }
    }

    fn record_metrics(&mut self) {
        let unexplored_pct = self.unexplored_pct();
        let (pos, rot) = if self.slam.is_some() {
            let t = CovarianceTraces::of(&self.est_cov6);
            (t.pos_cov_trace, t.rot_cov_trace)
        } else {
            (self.est_cov[(0, 0)] + self.est_cov[(1, 1)], self.est_cov[(2, 2)])
        };
        let ((gp, gr), (ep, er)) = self.body_poses();
        let ate = (ep - gp).norm();
        self.sq_err_sum += ate * ate;
        let loop_closures = self.slam.as_ref().map_or(0, |f| f.loop_closures());
        self.rows.push(MetricsRow {
            time_s: self.time_s,
            unexplored_pct,
            cov_trace: pos + rot,
            pos_cov_trace: pos,
            rot_cov_trace: rot,
            ate_m: ate,
            distance_m: self.distance_m,
            loop_closures,
            plan_ms: std::mem::take(&mut self.pending_plan_ms),
        });
        let stamp = |p: Point3<f64>, r: Rotation3<f64>, t: f64| {
            let q = UnitQuaternion::from_rotation_matrix(&r);
            StampedPose { time_s: t, position_m: [p.x, p.y, p.z], quaternion_xyzw: [q.i, q.j, q.k, q.w] }
        };
        self.trajectory_gt.push(stamp(gp, gr, self.time_s));
        self.trajectory_est.push(stamp(ep, er, self.time_s));
        self.next_metrics_s = self.time_s + self.mission.metrics_period_s;
    }

    /// The final figures so far.
    pub fn summary(&self) -> Summary {
        let last = self.rows.last();
        Summary {
            world: self.world.spec.name.clone(),
            strategy: self.strategy,
            localisation: self.localisation,
            seed: self.seed,
            end_reason: self.end,
            time_s: self.time_s,
            unexplored_pct: last.map(|r| r.unexplored_pct).unwrap_or(100.0),
            explorable_cells: self.world.explorable_count,
            distance_m: self.distance_m,
            ate_rmse_m: if self.rows.is_empty() { 0.0 } else { (self.sq_err_sum / self.rows.len() as f64).sqrt() },
            final_cov_trace: last.map(|r| r.cov_trace).unwrap_or(0.0),
            loop_closures: self.slam.as_ref().map_or(0, |f| f.loop_closures()),
            decisions: self.decisions,
            goals_reached: self.goals_reached,
            goals_failed: self.goals_failed,
            blacklist_len: self.blacklist.len(),
            gt_violations: self.violations,
            safety_stops: self.safety_stops,
            trap_recoveries: self.trap_recoveries,
            tight_plans: self.tight_plans,
            planning_errors: self.planning_errors,
            landmarks_mapped: self.slam.as_ref().map_or(self.landmark_sums.len(), |f| f.backend().landmark_count()),
            scans: self.scans,
            keyframes: self.slam.as_ref().map_or(0, |f| f.backend().keyframe_count()),
            reregistrations: self.slam.as_ref().map_or(0, |f| f.reregistrations()),
            slam_errors: self.slam_errors,
            total_plan_ms: self.total_plan_ms,
        }
    }

    /// Metrics as CSV (without `plan_ms`: byte-identical for a seed).
    pub fn metrics_csv(&self) -> String {
        let mut s = String::from("time_s,unexplored_pct,cov_trace,pos_cov_trace,rot_cov_trace,ate_m,distance_m,loop_closures\n");
        for r in &self.rows {
            s.push_str(&format!(
                "{:.1},{:.4},{:.6e},{:.6e},{:.6e},{:.5},{:.4},{}\n",
                r.time_s, r.unexplored_pct, r.cov_trace, r.pos_cov_trace, r.rot_cov_trace, r.ate_m, r.distance_m, r.loop_closures
            ));
        }
        s
    }

    /// Timing as CSV (`time_s,plan_ms`): wall time, not reproducible.
    pub fn timing_csv(&self) -> String {
        let mut s = String::from("time_s,plan_ms\n");
        for r in &self.rows {
            s.push_str(&format!("{:.1},{:.3}\n", r.time_s, r.plan_ms));
        }
        s
    }

    /// A trajectory in TUM format (`t x y z qx qy qz qw`).
    pub fn tum(poses: &[StampedPose]) -> String {
        let mut s = String::new();
        for p in poses {
            let [x, y, z] = p.position_m;
            let [qx, qy, qz, qw] = p.quaternion_xyzw;
            s.push_str(&format!("{:.3} {x:.5} {y:.5} {z:.5} {qx:.6} {qy:.6} {qz:.6} {qw:.6}\n", p.time_s));
        }
        s
    }
}

/// The planar pose (x, y, yaw) of a 3D pose.
fn pose2_of(t: &Se3) -> Pose2 {
    let r = t.rotation_matrix();
    Pose2 { x_m: t.translation.x, y_m: t.translation.y, yaw_rad: math::atan2(r[(1, 0)], r[(0, 0)]) }
}
