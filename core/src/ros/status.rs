//! The fitslam node's status, typed once: the JSON object it publishes on `/fitslam/status` (a
//! `std_msgs/String`, one per second and per change), which the simulator's mission recorder
//! writes into bags too and the bag replay reads back (the robot's own choice at an instant).
//!
//! Reading is tolerant: every field has a default, unknown keys are ignored and a phase this
//! version does not know reads as [`Phase::Unknown`], so statuses of older nodes (fewer fields)
//! and newer ones still read.

use crate::Pose2;
use crate::explore::{ExploreStats, Explorer};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Where the node stands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// No map received yet.
    WaitingForMap,
    /// A map, but no pose of the robot in it yet.
    WaitingForPose,
    /// The robot's pose is older than `node.pose_timeout_s`: no decision until a fresh one.
    PoseStale,
    /// Deciding, or waiting for a decision that finds a goal.
    Planning,
    /// A goal was sent and is being driven to.
    Navigating,
    /// Paused by a `pause` command: no goal runs, none is sent.
    Paused,
    /// The mission is over and the robot drives back to its start (`return_to_start`).
    Returning,
    /// The mission ended (`done_reason` says why).
    Done,
    /// Read only: a phase this version does not know (a newer node's), or none recorded.
    #[default]
    #[serde(other)]
    Unknown,
}

impl Phase {
    /// Its name in the status JSON: `waiting_for_map`, …, `done`, `unknown`.
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::WaitingForMap => "waiting_for_map",
            Phase::WaitingForPose => "waiting_for_pose",
            Phase::PoseStale => "pose_stale",
            Phase::Planning => "planning",
            Phase::Navigating => "navigating",
            Phase::Paused => "paused",
            Phase::Returning => "returning",
            Phase::Done => "done",
            Phase::Unknown => "unknown",
        }
    }
}

/// The goal the node sent to the navigation stack.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeGoal {
    /// The node's number for it, from 1 (0: none recorded).
    #[serde(default)]
    pub id: u64,
    /// The pose sent: on the frontier candidate's path, set back from unknown ground
    /// (`explore.goal_setback`).
    pub goal: Pose2,
    /// The frontier candidate it serves (what is kept, replaced and blacklisted); `None` only
    /// in statuses of nodes that did not record it.
    #[serde(default)]
    pub frontier_m: Option<[f64; 2]>,
    /// When it was sent, the node's clock, seconds.
    #[serde(default)]
    pub sent_s: f64,
    /// When the server accepted it (topic goals: when sent).
    #[serde(default)]
    pub accepted_s: Option<f64>,
    /// When the action server last sent feedback on it (or accepted it); `None` for topic goals.
    #[serde(default)]
    pub heard_s: Option<f64>,
    /// The inflation radius it was planned with, metres: the robot radius or one of
    /// `explore.tight_inflations_m`; it must stay free at that inflation.
    #[serde(default)]
    pub inflation_m: f64,
    /// Planned with the robot's trail open: a trail cell free in the map counts as free.
    #[serde(default)]
    pub on_trail: bool,
}

/// The node's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NodeStats {
    /// Selector runs (every retry counts).
    pub decisions: u64,
    /// Decisions that found no plan even after footprint clearing.
    pub decision_errors: u64,
    /// Goals sent to the navigation stack.
    pub goals_sent: u64,
    /// Goals the navigation stack reached.
    pub succeeded: u64,
    /// Goals it aborted (blacklisted).
    pub failed: u64,
    /// Goals its server rejected (blacklisted).
    pub rejected: u64,
    /// Goals not reached in `node.goal_timeout_s` (blacklisted).
    pub timed_out: u64,
    /// Goals given up without blame: no answer from the server, or their cell no longer free.
    pub lost: u64,
    /// Goals replaced by a new decision before they ended.
    pub replaced: u64,
    /// Maps received (occupancy grids, or clouds mapped by the node).
    pub maps: u64,
    /// Messages dropped as invalid (the warnings say why).
    pub messages_rejected: u64,
    /// Messages dropped as older than the ones already used.
    pub messages_late: u64,
    /// Cloud maps forgotten around a trapped robot (`explore.trap_recoveries`).
    pub trap_recoveries: u64,
    /// Decisions made again with the footprint cleared (`explore.clear_footprint`).
    pub footprint_clearings: u64,
    /// Goals planned with a tight inflation (`explore.tight_inflations_m`).
    pub tight_goals: u64,
    /// Wall time of the last decision, every retry included, milliseconds.
    pub last_decision_ms: f64,
}

impl NodeStats {
    /// These counters with the explorer's own in place: decisions, planning errors, trap
    /// recoveries, footprint clearings (not its wall times).
    pub fn with_explorer(self, e: &ExploreStats) -> Self {
        Self {
            decisions: e.decisions,
            decision_errors: e.planning_errors,
            trap_recoveries: e.trap_recoveries,
            footprint_clearings: e.footprint_clearings,
            ..self
        }
    }
}

/// The status JSON.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NodeStatus {
    /// The node's clock, seconds.
    pub t_s: f64,
    /// Where the node stands.
    pub phase: Phase,
    /// The goal being driven to, if any.
    pub goal: Option<NodeGoal>,
    /// The robot's pose in the map frame, when known and fresh.
    pub robot: Option<Pose2>,
    /// Frontier candidates of the last decision.
    pub candidates: usize,
    /// Of the last decision's candidates, how many were ranked (reachable, not blacklisted).
    pub ranked: usize,
    /// Entries of the blacklist.
    pub blacklisted: usize,
    /// Landmark voxels u2 reads (from the latest landmark cloud).
    pub landmark_voxels: usize,
    /// Width and height of the latest map, cells.
    pub map_cells: Option<[usize; 2]>,
    /// The node's counters.
    pub stats: NodeStats,
    /// Why the mission ended, in words, once it has.
    pub done_reason: Option<String>,
    /// The latest warning's text.
    pub last_warning: Option<String>,
    /// Warnings logged so far, by kind (`goal`, `goal_lost`, `wait`, `qos`, …): none is lost
    /// when several come between two statuses.
    pub warnings: BTreeMap<String, u64>,
    /// With `publish_only`: the goal the last decision would have sent.
    pub suggested_goal: Option<Pose2>,
    /// What wrote the status when not the node (`fitslam explore` records simulated missions).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

impl NodeStatus {
    /// A status at `t_s` in `phase` with what the explorer knows (the last decision's
    /// candidates and ranking, the blacklist) and `stats` with the explorer's counters; the
    /// rest empty.
    pub fn of_explorer(t_s: f64, phase: Phase, explorer: &Explorer, stats: NodeStats) -> Self {
        let d = explorer.last_decision();
        Self {
            t_s,
            phase,
            candidates: d.map_or(0, |d| d.candidates.len()),
            ranked: d.map_or(0, |d| d.ranking().len()),
            blacklisted: explorer.blacklist().len(),
            stats: stats.with_explorer(explorer.stats()),
            ..Self::default()
        }
    }

    /// The robot's choice in this status: the goal sent and the frontier it serves, else (with
    /// `publish_only`) the goal it would have sent.
    pub fn choice(&self) -> Option<(Pose2, Option<[f64; 2]>)> {
        match (&self.goal, self.suggested_goal) {
            (Some(g), _) => Some((g.goal, g.frontier_m)),
            (None, Some(p)) => Some((p, None)),
            (None, None) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_node_json_keeps_its_keys_and_reads_back() {
        let goal = NodeGoal {
            id: 3,
            goal: Pose2::new(1.0, 2.0, 0.5),
            frontier_m: Some([1.5, 2.0]),
            sent_s: 4.0,
            accepted_s: Some(4.1),
            heard_s: None,
            inflation_m: 0.25,
            on_trail: false,
        };
        let s =
            NodeStatus { t_s: 5.0, phase: Phase::Navigating, goal: Some(goal), warnings: [("qos".into(), 1)].into(), ..Default::default() };
        let v = serde_json::to_value(&s).unwrap();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        let mut expected = [
            "t_s",
            "phase",
            "goal",
            "robot",
            "candidates",
            "ranked",
            "blacklisted",
            "landmark_voxels",
            "map_cells",
            "stats",
            "done_reason",
            "last_warning",
            "warnings",
            "suggested_goal",
        ];
        expected.sort();
        assert_eq!(keys, expected, "no `source` key in the node's status");
        assert_eq!(v["phase"], "navigating");
        assert_eq!(v["goal"]["frontier_m"], serde_json::json!([1.5, 2.0]));
        assert_eq!(serde_json::from_value::<NodeStatus>(v).unwrap(), s);
    }

    #[test]
    fn phase_names_are_the_json_names() {
        use Phase::*;
        for p in [WaitingForMap, WaitingForPose, PoseStale, Planning, Navigating, Paused, Returning, Done, Unknown] {
            assert_eq!(serde_json::to_value(p).unwrap(), p.as_str());
            assert_eq!(serde_json::from_value::<Phase>(p.as_str().into()).unwrap(), p);
        }
    }

    #[test]
    fn older_and_newer_statuses_read_with_defaults() {
        // `fitslam explore --bag` before the typed status: goal without sent_s.
        let old = r#"{"t_s":1.5,"phase":"navigating","goal":{"id":2,"goal":{"x_m":1.0,"y_m":2.0,"yaw_rad":0.0},"frontier_m":[1.0,2.0],"inflation_m":0.25},"robot":null,"source":"fitslam explore"}"#;
        let s: NodeStatus = serde_json::from_str(old).unwrap();
        assert_eq!((s.phase, s.goal.map(|g| (g.id, g.sent_s))), (Phase::Navigating, Some((2, 0.0))));
        // A node before frontier_m; a later one with a phase and keys this version lacks.
        let s: NodeStatus = serde_json::from_str(r#"{"goal":{"goal":{"x_m":1.0,"y_m":2.0,"yaw_rad":0.0}}}"#).unwrap();
        assert_eq!(s.choice(), Some((Pose2::new(1.0, 2.0, 0.0), None)));
        assert_eq!(s.phase, Phase::Unknown);
        let s: NodeStatus = serde_json::from_str(r#"{"phase":"docking","battery":0.5}"#).unwrap();
        assert_eq!(s.phase, Phase::Unknown);
        assert!(serde_json::from_str::<NodeStatus>(r#"{"goal":{"id":1}}"#).is_err(), "a goal without its pose");
    }
}
