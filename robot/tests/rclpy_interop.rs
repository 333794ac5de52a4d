//! The node binary against ROS 2 Jazzy's official Python client, rclpy on rmw_fastrtps_cpp
//! (Fast DDS), both inside a private network namespace so that no traffic leaves 127.0.0.1: the
//! node takes rclpy's latched `nav_msgs/OccupancyGrid` from /map, rclpy reads the node's latched
//! status from /fitslam/status, and a `stop` on /fitslam/control ends the mission with a clean
//! exit.
//!
//! Needs the venv `scripts/ros2-jazzy-venv` installs (`scripts/test` runs it; or set
//! `FITSLAM_ROS2_VENV`) and `unshare -n` (root); without either this test FAILS and says so.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;

use common::{private_domain, scratch_dir};
use std::path::PathBuf;
use std::process::Command;

#[test]
fn rclpy_on_fast_dds_feeds_the_map_reads_the_status_and_stops_the_node() {
    let venv = std::env::var_os("FITSLAM_ROS2_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/ros2-jazzy-venv"));
    let python = venv.join("bin/python");
    assert!(
        Command::new(&python).args(["-c", "import rclpy"]).output().is_ok_and(|o| o.status.success()),
        "this test needs ROS 2 Jazzy's rclpy in {}: run scripts/ros2-jazzy-venv (scripts/test does)",
        venv.display()
    );
    let dir = scratch_dir("rclpy");
    let config = dir.join("node.yaml");
    std::fs::write(&config, "node:\n  replan_period_s: 0.5\n").unwrap();
    let domain = private_domain(90, 10).to_string();
    let peer = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/rclpy/peer.py");
    let node_log = dir.join("node.log");
    // One namespace for both: the node in the background, the peer in front; then the node's
    // exit status.
    let script = String::from(
        "ip link set lo up && { \"$NODE\" --config \"$CONFIG\" --localhost-only --domain-id \"$ROS_DOMAIN_ID\" > \"$NODE_LOG\" 2>&1 & } \
         && NP=$! && \"$PYTHON\" \"$PEER\" 30; PEER_EXIT=$?; \
         for _ in $(seq 50); do kill -0 $NP 2>/dev/null || break; sleep 0.1; done; \
         kill $NP 2>/dev/null; wait $NP; echo \"node exit $?\"; exit $PEER_EXIT",
    );
    let out = Command::new("unshare")
        .args(["-n", "sh", "-c", &script])
        .env("NODE", env!("CARGO_BIN_EXE_fitslam-robot"))
        .env("CONFIG", &config)
        .env("NODE_LOG", &node_log)
        .env("PYTHON", &python)
        .env("PEER", &peer)
        .env("ROS_DOMAIN_ID", &domain)
        .env("ROS_LOCALHOST_ONLY", "1")
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .output()
        .expect("unshare (this test needs `unshare -n`, i.e. root)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let log = std::fs::read_to_string(&node_log).unwrap_or_default();
    let context = format!("peer stdout:\n{stdout}\npeer stderr:\n{}\nnode log:\n{log}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{context}");
    assert!(log.contains("first map: 40×30 cells at 0.1 m"), "the node took rclpy's map: {context}");
    assert!(log.contains("mission complete: stopped on request"), "{context}");
    assert!(stdout.contains("node exit 0"), "{context}");
    let summary = stdout.lines().find(|l| l.starts_with("{\"statuses\"")).expect(&context);
    assert!(summary.contains("\"phase\": \"done\"") && summary.contains("stopped on request"), "rclpy read the status: {context}");
}
