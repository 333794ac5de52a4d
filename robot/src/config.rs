//! Node configuration: topic names, frames, timing, and the planner's [`Params`] — exactly the
//! core's struct, which the studio exports — in one YAML file with two sections:
//!
//! ```yaml
//! node:            # NodeConfig: every key optional, LeoRover defaults below
//!   map_topic: /map
//!   replan_period_s: 1.0
//! fitslam:         # fitslam_core::Params: every key optional, the paper's defaults
//!   u1: { alpha: 0.35 }
//! ```
//!
//! A plain parameter file (the studio's export, TOML or YAML) can be given instead of, or on
//! top of, the `fitslam:` section with `--params` (see `main.rs`). Unknown keys are errors in
//! both sections.

use fitslam_core::Params;
use fitslam_core::explore::{EXPLORE_KEYS, ExploreParams};
use fitslam_core::params::{InvalidParam, Validate, check_positive};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Where the traversability map comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MapSource {
    /// A thresholded `nav_msgs/OccupancyGrid` on `map_topic` (0 free, 100 lethal, −1 unknown).
    Occupancy,
    /// Registered LiDAR clouds (`sensor_msgs/PointCloud2` on `cloud_topic`), fused into a
    /// traversability map by the core (notes §2) over the fixed extent `cloud_map`.
    Clouds,
}

/// Where the robot's pose comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseSource {
    /// `/tf` + `/tf_static`: map_frame ← base_frame (REP-105: map → odom → base_link).
    Tf,
    /// `geometry_msgs/PoseWithCovarianceStamped` on `pose_topic`.
    Topic,
}

/// How goals reach the navigation stack.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GoalInterface {
    /// Nav2's `nav2_msgs/action/NavigateToPose` on `action_name`: accepted, aborted, rejected
    /// and succeeded are reported back.
    Action,
    /// `geometry_msgs/PoseStamped` on `goal_topic` (RViz's "2D Goal Pose" topic, which Nav2's
    /// bt_navigator also follows): a goal is reached when the pose is within
    /// `goal_tolerance_m`, failed after `goal_timeout_s`.
    Topic,
}

/// Request/reply header layout of ROS 2 services and actions on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ServiceMappingChoice {
    /// rmw_fastrtps / rmw_connextdds (Jazzy's default RMW).
    Enhanced,
    /// rmw_cyclonedds.
    Cyclone,
    /// Basic DDS-RPC.
    Basic,
}

/// Extent of the traversability map built from clouds (map frame).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CloudMapConfig {
    /// Lower-left corner, metres. Default (−25, −25).
    pub origin_x_m: f64,
    pub origin_y_m: f64,
    /// Size, metres. Default 50 × 50 (1000 × 1000 cells at 5 cm).
    pub size_x_m: f64,
    pub size_y_m: f64,
}

impl Default for CloudMapConfig {
    fn default() -> Self {
        Self { origin_x_m: -25.0, origin_y_m: -25.0, size_x_m: 50.0, size_y_m: 50.0 }
    }
}

/// Everything about the node that is not a planner parameter. Defaults are the LeoRover's
/// (leo_robot: base frame `base_link`; RTAB-Map publishes `/map` and `/cloud_map` in `map`;
/// Nav2 Jazzy serves `/navigate_to_pose`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NodeConfig {
    /// ROS node name. Default `fitslam_explorer`.
    pub name: String,
    /// ROS namespace. Default `/`.
    pub namespace: String,
    /// Global frame of the map and of the goals (REP-105). Default `map`.
    pub map_frame: String,
    /// Robot body frame (REP-105). Default `base_link`.
    pub base_frame: String,

    /// Default `occupancy`.
    pub map_source: MapSource,
    /// `nav_msgs/OccupancyGrid` topic. Default `/map`.
    pub map_topic: String,
    /// Subscribe to the map with TRANSIENT_LOCAL durability (receives the latched map of
    /// map_server / RTAB-Map; a VOLATILE publisher is then incompatible). Default true.
    pub map_transient_local: bool,
    /// `sensor_msgs/PointCloud2` LiDAR topic when `map_source: clouds`. Default `/points`.
    pub cloud_topic: String,
    /// Extent of the cloud-built map.
    pub cloud_map: CloudMapConfig,
    /// Landmark map (`sensor_msgs/PointCloud2` of map points, e.g. RTAB-Map's `/cloud_map`,
    /// ORB-SLAM3's map points). Empty string: no landmarks (u2 then has no information).
    /// Default `/cloud_map`.
    pub landmarks_topic: String,

    /// Default `tf`.
    pub pose_source: PoseSource,
    /// `geometry_msgs/PoseWithCovarianceStamped` when `pose_source: topic`. Default
    /// `/localization_pose` (RTAB-Map).
    pub pose_topic: String,
    /// A pose older than this is stale: no new decision until it updates, seconds. Default 2.
    pub pose_timeout_s: f64,

    /// Optional exploration boundary, `geometry_msgs/PolygonStamped`; empty string: none.
    /// Default `/fitslam/boundary`.
    pub boundary_topic: String,

    /// Default `action`.
    pub goal_interface: GoalInterface,
    /// NavigateToPose action. Default `/navigate_to_pose`.
    pub action_name: String,
    /// Default `enhanced`.
    pub service_mapping: ServiceMappingChoice,
    /// PoseStamped goal topic (`goal_interface: topic`). Default `/goal_pose`.
    pub goal_topic: String,
    /// `visualization_msgs/MarkerArray` for RViz. Default `/fitslam/markers`.
    pub marker_topic: String,
    /// `std_msgs/String` with one JSON object per update. Default `/fitslam/status`.
    pub status_topic: String,
    /// `std_msgs/String` commands to the node: `pause` (the running goal is cancelled, no goal is
    /// sent), `resume`, `stop` (the mission ends). Empty: not subscribed. Default
    /// `/fitslam/control`.
    pub control_topic: String,
    /// Rank and publish (markers, status with `suggested_goal`) but send no goal: another
    /// component drives the robot. Default false.
    pub publish_only: bool,
    /// At the end of the mission, send one last goal to where the robot started (its first pose
    /// in the map frame); the mission ends when that goal does. Default false.
    pub return_to_start: bool,

    /// Period of the decisions, seconds. Default 1.
    pub replan_period_s: f64,
    /// A goal not reached within this is cancelled and blacklisted, seconds. Default 120.
    pub goal_timeout_s: f64,
    /// No accept/reject from the action server within this: the goal is dropped (not
    /// blacklisted: the server may just not be up yet) and sent again, seconds. Default 5.
    pub goal_response_timeout_s: f64,
    /// An accepted action goal with no feedback for this long is dropped (not blacklisted) and
    /// planned again: the server was restarted or is gone, and its result will never come.
    /// Nav2's bt_navigator sends feedback on every behaviour-tree tick (10 ms by default); 0
    /// turns the check off, for servers that send none. Seconds. Default 10.
    pub goal_feedback_timeout_s: f64,
    /// Topic goals: reached within this distance, metres. Default 0.3.
    pub goal_tolerance_m: f64,
    /// Decisions in a row whose answer is "done" (no frontier left; trapped with the recoveries
    /// spent; stuck) before the mission ends: maps arrive asynchronously, so one decision on a
    /// map that has not caught up must not end it. Default 2.
    pub done_after_empty_decisions: u32,
    /// The exploration policy, as the simulator's (`fitslam_core::explore::ExploreParams`): the
    /// set-back from unknown ground (by the pose topic's position σ; tf carries no covariance, so
    /// no set-back), footprint clearing, the trail, the tight inflations, the trap check and its
    /// recoveries (a trapped node forgets its cloud map, `map_source: clouds`; an occupancy map
    /// comes from elsewhere and is not cleared here: the node waits for it to change).
    pub explore: ExploreParams,
    /// Stop after this long even if frontiers remain, seconds; none by default.
    pub max_mission_s: Option<f64>,
    /// How often the inputs are polled, seconds. Default 0.02.
    pub poll_period_s: f64,

    /// DDS domain. Default: `ROS_DOMAIN_ID`, else 0 (ros2-client itself ignores the variable).
    pub domain_id: Option<u16>,
    /// Talk on 127.0.0.1 only. Default: `ROS_LOCALHOST_ONLY=1`, else false.
    pub localhost_only: Option<bool>,
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self {
            name: "fitslam_explorer".into(),
            namespace: "/".into(),
            map_frame: "map".into(),
            base_frame: "base_link".into(),
            map_source: MapSource::Occupancy,
            map_topic: "/map".into(),
            map_transient_local: true,
            cloud_topic: "/points".into(),
            cloud_map: CloudMapConfig::default(),
            landmarks_topic: "/cloud_map".into(),
            pose_source: PoseSource::Tf,
            pose_topic: "/localization_pose".into(),
            pose_timeout_s: 2.0,
            boundary_topic: "/fitslam/boundary".into(),
            goal_interface: GoalInterface::Action,
            action_name: "/navigate_to_pose".into(),
            service_mapping: ServiceMappingChoice::Enhanced,
            goal_topic: "/goal_pose".into(),
            marker_topic: "/fitslam/markers".into(),
            status_topic: "/fitslam/status".into(),
            control_topic: "/fitslam/control".into(),
            publish_only: false,
            return_to_start: false,
            replan_period_s: 1.0,
            goal_timeout_s: 120.0,
            goal_response_timeout_s: 5.0,
            goal_feedback_timeout_s: 10.0,
            goal_tolerance_m: 0.3,
            done_after_empty_decisions: 2,
            explore: ExploreParams::default(),
            max_mission_s: None,
            poll_period_s: 0.02,
            domain_id: None,
            localhost_only: None,
        }
    }
}

/// The whole configuration file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConfigFile {
    pub node: NodeConfig,
    pub fitslam: Params,
}

/// A configuration that could not be read.
#[derive(Debug, Error, PartialEq)]
pub enum ConfigError {
    #[error("{source_name}: invalid YAML: {message}")]
    Yaml { source_name: String, message: String },
    #[error("{source_name}: {error}")]
    Invalid { source_name: String, error: InvalidParam },
    #[error("{source_name}: `{key}` has moved: write it as `{moved_to}`")]
    Moved { source_name: String, key: String, moved_to: String },
}

impl ConfigFile {
    /// Parses and validates YAML text; `source_name` is quoted in errors. An empty file is
    /// all defaults.
    pub fn from_yaml(text: &str, source_name: &str) -> Result<Self, ConfigError> {
        let text = fitslam_core::io::without_bom_str(text);
        let cfg: ConfigFile = if text.trim().is_empty() {
            ConfigFile::default()
        } else {
            if let Ok(value) = serde_yaml::from_str::<serde_yaml::Value>(text)
                && let Some(node) = value.get("node")
                && let Some(key) = EXPLORE_KEYS.iter().find(|k| node.get(**k).is_some())
            {
                let moved_to = format!("node.explore.{key}");
                return Err(ConfigError::Moved { source_name: source_name.into(), key: format!("node.{key}"), moved_to });
            }
            serde_yaml::from_str(text)
                .map_err(|e| ConfigError::Yaml { source_name: source_name.into(), message: e.to_string().replace('\n', " ") })?
        };
        cfg.validate().map_err(|error| ConfigError::Invalid { source_name: source_name.into(), error })?;
        Ok(cfg)
    }

    /// YAML text of this configuration (`--print-config`).
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).unwrap_or_default()
    }
}

impl Validate for ConfigFile {
    /// Checks both sections; the error names the first bad field.
    fn validate(&self) -> Result<(), InvalidParam> {
        self.node.validate()?;
        self.fitslam.validate().map_err(|e| e.under("fitslam."))?;
        if self.fitslam.selector.strategy.reads_true_landmarks() {
            let reason = format!("`{}` reads the simulated world's true landmarks: a robot has none", self.fitslam.selector.strategy);
            return Err(InvalidParam::new("fitslam.selector.strategy", reason));
        }
        Ok(())
    }
}

impl Validate for NodeConfig {
    /// Checks ranges and names; keys are named from the file's top (`node.replan_period_s`).
    fn validate(&self) -> Result<(), InvalidParam> {
        let pos = |name: &str, v: f64| check_positive(&format!("node.{name}"), v);
        let bad = |name: &str, reason: String| Err(InvalidParam::new(format!("node.{name}"), reason));
        pos("replan_period_s", self.replan_period_s)?;
        pos("goal_timeout_s", self.goal_timeout_s)?;
        pos("goal_response_timeout_s", self.goal_response_timeout_s)?;
        pos("goal_tolerance_m", self.goal_tolerance_m)?;
        if !(self.goal_feedback_timeout_s >= 0.0 && self.goal_feedback_timeout_s.is_finite()) {
            return bad("goal_feedback_timeout_s", format!("must be ≥ 0 (0: off), got {}", self.goal_feedback_timeout_s));
        }
        self.explore.validate().map_err(|e| e.under("node.explore."))?;
        pos("pose_timeout_s", self.pose_timeout_s)?;
        pos("poll_period_s", self.poll_period_s)?;
        if let Some(m) = self.max_mission_s {
            pos("max_mission_s", m)?;
        }
        if self.done_after_empty_decisions == 0 {
            return bad("done_after_empty_decisions", "must be ≥ 1".into());
        }
        pos("cloud_map.size_x_m", self.cloud_map.size_x_m)?;
        pos("cloud_map.size_y_m", self.cloud_map.size_y_m)?;
        let c = &self.cloud_map;
        if !(c.origin_x_m.is_finite() && c.origin_y_m.is_finite()) {
            return bad("cloud_map", format!("origin must be finite (got {}, {})", c.origin_x_m, c.origin_y_m));
        }
        for (name, v) in [("map_frame", &self.map_frame), ("base_frame", &self.base_frame), ("name", &self.name)] {
            if v.trim_start_matches('/').is_empty() {
                return bad(name, "must not be empty".into());
            }
        }
        if let Some(d) = self.domain_id
            && d > 232
        {
            return bad("domain_id", format!("must be ≤ 232 (got {d})"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_file_is_all_defaults() {
        let c = ConfigFile::from_yaml("", "x.yaml").unwrap();
        assert_eq!(c, ConfigFile::default());
        assert_eq!(c.node.map_topic, "/map");
        assert_eq!(c.fitslam, Params::default());
    }

    #[test]
    fn both_sections_are_read() {
        let c = ConfigFile::from_yaml(
            "node:\n  map_topic: /rtabmap/map\n  goal_interface: topic\n  replan_period_s: 0.5\nfitslam:\n  u1:\n    alpha: 0.5\n",
            "x.yaml",
        )
        .unwrap();
        assert_eq!(c.node.map_topic, "/rtabmap/map");
        assert_eq!(c.node.goal_interface, GoalInterface::Topic);
        assert_eq!(c.node.replan_period_s, 0.5);
        assert_eq!(c.fitslam.u1.alpha, 0.5);
        assert_eq!(c.fitslam.u2.beta, 0.4);
        // Round trip.
        assert_eq!(ConfigFile::from_yaml(&c.to_yaml(), "y.yaml").unwrap(), c);
        // A file an editor saved with a byte-order mark.
        assert_eq!(ConfigFile::from_yaml(&format!("\u{feff}{}", c.to_yaml()), "z.yaml").unwrap(), c);
    }

    #[test]
    fn typos_and_bad_values_are_rejected_with_the_field_name() {
        let e = ConfigFile::from_yaml("node:\n  map_topik: /map\n", "x.yaml").unwrap_err();
        assert!(matches!(&e, ConfigError::Yaml { message, .. } if message.contains("map_topik")), "{e}");
        let e = ConfigFile::from_yaml("node:\n  replan_period_s: 0\n", "x.yaml").unwrap_err();
        assert!(e.to_string().contains("node.replan_period_s"), "{e}");
        let e = ConfigFile::from_yaml("fitslam:\n  u1:\n    alpha: 2\n", "x.yaml").unwrap_err();
        assert!(e.to_string().contains("fitslam.u1.alpha"), "{e}");
        let e = ConfigFile::from_yaml("node:\n  domain_id: 300\n", "x.yaml").unwrap_err();
        assert!(e.to_string().contains("domain_id"), "{e}");
    }

    #[test]
    fn the_simulator_only_control_is_refused() {
        let e = ConfigFile::from_yaml("fitslam:\n  selector:\n    strategy: u2_truth\n", "leo.yaml").unwrap_err();
        let text = e.to_string();
        assert!(text.starts_with("leo.yaml: fitslam.selector.strategy") && text.contains("true landmarks"), "{text}");
        assert!(ConfigFile::from_yaml("fitslam:\n  selector:\n    strategy: u2_length\n", "leo.yaml").is_ok());
    }

    #[test]
    fn a_moved_key_is_named_with_where_it_went() {
        let e = ConfigFile::from_yaml("node:\n  reuse_trail: false\n", "x.yaml").unwrap_err();
        assert_eq!(e.to_string(), "x.yaml: `node.reuse_trail` has moved: write it as `node.explore.reuse_trail`");
        let c = ConfigFile::from_yaml("node:\n  explore:\n    reuse_trail: false\n    tight_inflations_m: [0.2, 0.1]\n", "x.yaml").unwrap();
        assert!(!c.node.explore.reuse_trail);
        assert_eq!(c.node.explore.tight_inflations_m, vec![0.2, 0.1]);
        let e = ConfigFile::from_yaml("node:\n  explore:\n    tight_inflations_m: [0.1, 0.2]\n", "x.yaml").unwrap_err();
        assert!(e.to_string().contains("node.explore.tight_inflations_m[1]"), "{e}");
    }
}
