//! The exploration state machine, free of DDS: messages in (with the caller's clock, seconds),
//! [`Command`]s out. The ROS adapter (`ros.rs`) only moves messages; everything that decides —
//! validation, staleness, timeouts, blacklisting, the goal-safety check, the end of mission — is
//! here and unit-tested with fake inputs.
//!
//! One cycle (every `replan_period_s`, or at once after a goal ends):
//! 1. the latest map (occupancy, or clouds fused by the core, notes §2), the robot pose (tf or
//!    a pose topic) and the landmark voxels go into `fitslam_core::select` (notes §3–7), which
//!    ranks every frontier candidate;
//! 2. candidates with no path are blacklisted (`NoPath`);
//! 3. the best-ranked candidate whose cell is free on the *latest inflated* grid becomes the
//!    goal (the selector already plans on the inflated grid; the re-check guards against a map
//!    that changed in between and is what makes "never a goal in a lethal cell" a local
//!    invariant of this file);
//! 4. a running goal is kept while it is still a frontier goal and still free; otherwise it is
//!    cancelled and replaced.
//!
//! A decision that finds no goal is made again with the robot's trail (its positions since the
//! start, map frame, laid on the latest map) free after inflation (`reuse_trail`, as the
//! simulator's), and if it still finds none, again with lethal cells inflated by each of
//! `tight_inflations_m` in turn instead of the robot radius (as the simulator's); a goal found so
//! is checked, picked and supervised at that inflation.
//!
//! Goals that end Aborted, Rejected, Canceled (by someone else) or time out are blacklisted
//! (`Failed`); reached goals are blacklisted as `Reselected` (notes §3: a goal selected before
//! and still a frontier goal now is not selected again). The mission ends after
//! `done_after_empty_decisions` consecutive decisions with no goal and none running, unless the
//! robot is walled in by its map (`trapped_radius_m`): then it warns and, on a cloud map it builds
//! itself, forgets that map around the robot (`trap_recoveries`), else waits.
//!
//! Costs per cycle: one selector run (notes §7) plus, once per new map, one inflation
//! (O(cells · disc)); per poll: O(1) goal checks.

use crate::config::{GoalInterface, MapSource, NodeConfig, PoseSource};
use crate::convert::{self, ConvertError};
use crate::msgs;
use crate::tf::{TfBuffer, normalise_frame};
use fitslam_core::frontier::{Blacklist, BlacklistReason, Boundary, enclosed_within, recovery_radius_m};
use fitslam_core::grid::{CellClass, FREE, GridGeometry, WorldTrail, fill_disc, free_traversed, inflate_lethal};
use fitslam_core::path::set_back;
use fitslam_core::select::{Decision, DecisionInput, GoalSelector, SelectError, make_selector};
use fitslam_core::traversability::{TraversabilityLayers, TraversabilityMap};
use fitslam_core::utility::LandmarkVoxels;
use fitslam_core::{OccupancyGrid, Params, PointCloud, Pose2};
use nalgebra::{Isometry3, Point3};
use serde::Serialize;
use std::collections::HashMap;

/// Same warning text under the same key is repeated at most this often, seconds.
pub const WARN_REPEAT_S: f64 = 10.0;

/// What the adapter must do.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Send this goal (map frame) under this id.
    SendGoal { id: u64, goal: Pose2 },
    /// Cancel the goal with this id (no-op for topic goals).
    CancelGoal { id: u64 },
    /// No frontier left (or the time limit): the mission is over.
    MissionComplete,
}

/// What the navigation stack reported about a goal.
#[derive(Clone, Debug, PartialEq)]
pub enum GoalEvent {
    Accepted,
    Rejected,
    Succeeded,
    /// Aborted by the navigation stack, with its message.
    Aborted(String),
    /// Cancelled by someone else.
    Canceled,
    /// Communication failure (no answer, undecodable result): dropped, not blacklisted.
    Lost(String),
}

/// Log severity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Level {
    Info,
    Warn,
    Error,
}

/// One log line, drained by the adapter with [`Explorer::drain_log`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LogLine {
    pub t_s: f64,
    pub level: Level,
    pub text: String,
}

/// The goal being pursued.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ActiveGoal {
    pub id: u64,
    /// The pose sent: on the frontier candidate's path, set back from unknown ground
    /// (`goal_setback`).
    pub goal: Pose2,
    /// The frontier candidate it serves (what is kept, replaced and blacklisted).
    pub frontier_m: [f64; 2],
    pub sent_s: f64,
    /// When the server accepted it (topic goals: when sent).
    pub accepted_s: Option<f64>,
    /// The inflation radius of the map it was picked on, metres: the robot radius or one of
    /// [`NodeConfig::tight_inflations_m`]; it must stay free at that inflation.
    pub inflation_m: f64,
}

/// Where the node stands (status topic).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    WaitingForMap,
    WaitingForPose,
    PoseStale,
    Planning,
    Navigating,
    Done,
}

/// Counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    pub decisions: u64,
    pub decision_errors: u64,
    pub goals_sent: u64,
    pub succeeded: u64,
    pub failed: u64,
    pub rejected: u64,
    pub timed_out: u64,
    pub lost: u64,
    pub replaced: u64,
    pub maps: u64,
    pub messages_rejected: u64,
    pub messages_late: u64,
    /// Cloud maps forgotten around a trapped robot ([`NodeConfig::trap_recoveries`]).
    pub trap_recoveries: u64,
    /// Decisions made with the footprint cleared ([`NodeConfig::clear_footprint`]).
    pub footprint_clearings: u64,
    /// Goals picked with a tight inflation ([`NodeConfig::tight_inflations_m`]).
    pub tight_goals: u64,
    /// Wall time of the last decision, milliseconds.
    pub last_decision_ms: f64,
}

/// The status topic's JSON.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Status {
    pub t_s: f64,
    pub phase: Phase,
    pub goal: Option<ActiveGoal>,
    pub robot: Option<Pose2>,
    pub candidates: usize,
    pub ranked: usize,
    pub blacklisted: usize,
    pub landmark_voxels: usize,
    pub map_cells: Option<[usize; 2]>,
    pub stats: Stats,
    pub done_reason: Option<String>,
    pub last_warning: Option<String>,
}

struct MapState {
    grid: OccupancyGrid,
    /// Inflated by the robot radius and by any tight radius used, each computed on first use:
    /// (radius, metres; grid).
    inflated: Vec<(f64, OccupancyGrid)>,
    stamp_s: f64,
}

/// A goal picked from a decision ([`Explorer::pick`]).
#[derive(Clone, Copy)]
struct Picked {
    /// The frontier candidate it serves.
    frontier_m: [f64; 2],
    goal: Pose2,
    /// The inflation radius of the decision, metres.
    inflation_m: f64,
}

struct CloudMapper {
    map: TraversabilityMap,
    layers: TraversabilityLayers,
    dirty: bool,
}

#[derive(Clone, Copy)]
struct PoseSample {
    pose: Pose2,
    /// Height of the base frame in the map frame, metres.
    z_m: f64,
    stamp_s: f64,
    received_s: f64,
    /// Mean of the roll and pitch variances of the message's covariance, rad² (0 if absent).
    tilt_var_rad2: f64,
    /// σx² + σy² of the message's covariance, m² (0 if absent; invariant under the yaw between
    /// the message's frame and the map's).
    position_var_m2: f64,
}

/// The exploration node's state.
pub struct Explorer {
    cfg: NodeConfig,
    params: Params,
    selector: Box<dyn GoalSelector>,
    tf: TfBuffer,
    map: Option<MapState>,
    cloud_mapper: Option<CloudMapper>,
    landmarks: LandmarkVoxels,
    landmark_points: Vec<[f64; 3]>,
    topic_pose: Option<PoseSample>,
    boundary: Option<Boundary>,
    blacklist: Blacklist,
    /// Where the base has driven, map frame ([`NodeConfig::reuse_trail`]).
    trail: WorldTrail,
    goal: Option<ActiveGoal>,
    next_goal_id: u64,
    last_decision_s: Option<f64>,
    replan_now: bool,
    empty_decisions: u32,
    started_s: Option<f64>,
    done_reason: Option<String>,
    phase: Phase,
    last_decision: Option<Decision>,
    last_warning: Option<String>,
    log: Vec<LogLine>,
    warned: HashMap<&'static str, (String, f64)>,
    stats: Stats,
}

impl Explorer {
    /// A node with this configuration (assumed validated: [`crate::config::ConfigFile::validate`]).
    pub fn new(cfg: NodeConfig, params: Params) -> Self {
        let selector = make_selector(&params.selector);
        Self {
            landmarks: LandmarkVoxels::empty(params.u2.voxel_m),
            blacklist: Blacklist::new(params.frontier.blacklist_radius_m),
            cfg,
            params,
            selector,
            tf: TfBuffer::new(),
            map: None,
            cloud_mapper: None,
            landmark_points: Vec::new(),
            topic_pose: None,
            boundary: None,
            trail: WorldTrail::default(),
            goal: None,
            next_goal_id: 1,
            last_decision_s: None,
            replan_now: false,
            empty_decisions: 0,
            started_s: None,
            done_reason: None,
            phase: Phase::WaitingForMap,
            last_decision: None,
            last_warning: None,
            log: Vec::new(),
            warned: HashMap::new(),
            stats: Stats::default(),
        }
    }

    // ---------------------------------------------------------------- logging

    fn info(&mut self, now_s: f64, text: String) {
        self.log.push(LogLine { t_s: now_s, level: Level::Info, text });
    }

    /// A warning, repeated under `key` only when its text changes or every [`WARN_REPEAT_S`].
    fn warn(&mut self, key: &'static str, now_s: f64, text: String) {
        if let Some((last, t)) = self.warned.get(key)
            && *last == text
            && now_s - t < WARN_REPEAT_S
        {
            return;
        }
        self.warned.insert(key, (text.clone(), now_s));
        self.last_warning = Some(text.clone());
        self.log.push(LogLine { t_s: now_s, level: Level::Warn, text });
    }

    /// Takes the log lines produced since the last call.
    pub fn drain_log(&mut self) -> Vec<LogLine> {
        std::mem::take(&mut self.log)
    }

    // ---------------------------------------------------------------- inputs

    fn reject(&mut self, key: &'static str, now_s: f64, what: &str, e: &ConvertError) {
        self.stats.messages_rejected += 1;
        self.warn(key, now_s, format!("{what} rejected: {e}"));
    }

    /// A `nav_msgs/OccupancyGrid` (used when `map_source: occupancy`).
    pub fn handle_map(&mut self, msg: &msgs::OccupancyGrid, now_s: f64) {
        let grid = match convert::occupancy_of_msg(msg) {
            Ok(g) => g,
            Err(e) => return self.reject("map", now_s, "map", &e),
        };
        let frame = normalise_frame(&msg.header.frame_id);
        if !frame.is_empty() && frame != normalise_frame(&self.cfg.map_frame) {
            self.stats.messages_rejected += 1;
            let text = format!("map rejected: frame '{frame}' is not the map frame '{}'", self.cfg.map_frame);
            return self.warn("map", now_s, text);
        }
        self.set_map(grid, msg.header.stamp.as_secs_f64(), now_s);
    }

    fn set_map(&mut self, grid: OccupancyGrid, stamp_s: f64, now_s: f64) {
        if let Some(old) = &self.map {
            if stamp_s != 0.0 && stamp_s < old.stamp_s {
                self.stats.messages_late += 1;
                let text = format!("late map dropped (stamp {stamp_s:.3} s < {:.3} s)", old.stamp_s);
                return self.warn("map_late", now_s, text);
            }
            if old.grid.geometry != grid.geometry {
                let (a, b) = (old.grid.geometry, grid.geometry);
                let text = format!(
                    "map geometry changed: {}×{} cells at {} m from ({}, {}) → {}×{} at {} m from ({}, {})",
                    a.width,
                    a.height,
                    a.resolution_m,
                    a.origin_x_m,
                    a.origin_y_m,
                    b.width,
                    b.height,
                    b.resolution_m,
                    b.origin_x_m,
                    b.origin_y_m
                );
                self.info(now_s, text);
            }
        } else {
            let g = grid.geometry;
            self.info(now_s, format!("first map: {}×{} cells at {} m", g.width, g.height, g.resolution_m));
        }
        self.stats.maps += 1;
        self.map = Some(MapState { grid, inflated: Vec::new(), stamp_s });
    }

    /// `/tf` (`is_static` false) or `/tf_static` (true).
    pub fn handle_tf(&mut self, msg: &msgs::TFMessage, is_static: bool, now_s: f64) {
        for t in &msg.transforms {
            match self.tf.insert(t, is_static, now_s) {
                Ok(true) => {}
                Ok(false) => self.stats.messages_late += 1,
                Err(e) => {
                    let what = format!("transform {} → {}", t.header.frame_id, t.child_frame_id);
                    self.reject("tf", now_s, &what, &e);
                }
            }
        }
    }

    /// `target_from_source` from the tf buffer.
    fn lookup(&self, target: &str, source: &str) -> Option<Isometry3<f64>> {
        self.tf.lookup(target, source).map(|l| l.transform)
    }

    /// Points of a cloud in the map frame (transformed by tf if it is in another frame).
    fn cloud_in_map(&mut self, msg: &msgs::PointCloud2, key: &'static str, what: &str, now_s: f64) -> Option<Vec<Point3<f64>>> {
        let (mut points, stats) = match convert::points_of_cloud(msg) {
            Ok(p) => p,
            Err(e) => {
                self.reject(key, now_s, what, &e);
                return None;
            }
        };
        if stats.non_finite > 0 {
            let text = format!("{what}: {} of {} points are not finite (skipped)", stats.non_finite, stats.records);
            self.warn(key, now_s, text);
        }
        let frame = normalise_frame(&msg.header.frame_id).to_owned();
        let map_frame = self.cfg.map_frame.clone();
        if !frame.is_empty() && frame != normalise_frame(&map_frame) {
            let Some(map_from_cloud) = self.lookup(&map_frame, &frame) else {
                self.stats.messages_rejected += 1;
                self.warn(key, now_s, format!("{what} dropped: no transform {map_frame} ← {frame}"));
                return None;
            };
            for p in &mut points {
                *p = map_from_cloud * *p;
            }
        }
        Some(points)
    }

    /// The landmark map (`sensor_msgs/PointCloud2` of map points): replaces the previous set.
    pub fn handle_landmarks(&mut self, msg: &msgs::PointCloud2, now_s: f64) {
        let Some(points) = self.cloud_in_map(msg, "landmarks", "landmark cloud", now_s) else { return };
        let n = points.len();
        let cloud = PointCloud::from_points(points);
        match LandmarkVoxels::new(&cloud, self.params.u2.voxel_m, self.params.u2.sigma_landmark_m) {
            Ok(v) => {
                if self.landmarks.is_empty() && !v.is_empty() {
                    self.info(now_s, format!("first landmark map: {n} points in {} voxels", v.len()));
                }
                self.landmarks = v;
                self.landmark_points = cloud.points.iter().map(|p| [p.x, p.y, p.z]).collect();
            }
            Err(e) => {
                self.stats.messages_rejected += 1;
                self.warn("landmarks", now_s, format!("landmark cloud rejected: {e}"));
            }
        }
    }

    /// A registered LiDAR cloud (used when `map_source: clouds`): fused into the traversability
    /// map; the occupancy grid is recomputed before the next decision.
    pub fn handle_cloud(&mut self, msg: &msgs::PointCloud2, now_s: f64) {
        let Some(points) = self.cloud_in_map(msg, "cloud", "LiDAR cloud", now_s) else { return };
        if self.cloud_mapper.is_none() {
            let c = &self.cfg.cloud_map;
            let res = self.params.grid.resolution_m;
            let geometry =
                GridGeometry::new(c.origin_x_m, c.origin_y_m, res, (c.size_x_m / res).ceil() as usize, (c.size_y_m / res).ceil() as usize);
            match TraversabilityMap::new(geometry) {
                Ok(map) => {
                    let layers = map.compute(&self.params.traversability);
                    self.cloud_mapper = Some(CloudMapper { map, layers, dirty: true });
                }
                Err(e) => {
                    self.stats.messages_rejected += 1;
                    return self.warn("cloud", now_s, format!("cannot build the cloud map: {e}"));
                }
            }
        }
        // With a pose topic that carries a covariance, each point's height gets the variance its
        // tilt uncertainty implies (σ_t² × horizontal range², as in the core's simulator), so the
        // map discounts the roughness that registration noise explains.
        let origin = self.topic_pose.filter(|s| self.cfg.pose_source == PoseSource::Topic && s.tilt_var_rad2 > 0.0);
        if let Some(m) = &mut self.cloud_mapper {
            let s = match origin {
                Some(o) => {
                    let (x, y, var) = (o.pose.x_m, o.pose.y_m, o.tilt_var_rad2);
                    m.map.insert_points_with_variance(points.into_iter().map(|p| (p, var * ((p.x - x).powi(2) + (p.y - y).powi(2)))))
                }
                None => m.map.insert_points(points),
            };
            m.dirty |= s.inserted > 0;
        }
    }

    /// `geometry_msgs/PoseWithCovarianceStamped` (used when `pose_source: topic`).
    pub fn handle_pose(&mut self, msg: &msgs::PoseWithCovarianceStamped, now_s: f64) {
        let iso = match convert::isometry_of_pose(&msg.pose.pose) {
            Ok(i) => i,
            Err(e) => return self.reject("pose", now_s, "pose", &e),
        };
        let frame = normalise_frame(&msg.header.frame_id).to_owned();
        let map_frame = self.cfg.map_frame.clone();
        let map_from_body = if frame.is_empty() || frame == normalise_frame(&map_frame) {
            iso
        } else {
            match self.lookup(&map_frame, &frame) {
                Some(t) => t * iso,
                None => {
                    self.stats.messages_rejected += 1;
                    return self.warn("pose", now_s, format!("pose dropped: no transform {map_frame} ← {frame}"));
                }
            }
        };
        let stamp_s = msg.header.stamp.as_secs_f64();
        if let Some(old) = self.topic_pose
            && stamp_s != 0.0
            && stamp_s < old.stamp_s
        {
            self.stats.messages_late += 1;
            return self.warn("pose_late", now_s, format!("late pose dropped (stamp {stamp_s:.3} s < {:.3} s)", old.stamp_s));
        }
        let pose = convert::pose2_of_isometry(&map_from_body);
        // ROS order (x, y, z, rot X, rot Y, rot Z), fixed axes: roll and pitch at 21 and 28.
        let c = &msg.pose.covariance;
        let tilt = 0.5 * (c[21] + c[28]);
        let tilt_var_rad2 = if tilt.is_finite() && tilt > 0.0 { tilt } else { 0.0 };
        let position = c[0] + c[7];
        let position_var_m2 = if position.is_finite() && position > 0.0 { position } else { 0.0 };
        let z_m = map_from_body.translation.z;
        self.topic_pose = Some(PoseSample { pose, z_m, stamp_s, received_s: now_s, tilt_var_rad2, position_var_m2 });
    }

    /// `geometry_msgs/PolygonStamped`: the exploration boundary; an empty polygon clears it.
    pub fn handle_boundary(&mut self, msg: &msgs::PolygonStamped, now_s: f64) {
        if msg.polygon.points.is_empty() {
            self.boundary = None;
            self.info(now_s, "boundary cleared".into());
            return;
        }
        let mut b = match convert::boundary_of_polygon(msg) {
            Ok(b) => b,
            Err(e) => return self.reject("boundary", now_s, "boundary", &e),
        };
        let frame = normalise_frame(&msg.header.frame_id).to_owned();
        let map_frame = self.cfg.map_frame.clone();
        if !frame.is_empty() && frame != normalise_frame(&map_frame) {
            let Some(t) = self.lookup(&map_frame, &frame) else {
                self.stats.messages_rejected += 1;
                return self.warn("boundary", now_s, format!("boundary dropped: no transform {map_frame} ← {frame}"));
            };
            for v in &mut b.vertices_m {
                let p = t * Point3::new(v[0], v[1], 0.0);
                *v = [p.x, p.y];
            }
        }
        self.info(now_s, format!("boundary: {} vertices, {:.1} m²", b.vertices_m.len(), b.area_m2()));
        self.boundary = Some(b);
        self.replan_now = true;
    }

    /// What the navigation stack said about goal `id`. Events for other ids (an old goal) are
    /// ignored.
    pub fn on_goal_event(&mut self, id: u64, event: GoalEvent, now_s: f64) {
        let Some(g) = self.goal.filter(|g| g.id == id) else { return };
        let (x, y) = (g.goal.x_m, g.goal.y_m);
        match event {
            GoalEvent::Accepted => {
                if let Some(g) = &mut self.goal {
                    g.accepted_s.get_or_insert(now_s);
                }
            }
            GoalEvent::Succeeded => {
                self.stats.succeeded += 1;
                self.info(now_s, format!("goal {id} at ({x:.2}, {y:.2}) reached"));
                self.end_goal(Some(BlacklistReason::Reselected), true);
            }
            GoalEvent::Rejected => {
                self.stats.rejected += 1;
                self.warn("goal", now_s, format!("goal {id} at ({x:.2}, {y:.2}) rejected: blacklisted"));
                self.end_goal(Some(BlacklistReason::Failed), true);
            }
            GoalEvent::Aborted(why) => {
                self.stats.failed += 1;
                self.warn("goal", now_s, format!("goal {id} at ({x:.2}, {y:.2}) aborted ({why}): blacklisted"));
                self.end_goal(Some(BlacklistReason::Failed), true);
            }
            GoalEvent::Canceled => {
                self.stats.failed += 1;
                self.warn("goal", now_s, format!("goal {id} at ({x:.2}, {y:.2}) cancelled by another client: blacklisted"));
                self.end_goal(Some(BlacklistReason::Failed), true);
            }
            GoalEvent::Lost(why) => {
                self.stats.lost += 1;
                self.warn("goal_lost", now_s, format!("goal {id} at ({x:.2}, {y:.2}) lost ({why}): will plan again"));
                self.end_goal(None, false);
            }
        }
    }

    fn end_goal(&mut self, reason: Option<BlacklistReason>, replan_now: bool) {
        if let (Some(g), Some(r)) = (self.goal.take(), reason) {
            self.blacklist.add(g.frontier_m[0], g.frontier_m[1], r);
        }
        self.replan_now |= replan_now;
    }

    // ---------------------------------------------------------------- state

    /// The robot's pose in the map frame now, or why there is none.
    fn robot_pose(&self, now_s: f64) -> Result<Pose2, Phase> {
        let (pose, received_s) = match self.cfg.pose_source {
            PoseSource::Tf => {
                let l = self.tf.lookup(&self.cfg.map_frame, &self.cfg.base_frame).ok_or(Phase::WaitingForPose)?;
                (convert::pose2_of_isometry(&l.transform), l.oldest_received_s.unwrap_or(now_s))
            }
            PoseSource::Topic => {
                let s = self.topic_pose.ok_or(Phase::WaitingForPose)?;
                (s.pose, s.received_s)
            }
        };
        if now_s - received_s > self.cfg.pose_timeout_s {
            return Err(Phase::PoseStale);
        }
        Ok(pose)
    }

    /// The ground's height under the robot in the map frame, metres: the base frame's (exact for
    /// a frame on the ground such as `base_footprint`; `base_link` adds its mounting height),
    /// where u2 puts the camera `camera_height_m` above. 0 without a pose.
    fn ground_z_m(&self) -> f64 {
        let z = match self.cfg.pose_source {
            PoseSource::Tf => self.tf.lookup(&self.cfg.map_frame, &self.cfg.base_frame).map(|l| l.transform.translation.z),
            PoseSource::Topic => self.topic_pose.map(|s| s.z_m),
        };
        z.filter(|z| z.is_finite()).unwrap_or(0.0)
    }

    /// Whether every free cell the robot can reach on the latest map inflated by `inflation_m`
    /// (with `trail`, cells of it, open as the last decision had them) lies within
    /// `trapped_radius_m` of it ([`enclosed_within`]).
    fn trapped(&mut self, robot: Pose2, trail: &[usize], inflation_m: f64) -> bool {
        let r = self.cfg.trapped_radius_m;
        if r <= 0.0 {
            return false;
        }
        let Some(inflated) = self.inflated(inflation_m) else { return false };
        let opened;
        let grid = if trail.is_empty() {
            inflated
        } else {
            let mut g = inflated.clone();
            free_traversed(&self.map.as_ref().expect("inflated above").grid, trail, &mut g);
            opened = g;
            &opened
        };
        grid.geometry.cell_of(robot.x_m, robot.y_m).is_some_and(|c| enclosed_within(grid, c, r))
    }

    /// With a cloud map and recoveries left ([`NodeConfig::trap_recoveries`]), forgets the map
    /// around `robot` and the `NoPath` blacklist entries judged on it; returns the points
    /// forgotten and the radius, metres.
    fn recover_from_trap(&mut self, robot: Pose2) -> Option<(u64, f64)> {
        if self.stats.trap_recoveries >= u64::from(self.cfg.trap_recoveries) {
            return None;
        }
        let m = self.cloud_mapper.as_mut()?;
        let r = recovery_radius_m(self.cfg.trapped_radius_m, &self.params);
        let points = m.map.forget_disc(robot.x_m, robot.y_m, r);
        m.dirty = true;
        // "No path" was judged on the map just forgotten.
        self.blacklist.remove_reason(BlacklistReason::NoPath);
        self.stats.trap_recoveries += 1;
        Some((points, r))
    }

    /// σx² + σy² of the pose, m²: the pose topic's covariance; 0 from tf, which has none.
    fn position_var_m2(&self) -> f64 {
        match (self.cfg.pose_source, self.topic_pose) {
            (PoseSource::Topic, Some(s)) => s.position_var_m2,
            _ => 0.0,
        }
    }

    /// Age of the pose, seconds (for the stale-pose message).
    fn pose_age_s(&self, now_s: f64) -> Option<f64> {
        match self.cfg.pose_source {
            PoseSource::Tf => {
                self.tf.lookup(&self.cfg.map_frame, &self.cfg.base_frame).map(|l| now_s - l.oldest_received_s.unwrap_or(now_s))
            }
            PoseSource::Topic => self.topic_pose.map(|s| now_s - s.received_s),
        }
    }

    /// The latest map with lethal cells inflated by `radius_m` (cached per map).
    fn inflated(&mut self, radius_m: f64) -> Option<&OccupancyGrid> {
        let m = self.map.as_mut()?;
        let k = match m.inflated.iter().position(|(r, _)| *r == radius_m) {
            Some(k) => k,
            None => {
                m.inflated.push((radius_m, inflate_lethal(&m.grid, radius_m)));
                m.inflated.len() - 1
            }
        };
        Some(&m.inflated[k].1)
    }

    /// Whether a goal at (x, y) lies on a free cell of the latest grid inflated by
    /// `inflation_m` (not lethal, not inflated, not unknown, inside the map).
    pub fn goal_is_free(&mut self, x_m: f64, y_m: f64, inflation_m: f64) -> bool {
        self.inflated(inflation_m).and_then(|g| g.at_world(x_m, y_m)).is_some_and(|&v| CellClass::of(v) == CellClass::Free)
    }

    fn refresh_cloud_map(&mut self, now_s: f64) {
        let tau = self.params.traversability.tau;
        let Some(m) = self.cloud_mapper.as_mut().filter(|m| m.dirty) else { return };
        m.map.update(&self.params.traversability, &mut m.layers);
        m.dirty = false;
        let grid = m.layers.to_occupancy(tau);
        // Cloud maps are built here, so they are never late.
        let stamp_s = self.map.as_ref().map_or(0.0, |m| m.stamp_s);
        self.set_map(grid, stamp_s, now_s);
    }

    fn send(&mut self, Picked { frontier_m, goal, inflation_m }: Picked, now_s: f64) -> Command {
        let id = self.next_goal_id;
        self.next_goal_id += 1;
        let accepted_s = (self.cfg.goal_interface == GoalInterface::Topic).then_some(now_s);
        self.goal = Some(ActiveGoal { id, goal, frontier_m, sent_s: now_s, accepted_s, inflation_m });
        self.stats.goals_sent += 1;
        self.info(now_s, format!("goal {id}: ({:.2}, {:.2}) m, heading {:.0}°", goal.x_m, goal.y_m, goal.yaw_rad.to_degrees()));
        Command::SendGoal { id, goal }
    }

    fn finish(&mut self, reason: &str, now_s: f64, out: &mut Vec<Command>) {
        if let Some(g) = self.goal.take() {
            out.push(Command::CancelGoal { id: g.id });
        }
        self.done_reason = Some(reason.to_owned());
        self.phase = Phase::Done;
        self.info(now_s, format!("mission complete: {reason}"));
        out.push(Command::MissionComplete);
    }

    /// Advances the clock: goal supervision every call, a decision every `replan_period_s` (or
    /// at once after a goal ended). Call it every poll period.
    pub fn tick(&mut self, now_s: f64) -> Vec<Command> {
        let mut out = Vec::new();
        if self.phase == Phase::Done {
            return out;
        }
        let started = *self.started_s.get_or_insert(now_s);
        if let Some(max) = self.cfg.max_mission_s
            && now_s - started >= max
        {
            self.finish(&format!("time limit of {max} s reached"), now_s, &mut out);
            return out;
        }
        if self.cfg.map_source == MapSource::Clouds {
            let due = self.last_decision_s.is_none_or(|t| now_s - t >= self.cfg.replan_period_s);
            if due || self.replan_now {
                self.refresh_cloud_map(now_s);
            }
        }
        if self.cfg.reuse_trail
            && let Ok(p) = self.robot_pose(now_s)
        {
            self.trail.push(p.x_m, p.y_m, 0.5 * self.params.grid.resolution_m);
        }
        self.supervise_goal(now_s, &mut out);
        let due = self.replan_now || self.last_decision_s.is_none_or(|t| now_s - t >= self.cfg.replan_period_s);
        if due {
            self.last_decision_s = Some(now_s);
            self.replan_now = false;
            self.plan(now_s, &mut out);
        }
        out
    }

    fn supervise_goal(&mut self, now_s: f64, out: &mut Vec<Command>) {
        let Some(g) = self.goal else { return };
        let (x, y) = (g.goal.x_m, g.goal.y_m);
        match g.accepted_s {
            None if now_s - g.sent_s > self.cfg.goal_response_timeout_s => {
                self.stats.lost += 1;
                let text = format!(
                    "no answer from the navigation server within {} s for goal {} at ({x:.2}, {y:.2}): dropped, will send again",
                    self.cfg.goal_response_timeout_s, g.id
                );
                self.warn("goal_lost", now_s, text);
                out.push(Command::CancelGoal { id: g.id });
                self.end_goal(None, false);
                return;
            }
            Some(t) if now_s - t > self.cfg.goal_timeout_s => {
                self.stats.timed_out += 1;
                let text =
                    format!("goal {} at ({x:.2}, {y:.2}) not reached within {} s: cancelled, blacklisted", g.id, self.cfg.goal_timeout_s);
                self.warn("goal", now_s, text);
                out.push(Command::CancelGoal { id: g.id });
                self.end_goal(Some(BlacklistReason::Failed), true);
                return;
            }
            _ => {}
        }
        if !self.goal_is_free(x, y, g.inflation_m) {
            let text = format!("goal {} at ({x:.2}, {y:.2}) is no longer free on the latest map: cancelled", g.id);
            self.warn("goal_lethal", now_s, text);
            out.push(Command::CancelGoal { id: g.id });
            self.stats.replaced += 1;
            self.end_goal(None, true);
            return;
        }
        if self.cfg.goal_interface == GoalInterface::Topic
            && let Ok(p) = self.robot_pose(now_s)
            && (p.x_m - x).hypot(p.y_m - y) <= self.cfg.goal_tolerance_m
        {
            self.on_goal_event(g.id, GoalEvent::Succeeded, now_s);
        }
    }

    /// One decision on the latest map (`None` without one), `traversed` (cells of it) free after
    /// inflation, lethal cells inflated by `inflation_m` (the robot radius, or one of
    /// [`NodeConfig::tight_inflations_m`]); made again with the robot's footprint free if it is
    /// blocked in the map ([`NodeConfig::clear_footprint`]); its unreachable candidates
    /// blacklisted.
    fn decide(&mut self, robot: Pose2, traversed: &[usize], inflation_m: f64, now_s: f64) -> Option<Result<Decision, SelectError>> {
        let map = self.map.as_ref()?;
        let tight_params;
        let params = if inflation_m == self.params.robot.radius_m {
            &self.params
        } else {
            tight_params = self.params.with_robot_radius_m(inflation_m);
            &tight_params
        };
        let mut input = DecisionInput::new(&map.grid, &self.landmarks, robot, &self.blacklist);
        input.ground_z_m = self.ground_z_m();
        input.traversed = traversed;
        if let Some(b) = &self.boundary {
            input = input.with_boundary(b);
        }
        let t0 = std::time::Instant::now();
        let mut result = self.selector.select(&input, params);
        // Blocked in its own map (speckle under the robot): decide again on its footprint.
        let mut cleared = None;
        if self.cfg.clear_footprint && matches!(result, Err(SelectError::RobotBlocked { .. })) {
            let mut grid = map.grid.clone();
            let radius_m = params.robot.radius_m + grid.geometry.resolution_m;
            fill_disc(&mut grid, robot.x_m, robot.y_m, radius_m, FREE);
            result = self.selector.select(&DecisionInput { grid: &grid, ..input }, params);
            cleared = Some(radius_m);
        }
        self.stats.last_decision_ms = t0.elapsed().as_secs_f64() * 1e3;
        if let (Some(r), Ok(_)) = (cleared, &result) {
            self.stats.footprint_clearings += 1;
            self.info(now_s, format!("robot blocked in its map: decided with the cells within {r:.2} m of it free"));
        }
        if let Ok(decision) = &result {
            self.stats.decisions += 1;
            for [x, y] in decision.unreachable_m() {
                self.blacklist.add(x, y, BlacklistReason::NoPath);
            }
        }
        Some(result)
    }

    /// The best-ranked candidate of `decision` (made at `inflation_m`) whose goal, set back along
    /// its path from unknown ground by the pose's uncertainty, is on a free cell of the latest
    /// grid inflated so.
    fn pick(&mut self, decision: &Decision, inflation_m: f64, now_s: f64) -> Option<Picked> {
        let margin_m = self.cfg.goal_setback.margin_m(self.position_var_m2(), 0.0);
        for i in decision.ranking() {
            let c = &decision.candidates[i];
            let mut goal = match (decision.chosen == Some(i), decision.goal) {
                (true, Some(g)) => g,
                _ => Pose2::new(c.x_m, c.y_m, c.theta_star_rad.unwrap_or(0.0)),
            };
            if margin_m > 0.0
                && let Some(map) = self.map.as_ref()
                && let Some(&[x, y]) = set_back(&c.path_m, &map.grid, margin_m).last()
            {
                (goal.x_m, goal.y_m) = (x, y);
            }
            if goal.is_finite() && self.goal_is_free(goal.x_m, goal.y_m, inflation_m) {
                return Some(Picked { frontier_m: [c.x_m, c.y_m], goal, inflation_m });
            }
            let text = format!("candidate at ({:.2}, {:.2}) is not free on the inflated map: skipped", goal.x_m, goal.y_m);
            self.warn("candidate_lethal", now_s, text);
        }
        None
    }

    /// The trail's cells on the latest map ([`NodeConfig::reuse_trail`]; empty without a map).
    fn trail_cells(&self) -> Vec<usize> {
        match (&self.map, self.cfg.reuse_trail) {
            (Some(m), true) => self.trail.cells(&m.grid.geometry),
            _ => Vec::new(),
        }
    }

    fn plan(&mut self, now_s: f64, out: &mut Vec<Command>) {
        if self.map.is_none() {
            self.phase = Phase::WaitingForMap;
            let topic = match self.cfg.map_source {
                MapSource::Occupancy => &self.cfg.map_topic,
                MapSource::Clouds => &self.cfg.cloud_topic,
            };
            let text = format!("waiting for the map on {topic}");
            return self.warn("wait", now_s, text);
        }
        let robot = match self.robot_pose(now_s) {
            Ok(p) => p,
            Err(phase) => {
                self.phase = phase;
                let text = match (phase, self.cfg.pose_source) {
                    (Phase::PoseStale, _) => format!(
                        "pose stale: last update {:.1} s ago (limit {} s); not planning",
                        self.pose_age_s(now_s).unwrap_or(f64::NAN),
                        self.cfg.pose_timeout_s
                    ),
                    (_, PoseSource::Tf) => format!("waiting for tf {} ← {}", self.cfg.map_frame, self.cfg.base_frame),
                    (_, PoseSource::Topic) => format!("waiting for the pose on {}", self.cfg.pose_topic),
                };
                return self.warn("wait", now_s, text);
            }
        };
        let mut inflation_m = self.params.robot.radius_m;
        let mut decision = match self.decide(robot, &[], inflation_m, now_s) {
            None => return,
            Some(Ok(d)) => d,
            Some(Err(e)) => {
                self.stats.decision_errors += 1;
                self.phase = if self.goal.is_some() { Phase::Navigating } else { Phase::Planning };
                return self.warn("decision", now_s, format!("no decision: {e}"));
            }
        };
        let mut picked = self.pick(&decision, inflation_m, now_s);
        // No goal: decide again with the cells the robot drove on open (and judge a trap so).
        let trail = if picked.is_none() && self.goal.is_none() { self.trail_cells() } else { Vec::new() };
        if !trail.is_empty()
            && let Some(Ok(d)) = self.decide(robot, &trail, inflation_m, now_s)
        {
            picked = self.pick(&d, inflation_m, now_s);
            decision = d;
        }
        // Still none: with each tight inflation smaller than the last radius tried (the trail
        // still open).
        for k in 0..self.cfg.tight_inflations_m.len() {
            let tight_m = self.cfg.tight_inflations_m[k];
            if picked.is_some() || self.goal.is_some() || tight_m >= inflation_m {
                continue;
            }
            let Some(Ok(d)) = self.decide(robot, &trail, tight_m, now_s) else { break };
            inflation_m = tight_m;
            picked = self.pick(&d, inflation_m, now_s);
            if picked.is_some() {
                self.stats.tight_goals += 1;
                self.info(now_s, format!("no goal at the full inflation: decided with lethal cells inflated by {tight_m} m"));
            }
            decision = d;
        }
        let radius = self.params.frontier.blacklist_radius_m;
        match (picked, self.goal) {
            (None, None) if self.trapped(robot, &trail, inflation_m) => {
                self.empty_decisions = 0;
                self.phase = Phase::Planning;
                let walled = format!(
                    "no frontier goal, but every free cell the robot can reach lies within {} m: walled in by its map, not done",
                    self.cfg.trapped_radius_m
                );
                let text = match self.recover_from_trap(robot) {
                    Some((points, r)) => format!(
                        "{walled}; recovery {} of {}: forgot the {points} cloud points within {r:.2} m of the robot, mapping them again",
                        self.stats.trap_recoveries, self.cfg.trap_recoveries
                    ),
                    None => format!("{walled}; waiting for the map to change"),
                };
                self.warn("trapped", now_s, text);
            }
            (None, None) => {
                self.empty_decisions += 1;
                self.phase = Phase::Planning;
                if self.empty_decisions >= self.cfg.done_after_empty_decisions {
                    let reason = format!(
                        "no reachable, non-blacklisted frontier left ({} candidates, {} blacklisted goals)",
                        decision.candidates.len(),
                        self.blacklist.len()
                    );
                    self.last_decision = Some(decision);
                    return self.finish(&reason, now_s, out);
                }
            }
            (None, Some(_)) => self.phase = Phase::Navigating,
            (Some(new), None) => {
                self.empty_decisions = 0;
                out.push(self.send(new, now_s));
                self.phase = Phase::Navigating;
            }
            (Some(new), Some(cur)) => {
                self.empty_decisions = 0;
                self.phase = Phase::Navigating;
                let [x, y] = cur.frontier_m;
                let same = (new.frontier_m[0] - x).hypot(new.frontier_m[1] - y) <= radius;
                let still_frontier = decision.candidates.iter().any(|c| c.is_scored() && (c.x_m - x).hypot(c.y_m - y) <= radius);
                if !same && !still_frontier {
                    let text = format!("goal {} at ({:.2}, {:.2}) is no longer a frontier: replaced", cur.id, cur.goal.x_m, cur.goal.y_m);
                    self.info(now_s, text);
                    self.stats.replaced += 1;
                    out.push(Command::CancelGoal { id: cur.id });
                    self.goal = None;
                    out.push(self.send(new, now_s));
                }
            }
        }
        self.last_decision = Some(decision);
    }

    // ---------------------------------------------------------------- outputs

    /// The status now.
    pub fn status(&self, now_s: f64) -> Status {
        let d = self.last_decision.as_ref();
        Status {
            t_s: now_s,
            phase: self.phase,
            goal: self.goal,
            robot: self.robot_pose(now_s).ok(),
            candidates: d.map_or(0, |d| d.candidates.len()),
            ranked: d.map_or(0, |d| d.ranking().len()),
            blacklisted: self.blacklist.len(),
            landmark_voxels: self.landmarks.len(),
            map_cells: self.map.as_ref().map(|m| [m.grid.geometry.width, m.grid.geometry.height]),
            stats: self.stats,
            done_reason: self.done_reason.clone(),
            last_warning: self.last_warning.clone(),
        }
    }

    /// The last decision (whole ranking).
    pub fn last_decision(&self) -> Option<&Decision> {
        self.last_decision.as_ref()
    }

    /// Number of decisions made so far (the adapter publishes markers when it changes).
    pub fn decisions(&self) -> u64 {
        self.stats.decisions
    }

    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }

    pub fn current_goal(&self) -> Option<ActiveGoal> {
        self.goal
    }

    pub fn blacklist(&self) -> &Blacklist {
        &self.blacklist
    }

    /// The latest (not inflated) map.
    pub fn map(&self) -> Option<&OccupancyGrid> {
        self.map.as_ref().map(|m| &m.grid)
    }

    /// The landmark points (map frame) of the latest landmark map.
    pub fn landmark_points(&self) -> &[[f64; 3]] {
        &self.landmark_points
    }

    pub fn landmark_voxels(&self) -> &LandmarkVoxels {
        &self.landmarks
    }

    /// The robot's pose if known and fresh.
    pub fn robot(&self, now_s: f64) -> Option<Pose2> {
        self.robot_pose(now_s).ok()
    }

    pub fn config(&self) -> &NodeConfig {
        &self.cfg
    }

    pub fn params(&self) -> &Params {
        &self.params
    }
}

#[cfg(test)]
mod tests;
