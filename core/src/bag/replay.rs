//! A recorded mission as decision inputs: what the robot had at an instant and what it chose.
//!
//! Time is seconds from the bag's first message (its log time, the recorder's receive time).
//! At an instant T a [`Snapshot`] holds, from the messages recorded up to T:
//! - the latest map (`nav_msgs/OccupancyGrid` on `map_topic`);
//! - the latest landmark cloud (`sensor_msgs/PointCloud2` on `landmarks_topic`), moved into the
//!   map frame through tf when recorded in another frame;
//! - the robot's pose: `map_frame ← base_frame` through the tf tree (`/tf` and `/tf_static`,
//!   REP-105's map → odom → base_link composed, the latest transform of every edge), else the
//!   latest `geometry_msgs/PoseWithCovarianceStamped` on `pose_topic`;
//! - the robot's own choice: the goal of the node's latest status (`std_msgs/String` JSON on
//!   `status_topic`), when recorded.
//!
//! Decision instants are the status messages that show a new goal (or, in publish-only mode, a
//! new suggested goal); a bag without status has one at each map update.
//!
//! Cost: a snapshot decodes one map, one cloud and the tf messages up to T: O(messages + cells).

use super::BagError;
use super::mcap::{Channel, Mcap, Message};
use crate::cloud::PointCloud;
use crate::grid::OccupancyGrid;
use crate::pose::Pose2;
use crate::ros::{self, NodeStatus, Phase};
use fitslam_msgs::{OccupancyGrid as MapMsg, PointCloud2, PoseWithCovarianceStamped, RosMessage, StringMsg, TFMessage, cdr};
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// The latest transform of every tf edge: child → (parent, parent_from_child, log time; `None`
/// for a static edge).
type TfEdges = HashMap<String, (String, Isometry3<f64>, Option<u64>)>;

/// Deepest tf tree walked (guards against cycles).
const MAX_TF_DEPTH: usize = 64;

/// Where a replay finds its inputs: the fitslam node's configuration defaults
/// (`robot/src/config.rs`, `NodeConfig`), each overridable.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BagTopics {
    /// `nav_msgs/OccupancyGrid`. Default `/map`.
    pub map_topic: String,
    /// `sensor_msgs/PointCloud2` landmark map; empty: none. Default `/cloud_map`.
    pub landmarks_topic: String,
    /// `geometry_msgs/PoseWithCovarianceStamped`, used when tf gives no pose. Default
    /// `/localization_pose`.
    pub pose_topic: String,
    /// The node's `std_msgs/String` status JSON. Default `/fitslam/status`.
    pub status_topic: String,
    /// Default `/tf`.
    pub tf_topic: String,
    /// Default `/tf_static`.
    pub tf_static_topic: String,
    /// Global frame (REP-105). Default `map`.
    pub map_frame: String,
    /// Robot body frame. Default `base_link`.
    pub base_frame: String,
    /// Where the pose comes from; `None`: tf when it links the two frames, else the pose topic.
    pub pose_source: Option<PoseSource>,
}

impl Default for BagTopics {
    fn default() -> Self {
        Self {
            map_topic: "/map".into(),
            landmarks_topic: "/cloud_map".into(),
            pose_topic: "/localization_pose".into(),
            status_topic: "/fitslam/status".into(),
            tf_topic: "/tf".into(),
            tf_static_topic: "/tf_static".into(),
            map_frame: "map".into(),
            base_frame: "base_link".into(),
            pose_source: None,
        }
    }
}

/// Where a snapshot's pose came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum PoseSource {
    /// The tf tree, `map_frame ← base_frame`.
    Tf,
    /// The pose topic.
    Topic,
}

/// One topic of a bag.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TopicInfo {
    /// The topic name.
    pub topic: String,
    /// Its message type as recorded (`nav_msgs/msg/OccupancyGrid`).
    pub msg_type: String,
    /// Messages recorded on it.
    pub count: usize,
    /// First and last message, seconds from the bag's start.
    pub first_s: f64,
    /// Last message, seconds from the bag's start.
    pub last_s: f64,
}

/// What marks a decision instant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InstantSource {
    /// A status message showing a goal the one before did not.
    NewGoal,
    /// A map update (bags without status).
    MapUpdate,
}

/// A moment the robot decided (or could have).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DecisionInstant {
    /// Seconds from the bag's start.
    pub t_s: f64,
    /// What marked it.
    pub source: InstantSource,
    /// The frontier (else the goal) the robot chose then, map frame.
    pub goal: Option<Pose2>,
}

/// The robot's choice, from its status.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RobotChoice {
    /// When the status was recorded, seconds from the bag's start.
    pub t_s: f64,
    /// The goal sent (set back from unknown ground by the node).
    pub goal: Pose2,
    /// The frontier candidate it serves, when the status names it.
    pub frontier_m: Option<[f64; 2]>,
    /// The node's phase then (`navigating`, `planning`…; `None` when not recorded).
    pub phase: Option<Phase>,
}

/// The decision inputs at an instant.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// The instant, seconds from the bag's start.
    pub t_s: f64,
    /// The latest map recorded at or before the instant (map frame).
    pub map: OccupancyGrid,
    /// When that map was recorded, seconds from the bag's start.
    pub map_t_s: f64,
    /// Landmarks in the map frame (empty when none was recorded before T).
    pub landmarks: PointCloud,
    /// When the landmarks were recorded, seconds from the bag's start (`None`: none were).
    pub landmarks_t_s: Option<f64>,
    /// The robot's pose at the instant, map frame (through tf, or from the pose topic).
    pub robot: Pose2,
    /// Where the pose came from.
    pub pose_source: PoseSource,
    /// When the newest message the pose rests on was recorded, seconds from the bag's start.
    pub pose_t_s: f64,
    /// What the robot had chosen by then: its latest status with a goal (`None`: no status named one).
    pub robot_choice: Option<RobotChoice>,
}

/// A parsed bag: its topics, its decision instants, and the decision inputs at any instant
/// (what `fitslam select --bag` and the studio's recording view read).
///
/// ```
/// use fitslam_core::bag::{Bag, BagTopics, McapWriter};
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::ros::{msg_of_occupancy, transform_of_pose2};
/// use fitslam_msgs::{Header, OccupancyGrid, TFMessage, Time, TransformStamped, cdr};
///
/// // A one-second recording: the map at 1 s, the robot's pose through tf at 1 s and 2 s.
/// let world = corridor_two_frontiers(true);
/// let mut w = McapWriter::new("doc example");
/// let (map, tf) = (w.channel::<OccupancyGrid>("/map"), w.channel::<TFMessage>("/tf"));
/// let header = |t_s: f64| Header::new(Time::from_secs_f64(t_s), "map");
/// w.message(map, 1_000_000_000, &cdr::to_vec(&msg_of_occupancy(&world.grid, header(1.0)))?);
/// for (t_s, x_m) in [(1.0, world.robot.x_m), (2.0, world.robot.x_m + 0.5)] {
///     let pose = fitslam_core::Pose2 { x_m, ..world.robot };
///     let link = TransformStamped { header: header(t_s), child_frame_id: "base_link".into(), transform: transform_of_pose2(pose) };
///     w.message(tf, (t_s * 1e9) as u64, &cdr::to_vec(&TFMessage { transforms: vec![link] })?);
/// }
/// let bag = Bag::parse(&w.finish(), "doc.mcap")?;
/// assert_eq!(bag.duration_s(), 1.0);
/// let at_end = bag.snapshot(&BagTopics::default(), 1.0)?;
/// assert_eq!(at_end.map, world.grid);
/// assert!((at_end.robot.x_m - (world.robot.x_m + 0.5)).abs() < 1e-9); // the latest pose
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct Bag {
    name: String,
    mcap: Mcap,
    start_ns: u64,
    end_ns: u64,
}

/// Whether a topic's recorded type is `M`: its rosbag2 name or the short one (`pkg/Type`).
fn type_matches<M: RosMessage>(found: &str) -> bool {
    found.split_once('/').is_some_and(|(pkg, rest)| pkg == M::PACKAGE && (rest == M::NAME || rest.strip_prefix("msg/") == Some(M::NAME)))
}

fn frame(f: &str) -> &str {
    f.trim_start_matches('/')
}

impl Bag {
    /// Reads an MCAP bag.
    pub fn parse(bytes: &[u8], name: &str) -> Result<Self, BagError> {
        let mcap = Mcap::parse(bytes, name)?;
        let (Some(first), Some(last)) = (mcap.messages.first(), mcap.messages.last()) else {
            return Err(BagError::Missing { name: name.into(), detail: "the bag holds no messages".into() });
        };
        let (start_ns, end_ns) = (first.log_time_ns, last.log_time_ns);
        Ok(Self { name: name.into(), mcap, start_ns, end_ns })
    }

    /// The name it was parsed with.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The container: schemas, channels, every message.
    pub fn mcap(&self) -> &Mcap {
        &self.mcap
    }

    /// From the first message to the last, seconds.
    pub fn duration_s(&self) -> f64 {
        (self.end_ns - self.start_ns) as f64 * 1e-9
    }

    /// Seconds from the bag's start of a log time.
    pub fn time_s(&self, log_time_ns: u64) -> f64 {
        log_time_ns.saturating_sub(self.start_ns) as f64 * 1e-9
    }

    /// Every topic, sorted by name.
    pub fn topics(&self) -> Vec<TopicInfo> {
        let mut out: Vec<TopicInfo> = Vec::new();
        for m in &self.mcap.messages {
            let Some(c) = self.mcap.channel(m.channel_id) else { continue };
            let t = self.time_s(m.log_time_ns);
            match out.iter_mut().find(|i| i.topic == c.topic) {
                Some(i) => {
                    i.count += 1;
                    i.last_s = t;
                }
                None => {
                    out.push(TopicInfo { topic: c.topic.clone(), msg_type: self.mcap.type_of(c).into(), count: 1, first_s: t, last_s: t })
                }
            }
        }
        out.sort_by(|a, b| a.topic.cmp(&b.topic));
        out
    }

    /// The messages on `topic` recorded at or before `until_ns`, in log-time order, each with its
    /// channel; a channel of another type than `M` is an error.
    fn on_topic<'a, M: RosMessage>(&'a self, topic: &str, until_ns: u64) -> Result<Vec<(&'a Channel, &'a Message)>, BagError> {
        let mut out = Vec::new();
        for m in self.mcap.messages.iter().take_while(|m| m.log_time_ns <= until_ns) {
            let Some(c) = self.mcap.channel(m.channel_id).filter(|c| !topic.is_empty() && c.topic == topic) else { continue };
            let found = self.mcap.type_of(c);
            if !type_matches::<M>(found) {
                return Err(BagError::WrongType {
                    name: self.name.clone(),
                    topic: topic.into(),
                    found: found.into(),
                    expected: M::ros_type(),
                });
            }
            out.push((c, m));
        }
        Ok(out)
    }

    /// A message decoded as `M` (its topic's type, checked by [`Self::on_topic`]).
    fn decode<M: RosMessage>(&self, c: &Channel, m: &Message) -> Result<M, BagError> {
        cdr::from_bytes(&m.data).map_err(|e| self.decode_err(c, m, e))
    }

    fn decode_err(&self, c: &Channel, m: &Message, detail: impl ToString) -> BagError {
        BagError::Message {
            name: self.name.clone(),
            topic: c.topic.clone(),
            msg_type: self.mcap.type_of(c).into(),
            t_s: self.time_s(m.log_time_ns),
            detail: detail.to_string(),
        }
    }

    /// The log time of an instant, after checking it lies in the bag.
    fn until_ns(&self, t_s: f64) -> Result<u64, BagError> {
        let d = self.duration_s();
        if !(t_s.is_finite() && t_s >= 0.0 && t_s <= d + 1e-9) {
            return Err(BagError::OutOfRange { name: self.name.clone(), t_s, duration_s: d });
        }
        Ok(self.start_ns.saturating_add(libm::round(t_s * 1e9) as u64))
    }

    /// The node's status messages up to `until_ns`: (seconds from start, parsed).
    fn statuses(&self, topics: &BagTopics, until_ns: u64) -> Result<Vec<(f64, NodeStatus)>, BagError> {
        let mut out = Vec::new();
        for (c, m) in self.on_topic::<StringMsg>(&topics.status_topic, until_ns)? {
            let text = self.decode::<StringMsg>(c, m)?.data;
            let s: NodeStatus =
                serde_json::from_str(&text).map_err(|e| self.decode_err(c, m, format!("status is not the node's JSON: {e}")))?;
            out.push((self.time_s(m.log_time_ns), s));
        }
        Ok(out)
    }

    /// The decision instants: new goals in the node's status, else map updates.
    pub fn decision_instants(&self, topics: &BagTopics) -> Result<Vec<DecisionInstant>, BagError> {
        let statuses = self.statuses(topics, u64::MAX)?;
        if statuses.is_empty() {
            let maps = self.on_topic::<MapMsg>(&topics.map_topic, u64::MAX)?;
            return Ok(maps
                .iter()
                .map(|(_, m)| DecisionInstant { t_s: self.time_s(m.log_time_ns), source: InstantSource::MapUpdate, goal: None })
                .collect());
        }
        let mut out = Vec::new();
        let mut last: Option<(Option<u64>, [f64; 2])> = None;
        for (t_s, s) in statuses {
            // A goal id identifies a goal; without one (0, or a suggested goal), the position does.
            let id = s.goal.map(|g| g.id).filter(|&id| id != 0);
            if let Some((goal, frontier_m)) = s.choice() {
                let xy = [goal.x_m, goal.y_m];
                let same = last.is_some_and(|(lid, lxy)| if id.is_some() { lid == id } else { lxy == xy });
                if !same {
                    let chosen = frontier_m.map_or(goal, |[x, y]| Pose2::new(x, y, goal.yaw_rad));
                    out.push(DecisionInstant { t_s, source: InstantSource::NewGoal, goal: Some(chosen) });
                }
                last = Some((id, xy));
            } else {
                last = None;
            }
        }
        Ok(out)
    }

    /// The latest transform of every tf edge recorded up to `until_ns`: child → (parent,
    /// parent_from_child, log time; `None` for a static edge).
    fn tf_edges(&self, topics: &BagTopics, until_ns: u64) -> Result<TfEdges, BagError> {
        let mut msgs_in_order: Vec<(&Channel, &Message, bool)> = Vec::new();
        for (topic, is_static) in [(&topics.tf_static_topic, true), (&topics.tf_topic, false)] {
            for (c, m) in self.on_topic::<TFMessage>(topic, until_ns)? {
                msgs_in_order.push((c, m, is_static));
            }
        }
        msgs_in_order.sort_by_key(|(_, m, _)| m.log_time_ns);
        let mut edges = HashMap::new();
        for (c, m, is_static) in msgs_in_order {
            for t in self.decode::<TFMessage>(c, m)?.transforms {
                let (parent, child) = (frame(&t.header.frame_id), frame(&t.child_frame_id));
                if parent.is_empty() || child.is_empty() || parent == child {
                    return Err(self.decode_err(c, m, format!("transform {parent:?} → {child:?}: empty or equal frame names")));
                }
                let iso = ros::isometry_of_transform(&t.transform)
                    .map_err(|e| self.decode_err(c, m, format!("transform {parent} → {child} rejected: {e}")))?;
                edges.insert(child.to_string(), (parent.to_string(), iso, (!is_static).then_some(m.log_time_ns)));
            }
        }
        Ok(edges)
    }

    /// `target_from_source` through the tree, with the newest log time of its dynamic edges.
    fn lookup(edges: &TfEdges, target: &str, source: &str) -> Option<(Isometry3<f64>, Option<u64>)> {
        // (ancestor, ancestor_from_frame, newest dynamic edge) from the frame up to its root.
        let to_root = |f: &str| {
            let mut out = vec![(f.to_string(), Isometry3::identity(), None::<u64>)];
            for _ in 0..MAX_TF_DEPTH {
                let Some((cur, cur_from_f, newest)) = out.last().cloned() else { break };
                let Some((parent, parent_from_cur, t)) = edges.get(&cur) else { break };
                out.push((parent.clone(), parent_from_cur * cur_from_f, newest.max(*t)));
            }
            out
        };
        let from_source = to_root(source);
        let from_target = to_root(target);
        for (name, anc_from_source, ts) in &from_source {
            if let Some((_, anc_from_target, tt)) = from_target.iter().find(|(n, _, _)| n == name) {
                return Some((anc_from_target.inverse() * anc_from_source, (*ts).max(*tt)));
            }
        }
        None
    }

    /// The decision inputs at `t_s` seconds from the bag's start.
    pub fn snapshot(&self, topics: &BagTopics, t_s: f64) -> Result<Snapshot, BagError> {
        let until = self.until_ns(t_s)?;
        let missing = |detail: String| BagError::Missing { name: self.name.clone(), detail };
        let maps = self.on_topic::<MapMsg>(&topics.map_topic, until)?;
        let Some(&(c, m)) = maps.last() else {
            let first = self.on_topic::<MapMsg>(&topics.map_topic, u64::MAX)?.first().map(|(_, m)| self.time_s(m.log_time_ns));
            return Err(missing(match first {
                Some(f) => format!("no map on {} at t = {t_s} s: the first is at {f:.6} s", topics.map_topic),
                None => format!("no map on {} (topics: {})", topics.map_topic, self.topic_names()),
            }));
        };
        let map = ros::occupancy_of_msg(&self.decode::<MapMsg>(c, m)?).map_err(|e| self.decode_err(c, m, e))?;
        let map_t_s = self.time_s(m.log_time_ns);

        let edges = self.tf_edges(topics, until)?;
        let map_frame = frame(&topics.map_frame);
        let to_map = |from: &str| Self::lookup(&edges, map_frame, frame(from)).map(|(iso, _)| iso);

        let tf_pose = match topics.pose_source {
            Some(PoseSource::Topic) => None,
            _ => Self::lookup(&edges, map_frame, frame(&topics.base_frame)),
        };
        let (robot, pose_source, pose_t_s) = match tf_pose {
            Some((iso, newest)) => (ros::pose2_of_isometry(&iso), PoseSource::Tf, newest.map_or(0.0, |t| self.time_s(t))),
            None if topics.pose_source == Some(PoseSource::Tf) => {
                return Err(missing(format!("no tf path {} ← {} at t = {t_s} s", topics.map_frame, topics.base_frame)));
            }
            None => {
                let poses = self.on_topic::<PoseWithCovarianceStamped>(&topics.pose_topic, until)?;
                let Some(&(c, m)) = poses.last() else {
                    return Err(missing(format!(
                        "no pose at t = {t_s} s: no tf path {} ← {} and no message on {}",
                        topics.map_frame, topics.base_frame, topics.pose_topic
                    )));
                };
                let p = self.decode::<PoseWithCovarianceStamped>(c, m)?;
                let frame_from_base =
                    ros::isometry_of_pose(&p.pose.pose).map_err(|e| self.decode_err(c, m, format!("pose rejected: {e}")))?;
                let pose_frame = if p.header.frame_id.is_empty() { map_frame } else { frame(&p.header.frame_id) };
                let map_from_base = if pose_frame == map_frame {
                    frame_from_base
                } else {
                    to_map(pose_frame).ok_or_else(|| self.decode_err(c, m, format!("no tf path {map_frame} ← {pose_frame}")))?
                        * frame_from_base
                };
                (ros::pose2_of_isometry(&map_from_base), PoseSource::Topic, self.time_s(m.log_time_ns))
            }
        };

        let clouds = self.on_topic::<PointCloud2>(&topics.landmarks_topic, until)?;
        let (landmarks, landmarks_t_s) = match clouds.last() {
            None => (PointCloud::default(), None),
            Some(&(c, m)) => {
                let cloud = self.decode::<PointCloud2>(c, m)?;
                let (mut points, _) = ros::points_of_cloud(&cloud).map_err(|e| self.decode_err(c, m, e))?;
                let cloud_frame = frame(&cloud.header.frame_id);
                if !cloud_frame.is_empty() && cloud_frame != map_frame {
                    let map_from_cloud =
                        to_map(cloud_frame).ok_or_else(|| self.decode_err(c, m, format!("no tf path {map_frame} ← {cloud_frame}")))?;
                    for p in &mut points {
                        *p = map_from_cloud * *p;
                    }
                }
                (PointCloud::from_points(points), Some(self.time_s(m.log_time_ns)))
            }
        };

        let robot_choice = self.statuses(topics, until)?.into_iter().last().and_then(|(st, s)| {
            let (goal, frontier_m) = s.choice()?;
            let phase = Some(s.phase).filter(|&p| p != Phase::Unknown);
            Some(RobotChoice { t_s: st, goal, frontier_m, phase })
        });
        Ok(Snapshot { t_s, map, map_t_s, landmarks, landmarks_t_s, robot, pose_source, pose_t_s, robot_choice })
    }

    fn topic_names(&self) -> String {
        let names: Vec<String> = self.topics().into_iter().map(|t| t.topic).collect();
        if names.is_empty() { "none".into() } else { names.join(", ") }
    }
}
