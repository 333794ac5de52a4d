//! The node's log: lines with their level, drained by the adapter; warnings counted by kind
//! and repeated at most every [`WARN_REPEAT_S`] under the same text; and the longer texts of
//! its warnings, apart from the state machine that decides when to say them.

use super::ExplorerNode;
use crate::config::PoseSource;
use fitslam_core::explore::EndReason;
use fitslam_core::ros::Phase;
use serde::Serialize;

/// Same warning text under the same key is repeated at most this often, seconds.
pub const WARN_REPEAT_S: f64 = 10.0;

/// Log severity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Level {
    Info,
    Warn,
    Error,
}

/// One log line, drained by the adapter with [`ExplorerNode::drain_log`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LogLine {
    pub t_s: f64,
    pub level: Level,
    pub text: String,
}

impl ExplorerNode {
    pub(super) fn info(&mut self, now_s: f64, text: String) {
        self.log.push(LogLine { t_s: now_s, level: Level::Info, text });
    }

    /// A warning, repeated under `key` only when its text changes or every [`WARN_REPEAT_S`].
    pub(super) fn warn(&mut self, key: &'static str, now_s: f64, text: String) {
        if let Some((last, t)) = self.warned.get(key)
            && *last == text
            && now_s - t < WARN_REPEAT_S
        {
            return;
        }
        self.warned.insert(key, (text.clone(), now_s));
        *self.warning_counts.entry(key).or_default() += 1;
        self.last_warning = Some(text.clone());
        self.log.push(LogLine { t_s: now_s, level: Level::Warn, text });
    }

    /// A fault of the transport seen by the ROS adapter (a publisher whose QoS the node cannot
    /// match): a warning like the node's own.
    pub fn transport_warning(&mut self, now_s: f64, text: String) {
        self.warn("qos", now_s, text);
    }

    /// Takes the log lines produced since the last call.
    pub fn drain_log(&mut self) -> Vec<LogLine> {
        std::mem::take(&mut self.log)
    }

    /// Why there is no pose to plan from (`phase` is `WaitingForPose` or `PoseStale`).
    pub(super) fn no_pose_text(&self, phase: Phase, now_s: f64) -> String {
        let (map, base) = (&self.cfg.map_frame, &self.cfg.base_frame);
        match (phase, self.cfg.pose_source) {
            (Phase::PoseStale, PoseSource::Tf) if let Some((parent, child, t)) = self.tf.stalest_link(map, base) => format!(
                "pose stale: tf {parent} → {child} last received {:.1} s ago (limit {} s); not planning",
                now_s - t,
                self.cfg.pose_timeout_s
            ),
            (Phase::PoseStale, _) => format!(
                "pose stale: last update {:.1} s ago (limit {} s); not planning",
                self.pose_age_s(now_s).unwrap_or(f64::NAN),
                self.cfg.pose_timeout_s
            ),
            (_, PoseSource::Tf) => {
                let (root_base, root_map) = (self.tf.root(base), self.tf.root(map));
                if root_base == *base && root_map == *map {
                    format!("waiting for tf {map} ← {base}: no transform of either yet")
                } else {
                    format!("waiting for tf {map} ← {base}: {base}'s tree ends at {root_base}, {map}'s at {root_map}")
                }
            }
            (_, PoseSource::Topic) => format!("waiting for the pose on {}", self.cfg.pose_topic),
        }
    }

    pub(super) fn walled_in(&self) -> String {
        format!(
            "no frontier goal, but every free cell the robot can reach lies within {} m: walled in by its map, not done",
            self.cfg.explore.trapped_radius_m
        )
    }

    pub(super) fn done_text(&self, reason: EndReason) -> String {
        let candidates = self.explorer.last_decision().map_or(0, |d| d.candidates.len());
        match reason {
            EndReason::NoFrontier => format!(
                "no reachable, non-blacklisted frontier left ({candidates} candidates, {} blacklisted goals)",
                self.explorer.blacklist().len()
            ),
            EndReason::Trapped => {
                format!("trapped: walled in by its map after {} recoveries", self.explorer.stats().trap_recoveries)
            }
            EndReason::Stuck => format!("stuck: {} decisions in a row found no plan", self.cfg.explore.max_failed_decisions),
            EndReason::TimeLimit => "time limit reached".into(),
        }
    }
}
