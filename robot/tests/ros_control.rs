//! The node binary over real DDS (ros2-client / RustDDS on 127.0.0.1, a private domain) obeys its
//! control topic: on the corridor map with topic goals it navigates, `pause` makes it cancel
//! and report `paused`, `resume` sends a goal again, `stop` ends the mission with a clean exit.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;

use common::{NodeProcess, RobotSide, private_domain, scratch_dir, tf_msg};
use fitslam_core::fixtures::corridor_two_frontiers;
use fitslam_core::ros::{cloud_of_points, msg_of_occupancy};
use fitslam_msgs::{Header, StringMsg};
use fitslam_robot::ros::{advertise, make_context, now_stamp, reliable};
use ros2_client::{NodeName, NodeOptions};
use std::time::{Duration, Instant};

#[test]
fn node_pauses_resumes_and_stops_on_its_control_topic_over_dds() {
    let domain = private_domain(210, 20);
    let dir = scratch_dir("ros-control");
    let config = dir.join("node.yaml");
    std::fs::write(&config, "node:\n  goal_interface: topic\n  replan_period_s: 0.5\n").unwrap();
    let ctx = make_context(domain, true).expect("loopback DDS participant");
    let mut node = ctx.new_node(NodeName::new("/", "control_peer").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
    let RobotSide { map_pub, cloud_pub, tf_pub, status_sub, server: _server } = RobotSide::new(&mut node);
    let control_pub = advertise::<StringMsg>(&mut node, "/fitslam/control", reliable(10)).unwrap();
    let mut proc = NodeProcess::start(&config, domain, &dir);

    let w = corridor_two_frontiers(true);
    // What to say once the node reports each phase, in order.
    let mut script = vec![("navigating", "pause"), ("paused", "resume"), ("navigating", "stop")];
    let (mut seen, mut last_status, mut said_at) = (Vec::new(), String::new(), -1.0);
    let t0 = Instant::now();
    let (mut last_map_s, mut last_tf_s) = (-1.0, -1.0);
    while t0.elapsed().as_secs_f64() < 60.0 {
        let t = t0.elapsed().as_secs_f64();
        if t - last_tf_s >= 0.05 {
            last_tf_s = t;
            let _ = tf_pub.publish(tf_msg(w.robot));
        }
        if t - last_map_s >= 1.0 {
            last_map_s = t;
            let _ = map_pub.publish(msg_of_occupancy(&w.grid, Header::new(now_stamp(), "map")));
            let _ = cloud_pub.publish(cloud_of_points(&w.landmarks.points, Header::new(now_stamp(), "map")));
        }
        while let Ok(Some((s, _))) = status_sub.take() {
            last_status = s.data;
        }
        let phase = status_phase(&last_status);
        if seen.last() != Some(&phase) && !phase.is_empty() {
            seen.push(phase.clone());
        }
        // Repeated every second until the node's phase moves on (a message may race discovery).
        if let Some(&(when, command)) = script.first() {
            if phase == when && t - said_at >= 1.0 {
                let _ = control_pub.publish(StringMsg { data: command.into() });
                said_at = t;
            } else if phase != when && said_at >= 0.0 {
                script.remove(0);
                said_at = -1.0;
            }
        }
        if phase == "done" {
            break;
        }
        if let Ok(Some(st)) = proc.child.try_wait() {
            panic!("node exited early ({st}):\n{}", proc.log());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let exit = proc.wait_exit(10.0);
    let log = proc.log();
    assert!(last_status.contains("stopped on request"), "last status {last_status}\nphases {seen:?}\n{log}");
    assert!(exit.is_some_and(|s| s.success()), "node did not exit cleanly: {exit:?}\n{log}");
    let order: Vec<&str> = seen.iter().map(String::as_str).filter(|p| ["navigating", "paused", "done"].contains(p)).collect();
    assert_eq!(order, ["navigating", "paused", "navigating", "done"], "{seen:?}\n{log}");
}

/// The `phase` field of a status JSON ("" if none).
fn status_phase(status: &str) -> String {
    status.split("\"phase\":\"").nth(1).and_then(|r| r.split('"').next()).unwrap_or("").to_owned()
}
