//! A whole exploration mission, headless (notes §1, §2, §7, §8): sense → localise → map → decide
//! → move, one control tick per [`Mission::step`]; [`Mission::run`] loops over it.
//!
//! The mission composes four layers: the world simulator ([`WorldSim`]: true motion with the
//! bumper, the sensors), localisation behind `Localiser` (ground truth, odometry, graph SLAM),
//! the exploration policy ([`Explorer`]) and the metrics (`Metrics`). What is its own is the
//! robot's local controller (a carrot follower along the chosen path, turning to Θ* on arrival)
//! and the schedule:
//!
//! Per tick (`dt_s`): the robot follows its path; the localiser follows the wheels and the gyro,
//! and a SLAM takes a keyframe when due; every `scan_every_*` the sensed points are registered
//! with the *estimate* into the traversability map (estimated lazily, below); every
//! `camera_every_s` the camera observes landmarks. The explorer decides on arrival (after turning
//! to Θ*), on failure (timeout or bumper → blacklisted `Failed`), when the path ahead is blocked
//! (checked after each scan, `corridor`; the part already driven is not checked), and
//! every `replan_period_s` (then the current goal is kept while it is still a reachable frontier
//! candidate). When it has no plan the robot turns in place for 2 s; when its map traps it, the
//! robot forgets that map around itself and turns a full circle. The mission ends when the
//! explorer says so or at the time limit.
//!
//! The traversability map is estimated lazily: a scan only adds its points (O(disc cells) each);
//! the cells along the path ahead are re-estimated for the blocked-path check, every stale
//! cell at a decision, and the metrics count known cells from flags kept without estimating.
//!
//! Cost per tick: O(path) control; per scan O(rays × march) + O(points × disc cells) + O(path
//! corridor); per decision the selector's (one Dijkstra, rays, u2), the stale cells' estimates,
//! O(cells) thresholding; per metrics row O(cells whose disc changed).

use super::corridor::CorridorCheck;
use super::localisation::{Localisation, Localiser, PoseCovariance, new_localiser};
use super::metrics::{Metrics, MetricsRow, Sample, StampedPose, Summary};
use super::params::MissionParams;
use super::robot::{PathFollower, Twist};
use super::world::World;
use super::world_sim::WorldSim;
use crate::PointCloud;
use crate::explore::{Action, ActiveGoal, EndReason, Explorer, Situation};
use crate::grid::OccupancyGrid;
use crate::math;
use crate::params::{Params, SelectorParams, Strategy, Valid};
use crate::pose::{Pose2, wrap_pi};
use crate::select::Decision;
use crate::slam::keyframes::SlamFrontend;
use crate::traversability::{TraversabilityLayers, TraversabilityMap};
use crate::utility::LandmarkVoxels;
use std::f64::consts::TAU;

/// Why a [`Mission`] could not start.
#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    /// The robot's traversability map could not be made on the world's geometry.
    #[error("traversability map: {0}")]
    Map(#[from] crate::traversability::TraversabilityError),
    /// The SLAM could not start (e.g. a non-finite start pose).
    #[error("SLAM: {0}")]
    Slam(#[from] crate::slam::SlamError),
}

/// What one [`Mission::step`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepOutcome {
    /// The mission goes on.
    Running,
    /// The mission has ended, for this reason (every later step answers the same).
    Finished(EndReason),
}

/// What the robot's controller is doing.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// No goal: decide on the next tick.
    Idle,
    Driving,
    /// At the goal position, turning to Θ*.
    Turning(f64),
    /// Turning in place (initial look-around, after a decision without a plan or a trap
    /// recovery) until the time.
    Spinning(f64),
}

/// A running mission.
///
/// # Examples
///
/// A tiny procedural world, built without files, explored for a few simulated seconds by the
/// greedy selector with ground-truth localisation:
///
/// ```
/// use fitslam_core::params::Strategy;
/// use fitslam_core::sim::{EndReason, StepOutcome};
/// use fitslam_core::{Localisation, Mission, MissionParams, Params, Valid, World, WorldSpec};
///
/// let spec = WorldSpec::from_toml(
///     "name = \"hills\"\nstart = [2.0, 2.0, 0.0]\n\
///      [terrain]\nkind = \"procedural\"\nseed = 4\nsize_m = 4.0\nhill_height_m = 0.1\n",
///     "hills.toml",
/// )?;
/// let params = Valid::new(Params::default())?;
/// let tr = &params.traversability;
/// // The loader is asked for the files a spec names (a DEM, a map): this one names none.
/// let world = World::build(&spec, tr, tr.tau, |name| Err(format!("no file {name}")))?;
///
/// let sim = Valid::new(MissionParams { time_limit_s: Some(3.0), ..MissionParams::default() })?;
/// let mut mission = Mission::new(world, params, sim, Strategy::Greedy, 7, Localisation::GroundTruth)?;
/// let mut steps = 0;
/// while mission.step() == StepOutcome::Running {
///     steps += 1;
/// }
/// assert_eq!(steps, 30); // 3 s of 0.1 s control ticks
/// assert!((mission.time_s() - 3.0).abs() < 1e-9);
/// let summary = mission.summary();
/// assert_eq!(summary.end_reason, Some(EndReason::TimeLimit));
/// // The first turn in place has already mapped part of the world.
/// assert!(summary.unexplored_pct < 100.0);
/// assert_eq!(mission.rows().len(), mission.trajectory_gt().len());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Mission {
    sim: WorldSim,
    localiser: Box<dyn Localiser>,
    explorer: Explorer,
    metrics: Metrics,
    mission: Valid<MissionParams>,
    strategy: Strategy,
    seed: u64,
    time_limit_s: f64,
    time_s: f64,
    tmap: TraversabilityMap,
    /// Estimated lazily: cells are refreshed along the path after each scan and everywhere at
    /// each decision ([`Self::layers`] brings them all up to date).
    layers: TraversabilityLayers,
    corridor: CorridorCheck,
    phase: Phase,
    follower: PathFollower,
    goal_deadline_s: f64,
    next_replan_s: f64,
    /// The grid the last decision planned on ([`Self::planning_grid`]).
    planning_grid: Option<OccupancyGrid>,
    last_scan: (Pose2, f64),
    last_camera_s: f64,
    end: Option<EndReason>,
}

impl Mission {
    /// A mission in `world` with planner `params` (its `selector.strategy` and `selector.seed`
    /// are overridden by `strategy` and `seed`), simulator `mission` parameters, sensor seed
    /// `seed`. Fails on a world too large for a map or a SLAM that cannot start (a non-finite
    /// start pose).
    pub fn new(
        world: World,
        params: Valid<Params>,
        mission: Valid<MissionParams>,
        strategy: Strategy,
        seed: u64,
        localisation: Localisation,
    ) -> Result<Self, MissionError> {
        let params = params.with_selector(SelectorParams { strategy, seed, ..params.selector.clone() });
        let tmap = TraversabilityMap::new(world.field.geometry)?;
        let layers = tmap.compute(&params.traversability);
        let time_limit_s = mission.time_limit_s.unwrap_or(world.spec.time_limit_s);
        let mut sim = WorldSim::new(world, &mission, &params, seed);
        let localiser = new_localiser(localisation, &mut sim, &mission.slam, seed)?;
        let start = sim.pose();
        let mut m = Self {
            localiser,
            explorer: Explorer::new(mission.explore(), params),
            metrics: Metrics::default(),
            strategy,
            seed,
            time_limit_s,
            time_s: 0.0,
            tmap,
            layers,
            corridor: CorridorCheck::default(),
            // A full turn in place first: the LiDAR is blind within ~1.1 m, the camera sees it.
            phase: Phase::Spinning(TAU / mission.drive.max_turn_rate_radps),
            follower: PathFollower::default(),
            goal_deadline_s: 0.0,
            next_replan_s: 0.0,
            planning_grid: None,
            last_scan: (start, 0.0),
            last_camera_s: if localisation.is_slam() { 0.0 } else { f64::NEG_INFINITY },
            end: None,
            mission,
            sim,
        };
        m.sense_geometry();
        m.sense_landmarks();
        m.record_metrics();
        Ok(m)
    }

    /// A wall clock in milliseconds used only to fill `plan_ms` (core has no clock).
    pub fn set_clock(&mut self, clock: Box<dyn FnMut() -> f64>) {
        self.explorer.set_clock(clock);
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
        let est = self.localiser.pose();
        let drive = &self.mission.drive;
        let cmd = match self.phase {
            Phase::Idle => Twist { v_mps: 0.0, omega_radps: 0.0 },
            Phase::Driving => self.follower.command(est, drive),
            Phase::Turning(yaw) => {
                let err = wrap_pi(yaw - est.yaw_rad);
                let w = drive.max_turn_rate_radps;
                Twist { v_mps: 0.0, omega_radps: (err / dt).clamp(-w, w) }
            }
            Phase::Spinning(_) => Twist { v_mps: 0.0, omega_radps: drive.max_turn_rate_radps },
        };
        let motion = self.sim.drive(cmd, dt);
        if motion.bumped {
            self.explorer.goal_failed();
            self.phase = Phase::Idle;
        }
        self.time_s = ((self.time_s + dt) * 1e6).round() / 1e6;
        self.localiser.propagate(&mut self.sim, &motion, dt);
        let now = self.localiser.pose();
        self.explorer.record_motion(est, now);

        match self.phase {
            Phase::Driving => {
                if self.follower.arrived(now, self.mission.drive.goal_tolerance_m) {
                    let yaw = self.explorer.goal().map(|g| g.goal.yaw_rad).unwrap_or(now.yaw_rad);
                    self.phase = Phase::Turning(yaw);
                } else if self.time_s > self.goal_deadline_s {
                    self.explorer.goal_failed();
                    self.phase = Phase::Idle;
                }
            }
            Phase::Turning(yaw) => {
                if wrap_pi(yaw - now.yaw_rad).abs() < 0.05 {
                    self.explorer.goal_reached();
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
        self.localiser.keyframe(&mut self.sim);
        let est = self.localiser.pose();
        let (p, t) = self.last_scan;
        let moved = math::hypot(est.x_m - p.x_m, est.y_m - p.y_m);
        let turned = wrap_pi(est.yaw_rad - p.yaw_rad).abs();
        if moved >= self.mission.scan_every_m || turned >= self.mission.scan_every_rad || self.time_s - t >= self.mission.scan_every_s {
            self.sense_geometry();
            if self.phase == Phase::Driving && self.path_blocked() {
                self.next_replan_s = self.time_s;
            }
        }
        if self.time_s - self.last_camera_s >= self.mission.camera_every_s - 1e-9 {
            self.sense_landmarks();
        }
        if self.metrics.due(self.time_s) {
            self.record_metrics();
        }
        StepOutcome::Running
    }

    fn finish(&mut self, reason: EndReason) -> StepOutcome {
        self.end = Some(reason);
        if self.metrics.rows().last().map(|r| r.time_s) != Some(self.time_s) {
            self.record_metrics();
        }
        StepOutcome::Finished(reason)
    }

    /// The sensed points (LiDAR, depth camera, footprint), registered with the estimate.
    fn sense_geometry(&mut self) {
        self.sim.scan();
        self.localiser.register(&self.sim, self.sim.scan_points(), &mut self.tmap);
        self.last_scan = (self.localiser.pose(), self.time_s);
    }

    /// The periodic camera frame.
    fn sense_landmarks(&mut self) {
        self.localiser.observe(&mut self.sim);
        self.last_camera_s = self.time_s;
    }

    /// Whether the path ahead crosses a lethal cell of the current map within the inflation it
    /// was planned with ([`CorridorCheck`]), refreshing the estimates of the cells it reads.
    fn path_blocked(&mut self) -> bool {
        let Some(goal) = self.explorer.goal() else { return false };
        let g = self.layers.geometry();
        let est = self.localiser.pose();
        let params = self.explorer.planner().traversability.clone();
        let on_trail: &[bool] = if goal.on_trail { self.explorer.trail().mask(&g) } else { &[] };
        let (tmap, layers) = (&mut self.tmap, &mut self.layers);
        let ahead = self.follower.remaining(est);
        let tau = params.tau as f32;
        self.corridor.blocked(&g, ahead, [est.x_m, est.y_m], goal.inflation_m, on_trail, |i| {
            tmap.refresh_cells([i], &params, layers);
            layers.score.data[i] < tau
        })
    }

    /// Asks the explorer for a goal and acts on its answer. `replanning`: periodic replanning
    /// keeps the current goal while it is still a reachable candidate. Returns the end reason at
    /// the end of the mission.
    fn decide(&mut self, replanning: bool) -> Option<EndReason> {
        let mut grid = self.occupancy();
        self.localiser.prepare_decision(&mut self.tmap);
        let (u2, cloud) = (&self.explorer.planner().u2, self.policy_landmarks());
        let voxels = LandmarkVoxels::new(&cloud, u2.voxel_m, u2.sigma_landmark_m).unwrap_or_else(|_| LandmarkVoxels::empty(u2.voxel_m));
        let est = self.localiser.pose();
        let cov = self.localiser.covariance().xy_yaw;
        let situation = Situation {
            landmarks: &voxels,
            robot: est,
            boundary: Some(&self.sim.world().boundary),
            // The camera's ground for u2: the estimated body's height, and the map's ground
            // (its layers were brought up to date by `occupancy` above).
            ground_z_m: self.localiser.body_pose(&self.sim).0.z,
            ground: Some(self.layers.ground()),
            position_var_m2: cov[(0, 0)] + cov[(1, 1)],
            replanning,
            can_forget_map: true,
        };
        let action = self.explorer.decide(&mut grid, &situation);
        self.planning_grid = Some(grid);
        let look_around = |m: &mut Self, s: f64| {
            m.phase = Phase::Spinning(m.time_s + s);
            m.next_replan_s = m.time_s + s;
        };
        match action {
            Action::Goal(plan) => {
                self.follower = PathFollower::new(plan.path_m);
                let d = &self.mission.drive;
                self.goal_deadline_s =
                    self.time_s + self.mission.goal_timeout_factor * plan.rho_m / d.max_speed_mps + self.mission.goal_timeout_extra_s;
                self.next_replan_s = self.time_s + self.mission.replan_period_s;
                self.phase = Phase::Driving;
            }
            Action::Keep(plan) => {
                self.follower = PathFollower::new(plan.path_m);
                self.next_replan_s = self.time_s + self.mission.replan_period_s;
            }
            // Typically the robot's cell is not free in its own map yet: look around.
            Action::Wait(_) => look_around(self, 2.0),
            Action::Recover { radius_m } => {
                self.localiser.forget_disc(&mut self.tmap, est.x_m, est.y_m, radius_m);
                look_around(self, TAU / self.mission.drive.max_turn_rate_radps);
            }
            Action::Done(reason) => return Some(reason),
        }
        None
    }

    fn record_metrics(&mut self) {
        let sample = Sample {
            time_s: self.time_s,
            covariance: self.localiser.covariance(),
            truth: self.sim.body_pose(),
            estimate: self.localiser.body_pose(&self.sim),
            distance_m: self.sim.distance_m(),
            loop_closures: self.localiser.stats().loop_closures,
            total_plan_ms: self.explorer.stats().total_plan_ms,
        };
        let params = &self.explorer.planner().traversability;
        self.metrics.record(&sample, &mut self.tmap, params, self.sim.world(), self.mission.metrics_period_s);
    }

    /// The robot's map: thresholded traversability (0 free, 100 lethal, −1 unknown).
    pub fn occupancy(&mut self) -> OccupancyGrid {
        let tau = self.explorer.planner().traversability.tau;
        self.layers().to_occupancy(tau)
    }

    /// The robot's traversability layers, brought up to date (O(cells changed since the last decision)).
    pub fn layers(&mut self) -> &TraversabilityLayers {
        self.tmap.update(&self.explorer.planner().traversability, &mut self.layers);
        &self.layers
    }

    /// The landmark map (estimated positions, in id order; with SLAM the graph's landmarks and
    /// their covariances).
    pub fn landmark_map(&self) -> PointCloud {
        self.localiser.landmark_map(self.explorer.planner().u2.sigma_landmark_m)
    }

    /// The landmarks the policy reads: the map's, or the world's true ones for a strategy that
    /// [`Strategy::reads_true_landmarks`] (the map frame starts as the world's).
    pub fn policy_landmarks(&self) -> PointCloud {
        let truth = self.strategy.reads_true_landmarks().then(|| PointCloud::from_points(self.sim.world().landmarks.clone()));
        truth.unwrap_or_else(|| self.landmark_map())
    }

    #[cfg(test)]
    /// The grid the last decision planned on (thresholded, its footprint cleared if blocked).
    pub(crate) fn planning_grid(&self) -> Option<&OccupancyGrid> {
        self.planning_grid.as_ref()
    }

    /// The tracking losses so far, with their ground (empty without SLAM).
    pub fn tracking_losses(&self) -> &[super::TrackingLoss] {
        self.localiser.tracking_losses()
    }

    /// The last decision that ranked candidates (the whole ranking).
    pub fn last_decision(&self) -> Option<&Decision> {
        self.explorer.last_decision()
    }

    /// The goal being pursued.
    pub fn goal(&self) -> Option<ActiveGoal> {
        self.explorer.goal()
    }

    /// The path being driven: the chosen candidate's, set back from unknown ground.
    pub fn driven_path_m(&self) -> &[[f64; 2]] {
        &self.follower.path_m
    }

    #[cfg(test)]
    /// How far a path planned now ends short of unknown ground, metres.
    pub(crate) fn goal_setback_m(&self) -> f64 {
        let c = self.localiser.covariance().xy_yaw;
        self.explorer.params().goal_setback.margin_m(c[(0, 0)] + c[(1, 1)], 0.0)
    }

    /// The cells (flat indices into the map) the estimated centre has driven on, in the order
    /// first reached (empty when `explore.reuse_trail` is off).
    pub fn trail(&mut self) -> &[usize] {
        let g = self.layers.geometry();
        self.explorer.trail().cells(&g)
    }

    /// Mission time, seconds.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The true planar pose.
    pub fn true_pose(&self) -> Pose2 {
        self.sim.pose()
    }

    /// The estimated planar pose.
    pub fn estimate(&self) -> Pose2 {
        self.localiser.pose()
    }

    /// The estimate's uncertainty.
    pub fn covariance(&self) -> PoseCovariance {
        self.localiser.covariance()
    }

    /// The ground truth.
    pub fn world(&self) -> &World {
        self.sim.world()
    }

    /// The planner's parameters (strategy and seed as the mission's).
    pub fn params(&self) -> &Params {
        self.explorer.planner()
    }

    /// The simulator's parameters.
    pub fn mission_params(&self) -> &MissionParams {
        &self.mission
    }

    /// The goal selector in use.
    pub fn strategy(&self) -> Strategy {
        self.strategy
    }

    /// The mission's seed (sensors and selector).
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Why the mission ended, once it has.
    pub fn end(&self) -> Option<EndReason> {
        self.end
    }

    /// Distance driven, metres.
    pub fn distance_m(&self) -> f64 {
        self.sim.distance_m()
    }

    /// The metrics rows so far, one per `metrics_period_s`.
    pub fn rows(&self) -> &[MetricsRow] {
        self.metrics.rows()
    }

    /// The true trajectory, one pose per metrics row.
    pub fn trajectory_gt(&self) -> &[StampedPose] {
        self.metrics.trajectory_gt()
    }

    /// The estimated trajectory, one pose per metrics row.
    pub fn trajectory_est(&self) -> &[StampedPose] {
        self.metrics.trajectory_est()
    }

    /// The explorer (its blacklist, statistics, trail).
    pub fn explorer(&self) -> &Explorer {
        &self.explorer
    }

    /// The SLAM front end and its back end ([`Localisation::Slam`] and [`Localisation::PoseGraph`]), for inspection.
    pub fn slam_frontend(&self) -> Option<&SlamFrontend> {
        self.localiser.slam()
    }

    /// The final figures so far.
    pub fn summary(&self) -> Summary {
        let last = self.metrics.rows().last();
        let l = self.localiser.stats();
        let e = self.explorer.stats();
        let world = self.sim.world();
        Summary {
            world: world.spec.name.clone(),
            strategy: self.strategy,
            localisation: self.localiser.kind(),
            seed: self.seed,
            end_reason: self.end,
            time_s: self.time_s,
            unexplored_pct: last.map(|r| r.unexplored_pct).unwrap_or(100.0),
            explorable_cells: world.explorable_count,
            distance_m: self.sim.distance_m(),
            ate_rmse_m: self.metrics.ate_rmse_m(),
            final_cov_trace: last.map(|r| r.cov_trace).unwrap_or(0.0),
            loop_closures: l.loop_closures,
            decisions: e.decisions,
            goals_reached: e.goals_reached,
            goals_failed: e.goals_failed,
            blacklist_len: self.explorer.blacklist().len(),
            gt_violations: self.sim.violations(),
            safety_stops: self.sim.safety_stops(),
            trap_recoveries: e.trap_recoveries,
            tight_plans: e.tight_plans,
            planning_errors: e.planning_errors,
            landmarks_mapped: l.landmarks_mapped,
            scans: self.sim.scans(),
            keyframes: l.keyframes,
            reregistrations: l.reregistrations,
            slam_errors: l.slam_errors,
            tracking_losses: l.tracking.losses,
            relocalisations: l.tracking.relocalisations,
            new_maps: l.tracking.new_maps,
            lost_s: l.tracking.lost_s,
            wrong_associations: l.wrong_associations,
            links: l.links,
            total_plan_ms: e.total_plan_ms,
        }
    }

    /// Registers `points_m` (true world frame) as if sensed now, as a sensing glitch would.
    #[cfg(test)]
    pub(crate) fn plant_points(&mut self, points_m: impl IntoIterator<Item = nalgebra::Point3<f64>>) {
        self.sim.replace_scan(points_m);
        self.localiser.register(&self.sim, self.sim.scan_points(), &mut self.tmap);
    }

    /// Rebuilds the map from the keyframe clouds now, as a loop closure would (no-op without SLAM).
    #[cfg(test)]
    pub(crate) fn reregister_now(&mut self) {
        if let Some(fe) = self.localiser.slam() {
            fe.rebuild_map(&mut self.tmap);
        }
    }
}
