//! A simulated mission recorded as a rosbag2 MCAP bag with the fitslam node's topics, so that a
//! simulated mission and a real one replay the same way ([`crate::bag`]): `/tf` (map → odom
//! identity, odom → base_link the estimated pose) every [`TF_PERIOD_S`]; at each decision `/map`
//! (the robot's thresholded map after that step), `/cloud_map` (the landmark map, map frame) and
//! `/fitslam/status` (the node's [`NodeStatus`], with `source: "fitslam explore"`), the status
//! 1 µs after the map it was decided on.

use super::Mission;
use crate::bag::McapWriter;
use crate::ros::{self, NodeGoal, NodeStats, NodeStatus, Phase};
use crate::utility::LandmarkVoxels;
use fitslam_msgs::{Header, OccupancyGrid, PointCloud2, StringMsg, TFMessage, Time, Transform, TransformStamped, cdr};
use serde::Serialize;

/// Period of the tf messages, simulated seconds.
pub const TF_PERIOD_S: f64 = 0.1;

/// Records a mission step by step.
pub struct MissionRecorder {
    w: McapWriter,
    ch: [u16; 4],
    last_tf_s: f64,
    decisions: u64,
    /// The goal of the last status: (id, frontier position, when it was first recorded).
    goal: Option<(u64, [f64; 2], f64)>,
    maps: u64,
}

impl MissionRecorder {
    /// A recorder with the node's four topics declared and nothing written yet.
    pub fn new() -> Self {
        let mut w = McapWriter::new("fitslam explore");
        let ch = [
            w.channel::<TFMessage>("/tf"),
            w.channel::<OccupancyGrid>("/map"),
            w.channel::<PointCloud2>("/cloud_map"),
            w.channel::<StringMsg>("/fitslam/status"),
        ];
        Self { w, ch, last_tf_s: f64::NEG_INFINITY, decisions: 0, goal: None, maps: 0 }
    }

    /// Writes one message; types with no CDR form cannot reach here (message types only).
    fn write<M: Serialize>(&mut self, channel: usize, t_ns: u64, msg: &M) {
        if let Ok(bytes) = cdr::to_vec(msg) {
            self.w.message(self.ch[channel], t_ns, &bytes);
        }
    }

    /// Records what changed since the last call (call after each `Mission::step`).
    pub fn record(&mut self, mission: &mut Mission) {
        let t_s = mission.time_s();
        let t_ns = (t_s.max(0.0) * 1e9) as u64;
        let decisions = mission.explorer().stats().decisions;
        let header = |frame: &str| Header::new(Time::from_secs_f64(t_s), frame);
        if t_s - self.last_tf_s >= TF_PERIOD_S - 1e-9 || decisions != self.decisions {
            self.last_tf_s = t_s;
            let tf =
                |parent: &str, child: &str, transform| TransformStamped { header: header(parent), child_frame_id: child.into(), transform };
            let transforms =
                vec![tf("map", "odom", Transform::default()), tf("odom", "base_link", ros::transform_of_pose2(mission.estimate()))];
            self.write(0, t_ns, &TFMessage { transforms });
        }
        if decisions == self.decisions {
            return;
        }
        self.decisions = decisions;
        let grid = mission.occupancy();
        self.write(1, t_ns, &ros::msg_of_occupancy(&grid, header("map")));
        self.maps += 1;
        let landmarks = mission.landmark_map();
        self.write(2, t_ns, &ros::cloud_of_points(&landmarks.points, header("map")));
        let u2 = &mission.params().u2;
        let mut status = self.status(mission, t_s);
        status.map_cells = Some([grid.geometry.width, grid.geometry.height]);
        status.landmark_voxels = LandmarkVoxels::new(&landmarks, u2.voxel_m, u2.sigma_landmark_m).map_or(0, |v| v.len());
        let data = serde_json::to_string(&status).unwrap_or_default();
        self.write(3, t_ns + 1000, &StringMsg { data });
    }

    /// The status the node would publish: the explorer's goal (its frontier candidate), the
    /// estimated pose, the decision's counts and the explorer's counters. What only a ROS node
    /// has (warnings, rejected or late messages, feedback times) stays empty.
    fn status(&mut self, mission: &Mission, t_s: f64) -> NodeStatus {
        let goal = mission.goal().map(|g| {
            let xy = [g.goal.x_m, g.goal.y_m];
            let (id, sent_s) = match self.goal {
                Some((id, last, sent_s)) if last == xy => (id, sent_s),
                Some((id, _, _)) => (id + 1, t_s),
                None => (1, t_s),
            };
            self.goal = Some((id, xy, sent_s));
            let accepted_s = Some(sent_s);
            NodeGoal {
                id,
                goal: g.goal,
                frontier_m: Some(xy),
                sent_s,
                accepted_s,
                heard_s: None,
                inflation_m: g.inflation_m,
                on_trail: g.on_trail,
            }
        });
        let phase = match (mission.end(), goal) {
            (Some(_), _) => Phase::Done,
            (None, Some(_)) => Phase::Navigating,
            (None, None) => Phase::Planning,
        };
        let e = mission.explorer().stats();
        let stats = NodeStats {
            goals_sent: self.goal.map_or(0, |(id, _, _)| id),
            succeeded: e.goals_reached,
            failed: e.goals_failed,
            maps: self.maps,
            ..NodeStats::default()
        };
        NodeStatus {
            goal,
            robot: Some(mission.estimate()),
            done_reason: mission.end().map(|r| r.as_str().into()),
            source: Some("fitslam explore".into()),
            ..NodeStatus::of_explorer(t_s, phase, mission.explorer(), stats)
        }
    }

    /// The bag's bytes.
    pub fn finish(self) -> Vec<u8> {
        self.w.finish()
    }
}

impl Default for MissionRecorder {
    fn default() -> Self {
        Self::new()
    }
}
