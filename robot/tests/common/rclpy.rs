//! Running the node binary beside an rclpy process (ROS 2 Jazzy's official Python client on
//! rmw_fastrtps_cpp), both inside one private network namespace (`unshare -n`, loopback up), so
//! that neither Fast DDS's nor RustDDS's discovery can leave 127.0.0.1.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The venv's python with rclpy and the message packages (`scripts/ros2-jazzy-venv`; or
/// `FITSLAM_ROS2_VENV`). Panics, naming the fix, when it is missing: these tests must not pass
/// without the stack they test against.
pub fn ros2_python() -> PathBuf {
    let venv = std::env::var_os("FITSLAM_ROS2_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/ros2-jazzy-venv"));
    let python = venv.join("bin/python");
    let check = "import rclpy, nav2_msgs.action, tf2_msgs.msg, visualization_msgs.msg, sensor_msgs.msg";
    assert!(
        Command::new(&python).args(["-c", check]).output().is_ok_and(|o| o.status.success()),
        "this test needs ROS 2 Jazzy's rclpy, nav2_msgs and tf2_msgs in {}: run scripts/ros2-jazzy-venv (scripts/test does)",
        venv.display()
    );
    python
}

/// A script in robot/tests/rclpy/.
pub fn peer_script(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/rclpy").join(name)
}

/// What one run produced.
pub struct Run {
    pub peer_ok: bool,
    pub stdout: String,
    pub stderr: String,
    pub node_log: String,
    /// The node's exit status, `None` if it had to be killed.
    pub node_exit: Option<i32>,
}

impl Run {
    /// Everything, for assertion messages.
    pub fn context(&self) -> String {
        format!("peer stdout:\n{}\npeer stderr:\n{}\nnode log:\n{}", self.stdout, self.stderr, self.node_log)
    }
}

/// Runs `fitslam-robot --config CONFIG` in the background and `python SCRIPT ARGS…` in front, in
/// one private network namespace on DDS domain `domain`; after the peer exits, waits up to 5 s
/// for the node to end by itself, then kills it.
pub fn run_beside_node(dir: &Path, config: &Path, script: &Path, args: &[&str], domain: u16) -> Run {
    let python = ros2_python();
    let node_log = dir.join("node.log");
    let script_sh = "ip link set lo up && { \"$NODE\" --config \"$CONFIG\" --localhost-only --domain-id \"$ROS_DOMAIN_ID\" > \"$NODE_LOG\" 2>&1 & } \
         && NP=$! && \"$PYTHON\" \"$PEER\" \"$@\"; PEER_EXIT=$?; \
         for _ in $(seq 50); do kill -0 $NP 2>/dev/null || break; sleep 0.1; done; \
         if kill -0 $NP 2>/dev/null; then kill $NP; wait $NP; echo 'node killed'; else wait $NP; echo \"node exit $?\"; fi; exit $PEER_EXIT";
    let out = Command::new("unshare")
        .args(["-n", "sh", "-c", script_sh, "sh"])
        .args(args)
        .env("NODE", env!("CARGO_BIN_EXE_fitslam-robot"))
        .env("CONFIG", config)
        .env("NODE_LOG", &node_log)
        .env("PYTHON", &python)
        .env("PEER", script)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_LOCALHOST_ONLY", "1")
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .output()
        .expect("unshare (these tests need `unshare -n`, i.e. root)");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let node_exit = stdout.lines().find_map(|l| l.strip_prefix("node exit ")).and_then(|s| s.trim().parse().ok());
    Run {
        peer_ok: out.status.success(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        node_log: std::fs::read_to_string(&node_log).unwrap_or_default(),
        stdout,
        node_exit,
    }
}
