//! The ROS 2 side: a DDS participant (ros2-client / RustDDS), the node's subscriptions,
//! publishers and NavigateToPose action client, and the loop that moves messages between them
//! and the [`ExplorerNode`]. Nothing here decides anything.
//!
//! The loop polls (non-blocking `take`) every `poll_period_s`: for the map, the landmark map,
//! the boundary and the pose only the newest message of each burst is decoded; every `/tf`
//! message is used. Every wait has a bound: goal responses and results are polled, never
//! awaited, and their timeouts are the explorer's.

use crate::config::{ConfigFile, GoalInterface, MapSource, PoseSource, ServiceMappingChoice};
use crate::markers::decision_markers;
use crate::node::{Command, ExplorerNode, GoalEvent, Level, LogLine};
use crate::qos_check::QosWatch;
use fitslam_core::ros::pose_of_pose2;
use fitslam_msgs::{self as msgs, Header, NavigateToPoseFeedback, NavigateToPoseGoal, NavigateToPoseResult, RosMessage, Time, nav2};
use ros2_client::action::{ActionClient, ActionClientQosPolicies, GoalId, GoalStatusEnum};
use ros2_client::dds::rustdds::{DomainParticipant, DomainParticipantBuilder};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    ActionTypeName, Context, Name, NodeName, NodeOptions, Publisher, QosProfile, RmwRequestId, ServiceMapping, Subscription,
};
use std::net::Ipv4Addr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use thiserror::Error;

/// Most messages taken from one subscription per poll (bounds a poll even if a reader keeps
/// returning errors).
const MAX_TAKES_PER_POLL: usize = 1000;

/// How often the discovered publishers' QoS is compared with the subscriptions', seconds.
const QOS_CHECK_PERIOD_S: f64 = 2.0;

/// Why the ROS side could not start.
#[derive(Debug, Error)]
pub enum RosError {
    #[error("DDS: {0}")]
    Dds(String),
    #[error("bad ROS name '{name}': {message}")]
    Name { name: String, message: String },
    #[error("configuration: {0}")]
    Config(#[from] fitslam_core::params::InvalidParam),
}

fn dds<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> RosError + '_ {
    move |e| RosError::Dds(format!("{what}: {e:?}"))
}

/// `ROS_DOMAIN_ID` / `ROS_LOCALHOST_ONLY` unless the configuration says otherwise (ros2-client
/// reads neither).
pub fn domain_and_localhost(cfg: &crate::config::NodeConfig) -> (u16, bool) {
    let domain = cfg.domain_id.or_else(|| std::env::var("ROS_DOMAIN_ID").ok().and_then(|v| v.trim().parse().ok())).unwrap_or(0);
    let localhost = cfg.localhost_only.unwrap_or_else(|| std::env::var("ROS_LOCALHOST_ONLY").is_ok_and(|v| v.trim() == "1"));
    (domain, localhost)
}

/// A ros2-client context on `domain`, on 127.0.0.1 only if `localhost_only`.
pub fn make_context(domain: u16, localhost_only: bool) -> Result<Context, RosError> {
    let mut b = DomainParticipantBuilder::new(domain);
    if localhost_only {
        b = b.with_only_networks([Ipv4Addr::LOCALHOST]);
    }
    let dp = b.build().map_err(dds("participant"))?;
    Context::from_domain_participant(dp).map_err(dds("context"))
}

/// A topic name as a ros2-client `Name` (absolute or relative to the node's namespace).
pub fn topic_name(name: &str) -> Result<Name, RosError> {
    Name::parse(name).map_err(|e| RosError::Name { name: name.into(), message: format!("{e}") })
}

/// Reliable, volatile, keep last `depth`.
pub fn reliable(depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable { when_full: WhenFull::Wait(Duration::from_millis(20)) })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth })
}

/// Reliable, transient local (latched), keep last `depth`.
pub fn latched(depth: usize) -> QosProfile {
    reliable(depth).durability(Durability::TransientLocal)
}

/// Best effort, volatile, keep last `depth` (sensor data).
pub fn best_effort(depth: usize) -> QosProfile {
    QosProfile::subscription_default().history(History::KeepLast { depth })
}

/// A subscription to `name` with type `M`.
pub fn subscribe<M: RosMessage + ros2_client::Message + 'static>(
    node: &mut ros2_client::Node,
    name: &str,
    qos: QosProfile,
) -> Result<Subscription<M>, RosError> {
    let topic = node.create_topic(&topic_name(name)?, M::type_name(), &qos).map_err(dds(name))?;
    node.create_subscription(&topic, Some(qos)).map_err(dds(name))
}

/// A publisher on `name` with type `M`.
pub fn advertise<M: RosMessage + ros2_client::Message>(
    node: &mut ros2_client::Node,
    name: &str,
    qos: QosProfile,
) -> Result<Publisher<M>, RosError> {
    let topic = node.create_topic(&topic_name(name)?, M::type_name(), &qos).map_err(dds(name))?;
    node.create_publisher(&topic, Some(qos)).map_err(dds(name))
}

/// QoS of the action's services and topics (all reliable volatile: compatible with rcl_action's
/// defaults, including the transient-local status topic).
pub fn action_client_qos() -> ActionClientQosPolicies {
    let q = reliable(10);
    ActionClientQosPolicies {
        goal_service: q.clone(),
        result_service: q.clone(),
        cancel_service: q.clone(),
        feedback_subscription: q.clone(),
        status_subscription: q,
    }
}

/// The service mapping chosen in the configuration.
pub fn service_mapping(c: ServiceMappingChoice) -> ServiceMapping {
    match c {
        ServiceMappingChoice::Enhanced => ServiceMapping::Enhanced,
        ServiceMappingChoice::Cyclone => ServiceMapping::Cyclone,
        ServiceMappingChoice::Basic => ServiceMapping::Basic,
    }
}

/// The NavigateToPose client type.
pub type NavClient = ActionClient<NavigateToPoseGoal, NavigateToPoseResult, NavigateToPoseFeedback>;

/// Wall-clock stamp for outgoing headers.
pub fn now_stamp() -> Time {
    let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0);
    Time::from_secs_f64(t)
}

/// Hands every pending message of `sub` (at most [`MAX_TAKES_PER_POLL`]) to `f`, in order. Read
/// errors are counted in `errors`.
fn each<M: 'static + serde::de::DeserializeOwned>(sub: Option<&Subscription<M>>, errors: &mut u64, mut f: impl FnMut(M)) {
    let Some(sub) = sub else { return };
    for _ in 0..MAX_TAKES_PER_POLL {
        match sub.take() {
            Ok(Some((m, _))) => f(m),
            Ok(None) => break,
            Err(_) => *errors += 1,
        }
    }
}

/// Newest message of a subscription; older ones of the same burst are dropped. Read errors are
/// counted in `errors`.
fn newest<M: 'static + serde::de::DeserializeOwned>(sub: Option<&Subscription<M>>, errors: &mut u64) -> Option<M> {
    let mut last = None;
    each(sub, errors, |m| last = Some(m));
    last
}

enum Stage {
    AwaitingResponse { req: RmwRequestId },
    AwaitingResult { req: RmwRequestId },
}

struct Tracked {
    id: u64,
    goal_id: GoalId,
    stage: Stage,
}

/// Something that watches the loop (the rerun logger; tests).
pub trait Observer {
    /// After each decision.
    fn on_decision(&mut self, _explorer: &ExplorerNode, _now_s: f64) {}
    /// After each status publication (about 1 Hz).
    fn on_status(&mut self, _explorer: &ExplorerNode, _now_s: f64) {}
    /// The node's log lines, as they are printed.
    fn on_log(&mut self, _lines: &[LogLine]) {}
}

/// No observer.
pub struct NoObserver;
impl Observer for NoObserver {}

/// How the loop ended.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    pub mission_complete: bool,
    pub duration_s: f64,
    pub status_json: String,
}

/// The node's ROS endpoints.
pub struct RosNode {
    node: ros2_client::Node,
    map_sub: Option<Subscription<msgs::OccupancyGrid>>,
    cloud_sub: Option<Subscription<msgs::PointCloud2>>,
    landmarks_sub: Option<Subscription<msgs::PointCloud2>>,
    tf_sub: Option<Subscription<msgs::TFMessage>>,
    tf_static_sub: Option<Subscription<msgs::TFMessage>>,
    pose_sub: Option<Subscription<msgs::PoseWithCovarianceStamped>>,
    boundary_sub: Option<Subscription<msgs::PolygonStamped>>,
    control_sub: Option<Subscription<msgs::StringMsg>>,
    goal_pub: Option<Publisher<msgs::PoseStamped>>,
    action: Option<NavClient>,
    marker_pub: Publisher<msgs::MarkerArray>,
    status_pub: Publisher<msgs::StringMsg>,
    tracked: Option<Tracked>,
    read_errors: u64,
    participant: DomainParticipant,
    /// The subscriptions' requested QoS, against the discovered publishers'.
    qos_watch: QosWatch,
    qos_checked_s: Option<f64>,
    _spinner: Option<std::thread::JoinHandle<()>>,
}

impl RosNode {
    /// Creates every endpoint the configuration asks for, on `context`.
    pub fn new(context: &Context, cfg: &ConfigFile) -> Result<Self, RosError> {
        let c = &cfg.node;
        let node_name =
            NodeName::new(&c.namespace, &c.name).map_err(|e| RosError::Name { name: c.name.clone(), message: format!("{e}") })?;
        let mut node = context.new_node(node_name.clone(), NodeOptions::new().enable_rosout(true)).map_err(dds("node"))?;
        let spinner = node.spinner().map_err(dds("spinner"))?;
        let spin_thread = std::thread::Builder::new()
            .name("ros2-spinner".into())
            .spawn(move || {
                let _ = futures::executor::block_on(spinner.spin());
            })
            .map_err(dds("spinner thread"))?;
        let mut qos_watch = QosWatch::default();
        let mut sub = |name: &str, qos: QosProfile, hint: &'static str| {
            let dds_topic = topic_name(name)?.to_dds_name("rt", &node_name, "");
            qos_watch.add(name, dds_topic, &qos, hint);
            Ok::<_, RosError>((name.to_owned(), qos))
        };
        const RELIABLE_HINT: &str = "Publish it RELIABLE.";
        let map_qos = if c.map_transient_local { latched(1) } else { reliable(1) };
        let map_hint = "Publish it TRANSIENT_LOCAL (as map_server does), or set node.map_transient_local: false.";
        let map = (c.map_source == MapSource::Occupancy).then(|| sub(&c.map_topic, map_qos, map_hint)).transpose()?;
        let cloud = (c.map_source == MapSource::Clouds).then(|| sub(&c.cloud_topic, best_effort(10), "")).transpose()?;
        let landmarks = (!c.landmarks_topic.is_empty()).then(|| sub(&c.landmarks_topic, reliable(1), RELIABLE_HINT)).transpose()?;
        let tf = sub("/tf", reliable(100), RELIABLE_HINT)?;
        let tf_static = sub("/tf_static", latched(100), "Publish it TRANSIENT_LOCAL, as tf2's static broadcaster does.")?;
        let pose = (c.pose_source == PoseSource::Topic).then(|| sub(&c.pose_topic, reliable(5), RELIABLE_HINT)).transpose()?;
        let boundary = (!c.boundary_topic.is_empty()).then(|| sub(&c.boundary_topic, reliable(1), RELIABLE_HINT)).transpose()?;
        let control = (!c.control_topic.is_empty()).then(|| sub(&c.control_topic, reliable(10), RELIABLE_HINT)).transpose()?;
        let map_sub = map.map(|(n, q)| subscribe(&mut node, &n, q)).transpose()?;
        let cloud_sub = cloud.map(|(n, q)| subscribe(&mut node, &n, q)).transpose()?;
        let landmarks_sub = landmarks.map(|(n, q)| subscribe(&mut node, &n, q)).transpose()?;
        let tf_sub = Some(subscribe(&mut node, &tf.0, tf.1)?);
        let tf_static_sub = Some(subscribe(&mut node, &tf_static.0, tf_static.1)?);
        let pose_sub = pose.map(|(n, q)| subscribe(&mut node, &n, q)).transpose()?;
        let boundary_sub = boundary.map(|(n, q)| subscribe(&mut node, &n, q)).transpose()?;
        let control_sub = control.map(|(n, q)| subscribe(&mut node, &n, q)).transpose()?;
        let (goal_pub, action) = match c.goal_interface {
            GoalInterface::Topic => (Some(advertise(&mut node, &c.goal_topic, reliable(1))?), None),
            GoalInterface::Action => {
                let a = node
                    .create_action_client(
                        service_mapping(c.service_mapping),
                        &topic_name(&c.action_name)?,
                        &ActionTypeName::new(nav2::ACTION_PACKAGE, nav2::ACTION_NAME),
                        action_client_qos(),
                    )
                    .map_err(dds("NavigateToPose client"))?;
                (None, Some(a))
            }
        };
        let marker_pub = advertise(&mut node, &c.marker_topic, reliable(1))?;
        let status_pub = advertise(&mut node, &c.status_topic, latched(1))?;
        Ok(Self {
            node,
            map_sub,
            cloud_sub,
            landmarks_sub,
            tf_sub,
            tf_static_sub,
            pose_sub,
            boundary_sub,
            control_sub,
            goal_pub,
            action,
            marker_pub,
            status_pub,
            tracked: None,
            read_errors: 0,
            participant: context.domain_participant(),
            qos_watch,
            qos_checked_s: None,
            _spinner: Some(spin_thread),
        })
    }

    /// Moves every pending message into the explorer.
    pub fn poll_inputs(&mut self, e: &mut ExplorerNode, now_s: f64) {
        let errs = &mut self.read_errors;
        each(self.tf_static_sub.as_ref(), errs, |m| e.handle_tf(&m, true, now_s));
        each(self.tf_sub.as_ref(), errs, |m| e.handle_tf(&m, false, now_s));
        if let Some(m) = newest(self.pose_sub.as_ref(), errs) {
            e.handle_pose(&m, now_s);
        }
        if let Some(m) = newest(self.boundary_sub.as_ref(), errs) {
            e.handle_boundary(&m, now_s);
        }
        each(self.control_sub.as_ref(), errs, |m| e.handle_control(&m, now_s));
        if let Some(m) = newest(self.map_sub.as_ref(), errs) {
            e.handle_map(&m, now_s);
        }
        each(self.cloud_sub.as_ref(), errs, |m| e.handle_cloud(&m, now_s));
        if let Some(m) = newest(self.landmarks_sub.as_ref(), errs) {
            e.handle_landmarks(&m, now_s);
        }
        self.poll_action(e, now_s);
        if self.qos_checked_s.is_none_or(|t| now_s - t >= QOS_CHECK_PERIOD_S) {
            self.qos_checked_s = Some(now_s);
            for text in self.qos_watch.incompatible(&self.participant) {
                e.transport_warning(now_s, text);
            }
        }
    }

    fn poll_action(&mut self, e: &mut ExplorerNode, now_s: f64) {
        let Some(a) = &self.action else { return };
        // Feedback tells that the tracked goal is alive; drain what we do not use, so that
        // nothing piles up.
        let mut heard = false;
        for _ in 0..MAX_TAKES_PER_POLL {
            match a.feedback_subscription().take() {
                Ok(Some((m, _))) => heard |= self.tracked.as_ref().is_some_and(|t| t.goal_id == m.goal_id),
                _ => break,
            }
        }
        for _ in 0..MAX_TAKES_PER_POLL {
            if !matches!(a.receive_status(), Ok(Some(_))) {
                break;
            }
        }
        for _ in 0..MAX_TAKES_PER_POLL {
            if !matches!(a.cancel_client().receive_response(), Ok(Some(_))) {
                break;
            }
        }
        let Some(t) = &mut self.tracked else { return };
        if heard {
            e.on_goal_event(t.id, GoalEvent::Feedback, now_s);
        }
        match t.stage {
            Stage::AwaitingResponse { req } => match a.receive_goal_response(req) {
                Ok(Some(resp)) if resp.accepted => {
                    e.on_goal_event(t.id, GoalEvent::Accepted, now_s);
                    match a.request_result(t.goal_id) {
                        Ok(req) => t.stage = Stage::AwaitingResult { req },
                        Err(err) => {
                            e.on_goal_event(t.id, GoalEvent::Lost(format!("result request failed: {err:?}")), now_s);
                            self.tracked = None;
                        }
                    }
                }
                Ok(Some(_)) => {
                    e.on_goal_event(t.id, GoalEvent::Rejected, now_s);
                    self.tracked = None;
                }
                Ok(None) => {}
                Err(err) => {
                    e.on_goal_event(t.id, GoalEvent::Lost(format!("undecodable goal response: {err:?}")), now_s);
                    self.tracked = None;
                }
            },
            Stage::AwaitingResult { req } => match a.receive_result(req) {
                Ok(Some((status, result))) => {
                    let event = match status {
                        GoalStatusEnum::Succeeded => GoalEvent::Succeeded,
                        GoalStatusEnum::Canceled => GoalEvent::Canceled,
                        GoalStatusEnum::Aborted => GoalEvent::Aborted(format!("error {}: {}", result.error_code, result.error_msg)),
                        other => GoalEvent::Lost(format!("result with status {other:?}")),
                    };
                    e.on_goal_event(t.id, event, now_s);
                    self.tracked = None;
                }
                Ok(None) => {}
                Err(err) => {
                    e.on_goal_event(t.id, GoalEvent::Lost(format!("undecodable result: {err:?}")), now_s);
                    self.tracked = None;
                }
            },
        }
    }

    /// Carries out one command. Send failures are reported back to the explorer as lost goals.
    pub fn execute(&mut self, e: &mut ExplorerNode, cmd: &Command, map_frame: &str, now_s: f64) {
        match cmd {
            Command::SendGoal { id, goal } => {
                let pose = msgs::PoseStamped { header: Header::new(now_stamp(), map_frame), pose: pose_of_pose2(*goal) };
                if let Some(p) = &self.goal_pub
                    && let Err(err) = p.publish(pose.clone())
                {
                    e.on_goal_event(*id, GoalEvent::Lost(format!("publish failed: {err:?}")), now_s);
                }
                if let Some(a) = &self.action {
                    match a.send_goal(NavigateToPoseGoal { pose, behavior_tree: String::new() }) {
                        Ok((req, goal_id)) => self.tracked = Some(Tracked { id: *id, goal_id, stage: Stage::AwaitingResponse { req } }),
                        Err(err) => e.on_goal_event(*id, GoalEvent::Lost(format!("send failed: {err:?}")), now_s),
                    }
                }
            }
            Command::CancelGoal { id } => {
                if let (Some(a), Some(t)) = (&self.action, &self.tracked)
                    && t.id == *id
                {
                    let _ = a.cancel_goal(t.goal_id);
                    self.tracked = None;
                }
            }
            Command::MissionComplete => {}
        }
    }

    /// Publishes the markers of the explorer's last decision.
    pub fn publish_markers(&self, e: &ExplorerNode, map_frame: &str) {
        let (Some(d), Some(map)) = (e.last_decision(), e.map()) else { return };
        let header = Header::new(now_stamp(), map_frame);
        let m = decision_markers(d, &map.geometry, e.blacklist(), e.shown_goal(), e.params(), &header);
        let _ = self.marker_pub.publish(m);
    }

    /// Publishes the status JSON; returns it.
    pub fn publish_status(&self, e: &ExplorerNode, now_s: f64) -> String {
        let json = serde_json::to_string(&e.status(now_s)).unwrap_or_default();
        let _ = self.status_pub.publish(msgs::StringMsg { data: json.clone() });
        json
    }

    /// Messages that could not be decoded so far.
    pub fn read_errors(&self) -> u64 {
        self.read_errors
    }

    pub fn ros_node(&self) -> &ros2_client::Node {
        &self.node
    }
}

/// Prints log lines to stderr (`[t s] LEVEL text`).
pub fn print_log(lines: &[LogLine]) {
    for l in lines {
        let level = match l.level {
            Level::Info => "INFO",
            Level::Warn => "WARN",
            Level::Error => "ERROR",
        };
        eprintln!("[{:9.3}] {level:5} {}", l.t_s, l.text);
    }
}

/// Runs the node until the mission completes or `stop` is set.
pub fn run(cfg: &ConfigFile, observer: &mut dyn Observer, stop: &AtomicBool) -> Result<RunSummary, RosError> {
    let (domain, localhost) = domain_and_localhost(&cfg.node);
    eprintln!(
        "fitslam-robot: node {}{} on DDS domain {domain}{}; strategy {:?}",
        cfg.node.namespace.trim_end_matches('/'),
        format_args!("/{}", cfg.node.name),
        if localhost { " (127.0.0.1 only)" } else { "" },
        cfg.fitslam.selector.strategy
    );
    let context = make_context(domain, localhost)?;
    let mut ros = RosNode::new(&context, cfg)?;
    let mut explorer = ExplorerNode::new(cfg.node.clone(), cfg.fitslam.clone())?;
    let start = Instant::now();
    let poll = Duration::from_secs_f64(cfg.node.poll_period_s);
    let map_frame = cfg.node.map_frame.clone();
    let mut decisions_seen = 0;
    let mut last_status_s = f64::NEG_INFINITY;
    let mut complete = false;
    while !stop.load(Ordering::Relaxed) {
        let now_s = start.elapsed().as_secs_f64();
        ros.poll_inputs(&mut explorer, now_s);
        let cmds = explorer.tick(now_s);
        for c in &cmds {
            ros.execute(&mut explorer, c, &map_frame, now_s);
            complete |= *c == Command::MissionComplete;
        }
        let lines = explorer.drain_log();
        if !lines.is_empty() {
            print_log(&lines);
            observer.on_log(&lines);
        }
        if explorer.decisions() != decisions_seen {
            decisions_seen = explorer.decisions();
            ros.publish_markers(&explorer, &map_frame);
            observer.on_decision(&explorer, now_s);
        }
        if complete || now_s - last_status_s >= 1.0 || !cmds.is_empty() {
            last_status_s = now_s;
            ros.publish_status(&explorer, now_s);
            observer.on_status(&explorer, now_s);
        }
        if complete {
            // Let the last status and markers go out before the participant closes.
            std::thread::sleep(Duration::from_millis(500));
            break;
        }
        std::thread::sleep(poll);
    }
    let now_s = start.elapsed().as_secs_f64();
    let status_json = ros.publish_status(&explorer, now_s);
    Ok(RunSummary { mission_complete: complete, duration_s: now_s, status_json })
}

/// Convenience for tests and tools: a stop flag that is never set.
pub fn never_stop() -> Arc<AtomicBool> {
    Arc::new(AtomicBool::new(false))
}
