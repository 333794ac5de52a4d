//! The exploration node's state, free of DDS: messages in (with the caller's clock, seconds),
//! [`Command`]s out. The ROS adapter (`ros.rs`) only moves messages. The decisions are the
//! core's exploration policy ([`fitslam_core::explore::Explorer`]: the retry chain, goal
//! keep/replace, the blacklist, the trail, the set-back), the same one the simulator runs; what
//! is here is what only a ROS node has: message validation and staleness ([`inputs`]), the
//! supervision of goals sent to Nav2 — acceptance, timeouts, a goal whose cell the latest map no
//! longer holds free ([`goals`]) — and the end of a mission confirmed over several decisions.
//!
//! One cycle (every `replan_period_s`, or at once after a goal ends): the latest map (occupancy,
//! or clouds fused by the core, notes §2), the robot pose (tf or a pose topic) and the landmark
//! voxels go to the explorer (notes §3–7), whose answer is acted on: a new goal is sent
//! (replacing the running one), a kept goal runs on, a trapped robot forgets its cloud map around
//! itself (an occupancy map comes from elsewhere: it waits for it to change), and
//! `done_after_empty_decisions` answers "done" in a row end the mission (maps arrive
//! asynchronously: one decision on a map that has not caught up must not end it).
//!
//! Costs per cycle: one explorer decision (notes §7) plus, once per new map, one inflation
//! (O(cells · disc)); per poll: O(1) goal checks.

mod goals;
mod inputs;
mod log;
mod status;
mod types;

pub use fitslam_core::ros::{NodeGoal, NodeStats, NodeStatus, Phase};
pub use log::{Level, LogLine, WARN_REPEAT_S};
pub use types::{Command, GoalEvent};

use crate::config::{GoalInterface, MapSource, NodeConfig, PoseSource};
use crate::tf::TfBuffer;
use fitslam_core::explore::{Action, Explorer, Situation, WaitReason};
use fitslam_core::frontier::Boundary;
use fitslam_core::grid::inflate_lethal;
use fitslam_core::params::{InvalidParam, Valid, Validate};
use fitslam_core::ros::pose2_of_isometry;
use fitslam_core::traversability::{TraversabilityLayers, TraversabilityMap};
use fitslam_core::utility::LandmarkVoxels;
use fitslam_core::{OccupancyGrid, Params, Pose2};
use std::collections::{BTreeMap, HashMap};

struct MapState {
    grid: OccupancyGrid,
    /// Inflated by the robot radius and by any tight radius used, each computed on first use:
    /// (radius, metres; grid).
    inflated: Vec<(f64, OccupancyGrid)>,
    stamp_s: f64,
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
pub struct ExplorerNode {
    cfg: NodeConfig,
    explorer: Explorer,
    tf: TfBuffer,
    map: Option<MapState>,
    cloud_mapper: Option<CloudMapper>,
    landmarks: LandmarkVoxels,
    landmark_points: Vec<[f64; 3]>,
    topic_pose: Option<PoseSample>,
    boundary: Option<Boundary>,
    goal: Option<NodeGoal>,
    next_goal_id: u64,
    last_decision_s: Option<f64>,
    replan_now: bool,
    /// Decisions in a row whose answer was "done".
    empty_decisions: u32,
    started_s: Option<f64>,
    /// The robot's first pose in the map frame (`return_to_start`).
    start_pose: Option<Pose2>,
    /// A `pause` command holds; `stop` asked.
    paused: bool,
    stop_requested: bool,
    /// Driving back to the start after the mission ended for this reason; how that goal ended.
    returning: Option<String>,
    return_outcome: Option<&'static str>,
    suggested_goal: Option<Pose2>,
    done_reason: Option<String>,
    phase: Phase,
    last_warning: Option<String>,
    log: Vec<LogLine>,
    warned: HashMap<&'static str, (String, f64)>,
    /// Warnings logged, by kind.
    warning_counts: BTreeMap<&'static str, u64>,
    stats: NodeStats,
}

impl ExplorerNode {
    /// A node with this configuration, checked here once (the error names the first bad key,
    /// `node.…` or `fitslam.…`): the exploration policy takes only checked parameters.
    pub fn new(cfg: NodeConfig, params: Params) -> Result<Self, InvalidParam> {
        cfg.validate()?;
        let explore = Valid::new(cfg.explore.clone()).map_err(|e| e.under("node.explore."))?;
        let params = Valid::new(params).map_err(|e| e.under("fitslam."))?;
        let mut explorer = Explorer::new(explore, params);
        let t0 = std::time::Instant::now();
        explorer.set_clock(Box::new(move || t0.elapsed().as_secs_f64() * 1e3));
        Ok(Self {
            landmarks: LandmarkVoxels::empty(explorer.planner().u2.voxel_m),
            explorer,
            cfg,
            tf: TfBuffer::new(),
            map: None,
            cloud_mapper: None,
            landmark_points: Vec::new(),
            topic_pose: None,
            boundary: None,
            goal: None,
            next_goal_id: 1,
            last_decision_s: None,
            replan_now: false,
            empty_decisions: 0,
            started_s: None,
            start_pose: None,
            paused: false,
            stop_requested: false,
            returning: None,
            return_outcome: None,
            suggested_goal: None,
            done_reason: None,
            phase: Phase::WaitingForMap,
            last_warning: None,
            log: Vec::new(),
            warned: HashMap::new(),
            warning_counts: BTreeMap::new(),
            stats: NodeStats::default(),
        })
    }

    // ---------------------------------------------------------------- state

    /// The robot's pose in the map frame now, or why there is none.
    fn robot_pose(&self, now_s: f64) -> Result<Pose2, Phase> {
        let (pose, received_s) = match self.cfg.pose_source {
            PoseSource::Tf => {
                let l = self.tf.lookup(&self.cfg.map_frame, &self.cfg.base_frame).ok_or(Phase::WaitingForPose)?;
                (pose2_of_isometry(&l.transform), l.oldest_received_s.unwrap_or(now_s))
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

    fn refresh_cloud_map(&mut self, now_s: f64) {
        let params = self.explorer.planner().traversability.clone();
        let Some(m) = self.cloud_mapper.as_mut().filter(|m| m.dirty) else { return };
        m.map.update(&params, &mut m.layers);
        m.dirty = false;
        let grid = m.layers.to_occupancy(params.tau);
        // Cloud maps are built here, so they are never late.
        let stamp_s = self.map.as_ref().map_or(0.0, |m| m.stamp_s);
        self.set_map(grid, stamp_s, now_s);
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
        if self.stop_requested {
            self.finish("stopped on request", now_s, &mut out);
            return out;
        }
        if let Some(max) = self.cfg.max_mission_s
            && now_s - started >= max
            && self.returning.is_none()
        {
            self.end_mission(format!("time limit of {max} s reached"), now_s, &mut out);
            return out;
        }
        if self.cfg.map_source == MapSource::Clouds {
            let due = self.last_decision_s.is_none_or(|t| now_s - t >= self.cfg.replan_period_s);
            if due || self.replan_now {
                self.refresh_cloud_map(now_s);
            }
        }
        if let Ok(p) = self.robot_pose(now_s) {
            self.explorer.record_position(p.x_m, p.y_m);
            self.start_pose.get_or_insert(p);
        }
        if self.paused && self.returning.is_none() {
            self.phase = Phase::Paused;
            if let Some(g) = self.goal.take() {
                out.push(Command::CancelGoal { id: g.id });
                self.explorer.goal_dropped();
            }
            return out;
        }
        self.supervise_goal(now_s, &mut out);
        if let Some(reason) = self.returning.clone() {
            if self.goal.is_none() {
                let outcome = self.return_outcome.take().unwrap_or("the return to start ended");
                self.finish(&format!("{reason}; {outcome}"), now_s, &mut out);
            }
            return out;
        }
        let due = self.replan_now || self.last_decision_s.is_none_or(|t| now_s - t >= self.cfg.replan_period_s);
        if due {
            self.last_decision_s = Some(now_s);
            self.replan_now = false;
            self.plan(now_s, &mut out);
        }
        out
    }

    /// One decision on the latest map, acted on.
    fn plan(&mut self, now_s: f64, out: &mut Vec<Command>) {
        let Some(map) = self.map.as_ref() else {
            self.phase = Phase::WaitingForMap;
            let topic = match self.cfg.map_source {
                MapSource::Occupancy => &self.cfg.map_topic,
                MapSource::Clouds => &self.cfg.cloud_topic,
            };
            let text = format!("waiting for the map on {topic}");
            return self.warn("wait", now_s, text);
        };
        let robot = match self.robot_pose(now_s) {
            Ok(p) => p,
            Err(phase) => {
                self.phase = phase;
                let text = self.no_pose_text(phase, now_s);
                return self.warn("wait", now_s, text);
            }
        };
        let mut grid = map.grid.clone();
        let situation = Situation {
            landmarks: &self.landmarks,
            robot,
            boundary: self.boundary.as_ref(),
            ground_z_m: self.ground_z_m(),
            // The ground the node maps itself from the clouds; with a map from elsewhere, flat.
            ground: self.cloud_mapper.as_ref().map(|m| m.layers.ground()),
            position_var_m2: self.position_var_m2(),
            replanning: self.goal.is_some(),
            can_forget_map: self.cloud_mapper.is_some(),
        };
        let clearings = self.explorer.stats().footprint_clearings;
        let action = self.explorer.decide(&mut grid, &situation);
        self.stats.last_decision_ms = self.explorer.stats().last_decide_ms;
        if self.explorer.stats().footprint_clearings > clearings && !matches!(action, Action::Wait(_)) {
            let r = self.explorer.planner().robot.radius_m + grid.geometry.resolution_m;
            self.info(now_s, format!("robot blocked in its map: decided with the cells within {r:.2} m of it free"));
        }
        if !matches!(action, Action::Done(_)) {
            self.empty_decisions = 0;
        }
        match action {
            Action::Goal(plan) => {
                let target = plan.target();
                if !(target.is_finite() && self.goal_is_free(target.x_m, target.y_m, plan.goal.inflation_m, plan.goal.on_trail)) {
                    let text = format!("candidate at ({:.2}, {:.2}) is not free on the inflated map: skipped", target.x_m, target.y_m);
                    self.warn("candidate_lethal", now_s, text);
                    self.explorer.goal_dropped();
                    self.drop_goal_the_explorer_dropped(out);
                    self.phase = Phase::Planning;
                    return;
                }
                if self.cfg.publish_only {
                    self.suggested_goal = Some(target);
                    self.explorer.goal_dropped();
                    self.phase = Phase::Planning;
                    return;
                }
                if plan.tight {
                    self.stats.tight_goals += 1;
                    let text = format!("no goal at the full inflation: decided with lethal cells inflated by {} m", plan.goal.inflation_m);
                    self.info(now_s, text);
                }
                if let Some(cur) = self.goal.take() {
                    let text = format!("goal {} at ({:.2}, {:.2}) is no longer a frontier: replaced", cur.id, cur.goal.x_m, cur.goal.y_m);
                    self.info(now_s, text);
                    self.stats.replaced += 1;
                    out.push(Command::CancelGoal { id: cur.id });
                }
                out.push(self.send(&plan, now_s));
                self.phase = Phase::Navigating;
            }
            Action::Keep(plan) => {
                if let Some(g) = &mut self.goal {
                    (g.inflation_m, g.on_trail) = (plan.goal.inflation_m, plan.goal.on_trail);
                }
                self.phase = Phase::Navigating;
            }
            Action::Wait(why) => {
                match why {
                    WaitReason::NoPlan(e) => self.warn("decision", now_s, format!("no decision: {e}")),
                    WaitReason::Reselected => {}
                    WaitReason::Trapped => {
                        let text = format!("{}; waiting for the map to change", self.walled_in());
                        self.warn("trapped", now_s, text);
                    }
                }
                self.drop_goal_the_explorer_dropped(out);
                self.phase = if self.goal.is_some() { Phase::Navigating } else { Phase::Planning };
            }
            Action::Recover { radius_m } => {
                let points = self.cloud_mapper.as_mut().map_or(0, |m| {
                    m.dirty = true;
                    m.map.forget_disc(robot.x_m, robot.y_m, radius_m)
                });
                let (n, max) = (self.explorer.stats().trap_recoveries, self.cfg.explore.trap_recoveries);
                let text = format!(
                    "{}; recovery {n} of {max}: forgot the {points} cloud points within {radius_m:.2} m of the robot, mapping them again",
                    self.walled_in()
                );
                self.warn("trapped", now_s, text);
                self.drop_goal_the_explorer_dropped(out);
                self.phase = Phase::Planning;
            }
            Action::Done(reason) => {
                self.empty_decisions += 1;
                self.phase = if self.goal.is_some() { Phase::Navigating } else { Phase::Planning };
                if self.empty_decisions >= self.cfg.done_after_empty_decisions {
                    let text = self.done_text(reason);
                    self.end_mission(text, now_s, out);
                }
            }
        }
    }

    /// The mission is over for `reason`: with `return_to_start` (and a start pose farther than
    /// the goal tolerance) one last goal to the start is sent first, else it ends now.
    fn end_mission(&mut self, reason: String, now_s: f64, out: &mut Vec<Command>) {
        let start = self.start_pose.filter(|_| self.cfg.return_to_start && !self.cfg.publish_only);
        let away = |p: Pose2, s: Pose2| (p.x_m - s.x_m).hypot(p.y_m - s.y_m) > self.cfg.goal_tolerance_m;
        if let (Some(start), Ok(p)) = (start, self.robot_pose(now_s))
            && away(p, start)
        {
            if let Some(g) = self.goal.take() {
                out.push(Command::CancelGoal { id: g.id });
                self.explorer.goal_dropped();
            }
            self.info(now_s, format!("{reason}: returning to the start ({:.2}, {:.2})", start.x_m, start.y_m));
            let radius_m = self.explorer.planner().robot.radius_m;
            out.push(self.send_goal(start, [start.x_m, start.y_m], radius_m, true, now_s));
            self.returning = Some(reason);
            self.phase = Phase::Returning;
            return;
        }
        self.finish(&reason, now_s, out);
    }

    /// Cancels the goal sent when the explorer gave it up (no plan from here, trap recovery).
    fn drop_goal_the_explorer_dropped(&mut self, out: &mut Vec<Command>) {
        if self.explorer.goal().is_none()
            && let Some(g) = self.goal.take()
        {
            out.push(Command::CancelGoal { id: g.id });
        }
    }
    /// Whether a goal at (x, y) lies on a free cell of the latest grid inflated by
    /// `inflation_m` (not lethal, not inflated, not unknown, inside the map); with `on_trail`, a
    /// cell of the robot's trail that the map holds free counts as free too.
    pub fn goal_is_free(&mut self, x_m: f64, y_m: f64, inflation_m: f64, on_trail: bool) -> bool {
        use fitslam_core::grid::CellClass;
        let free_inflated =
            self.inflated(inflation_m).and_then(|g| g.at_world(x_m, y_m)).is_some_and(|&v| CellClass::of(v) == CellClass::Free);
        if free_inflated || !on_trail {
            return free_inflated;
        }
        let Some(m) = self.map.as_ref() else { return false };
        let g = m.grid.geometry;
        let Some(i) = g.cell_of(x_m, y_m).and_then(|c| g.index(c)) else { return false };
        CellClass::of(m.grid.data[i]) == CellClass::Free && self.explorer.trail().mask(&g)[i]
    }

    /// Matches the goal kind the node was configured for.
    fn topic_goals(&self) -> bool {
        self.cfg.goal_interface == GoalInterface::Topic
    }
}

#[cfg(test)]
mod tests;
