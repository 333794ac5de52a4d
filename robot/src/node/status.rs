//! What the node shows: its status (the `/fitslam/status` JSON, [`NodeStatus`]), its counters,
//! and read access to its state for the adapter, the markers and the rerun log.

use super::ExplorerNode;
use crate::config::NodeConfig;
use fitslam_core::frontier::Blacklist;
use fitslam_core::ros::{NodeGoal, NodeStats, NodeStatus, Phase};
use fitslam_core::select::Decision;
use fitslam_core::utility::LandmarkVoxels;
use fitslam_core::{OccupancyGrid, Params, Pose2};

impl ExplorerNode {
    /// The status now.
    pub fn status(&self, now_s: f64) -> NodeStatus {
        NodeStatus {
            goal: self.goal,
            robot: self.robot_pose(now_s).ok(),
            landmark_voxels: self.landmarks.len(),
            map_cells: self.map.as_ref().map(|m| [m.grid.geometry.width, m.grid.geometry.height]),
            done_reason: self.done_reason.clone(),
            last_warning: self.last_warning.clone(),
            warnings: self.warning_counts.iter().map(|(&k, &n)| (k.to_owned(), n)).collect(),
            suggested_goal: self.suggested_goal,
            ..NodeStatus::of_explorer(now_s, self.phase, &self.explorer, self.stats)
        }
    }

    /// The last decision (whole ranking).
    pub fn last_decision(&self) -> Option<&Decision> {
        self.explorer.last_decision()
    }

    /// Number of decisions made so far (the adapter publishes markers when it changes).
    pub fn decisions(&self) -> u64 {
        self.explorer.stats().decisions
    }

    /// The counters, the explorer's among them.
    pub fn stats(&self) -> NodeStats {
        self.stats.with_explorer(self.explorer.stats())
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }

    pub fn current_goal(&self) -> Option<NodeGoal> {
        self.goal
    }

    /// The goal to draw: the one sent, or with `publish_only` the one the last decision would
    /// have sent.
    pub fn shown_goal(&self) -> Option<Pose2> {
        self.goal.map(|g| g.goal).or(self.suggested_goal)
    }

    pub fn blacklist(&self) -> &Blacklist {
        self.explorer.blacklist()
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
        self.explorer.planner()
    }
}
