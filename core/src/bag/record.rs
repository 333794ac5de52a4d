//! A simulated mission recorded as a rosbag2 MCAP bag with the fitslam node's topics, so that a
//! simulated mission and a real one replay the same way: `/tf` (map → odom identity, odom →
//! base_link the estimated pose) every [`TF_PERIOD_S`]; at each decision `/map` (the robot's
//! thresholded map after that step), `/cloud_map` (the landmark map, map frame) and
//! `/fitslam/status` (the node's JSON: `t_s`, `phase`, `goal` with `id`, `goal`, `frontier_m`,
//! `robot`), the status 1 µs after the map it was decided on.

use super::McapWriter;
use super::msgs::{self, Header, OccupancyGridMsg, PointCloud2, RigidPose, TransformStamped};
use super::schemas;
use crate::sim::Mission;

/// Period of the tf messages, simulated seconds.
pub const TF_PERIOD_S: f64 = 0.1;

/// Records a mission step by step.
pub struct MissionRecorder {
    w: McapWriter,
    ch: [u16; 4],
    last_tf_s: f64,
    decisions: u64,
    goal: Option<(u64, [f64; 2])>,
}

impl MissionRecorder {
    pub fn new() -> Self {
        let mut w = McapWriter::new("fitslam explore");
        let ch = [
            w.channel("/tf", schemas::TF_MESSAGE),
            w.channel("/map", schemas::OCCUPANCY_GRID),
            w.channel("/cloud_map", schemas::POINT_CLOUD2),
            w.channel("/fitslam/status", schemas::STRING),
        ];
        Self { w, ch, last_tf_s: f64::NEG_INFINITY, decisions: 0, goal: None }
    }

    /// Records what changed since the last call (call after each `Mission::step`).
    pub fn record(&mut self, mission: &mut Mission) {
        let t_s = mission.time_s();
        let t_ns = (t_s.max(0.0) * 1e9) as u64;
        let decisions = mission.explorer().stats().decisions;
        if t_s - self.last_tf_s >= TF_PERIOD_S - 1e-9 || decisions != self.decisions {
            self.last_tf_s = t_s;
            let e = mission.estimate();
            let h = |f: &str| Header { stamp_s: t_s, frame_id: f.into() };
            let tfs = [
                TransformStamped { header: h("map"), child_frame_id: "odom".into(), transform: RigidPose::default() },
                TransformStamped {
                    header: h("odom"),
                    child_frame_id: "base_link".into(),
                    transform: RigidPose::planar(e.x_m, e.y_m, e.yaw_rad),
                },
            ];
            self.w.message(self.ch[0], t_ns, &msgs::encode_tf_message(&tfs));
        }
        if decisions == self.decisions {
            return;
        }
        self.decisions = decisions;
        let header = Header { stamp_s: t_s, frame_id: "map".into() };
        let grid = mission.occupancy();
        self.w.message(self.ch[1], t_ns, &msgs::encode_occupancy_grid(&OccupancyGridMsg::from_grid(&grid, header.clone())));
        let landmarks = mission.landmark_map();
        self.w.message(self.ch[2], t_ns, &msgs::encode_point_cloud2(&PointCloud2::from_points(&landmarks.points, header)));
        let goal = mission.goal().map(|g| {
            let xy = [g.goal.x_m, g.goal.y_m];
            let id = match self.goal {
                Some((id, last)) if last == xy => id,
                Some((id, _)) => id + 1,
                None => 1,
            };
            self.goal = Some((id, xy));
            serde_json::json!({ "id": id, "goal": g.goal, "frontier_m": xy, "inflation_m": g.inflation_m })
        });
        let phase = if mission.end().is_some() {
            "done"
        } else if goal.is_some() {
            "navigating"
        } else {
            "planning"
        };
        let status =
            serde_json::json!({ "t_s": t_s, "phase": phase, "goal": goal, "robot": mission.estimate(), "source": "fitslam explore" });
        self.w.message(self.ch[3], t_ns + 1000, &msgs::encode_string(&status.to_string()));
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
