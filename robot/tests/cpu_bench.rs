//! CPU use of the node binary at 1 Hz replanning on the asset map `assets/maps/jacksboro`
//! (400 × 400 cells at 5 cm, 1196 landmarks), over real DDS on 127.0.0.1: a publisher feeds the
//! map (latched), the landmark cloud (1 Hz) and /tf (20 Hz, robot at the scene's start pose), and
//! a NavigateToPose server accepts goals and never finishes them, so the node keeps deciding
//! once a second for the whole window. The node's own CPU time (utime + stime of its process,
//! /proc/<pid>/stat) is sampled over the window.
//!
//! Ignored by default (it is a measurement, and takes a minute); run it in release:
//! `cargo test -p fitslam-robot --release --no-default-features --test cpu_bench -- --ignored --nocapture`
//! (`FITSLAM_CPU_BENCH_S` sets the window, default 60 s).

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;

use common::{NodeProcess, RobotSide, private_domain, scratch_dir};
use fitslam_core::io::{load_cloud, load_map};
use fitslam_core::ros::{cloud_of_points, msg_of_occupancy};
use fitslam_msgs::{Header, Quaternion, TFMessage, Transform, TransformStamped, Vector3};
use fitslam_robot::ros::{make_context, now_stamp};
use ros2_client::action::SendGoalResponse;
use ros2_client::{NodeName, NodeOptions};
use std::time::{Duration, Instant};

const ASSET: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/maps/jacksboro");

/// utime + stime of a process, seconds.
fn cpu_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the ")" that closes the command name: state is field 3, utime 14, stime 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11).and_then(|v| v.parse().ok()).unwrap_or(0.0) + f.get(12).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    let hz: f64 = std::process::Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8_lossy(&o.stdout).trim().parse().ok())
        .unwrap_or(100.0);
    ticks / hz
}

fn decisions_in(status: &str) -> Option<u64> {
    let v: serde_json::Value = serde_json::from_str(status).ok()?;
    v["stats"]["decisions"].as_u64()
}

#[test]
#[ignore = "measurement: run in release with --ignored"]
fn cpu_use_at_1hz_replanning_on_the_asset_map() {
    let window_s: f64 = std::env::var("FITSLAM_CPU_BENCH_S").ok().and_then(|v| v.parse().ok()).unwrap_or(60.0);
    let yaml = std::fs::read(format!("{ASSET}/map.yaml")).unwrap();
    let pgm = std::fs::read(format!("{ASSET}/map.pgm")).unwrap();
    let grid = load_map(&yaml, "map.yaml", &pgm, "map.pgm").unwrap();
    let landmarks = load_cloud(&std::fs::read(format!("{ASSET}/landmarks.ply")).unwrap(), "landmarks.ply").unwrap();
    let (x0, y0) = (3.0, 3.0); // scene.toml's start

    let domain = private_domain(200, 30);
    let dir = scratch_dir("cpu-bench");
    let config = dir.join("node.yaml");
    std::fs::write(&config, "node:\n  replan_period_s: 1.0\n  goal_timeout_s: 100000\n").unwrap();

    let ctx = make_context(domain, true).unwrap();
    let mut node = ctx.new_node(NodeName::new("/", "bench_robot").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
    let RobotSide { map_pub, cloud_pub, tf_pub, status_sub, server } = RobotSide::new(&mut node);
    let proc = NodeProcess::start(&config, domain, &dir);
    let pid = proc.child.id();
    let _ = map_pub.publish(msg_of_occupancy(&grid, Header::new(now_stamp(), "map")));

    let t0 = Instant::now();
    let warmup_s = 5.0;
    let (mut last_tf, mut last_cloud) = (-1.0, -1.0);
    let (mut cpu0, mut dec0, mut goals) = (None, None, 0);
    let mut last_status = String::new();
    while t0.elapsed().as_secs_f64() < warmup_s + window_s {
        let t = t0.elapsed().as_secs_f64();
        if t - last_tf >= 0.05 {
            last_tf = t;
            let tr = |p: &str, c: &str, x, y| TransformStamped {
                header: Header::new(now_stamp(), p),
                child_frame_id: c.into(),
                transform: Transform { translation: Vector3 { x, y, z: 0.0 }, rotation: Quaternion::default() },
            };
            let _ = tf_pub.publish(TFMessage { transforms: vec![tr("map", "odom", 0.0, 0.0), tr("odom", "base_link", x0, y0)] });
        }
        if t - last_cloud >= 1.0 {
            last_cloud = t;
            let _ = cloud_pub.publish(cloud_of_points(&landmarks.points, Header::new(now_stamp(), "map")));
        }
        while let Ok(Some((rid, _))) = server.receive_goal() {
            goals += 1;
            let _ =
                server.send_goal_response(rid, SendGoalResponse { accepted: true, stamp: ros2_client::builtin_interfaces::Time::now() });
        }
        while let Ok(Some(_)) = server.receive_result_request() {}
        while let Ok(Some((s, _))) = status_sub.take() {
            last_status = s.data;
        }
        if cpu0.is_none() && t >= warmup_s {
            cpu0 = Some((cpu_s(pid), t));
            dec0 = decisions_in(&last_status);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let (c0, ts0) = cpu0.unwrap();
    let (c1, ts1) = (cpu_s(pid), t0.elapsed().as_secs_f64());
    let decisions = decisions_in(&last_status).unwrap_or(0) - dec0.unwrap_or(0);
    let ms: f64 = serde_json::from_str::<serde_json::Value>(&last_status)
        .ok()
        .and_then(|v| v["stats"]["last_decision_ms"].as_f64())
        .unwrap_or(f64::NAN);
    let pct = 100.0 * (c1 - c0) / (ts1 - ts0);
    eprintln!(
        "node CPU: {:.2} s over {:.1} s = {pct:.2}% of one core; {decisions} decisions ({:.2}/s), last decision {ms:.1} ms; {goals} goals",
        c1 - c0,
        ts1 - ts0,
        decisions as f64 / (ts1 - ts0)
    );
    assert!(decisions > 0 && goals > 0, "the node made no decision: {last_status}\n{}", proc.log());
}
