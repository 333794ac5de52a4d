//! Shared test helpers: the simulated robot and the loopback DDS plumbing.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod core_sim;
pub mod rclpy;
pub mod sim;

use fitslam_core::Pose2;
use fitslam_msgs::{
    Header, NavigateToPoseFeedback, NavigateToPoseGoal, NavigateToPoseResult, OccupancyGrid as MapMsg, PointCloud2, Quaternion, StringMsg,
    TFMessage, Transform, TransformStamped, Vector3, nav2,
};
use fitslam_robot::ros::{advertise, latched, now_stamp, reliable, subscribe, topic_name};
use ros2_client::action::{ActionServer, ActionServerQosPolicies};
use ros2_client::{ActionTypeName, Publisher, ServiceMapping, Subscription};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// A DDS domain private to this test process: `base + pid % span` (domains ≤ 232).
pub fn private_domain(base: u16, span: u16) -> u16 {
    base + (std::process::id() % span as u32) as u16
}

/// map → odom (identity) and odom → base_link at `p`, stamped now: what a SLAM and the wheel
/// odometry publish on /tf.
pub fn tf_msg(p: Pose2) -> TFMessage {
    let t = |parent: &str, child: &str, x, y, yaw| TransformStamped {
        header: Header::new(now_stamp(), parent),
        child_frame_id: child.into(),
        transform: Transform { translation: Vector3 { x, y, z: 0.0 }, rotation: Quaternion::from_yaw(yaw) },
    };
    TFMessage { transforms: vec![t("map", "odom", 0.0, 0.0, 0.0), t("odom", "base_link", p.x_m, p.y_m, p.yaw_rad)] }
}

/// A fresh scratch directory under the system temp dir.
pub fn scratch_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fitslam-robot-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// The node binary running as a child process, killed when dropped.
pub struct NodeProcess {
    pub child: Child,
    pub log_path: PathBuf,
}

impl NodeProcess {
    /// Starts `fitslam-robot --config <config>` on `domain`, loopback only, its stderr and
    /// stdout in `<dir>/node.log`.
    pub fn start(config: &Path, domain: u16, dir: &Path) -> Self {
        Self::start_with(config, domain, dir, &[])
    }

    /// [`Self::start`] with extra command-line arguments.
    pub fn start_with(config: &Path, domain: u16, dir: &Path, extra: &[&str]) -> Self {
        let log_path = dir.join("node.log");
        let log = std::fs::File::create(&log_path).expect("log file");
        let child = Command::new(env!("CARGO_BIN_EXE_fitslam-robot"))
            .arg("--config")
            .arg(config)
            .arg("--localhost-only")
            .arg("--domain-id")
            .arg(domain.to_string())
            .args(extra)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("ROS_LOCALHOST_ONLY", "1")
            .stdout(Stdio::from(log.try_clone().expect("log file")))
            .stderr(Stdio::from(log))
            .spawn()
            .expect("spawn fitslam-robot");
        Self { child, log_path }
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log_path).unwrap_or_default()
    }

    /// Waits up to `timeout_s` for the process to exit; its exit status.
    pub fn wait_exit(&mut self, timeout_s: f64) -> Option<std::process::ExitStatus> {
        let t0 = std::time::Instant::now();
        while t0.elapsed().as_secs_f64() < timeout_s {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Some(s);
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        None
    }
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// What a simulated robot offers the node over DDS: the map, landmark cloud and /tf publishers,
/// the node's status subscription, and a Nav2 NavigateToPose action server (Jazzy layout).
pub struct RobotSide {
    pub map_pub: Publisher<MapMsg>,
    pub cloud_pub: Publisher<PointCloud2>,
    pub tf_pub: Publisher<TFMessage>,
    pub status_sub: Subscription<StringMsg>,
    pub server: ActionServer<NavigateToPoseGoal, NavigateToPoseResult, NavigateToPoseFeedback>,
}

impl RobotSide {
    /// Creates the endpoints on `node` with the node's default topic names.
    pub fn new(node: &mut ros2_client::Node) -> Self {
        let q = reliable(10);
        let server = node
            .create_action_server::<NavigateToPoseGoal, NavigateToPoseResult, NavigateToPoseFeedback>(
                ServiceMapping::Enhanced,
                &topic_name("/navigate_to_pose").unwrap(),
                &ActionTypeName::new(nav2::ACTION_PACKAGE, nav2::ACTION_NAME),
                ActionServerQosPolicies {
                    goal_service: q.clone(),
                    result_service: q.clone(),
                    cancel_service: q.clone(),
                    feedback_publisher: q.clone(),
                    status_publisher: latched(1),
                },
            )
            .unwrap();
        Self {
            map_pub: advertise::<MapMsg>(node, "/map", latched(1)).unwrap(),
            cloud_pub: advertise::<PointCloud2>(node, "/cloud_map", reliable(1)).unwrap(),
            tf_pub: advertise::<TFMessage>(node, "/tf", reliable(100)).unwrap(),
            status_sub: subscribe::<StringMsg>(node, "/fitslam/status", reliable(10)).unwrap(),
            server,
        }
    }
}
