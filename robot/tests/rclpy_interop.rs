//! The node binary against ROS 2 Jazzy's official stack: rclpy on rmw_fastrtps_cpp (Fast DDS),
//! with Nav2's `nav2_msgs/action/NavigateToPose` and tf2's `tf2_msgs/TFMessage` built from
//! their Jazzy interface files (`scripts/ros2-jazzy-venv`). Every run is inside a private
//! network namespace, so that no traffic leaves 127.0.0.1.
//!
//! - the control path: rclpy's latched map reaches the node, rclpy reads the latched status, a
//!   `stop` on /fitslam/control ends the mission with exit 0 (`tests/rclpy/peer.py`);
//! - the closed loop: rclpy stands in for the robot's stack (`tests/rclpy/nav2_stack.py`: a
//!   SLAM side publishing /map, /tf, /tf_static and the landmark cloud, Nav2's action server
//!   driving a simulated robot, a monitor of the node's status and markers); the node explores
//!   the two-room world to `done`, once clean and once under the faults of the real side.
//!
//! Needs the venv `scripts/ros2-jazzy-venv` installs (`scripts/test` runs it; or set
//! `FITSLAM_ROS2_VENV`) and `unshare -n` (root); without either these tests FAIL and say so.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;

use common::rclpy::{peer_script, run_beside_node};
use common::sim::two_rooms;
use common::{private_domain, scratch_dir};
use serde_json::Value;

#[test]
fn rclpy_on_fast_dds_feeds_the_map_reads_the_status_and_stops_the_node() {
    let dir = scratch_dir("rclpy");
    let config = dir.join("node.yaml");
    std::fs::write(&config, "node:\n  replan_period_s: 0.5\n").unwrap();
    let run = run_beside_node(&dir, &config, &peer_script("peer.py"), &["30"], private_domain(90, 10));
    let context = run.context();
    assert!(run.peer_ok, "{context}");
    assert!(run.node_log.contains("first map: 40×30 cells at 0.1 m"), "the node took rclpy's map: {context}");
    assert!(run.node_log.contains("mission complete: stopped on request"), "{context}");
    assert_eq!(run.node_exit, Some(0), "{context}");
    let summary = run.stdout.lines().find(|l| l.starts_with("{\"statuses\"")).expect(&context);
    assert!(summary.contains("\"phase\": \"done\"") && summary.contains("stopped on request"), "rclpy read the status: {context}");
}

/// The ground truth of the stack's simulated robot: the two-room world, the robot at (1.5, 1.5)
/// with a 4 m range sensor, driving at 2 m/s.
fn world_json() -> String {
    let truth = two_rooms();
    let g = truth.geometry;
    serde_json::json!({
        "resolution_m": g.resolution_m, "origin_m": [g.origin_x_m, g.origin_y_m],
        "width": g.width, "height": g.height, "data": truth.data,
        "start": [1.5, 1.5, 0.0], "robot_radius_m": 0.25, "range_m": 4.0, "speed_mps": 2.0,
    })
    .to_string()
}

/// The node's configuration in the closed loop: faster decisions and a tighter pose timeout than
/// the defaults, so that a run takes seconds.
const NODE_YAML: &str = "node:\n  replan_period_s: 0.5\n  pose_timeout_s: 1.0\n  goal_timeout_s: 60\n  max_mission_s: 400\n";

/// The node explores the two-room world (14 m × 10 m, a door, three boxes) to the end against
/// the rclpy stack; returns the stack's summary after the common checks: `phase: done` with no
/// frontier left, a clean exit, ≥ 90 % of the reachable floor known, every goal the action
/// server received and every goal marker on a free cell of the ground truth, markers in every
/// namespace the node draws while it explores, and goals sent through the action server.
/// Returns the summary, everything for assertion messages, and the node's log.
fn explore_against_rclpy_stack(name: &str, faults: &str, node_yaml: &str, domain: u16) -> (Value, String, String) {
    let dir = scratch_dir(name);
    std::fs::write(dir.join("world.json"), world_json()).unwrap();
    let config = dir.join("node.yaml");
    std::fs::write(&config, node_yaml).unwrap();
    let out = dir.join("summary.json");
    let (w, o) = (dir.join("world.json"), out.clone());
    let args = ["--world", w.to_str().unwrap(), "--out", o.to_str().unwrap(), "--limit", "300", "--faults", faults];
    let run = run_beside_node(&dir, &config, &peer_script("nav2_stack.py"), &args, domain);
    let context = run.context();
    assert!(run.peer_ok, "{context}");
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(&out).expect(&context)).unwrap();
    let context = format!("summary: {summary:#}\n{context}");
    let last = &summary["last"];
    assert_eq!(last["phase"], "done", "{context}");
    assert!(last["done_reason"].as_str().unwrap_or("").contains("frontier left"), "{context}");
    assert_eq!(run.node_exit, Some(0), "{context}");
    assert!(summary["explored"].as_f64().unwrap() >= 0.9, "{context}");
    assert_eq!(summary["goals_free_on_truth"], true, "{context}");
    assert!(summary["goals"].as_array().unwrap().len() >= 3, "goals went through rclpy's action server: {context}");
    assert!(summary["goal_markers"].as_u64().unwrap() > 0 && summary["goal_markers_free_on_truth"] == true, "{context}");
    for ns in ["frontiers", "candidates", "theta_star", "path", "goal"] {
        assert!(summary["marker_namespaces"][ns].as_u64().is_some_and(|n| n > 0), "markers in `{ns}`: {context}");
    }
    (summary, context, run.node_log)
}

#[test]
fn rclpy_nav2_stand_in_explores_the_world_to_the_end() {
    // With the return to the start: one last goal through the action server.
    let yaml = format!("{NODE_YAML}  return_to_start: true\n");
    let (summary, context, _) = explore_against_rclpy_stack("rclpy-nav2", "none", &yaml, private_domain(60, 10));
    assert!(summary["last"]["done_reason"].as_str().unwrap().ends_with("; returned to the start"), "{context}");
    let home = summary["goals"].as_array().unwrap().last().cloned().unwrap();
    assert!((home[0].as_f64().unwrap() - 1.5).hypot(home[1].as_f64().unwrap() - 1.5) < 0.3 && home[2] == "succeeded", "{context}");
    // Without faults nothing is lost, rejected or timed out (a frontier goal next to a wall the
    // map has not seen yet may still have no path: Nav2 aborts those too).
    let stats = &summary["last"]["stats"];
    for counter in ["lost", "rejected", "timed_out"] {
        assert_eq!(stats[counter], 0, "{counter}: {context}");
    }
}

#[test]
fn rclpy_sees_a_publish_only_node_rank_and_suggest_without_sending_a_goal_on_the_pose_topic() {
    let dir = scratch_dir("rclpy-publish-only");
    std::fs::write(dir.join("world.json"), world_json()).unwrap();
    let config = dir.join("node.yaml");
    // The pose from the SLAM's PoseWithCovarianceStamped this time, not tf.
    std::fs::write(&config, format!("{NODE_YAML}  publish_only: true\n  pose_source: topic\n")).unwrap();
    let (w, o) = (dir.join("world.json"), dir.join("summary.json"));
    let args = ["--world", w.to_str().unwrap(), "--out", o.to_str().unwrap(), "--limit", "8", "--faults", "none"];
    let run = run_beside_node(&dir, &config, &peer_script("nav2_stack.py"), &args, private_domain(80, 10));
    let context = run.context();
    assert!(run.peer_ok, "{context}");
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(&o).expect(&context)).unwrap();
    let context = format!("summary: {summary:#}\n{context}");
    assert_eq!(summary["goals"], serde_json::json!([]), "no goal reached rclpy's action server: {context}");
    let suggested = &summary["last"]["suggested_goal"];
    assert!(suggested["x_m"].is_f64() && summary["last"]["goal"].is_null(), "{context}");
    let robot = &summary["last"]["robot"];
    assert!((robot["x_m"].as_f64().unwrap() - 1.5).hypot(robot["y_m"].as_f64().unwrap() - 1.5) < 1e-3, "the pose topic's pose: {context}");
    for ns in ["frontiers", "candidates", "goal"] {
        assert!(summary["marker_namespaces"][ns].as_u64().is_some_and(|n| n > 0), "markers in `{ns}`: {context}");
    }
}

#[test]
fn rclpy_stack_faults_give_warnings_not_crashes() {
    // The action server's silence after its restart is noticed after 3 s.
    let yaml = format!("{NODE_YAML}  goal_feedback_timeout_s: 3\n");
    let (summary, context, node_log) = explore_against_rclpy_stack("rclpy-nav2-faults", "all", &yaml, private_domain(70, 10));
    let warnings = summary["warnings"].as_array().unwrap().iter().map(|w| w.as_str().unwrap().to_owned()).collect::<Vec<_>>().join("\n");
    let goals = summary["goals"].as_array().unwrap();
    for outcome in ["rejected", "aborted", "lost in a server restart"] {
        assert!(goals.iter().any(|g| g[2] == outcome), "the stack's `{outcome}` goal happened: {context}");
    }
    for (fault, needle) in [
        ("volatile map publisher", "VOLATILE"),
        ("rejected goal", "rejected"),
        ("aborted goal", "aborted"),
        // The node's goal on the server that went away is dropped: by the feedback timeout, or
        // (when the node had replaced it meanwhile) its successor's unanswered request.
        ("action server restarted", "from the navigation server"),
        ("tf stale", "pose stale: tf"),
        ("map → odom stopped", "pose stale: tf map → odom"),
        ("late pose, map → odom missing", "base_link's tree ends at odom"),
        ("a map whose data does not match its size", "cells of data but width × height"),
    ] {
        assert!(warnings.contains(needle), "{fault}: a warning with `{needle}` in the status; warnings:\n{warnings}\n{context}");
    }
    // Nothing lost: the goal on the vanished server was dropped, not blacklisted; the rejected
    // and the aborted ones were.
    let stats = &summary["last"]["stats"];
    assert!(stats["lost"].as_u64().unwrap() >= 1 && stats["rejected"] == 1 && stats["failed"].as_u64().unwrap() >= 1, "{context}");
    // The map grew (changed size) many times, as a SLAM's does, and ended whole.
    assert!(node_log.matches("map geometry changed").count() >= 3, "{context}");
    assert_eq!(summary["last"]["map_cells"], serde_json::json!([140, 100]), "{context}");
    let phases = summary["phases"].as_array().unwrap();
    assert!(phases.iter().any(|p| p == "waiting_for_map") && phases.iter().any(|p| p == "waiting_for_pose"), "{context}");
}
