//! The exploration state machine against the simulated robot, without DDS, on a simulated
//! clock: exploration of a small world completes, every goal is free, and the faults the node
//! must survive (late and NaN messages, a growing map, aborts, a pose that stops) only slow it
//! down.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;

use common::sim::{GridSim, SimRobot, two_rooms};
use fitslam_core::grid::{CellClass, inflate_lethal};
use fitslam_core::ros::{cloud_of_points, msg_of_occupancy};
use fitslam_core::{Params, Pose2};
use fitslam_msgs::{Header, Quaternion, TFMessage, Time, Transform, TransformStamped, Vector3};
use fitslam_robot::config::NodeConfig;
use fitslam_robot::node::{Command, ExplorerNode, GoalEvent};

fn tf(p: Pose2, stamp_s: f64) -> TFMessage {
    TFMessage {
        transforms: vec![TransformStamped {
            header: Header::new(Time::from_secs_f64(stamp_s), "map"),
            child_frame_id: "base_link".into(),
            transform: Transform { translation: Vector3 { x: p.x_m, y: p.y_m, z: 0.0 }, rotation: Quaternion::from_yaw(p.yaw_rad) },
        }],
    }
}

struct Outcome {
    goals: usize,
    explored: f64,
    done: bool,
    log: String,
    end_s: f64,
}

/// Runs a mission on simulated time (20 ms ticks, at most `limit_s`); `faults` injects one of
/// each fault.
fn mission(faults: bool, limit_s: f64) -> Outcome {
    let params = Params::default();
    let cfg = NodeConfig { replan_period_s: 0.5, goal_timeout_s: 60.0, ..NodeConfig::default() };
    let mut sim = GridSim::new(two_rooms(), Pose2::new(1.5, 1.5, 0.0), params.robot.radius_m);
    let mut e = ExplorerNode::new(cfg, params.clone()).unwrap();
    let mut log = String::new();
    let (dt, mut t) = (0.02, 0.0);
    let mut goal: Option<u64> = None;
    let mut goals = 0;
    let mut maps_sent = 0u32;
    while t < limit_s && !e.is_done() {
        let pose_paused = faults && (5.0..9.0).contains(&t);
        if !pose_paused {
            e.handle_tf(&tf(sim.pose(), t), false, t);
        }
        if ((t * 50.0).round() as u64).is_multiple_of(25) {
            maps_sent += 1;
            let header = Header::new(Time::from_secs_f64(1.0 + t), "map");
            let mut m = msg_of_occupancy(sim.map(), header.clone());
            if faults && maps_sent % 7 == 3 {
                m.info.resolution = f32::NAN; // a NaN field
            }
            if faults && maps_sent % 7 == 5 {
                m.header.stamp = Time::from_secs_f64(0.5); // late
            }
            if !(faults && maps_sent.is_multiple_of(5)) {
                // (every 5th map dropped)
                e.handle_map(&m, t);
            }
            e.handle_landmarks(&cloud_of_points(&sim.landmarks(), header), t);
        }
        for c in e.tick(t) {
            match c {
                Command::SendGoal { id, goal: g } => {
                    goals += 1;
                    let map = inflate_lethal(e.map().expect("a map"), params.robot.radius_m);
                    assert!(map.at_world(g.x_m, g.y_m).is_some_and(|&v| CellClass::of(v) == CellClass::Free), "goal {g:?} not free");
                    assert!(!sim.truth_lethal(g.x_m, g.y_m));
                    if faults && goals == 2 {
                        e.on_goal_event(id, GoalEvent::Accepted, t);
                        e.on_goal_event(id, GoalEvent::Aborted("simulated controller failure".into()), t);
                        continue;
                    }
                    match sim.go_to(g) {
                        Ok(()) => {
                            e.on_goal_event(id, GoalEvent::Accepted, t);
                            goal = Some(id);
                        }
                        Err(why) => e.on_goal_event(id, GoalEvent::Aborted(why), t),
                    }
                }
                Command::CancelGoal { id } => {
                    if goal == Some(id) {
                        sim.stop();
                        goal = None;
                    }
                }
                Command::MissionComplete => {}
            }
        }
        if let Some(id) = goal {
            if sim.advance(dt) {
                e.on_goal_event(id, GoalEvent::Succeeded, t);
                goal = None;
            } else {
                e.on_goal_event(id, GoalEvent::Feedback, t);
            }
        }
        for l in e.drain_log() {
            log.push_str(&format!("[{:7.2}] {:?} {}\n", l.t_s, l.level, l.text));
        }
        t += dt;
    }
    Outcome { goals, explored: sim.explored_fraction(), done: e.is_done(), log, end_s: t }
}

#[test]
fn exploration_of_two_rooms_completes() {
    let o = mission(false, 600.0);
    assert!(o.done, "not done after {} s:\n{}", o.end_s, o.log);
    assert!(o.explored > 0.95, "explored {:.3}:\n{}", o.explored, o.log);
    assert!(o.goals >= 3, "{}", o.log);
    eprintln!("clean: {} goals, {:.1}% explored, {:.1} s simulated", o.goals, 100.0 * o.explored, o.end_s);
}

#[test]
fn exploration_survives_faults_and_says_why() {
    let o = mission(true, 600.0);
    assert!(o.done, "not done after {} s:\n{}", o.end_s, o.log);
    assert!(o.explored > 0.9, "explored {:.3}:\n{}", o.explored, o.log);
    for needle in ["map rejected: map resolution", "late map dropped", "aborted (simulated controller failure)", "pose stale"] {
        assert!(o.log.contains(needle), "log lacks '{needle}':\n{}", o.log);
    }
    eprintln!("faults: {} goals, {:.1}% explored, {:.1} s simulated", o.goals, 100.0 * o.explored, o.end_s);
}
