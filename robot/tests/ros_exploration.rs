//! The node binary over real DDS (ros2-client / RustDDS on 127.0.0.1, a private domain) against
//! a simulated robot — map, landmark cloud and /tf publishers — and a minimal Nav2
//! NavigateToPose action server, all written here on ros2-client. Exploration of a small world
//! must complete within a time bound with every goal on a cell free in a map the node was sent
//! (and, where that map is the ground truth, free in the truth), while the harness injects
//! faults: dropped, late and NaN maps, a map that grows (changes size), one aborted goal and a
//! pose that stops updating for a few seconds.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;

use common::core_sim::CoreSim;
use common::sim::{GridSim, SimRobot, two_rooms};
use common::{NodeProcess, RobotSide, private_domain, scratch_dir, tf_msg};
use fitslam_core::grid::{CellClass, Grid, UNKNOWN, inflate_lethal};
use fitslam_core::ros::{cloud_of_points, msg_of_occupancy, pose_of_pose2, pose2_of_pose};
use fitslam_core::{GridGeometry, OccupancyGrid, Pose2};
use fitslam_msgs::{Header, NavigateToPoseFeedback, NavigateToPoseResult, PoseStamped};
use fitslam_robot::ros::{make_context, now_stamp};
use ros2_client::action::{GetResultResponse, GoalId, GoalStatusEnum, SendGoalResponse};
use ros2_client::action_msgs::{CancelGoalResponse, CancelGoalResponseEnum};
use ros2_client::{NodeName, NodeOptions, RmwRequestId};
use std::time::{Duration, Instant};

const ROBOT_RADIUS_M: f64 = 0.25;
const TIME_LIMIT_S: f64 = 240.0;

/// The map the sim publishes: the bounding box of the known cells plus 1 m, so that it grows
/// (changes size and origin) as the robot explores, like RTAB-Map's.
fn cropped(map: &OccupancyGrid) -> OccupancyGrid {
    let g = map.geometry;
    let (mut c0, mut r0, mut c1, mut r1) = (usize::MAX, usize::MAX, 0, 0);
    for (i, &v) in map.data.iter().enumerate() {
        if v != UNKNOWN {
            let (c, r) = (i % g.width, i / g.width);
            (c0, r0, c1, r1) = (c0.min(c), r0.min(r), c1.max(c), r1.max(r));
        }
    }
    let m = (1.0 / g.resolution_m).round() as usize;
    let (c0, r0) = (c0.saturating_sub(m), r0.saturating_sub(m));
    let (c1, r1) = ((c1 + m).min(g.width - 1), (r1 + m).min(g.height - 1));
    let (w, h) = (c1 + 1 - c0, r1 + 1 - r0);
    let geo = GridGeometry::new(g.origin_x_m + c0 as f64 * g.resolution_m, g.origin_y_m + r0 as f64 * g.resolution_m, g.resolution_m, w, h);
    let mut out = Grid::filled(geo, UNKNOWN);
    for r in 0..h {
        for c in 0..w {
            out.data[r * w + c] = map.data[(r + r0) * g.width + c + c0];
        }
    }
    out
}

struct Running {
    goal_id: GoalId,
    result_req: Option<RmwRequestId>,
    outcome: Option<(GoalStatusEnum, NavigateToPoseResult)>,
}

#[test]
fn node_explores_a_simulated_world_over_dds_despite_faults() {
    let mut sim = GridSim::new(two_rooms(), Pose2::new(1.5, 1.5, 0.0), ROBOT_RADIUS_M);
    explore_over_dds(&mut sim, "ros-exploration", private_domain(100, 50), 0.9);
}

/// The same closed loop with the core's simulator as the robot: 3D terrain, the LiDAR ray-cast
/// into a traversability map, the camera mapping landmarks.
#[test]
fn node_explores_a_core_simulator_world_over_dds_despite_faults() {
    let world = include_str!("../../assets/worlds/tiny_test.toml");
    let mut sim = CoreSim::new(world, "tiny_test.toml", fitslam_core::Params::default(), 7).expect("tiny_test world");
    explore_over_dds(&mut sim, "ros-exploration-core-sim", private_domain(150, 50), 0.85);
}

/// Runs the node binary against `sim` until it reports `done`, injecting the faults, and checks
/// that every goal was free, the exploration completed (≥ `min_explored` of the explorable
/// cells known) and the faults were logged.
fn explore_over_dds(sim: &mut dyn SimRobot, name: &str, domain: u16, min_explored: f64) {
    let dir = scratch_dir(name);
    let config = dir.join("node.yaml");
    std::fs::write(
        &config,
        "node:\n  replan_period_s: 0.5\n  pose_timeout_s: 1.5\n  goal_timeout_s: 60\n  goal_response_timeout_s: 5\n  max_mission_s: 600\n",
    )
    .unwrap();

    // The simulated robot's side.
    let ctx = make_context(domain, true).expect("loopback DDS participant");
    let mut node = ctx.new_node(NodeName::new("/", "sim_robot").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
    let RobotSide { map_pub, cloud_pub, tf_pub, status_sub, server } = RobotSide::new(&mut node);

    // With rerun built in, the node also records the mission.
    let rrd = dir.join("mission.rrd");
    let rrd_arg = rrd.display().to_string();
    let extra: Vec<&str> = if cfg!(feature = "rerun") { vec!["--rerun-save", &rrd_arg] } else { vec![] };
    let mut proc = NodeProcess::start_with(&config, domain, &dir, &extra);
    let mut published: Vec<OccupancyGrid> = Vec::new();
    let mut running: Option<Running> = None;
    // Results to send: (result request, status, result).
    let mut finished: Vec<(RmwRequestId, GoalStatusEnum, NavigateToPoseResult)> = Vec::new();
    let mut goals: Vec<Pose2> = Vec::new();
    let mut bad_goals: Vec<String> = Vec::new();
    let mut mapping_errors = 0usize;
    let mut last_status = String::new();
    let (mut maps, mut done) = (0u32, false);
    let t0 = Instant::now();
    let (mut last_map_s, mut last_cloud_s, mut last_tf_s) = (-1.0, -1.0, -1.0);
    let dt = 0.02;

    while t0.elapsed().as_secs_f64() < TIME_LIMIT_S {
        let t = t0.elapsed().as_secs_f64();
        // Fault: the pose stops updating for 3 s (the node must wait, then go on).
        let pose_paused = (6.0..9.0).contains(&t);
        if t - last_tf_s >= 0.05 && !pose_paused {
            last_tf_s = t;
            let _ = tf_pub.publish(tf_msg(sim.pose()));
        }
        if t - last_map_s >= 0.5 {
            last_map_s = t;
            maps += 1;
            let grid = cropped(sim.map());
            let mut m = msg_of_occupancy(&grid, Header::new(now_stamp(), "map"));
            match maps % 6 {
                2 => m.info.resolution = f32::NAN,                            // NaN field
                4 => m.header.stamp = fitslam_msgs::Time::from_secs_f64(1.0), // late
                5 => {}                                                       // dropped
                _ => {
                    let _ = map_pub.publish(m.clone());
                    published.push(grid);
                    if published.len() > 8 {
                        published.remove(0);
                    }
                }
            }
            if matches!(maps % 6, 2 | 4) {
                let _ = map_pub.publish(m);
            }
        }
        if t - last_cloud_s >= 1.0 {
            last_cloud_s = t;
            let _ = cloud_pub.publish(cloud_of_points(&sim.landmarks(), Header::new(now_stamp(), "map")));
        }

        // The action server.
        while let Ok(Some((req_id, req))) = server.receive_goal() {
            let g = pose2_of_pose(&req.goal.pose.pose).unwrap_or(Pose2::new(f64::NAN, f64::NAN, 0.0));
            let free_somewhere = published
                .iter()
                .any(|m| inflate_lethal(m, ROBOT_RADIUS_M).at_world(g.x_m, g.y_m).is_some_and(|&v| CellClass::of(v) == CellClass::Free));
            // On an estimated map, a goal the map calls free may be lethal in the truth: a
            // mapping error, not the node's; the server aborts it and the node must go on.
            let truth_lethal = sim.truth_lethal(g.x_m, g.y_m);
            if truth_lethal && !sim.map_is_truth() {
                mapping_errors += 1;
            }
            if !free_somewhere || (truth_lethal && sim.map_is_truth()) || req.goal.pose.header.frame_id != "map" {
                let why = if !free_somewhere {
                    "not free in any recent map"
                } else if truth_lethal {
                    "lethal in the ground truth"
                } else {
                    "wrong frame"
                };
                bad_goals.push(format!("{g:?} in '{}': {why}", req.goal.pose.header.frame_id));
            }
            goals.push(g);
            let _ =
                server.send_goal_response(req_id, SendGoalResponse { accepted: true, stamp: ros2_client::builtin_interfaces::Time::now() });
            if let Some(rid) = running.take().and_then(|r| r.result_req) {
                // Preempted, as Nav2 does.
                finished.push((rid, GoalStatusEnum::Canceled, NavigateToPoseResult::default()));
            }
            // Fault: the second goal is aborted by "the controller".
            let outcome = if goals.len() == 2 {
                Some((GoalStatusEnum::Aborted, NavigateToPoseResult { error_code: 9000, error_msg: "simulated controller failure".into() }))
            } else {
                match sim.go_to(g) {
                    Ok(()) => None,
                    Err(why) => Some((GoalStatusEnum::Aborted, NavigateToPoseResult { error_code: 9001, error_msg: why })),
                }
            };
            running = Some(Running { goal_id: req.goal_id, result_req: None, outcome });
        }
        while let Ok(Some((rid, rr))) = server.receive_result_request() {
            match &mut running {
                Some(r) if r.goal_id == rr.goal_id => r.result_req = Some(rid),
                _ => finished.push((rid, GoalStatusEnum::Canceled, NavigateToPoseResult::default())),
            }
        }
        while let Ok(Some((rid, req))) = server.receive_cancel_request() {
            // ros2-client keeps the request's goal id private; read it through serde.
            let target = serde_json::to_value(&req).ok().map(|v| v["goal_info"]["goal_id"].clone());
            let is_running = running.as_ref().is_some_and(|r| serde_json::to_value(r.goal_id).ok() == target);
            if is_running && let Some(r) = running.take() {
                sim.stop();
                if let Some(rid) = r.result_req {
                    finished.push((rid, GoalStatusEnum::Canceled, NavigateToPoseResult::default()));
                }
            }
            let _ =
                server.send_cancel_response(rid, CancelGoalResponse { return_code: CancelGoalResponseEnum::None, goals_canceling: vec![] });
        }
        if let Some(r) = &mut running
            && r.outcome.is_none()
        {
            if sim.advance(dt) {
                r.outcome = Some((GoalStatusEnum::Succeeded, NavigateToPoseResult::default()));
            } else {
                // Nav2 sends feedback while it drives (the node drops a goal whose server falls silent).
                let pose = PoseStamped { header: Header::new(now_stamp(), "map"), pose: pose_of_pose2(sim.pose()) };
                let feedback = NavigateToPoseFeedback { current_pose: pose, ..Default::default() };
                let _ = server.send_feedback(r.goal_id, feedback);
            }
        }
        if let Some(r) = running.take() {
            match (r.result_req, r.outcome.clone()) {
                (Some(rid), Some((status, result))) => finished.push((rid, status, result)),
                _ => running = Some(r),
            }
        }
        for (rid, status, result) in finished.drain(..) {
            let _ = server.send_result(rid, GetResultResponse { status, result });
        }

        while let Ok(Some((s, _))) = status_sub.take() {
            done |= s.data.contains("\"phase\":\"done\"");
            last_status = s.data;
        }
        if done {
            break;
        }
        if let Ok(Some(st)) = proc.child.try_wait() {
            panic!("node exited early ({st}):\n{}", proc.log());
        }
        std::thread::sleep(Duration::from_secs_f64(dt));
    }
    let elapsed = t0.elapsed().as_secs_f64();
    let exit = proc.wait_exit(10.0);
    let log = proc.log();
    eprintln!(
        "DDS exploration ({name}): {} goals ({mapping_errors} free in the map but lethal in the truth), {:.1}% explored, {:.1} s; last status {last_status}",
        goals.len(),
        100.0 * sim.explored_fraction(),
        elapsed
    );
    assert!(done, "no 'done' status within {TIME_LIMIT_S} s (explored {:.3}); node log:\n{log}", sim.explored_fraction());
    assert!(exit.is_some_and(|s| s.success()), "node did not exit cleanly: {exit:?}\n{log}");
    assert!(bad_goals.is_empty(), "goals not free: {bad_goals:?}\n{log}");
    assert!(goals.len() >= 3, "{log}");
    assert!(sim.explored_fraction() > min_explored, "explored {:.3}\n{log}", sim.explored_fraction());
    if cfg!(feature = "rerun") {
        let bytes = std::fs::read(&rrd).unwrap_or_default();
        assert!(bytes.len() > 10_000 && bytes.starts_with(b"RRF"), "rerun recording: {} bytes", bytes.len());
    }
    for needle in [
        "map rejected: map resolution",
        "late map dropped",
        "aborted (error 9000: simulated controller failure)",
        "pose stale",
        "map geometry changed",
    ] {
        assert!(log.contains(needle), "node log lacks '{needle}':\n{log}");
    }
}
