//! The state machine with fake inputs: no DDS, explicit clock.

use super::*;
use crate::config::{GoalInterface, MapSource, NodeConfig, PoseSource};
use fitslam_core::explore::ExploreParams;
use fitslam_core::fixtures::{SyntheticWorldSpec, corridor_two_frontiers, synthetic_world};
use fitslam_core::frontier::BlacklistReason;
use fitslam_core::grid::{CellClass, GridGeometry};
use fitslam_core::grid::{FREE, Grid, LETHAL, UNKNOWN, fill_disc};
use fitslam_core::path::known_around;
use fitslam_core::ros::{cloud_of_points, msg_of_occupancy, pose_of_pose2};
use fitslam_msgs as msgs;
use fitslam_msgs::{Header, Point32, Polygon, PolygonStamped, Quaternion, TFMessage, Time, Transform, TransformStamped, Vector3};
use nalgebra::Point3;

fn header(stamp_s: f64, frame: &str) -> Header {
    Header::new(Time::from_secs_f64(stamp_s), frame)
}

fn map_msg(grid: &OccupancyGrid, stamp_s: f64) -> msgs::OccupancyGrid {
    msg_of_occupancy(grid, header(stamp_s, "map"))
}

fn tf_msg(parent: &str, child: &str, p: Pose2, stamp_s: f64) -> TFMessage {
    TFMessage {
        transforms: vec![TransformStamped {
            header: header(stamp_s, parent),
            child_frame_id: child.into(),
            transform: Transform { translation: Vector3 { x: p.x_m, y: p.y_m, z: 0.0 }, rotation: Quaternion::from_yaw(p.yaw_rad) },
        }],
    }
}

/// map → odom (identity) and odom → base_link at `robot`.
fn feed_pose(e: &mut ExplorerNode, robot: Pose2, now_s: f64) {
    e.handle_tf(&tf_msg("map", "odom", Pose2::new(0.0, 0.0, 0.0), now_s), false, now_s);
    e.handle_tf(&tf_msg("odom", "base_link", robot, now_s), false, now_s);
}

fn goals(cmds: &[Command]) -> Vec<(u64, Pose2)> {
    cmds.iter().filter_map(|c| if let Command::SendGoal { id, goal } = c { Some((*id, *goal)) } else { None }).collect()
}

fn cancels(cmds: &[Command]) -> Vec<u64> {
    cmds.iter().filter_map(|c| if let Command::CancelGoal { id } = c { Some(*id) } else { None }).collect()
}

fn log_has(e: &mut ExplorerNode, needle: &str) -> bool {
    e.drain_log().iter().any(|l| l.text.contains(needle))
}

fn free_on_inflated(grid: &OccupancyGrid, radius_m: f64, g: Pose2) -> bool {
    let inflated = inflate_lethal(grid, radius_m);
    inflated.at_world(g.x_m, g.y_m).is_some_and(|&v| CellClass::of(v) == CellClass::Free)
}

/// The corridor world fed at t = 0; returns the explorer and the world.
fn corridor_explorer(cfg: NodeConfig) -> (ExplorerNode, fitslam_core::fixtures::SyntheticWorld) {
    let w = corridor_two_frontiers(true);
    let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
    e.handle_map(&map_msg(&w.grid, 1.0), 0.0);
    e.handle_landmarks(&cloud_of_points(&w.landmarks.points, header(1.0, "map")), 0.0);
    feed_pose(&mut e, w.robot, 0.0);
    (e, w)
}

#[test]
fn waits_for_the_map_then_the_pose_then_sends_a_free_goal_east() {
    let w = corridor_two_frontiers(true);
    let mut e = ExplorerNode::new(NodeConfig::default(), Params::default()).unwrap();
    assert!(e.tick(0.0).is_empty());
    assert_eq!(e.phase(), Phase::WaitingForMap);
    assert!(log_has(&mut e, "waiting for the map on /map"));
    e.handle_map(&map_msg(&w.grid, 1.0), 0.5);
    e.handle_landmarks(&cloud_of_points(&w.landmarks.points, header(1.0, "map")), 0.5);
    assert!(e.tick(0.6).is_empty(), "not due yet: one decision per second");
    assert!(e.tick(1.0).is_empty());
    assert_eq!(e.phase(), Phase::WaitingForPose);
    assert!(log_has(&mut e, "waiting for tf map ← base_link"));
    feed_pose(&mut e, w.robot, 1.5);
    let cmds = e.tick(2.0);
    let g = goals(&cmds);
    assert_eq!(g.len(), 1, "{cmds:?}");
    let (id, goal) = g[0];
    assert_eq!(id, 1);
    // FIT-SLAM picks the east frontier, where the landmarks are.
    assert!(goal.x_m > w.robot.x_m + 5.0, "{goal:?}");
    assert!(free_on_inflated(&w.grid, 0.25, goal));
    assert_eq!(e.phase(), Phase::Navigating);
    // Kept while it is still a frontier goal.
    feed_pose(&mut e, w.robot, 2.9);
    assert!(e.tick(3.0).is_empty());
    assert_eq!(e.current_goal().map(|g| g.id), Some(1));
}

#[test]
fn aborted_and_rejected_goals_are_blacklisted_and_not_sent_again() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    let (id1, g1) = goals(&e.tick(0.0))[0];
    e.on_goal_event(id1, GoalEvent::Accepted, 0.1);
    e.on_goal_event(id1, GoalEvent::Aborted("controller failed".into()), 0.2);
    assert!(log_has(&mut e, "aborted (controller failed): blacklisted"));
    assert_eq!(e.blacklist().contains(g1.x_m, g1.y_m), Some(BlacklistReason::Failed));
    // Replans at once, not after a period.
    let (id2, g2) = goals(&e.tick(0.25))[0];
    assert_eq!(id2, 2);
    assert!((g2.x_m - g1.x_m).hypot(g2.y_m - g1.y_m) > 0.5, "{g1:?} {g2:?}");
    assert!(g2.x_m < w.robot.x_m, "the other frontier is west");
    e.on_goal_event(id2, GoalEvent::Rejected, 0.3);
    assert_eq!(e.blacklist().contains(g2.x_m, g2.y_m), Some(BlacklistReason::Failed));
    // Both frontiers blacklisted: two empty decisions end the mission.
    assert!(e.tick(0.35).is_empty());
    let cmds = e.tick(1.4);
    assert_eq!(cmds, vec![Command::MissionComplete]);
    assert!(e.is_done());
    assert!(e.status(1.4).done_reason.unwrap().contains("no reachable"));
    assert!(e.tick(5.0).is_empty());
    // Events for old goals are ignored.
    e.on_goal_event(id1, GoalEvent::Succeeded, 5.0);
    assert_eq!(e.stats().succeeded, 0);
}

#[test]
fn a_goal_not_reached_in_time_is_cancelled_and_blacklisted() {
    let cfg = NodeConfig { goal_timeout_s: 30.0, ..NodeConfig::default() };
    let (mut e, w) = corridor_explorer(cfg);
    let (id1, g1) = goals(&e.tick(0.0))[0];
    e.on_goal_event(id1, GoalEvent::Accepted, 0.5);
    for t in 1..=30 {
        e.on_goal_event(id1, GoalEvent::Feedback, t as f64);
        feed_pose(&mut e, w.robot, t as f64);
        assert!(cancels(&e.tick(t as f64)).is_empty());
    }
    feed_pose(&mut e, w.robot, 30.6);
    let cmds = e.tick(30.6);
    assert_eq!(cancels(&cmds), vec![id1]);
    assert_eq!(e.blacklist().contains(g1.x_m, g1.y_m), Some(BlacklistReason::Failed));
    let g = goals(&cmds);
    assert_eq!(g.len(), 1);
    assert!((g[0].1.x_m - g1.x_m).abs() > 1.0);
    assert_eq!(e.stats().timed_out, 1);
}

#[test]
fn no_answer_from_the_server_drops_the_goal_without_blacklisting_it() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    let (id1, g1) = goals(&e.tick(0.0))[0];
    feed_pose(&mut e, w.robot, 5.0);
    assert!(e.tick(5.0).is_empty());
    feed_pose(&mut e, w.robot, 5.1);
    let cmds = e.tick(5.1);
    assert_eq!(cancels(&cmds), vec![id1]);
    assert!(e.blacklist().is_empty());
    assert!(log_has(&mut e, "no answer from the navigation server"));
    // Sent again (a new id) at the next decision.
    feed_pose(&mut e, w.robot, 6.0);
    let g = goals(&e.tick(6.0));
    assert_eq!(g.len(), 1);
    assert_eq!(g[0].0, 2);
    assert!((g[0].1.x_m - g1.x_m).abs() < 1e-9);
}

#[test]
fn an_action_server_gone_silent_drops_the_goal_without_blacklisting_it() {
    let cfg = NodeConfig { goal_feedback_timeout_s: 3.0, ..NodeConfig::default() };
    let (mut e, w) = corridor_explorer(cfg);
    let (id1, g1) = goals(&e.tick(0.0))[0];
    e.on_goal_event(id1, GoalEvent::Accepted, 0.5);
    // Feedback at 2 s keeps it alive until 5 s.
    e.on_goal_event(id1, GoalEvent::Feedback, 2.0);
    feed_pose(&mut e, w.robot, 4.9);
    assert!(cancels(&e.tick(4.9)).is_empty());
    feed_pose(&mut e, w.robot, 5.1);
    let cmds = e.tick(5.1);
    assert_eq!(cancels(&cmds), vec![id1]);
    assert!(e.blacklist().is_empty());
    assert!(log_has(&mut e, "no feedback from the navigation server for 3 s on goal 1"));
    // Decided again at once and sent again, for the server that comes back.
    let g = goals(&cmds);
    assert_eq!(g.len(), 1);
    assert!((g[0].1.x_m - g1.x_m).abs() < 1e-9);
    // 0 turns the check off.
    let cfg = NodeConfig { goal_feedback_timeout_s: 0.0, ..NodeConfig::default() };
    let (mut e, w) = corridor_explorer(cfg);
    let (id1, _) = goals(&e.tick(0.0))[0];
    e.on_goal_event(id1, GoalEvent::Accepted, 0.5);
    feed_pose(&mut e, w.robot, 60.0);
    assert!(cancels(&e.tick(60.0)).is_empty());
}

#[test]
fn a_stale_pose_stops_decisions_and_says_why() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    let _ = e.drain_log();
    assert!(goals(&e.tick(3.0)).is_empty());
    assert_eq!(e.phase(), Phase::PoseStale);
    assert!(log_has(&mut e, "pose stale: tf odom → base_link last received 3.0 s ago"));
    // The odometry comes back.
    feed_pose(&mut e, w.robot, 4.0);
    assert_eq!(goals(&e.tick(4.0)).len(), 1);
}

#[test]
fn nan_fields_and_bad_sizes_are_rejected_and_the_last_good_input_kept() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    // A map whose data length disagrees with its size.
    let mut bad = map_msg(&w.grid, 2.0);
    bad.data.pop();
    e.handle_map(&bad, 0.1);
    assert!(log_has(&mut e, "map rejected: map has 9599 cells of data but width × height = 240 × 40"));
    // NaN origin, NaN resolution.
    let mut bad = map_msg(&w.grid, 2.0);
    bad.info.origin.position.y = f64::NAN;
    e.handle_map(&bad, 0.1);
    let mut bad = map_msg(&w.grid, 2.0);
    bad.info.resolution = f32::NAN;
    e.handle_map(&bad, 0.1);
    // A NaN transform, a NaN quaternion.
    e.handle_tf(&tf_msg("odom", "base_link", Pose2::new(f64::NAN, 0.0, 0.0), 0.2), false, 0.2);
    let mut t = tf_msg("odom", "base_link", w.robot, 0.2);
    t.transforms[0].transform.rotation.w = f64::NAN;
    e.handle_tf(&t, false, 0.2);
    // A NaN pose on the pose topic, a cloud with NaN points, a polygon of NaNs.
    let mut p = msgs::PoseWithCovarianceStamped::default();
    p.pose.pose = pose_of_pose2(Pose2::new(f64::NAN, 1.0, 0.0));
    e.handle_pose(&p, 0.2);
    let mut pts = w.landmarks.points.clone();
    pts.push(Point3::new(f64::NAN, 0.0, 0.0));
    e.handle_landmarks(&cloud_of_points(&pts, header(1.0, "map")), 0.2);
    assert!(log_has(&mut e, "1 of"));
    let nan = Point32 { x: f32::NAN, y: 0.0, z: 0.0 };
    e.handle_boundary(&PolygonStamped { header: header(0.0, "map"), polygon: Polygon { points: vec![nan; 4] } }, 0.2);
    assert_eq!(e.stats().messages_rejected, 7);
    // Still plans on the last good map and pose: a free goal east.
    let g = goals(&e.tick(0.3));
    assert_eq!(g.len(), 1);
    assert!(g[0].1.x_m > w.robot.x_m && free_on_inflated(&w.grid, 0.25, g[0].1));
}

#[test]
fn a_map_in_another_frame_or_late_is_dropped() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    let mut other = map_msg(&w.grid, 2.0);
    other.header.frame_id = "odom".into();
    e.handle_map(&other, 0.1);
    assert!(log_has(&mut e, "frame 'odom' is not the map frame"));
    let blank = Grid::filled(w.grid.geometry, UNKNOWN);
    e.handle_map(&map_msg(&blank, 0.5), 0.2); // stamp 0.5 < 1.0
    assert_eq!(e.stats().messages_late, 1);
    assert!(e.map().is_some_and(|m| m.data == w.grid.data), "the old map is kept");
}

#[test]
fn a_map_that_changes_size_and_makes_the_goal_lethal_cancels_it() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    let (id1, g1) = goals(&e.tick(0.0))[0];
    e.on_goal_event(id1, GoalEvent::Accepted, 0.1);
    // A bigger map (one more metre on every side, 0.1 m cells) with a rock on the goal.
    let old = w.grid.geometry;
    let geometry = GridGeometry::new(-1.0, -1.0, 0.1, old.width + 20, old.height + 20);
    let mut grid = Grid::filled(geometry, UNKNOWN);
    for r in 0..old.height {
        for c in 0..old.width {
            grid.data[(r + 10) * geometry.width + c + 10] = w.grid.data[r * old.width + c];
        }
    }
    let goal_cell = geometry.cell_of(g1.x_m, g1.y_m).unwrap();
    *grid.get_mut(goal_cell).unwrap() = LETHAL;
    e.handle_map(&map_msg(&grid, 2.0), 0.5);
    assert!(log_has(&mut e, "map geometry changed: 240×40"));
    feed_pose(&mut e, w.robot, 0.5);
    let cmds = e.tick(0.5);
    assert_eq!(cancels(&cmds), vec![id1]);
    let g = goals(&cmds);
    assert_eq!(g.len(), 1, "replans at once: {cmds:?}");
    assert!(free_on_inflated(&grid, 0.25, g[0].1), "{:?}", g[0]);
    // The rock is not blacklisted as a failure: nothing failed.
    assert!(e.blacklist().entries().iter().all(|b| b.reason != BlacklistReason::Failed));
}

#[test]
fn a_reached_goal_chosen_again_is_blacklisted_as_reselected_and_a_closed_world_ends_the_mission() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    let (id1, _) = goals(&e.tick(0.0))[0];
    let [fx, fy] = e.current_goal().unwrap().frontier_m.unwrap();
    e.on_goal_event(id1, GoalEvent::Accepted, 0.1);
    e.on_goal_event(id1, GoalEvent::Succeeded, 0.2);
    // Remembered, not yet blacklisted: the map may have moved the frontier on.
    assert_eq!(e.blacklist().contains(fx, fy), None);
    // The robot did not move, so the same frontier is chosen again: blacklisted, the other one
    // (west) is sent at once.
    let g2 = goals(&e.tick(0.2));
    assert_eq!(e.blacklist().contains(fx, fy), Some(BlacklistReason::Reselected));
    assert!(g2.len() == 1 && g2[0].1.x_m < w.robot.x_m, "{g2:?}");
    // Close the corridor: everything known, no frontier.
    let mut grid = w.grid.clone();
    for v in &mut grid.data {
        if *v == UNKNOWN {
            *v = LETHAL;
        }
    }
    e.handle_map(&map_msg(&grid, 2.0), 0.3);
    feed_pose(&mut e, w.robot, 1.2);
    let mut cmds = e.tick(1.2);
    assert!(!e.is_done(), "one empty decision does not end it: {cmds:?}");
    feed_pose(&mut e, w.robot, 2.5);
    cmds.extend(e.tick(2.5));
    assert_eq!(cmds.last(), Some(&Command::MissionComplete), "{cmds:?}");
    assert!(cancels(&cmds).contains(&g2[0].0), "the running goal is cancelled: {cmds:?}");
    assert_eq!(e.status(2.5).phase, Phase::Done);
}

#[test]
fn a_robot_walled_in_by_its_map_is_trapped_not_done() {
    // The corridor world with a ring of lethal cells 0.6 m around the robot (as registration
    // speckle makes one): no frontier is reachable, and every reachable cell is within 2 m.
    let trapped = |cfg: NodeConfig| {
        let w = corridor_two_frontiers(true);
        let mut grid = w.grid.clone();
        let g = grid.geometry;
        for (i, v) in grid.data.iter_mut().enumerate() {
            let (x, y) = g.center_of(g.cell_at(i));
            if ((x - w.robot.x_m).hypot(y - w.robot.y_m) - 0.6).abs() < 0.1 {
                *v = LETHAL;
            }
        }
        let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
        e.handle_map(&map_msg(&grid, 1.0), 0.0);
        feed_pose(&mut e, w.robot, 0.0);
        let mut cmds = e.tick(0.0);
        feed_pose(&mut e, w.robot, 1.0);
        cmds.extend(e.tick(1.0));
        feed_pose(&mut e, w.robot, 2.0);
        cmds.extend(e.tick(2.0));
        (e, cmds)
    };
    let (mut e, cmds) = trapped(NodeConfig::default());
    assert!(cmds.is_empty(), "{cmds:?}");
    assert!(!e.is_done() && e.phase() == Phase::Planning);
    assert!(log_has(&mut e, "walled in by its map, not done"));
    // With the check off, two empty decisions end the mission as before.
    let (e, cmds) =
        trapped(NodeConfig { explore: ExploreParams { trapped_radius_m: 0.0, ..ExploreParams::default() }, ..NodeConfig::default() });
    assert_eq!(cmds, vec![Command::MissionComplete]);
    assert!(e.is_done());
}

/// The corridor world (0.1 m cells) with a lethal blob of radius 0.2 m under the robot: no cell within
/// its radius plus one cell is free after inflation. With footprint clearing a goal follows;
/// without it every decision fails and says why.
#[test]
fn a_robot_blocked_by_speckle_under_it_decides_on_its_cleared_footprint() {
    let run = |cfg: NodeConfig| {
        let w = corridor_two_frontiers(true);
        let mut grid = w.grid.clone();
        fill_disc(&mut grid, w.robot.x_m, w.robot.y_m, 0.2, LETHAL);
        let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
        e.handle_map(&map_msg(&grid, 1.0), 0.0);
        e.handle_landmarks(&cloud_of_points(&w.landmarks.points, header(1.0, "map")), 0.0);
        feed_pose(&mut e, w.robot, 0.0);
        let cmds = e.tick(0.0);
        (e, goals(&cmds), grid)
    };
    let (mut e, sent, grid) = run(NodeConfig::default());
    assert_eq!(sent.len(), 1, "{sent:?}");
    assert!(free_on_inflated(&grid, 0.25, sent[0].1));
    assert_eq!(e.stats().footprint_clearings, 1);
    let log = e.drain_log();
    assert!(log.iter().any(|l| l.text.contains("robot blocked in its map: decided with the cells within 0.35 m of it free")), "{log:?}");
    let (mut e, sent, _) =
        run(NodeConfig { explore: ExploreParams { clear_footprint: false, ..ExploreParams::default() }, ..NodeConfig::default() });
    assert!(sent.is_empty(), "{sent:?}");
    assert_eq!((e.stats().footprint_clearings, e.stats().decision_errors), (0, 1));
    assert!(log_has(&mut e, "is blocked and no free cell lies within"));
}

/// A 6 m × 3 m map at 5 cm: a hall west of a wall one cell thick (x = 4.0–4.05 m) with a door
/// where its y lies in `door_y_m`, a room east of it; walls along the north, south and east
/// edges (the west one too if `west_wall`); free cells whose x satisfies `unknown` unknown.
fn hall_and_room(door_y_m: std::ops::Range<f64>, west_wall: bool, unknown: impl Fn(f64) -> bool) -> OccupancyGrid {
    let g = GridGeometry::new(0.0, 0.0, 0.05, 120, 60);
    let mut grid = Grid::filled(g, FREE);
    for (i, v) in grid.data.iter_mut().enumerate() {
        let c = g.cell_at(i);
        let (x, y) = g.center_of(c);
        let wall = c.row == 0 || c.row == 59 || (west_wall && c.col == 0) || c.col == 119 || (c.col == 80 && !door_y_m.contains(&y));
        if wall {
            *v = LETHAL;
        } else if unknown(x) {
            *v = UNKNOWN;
        }
    }
    grid
}

/// An explorer given `grid` at t = 0 and the pose (2.0, 1.5) m (in [`hall_and_room`]'s hall),
/// ticked once a second `ticks` times: it and every command.
fn in_the_hall(cfg: NodeConfig, grid: &OccupancyGrid, ticks: u32) -> (ExplorerNode, Vec<Command>) {
    let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
    e.handle_map(&map_msg(grid, 0.0), 0.0);
    let mut cmds = Vec::new();
    for k in 0..ticks {
        let t = f64::from(k);
        feed_pose(&mut e, Pose2::new(2.0, 1.5, 0.0), t);
        cmds.extend(e.tick(t));
    }
    (e, cmds)
}

/// A hall, fully mapped, and a room east of it whose far part is unknown, joined by a door in a
/// wall one cell thick. 0.45 m wide, the 0.25 m inflation shuts it (the cell in its middle is
/// 0.25 m from both jambs) and the default tight radius, 0.20 m, leaves that cell open; 0.35 m
/// wide, only a second one, 0.10 m, does. With the tight retries the node sends a goal into the
/// room and counts it; without the radius that opens the door, no goal is left and the mission
/// ends.
#[test]
fn a_door_the_full_inflation_shuts_is_passed_with_a_tight_one() {
    for (door_y_m, opens_at_m, radii, fewer) in [(1.3..1.75, 0.20, vec![0.20], vec![]), (1.35..1.7, 0.10, vec![0.20, 0.10], vec![0.20])] {
        let grid = hall_and_room(door_y_m.clone(), true, |x| x > 4.6);
        let door = Pose2::new(4.025, 1.525, 0.0);
        assert!(!free_on_inflated(&grid, 0.25, door) && free_on_inflated(&grid, opens_at_m, door));
        assert!(fewer.iter().all(|&r| !free_on_inflated(&grid, r, door)));
        let run = |cfg: NodeConfig| in_the_hall(cfg, &grid, 3);
        let (mut e, cmds) =
            run(NodeConfig { explore: ExploreParams { tight_inflations_m: radii, ..ExploreParams::default() }, ..NodeConfig::default() });
        let sent = goals(&cmds);
        assert_eq!(sent.len(), 1, "door {door_y_m:?}: {cmds:?}");
        assert!(sent[0].1.x_m > 4.1, "the goal is in the room: {sent:?}");
        assert_eq!(e.stats().tight_goals, 1);
        assert!(log_has(&mut e, &format!("decided with lethal cells inflated by {opens_at_m} m")));
        assert!(!e.is_done());
        let (e, cmds) =
            run(NodeConfig { explore: ExploreParams { tight_inflations_m: fewer, ..ExploreParams::default() }, ..NodeConfig::default() });
        assert_eq!(cmds, vec![Command::MissionComplete], "door {door_y_m:?}");
        assert!(e.is_done() && e.stats().tight_goals == 0);
    }
}

/// The only frontier is a 0.45 m door itself (all beyond the wall unknown): its goal is free
/// only at a tight inflation (the frontier cells free at 0.20 m are too few to make a candidate,
/// so a 0.10 m retry finds it). It is picked there, and supervised there: later cycles on the
/// same map keep it (judged at the robot radius it would be cancelled as lethal at once).
#[test]
fn a_goal_found_with_a_tight_inflation_is_kept_at_that_inflation() {
    let grid = hall_and_room(1.3..1.75, true, |x| x > 4.06);
    let explore = ExploreParams { tight_inflations_m: vec![0.20, 0.10], ..ExploreParams::default() };
    let cfg = NodeConfig { goal_interface: GoalInterface::Topic, explore, ..NodeConfig::default() };
    let (e, cmds) = in_the_hall(cfg, &grid, 12);
    let sent = goals(&cmds);
    assert_eq!(sent.len(), 1, "{cmds:?}");
    assert!(!free_on_inflated(&grid, 0.25, sent[0].1) && free_on_inflated(&grid, 0.10, sent[0].1), "{sent:?}");
    assert_eq!((e.stats().tight_goals, e.stats().replaced), (1, 0));
    assert_eq!(e.current_goal().map(|g| g.inflation_m), Some(0.10));
}

/// A hall (frontier at its west end) and a 1.5 m room east of it, joined by a door 0.4 m wide:
/// free in the map but shut by the 0.25 m inflation, as a doorway whose jambs the robot mapped
/// better from inside. The robot drove in through it. With its trail it plans back out; without
/// it, it is walled in.
#[test]
fn a_robot_shut_in_a_room_by_its_map_goes_back_out_along_its_trail() {
    let grid = hall_and_room(1.3..1.7, false, |x| x < 0.5);
    let run = |cfg: NodeConfig, grid: &OccupancyGrid| {
        let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
        let mut cmds = Vec::new();
        // Drive from the hall at (2, 1.5) into the room at (5.2, 1.5), 2 cm per 20 ms tick,
        // before the map comes (the node only waits for it).
        let mut t = 0.0;
        for k in 0..=160 {
            feed_pose(&mut e, Pose2::new(2.0 + 0.02 * f64::from(k), 1.5, 0.0), t);
            cmds.extend(e.tick(t));
            t += 0.02;
        }
        e.handle_map(&map_msg(grid, t), t);
        for _ in 0..3 {
            feed_pose(&mut e, Pose2::new(5.2, 1.5, 0.0), t);
            cmds.extend(e.tick(t));
            t += 1.0;
        }
        (e, goals(&cmds))
    };
    // The door is shut on the inflated map.
    assert!(!free_on_inflated(&grid, 0.25, Pose2::new(4.025, 1.5, 0.0)));
    let (e, sent) = run(NodeConfig::default(), &grid);
    assert_eq!(sent.len(), 1, "{sent:?}");
    let goal = sent[0].1;
    assert!(goal.x_m < 4.0, "the goal is in the hall: {goal:?}");
    assert!(!e.is_done());
    let (mut e, sent) =
        run(NodeConfig { explore: ExploreParams { reuse_trail: false, ..ExploreParams::default() }, ..NodeConfig::default() }, &grid);
    assert!(sent.is_empty(), "{sent:?}");
    assert!(log_has(&mut e, "walled in by its map, not done"));
    // With the hall mapped too, no frontier is left: along its trail the robot reaches the whole
    // hall, so it is done, not walled in.
    let mut known = grid.clone();
    known.data.iter_mut().filter(|v| **v == UNKNOWN).for_each(|v| *v = FREE);
    let (mut e, sent) = run(NodeConfig::default(), &known);
    assert!(sent.is_empty() && e.is_done(), "{sent:?}");
    assert!(!log_has(&mut e, "walled in"));
}

/// A cloud map: a flat floor of radius 2.5 m around the robot at the origin, and in the first
/// cloud a ring of points 0.4 m up, 0.6 m around it (lethal speckle). Trapped, the node forgets
/// its map around the robot; the next cloud (floor only) maps the ground again and a goal
/// follows. With no recovery left the mission ends, trapped.
#[test]
fn a_trapped_node_forgets_its_cloud_map_around_the_robot() {
    let floor: Vec<Point3<f64>> = (-125..=125)
        .flat_map(|i| (-125..=125).map(move |j| Point3::new(i as f64 * 0.02, j as f64 * 0.02, 0.0)))
        .filter(|p| p.x.hypot(p.y) < 2.5)
        .collect();
    let ring = (0..2000).map(|k| {
        let a = k as f64 * std::f64::consts::TAU / 2000.0;
        Point3::new(0.6 * a.cos(), 0.6 * a.sin(), 0.4)
    });
    let first: Vec<_> = floor.iter().copied().chain(ring).collect();
    let run = |recoveries: u32| {
        let cfg = NodeConfig {
            map_source: MapSource::Clouds,
            cloud_map: crate::config::CloudMapConfig { origin_x_m: -4.0, origin_y_m: -4.0, size_x_m: 8.0, size_y_m: 8.0 },
            explore: ExploreParams { trap_recoveries: recoveries, ..ExploreParams::default() },
            ..NodeConfig::default()
        };
        let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
        feed_pose(&mut e, Pose2::new(0.0, 0.0, 0.0), 0.0);
        e.handle_cloud(&cloud_of_points(&first, header(0.0, "map")), 0.0);
        let mut cmds = e.tick(0.0);
        let trapped_log = e.drain_log();
        feed_pose(&mut e, Pose2::new(0.0, 0.0, 0.0), 1.0);
        e.handle_cloud(&cloud_of_points(&floor, header(1.0, "map")), 1.0);
        cmds.extend(e.tick(1.0));
        (e, cmds, trapped_log)
    };
    let (e, cmds, log) = run(2);
    assert!(log.iter().any(|l| l.text.contains("walled in by its map") && l.text.contains("recovery 1 of 2: forgot the")), "{log:?}");
    assert_eq!(e.stats().trap_recoveries, 1);
    let g = goals(&cmds);
    assert_eq!(g.len(), 1, "{cmds:?}");
    assert!(g[0].1.x_m.hypot(g[0].1.y_m) > 1.5, "{g:?}");
    // The ring's cells are free again: only the new cloud's points are there.
    assert_eq!(e.map().unwrap().at_world(0.6, 0.0), Some(&FREE));
    let (e, cmds, _) = run(0);
    assert_eq!(cmds, vec![Command::MissionComplete]);
    assert!(e.status(1.0).done_reason.unwrap().contains("trapped: walled in by its map after 0 recoveries"));
    assert_eq!(e.stats().trap_recoveries, 0);
}

#[test]
fn time_limit_cancels_the_goal_and_ends() {
    let cfg = NodeConfig { max_mission_s: Some(10.0), ..NodeConfig::default() };
    let (mut e, w) = corridor_explorer(cfg);
    let (id1, _) = goals(&e.tick(0.0))[0];
    e.on_goal_event(id1, GoalEvent::Accepted, 0.1);
    feed_pose(&mut e, w.robot, 10.0);
    assert_eq!(e.tick(10.0), vec![Command::CancelGoal { id: id1 }, Command::MissionComplete]);
}

#[test]
fn topic_goals_succeed_when_the_robot_is_close() {
    let explore = ExploreParams { tight_inflations_m: vec![0.20, 0.10], ..ExploreParams::default() };
    let cfg = NodeConfig { goal_interface: GoalInterface::Topic, explore, ..NodeConfig::default() };
    let (mut e, _w) = corridor_explorer(cfg);
    let (id1, g1) = goals(&e.tick(0.0))[0];
    assert!(e.current_goal().unwrap().accepted_s.is_some());
    feed_pose(&mut e, Pose2::new(g1.x_m + 0.2, g1.y_m, 0.0), 0.5);
    let _ = e.tick(0.5);
    assert_eq!(e.stats().succeeded, 1);
    assert!(e.current_goal().is_none_or(|g| g.id != id1));
}

#[test]
fn pose_topic_is_used_and_transformed_into_the_map_frame() {
    let cfg = NodeConfig { pose_source: PoseSource::Topic, ..NodeConfig::default() };
    let w = corridor_two_frontiers(true);
    let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
    e.handle_map(&map_msg(&w.grid, 1.0), 0.0);
    // Pose given in odom, which sits 1 m east of map.
    e.handle_tf(&tf_msg("map", "odom", Pose2::new(1.0, 0.0, 0.0), 0.0), true, 0.0);
    let mut p = msgs::PoseWithCovarianceStamped { header: header(1.0, "odom"), ..Default::default() };
    p.pose.pose = pose_of_pose2(Pose2::new(w.robot.x_m - 1.0, w.robot.y_m, 0.0));
    e.handle_pose(&p, 0.0);
    let r = e.robot(0.0).unwrap();
    assert!((r.x_m - w.robot.x_m).abs() < 1e-9 && (r.y_m - w.robot.y_m).abs() < 1e-9);
    // Late pose dropped.
    p.header.stamp = Time::from_secs_f64(0.5);
    p.pose.pose.position.x = 0.0;
    e.handle_pose(&p, 0.1);
    assert_eq!(e.stats().messages_late, 1);
    assert_eq!(goals(&e.tick(0.1)).len(), 1);
}

/// u2's camera rides at the robot's height: the same scene lifted 3 m (landmarks and pose) gives
/// the same path information; the landmarks lifted alone (the robot still at 0) do not.
#[test]
fn the_camera_sits_above_the_robots_height_in_the_map() {
    let w = corridor_two_frontiers(true);
    let info = |landmarks_dz: f64, robot_z: f64| {
        let cfg = NodeConfig { pose_source: PoseSource::Topic, ..NodeConfig::default() };
        let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
        e.handle_map(&map_msg(&w.grid, 1.0), 0.0);
        let lifted: Vec<_> = w.landmarks.points.iter().map(|p| Point3::new(p.x, p.y, p.z + landmarks_dz)).collect();
        e.handle_landmarks(&cloud_of_points(&lifted, header(1.0, "map")), 0.0);
        let mut p = msgs::PoseWithCovarianceStamped { header: header(1.0, "map"), ..Default::default() };
        p.pose.pose = pose_of_pose2(w.robot);
        p.pose.pose.position.z = robot_z;
        e.handle_pose(&p, 0.0);
        let _ = e.tick(0.0);
        let d = e.last_decision().expect("a decision");
        d.candidates.iter().map(|c| c.path_info_raw).collect::<Vec<_>>()
    };
    let same = |a: &[Option<f64>], b: &[Option<f64>]| {
        a.len() == b.len()
            && a.iter().zip(b).all(|(x, y)| match (x, y) {
                (Some(x), Some(y)) => (x - y).abs() <= 1e-9 * x.abs().max(1.0),
                _ => x == y,
            })
    };
    let flat = info(0.0, 0.0);
    assert!(flat.iter().any(|i| i.is_some_and(|v| v > 0.0)), "{flat:?}");
    assert!(same(&info(3.0, 3.0), &flat));
    assert!(!same(&info(3.0, 0.0), &flat));
}

#[test]
fn a_pose_covariance_sets_the_goal_back_from_unknown_ground() {
    let w = corridor_two_frontiers(true);
    let run = |var_m2: f64| {
        let cfg = NodeConfig { pose_source: PoseSource::Topic, ..NodeConfig::default() };
        let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
        e.handle_map(&map_msg(&w.grid, 1.0), 0.0);
        e.handle_landmarks(&cloud_of_points(&w.landmarks.points, header(1.0, "map")), 0.0);
        let mut p = msgs::PoseWithCovarianceStamped { header: header(1.0, "map"), ..Default::default() };
        p.pose.pose = pose_of_pose2(w.robot);
        (p.pose.covariance[0], p.pose.covariance[7]) = (var_m2, var_m2);
        e.handle_pose(&p, 0.0);
        let (id, goal) = goals(&e.tick(0.0))[0];
        (e, id, goal)
    };
    // No covariance: the goal is the frontier candidate itself.
    let (e, _, goal) = run(0.0);
    let frontier_m = e.current_goal().unwrap().frontier_m.unwrap();
    assert_eq!(frontier_m, [goal.x_m, goal.y_m]);
    assert!(!known_around(&w.grid, frontier_m, 0.4), "the candidate is on the edge of unknown ground");
    // σx² = σy² = 0.02 m²: sqrt(0.04) = 0.2 m, 2 σ = 0.4 m of known ground all round the goal.
    let (mut e, id, goal) = run(0.02);
    let [fx, fy] = e.current_goal().unwrap().frontier_m.unwrap();
    assert!(known_around(&w.grid, [goal.x_m, goal.y_m], 0.4), "{goal:?}");
    let back_m = (goal.x_m - fx).hypot(goal.y_m - fy);
    assert!((0.3..1.0).contains(&back_m), "{back_m} m");
    assert!(free_on_inflated(&w.grid, 0.25, goal));
    // Kept and blacklisted as the frontier it serves.
    assert!(e.tick(1.0).is_empty());
    assert_eq!(e.current_goal().map(|g| g.id), Some(id));
    e.on_goal_event(id, GoalEvent::Aborted("stuck".into()), 1.1);
    assert_eq!(e.blacklist().contains(fx, fy), Some(BlacklistReason::Failed));
}

#[test]
fn a_boundary_restricts_the_frontiers() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    // West half only: the east frontier is outside.
    let pts = [[0.0f32, 0.0], [12.0, 0.0], [12.0, 4.0], [0.0, 4.0]].map(|[x, y]| Point32 { x, y, z: 0.0 });
    e.handle_boundary(&PolygonStamped { header: header(0.0, "map"), polygon: Polygon { points: pts.to_vec() } }, 0.0);
    let g = goals(&e.tick(0.0));
    assert!(g[0].1.x_m < w.robot.x_m, "{g:?}");
}

#[test]
fn clouds_build_the_map() {
    let cfg = NodeConfig {
        map_source: MapSource::Clouds,
        cloud_map: crate::config::CloudMapConfig { origin_x_m: -4.0, origin_y_m: -4.0, size_x_m: 8.0, size_y_m: 8.0 },
        ..NodeConfig::default()
    };
    let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
    // A flat floor of radius 2.5 m around the robot, in the laser frame 0.2 m above base_link.
    let mut pts = Vec::new();
    for i in -125..=125 {
        for j in -125..=125 {
            let (x, y) = (i as f64 * 0.02, j as f64 * 0.02);
            if x.hypot(y) < 2.5 {
                pts.push(Point3::new(x, y, -0.2));
            }
        }
    }
    feed_pose(&mut e, Pose2::new(0.0, 0.0, 0.0), 0.0);
    e.handle_tf(&tf_msg("base_link", "laser", Pose2::new(0.0, 0.0, 0.0), 0.0), true, 0.0);
    let mut cloud = cloud_of_points(&pts, header(0.0, "laser"));
    cloud.header.frame_id = "laser".into();
    e.handle_cloud(&cloud, 0.0);
    let cmds = e.tick(0.0);
    let map = e.map().expect("map built from the cloud");
    assert_eq!(map.geometry.width, 160);
    let free = map.data.iter().filter(|&&v| v == FREE).count();
    assert!(free > 5000, "{free}");
    let g = goals(&cmds);
    assert_eq!(g.len(), 1, "{:?}", e.drain_log());
    assert!(g[0].1.x_m.hypot(g[0].1.y_m) > 1.5);
}

/// A patch 5 m from the robot sampled twice, 6 cm apart in height (two scans registered with
/// different tilts): roughness 3 cm, lethal as measured. With the pose's roll/pitch variance
/// (2e-5 rad² each → σ_z = √(2e-5 · 25) = 2.2 cm at 5 m) the hazard discounts it (√(9 − 4·5) cm
/// → 0): free. Without a covariance nothing changes.
#[test]
fn pose_covariance_discounts_registration_noise_in_cloud_maps() {
    let run = |tilt_var: f64| {
        let cfg = NodeConfig {
            map_source: MapSource::Clouds,
            pose_source: PoseSource::Topic,
            cloud_map: crate::config::CloudMapConfig { origin_x_m: -1.0, origin_y_m: -1.0, size_x_m: 8.0, size_y_m: 2.0 },
            ..NodeConfig::default()
        };
        let mut e = ExplorerNode::new(cfg, Params::default()).unwrap();
        let mut p = msgs::PoseWithCovarianceStamped { header: header(0.0, "map"), ..Default::default() };
        p.pose.pose = pose_of_pose2(Pose2::new(0.0, 0.0, 0.0));
        p.pose.covariance[21] = tilt_var;
        p.pose.covariance[28] = tilt_var;
        e.handle_pose(&p, 0.0);
        let mut pts = Vec::new();
        for i in 0..50 {
            for j in 0..50 {
                let (x, y) = (4.5 + i as f64 * 0.02, -0.5 + j as f64 * 0.02);
                pts.push(Point3::new(x, y, 0.03));
                pts.push(Point3::new(x, y, -0.03));
            }
        }
        e.handle_cloud(&cloud_of_points(&pts, header(0.0, "map")), 0.0);
        let _ = e.tick(0.0);
        *e.map().expect("map built from the cloud").at_world(5.0, 0.0).unwrap()
    };
    assert_eq!(run(0.0), LETHAL);
    assert_eq!(run(2e-5), FREE);
}

#[test]
fn every_goal_is_free_on_random_worlds() {
    for seed in 0..4 {
        let w = synthetic_world(&SyntheticWorldSpec::small(seed));
        let mut e = ExplorerNode::new(NodeConfig::default(), Params::default()).unwrap();
        e.handle_map(&map_msg(&w.grid, 1.0), 0.0);
        e.handle_landmarks(&cloud_of_points(&w.landmarks.points, header(1.0, "map")), 0.0);
        let mut t = 0.0;
        // Fail every goal: the node walks down its whole ranking, each goal free.
        for _ in 0..40 {
            feed_pose(&mut e, w.robot, t);
            for (id, g) in goals(&e.tick(t)) {
                assert!(free_on_inflated(&w.grid, 0.25, g), "seed {seed}: {g:?}");
                assert!(w.grid.geometry.cell_of(g.x_m, g.y_m).is_some());
                e.on_goal_event(id, GoalEvent::Aborted("test".into()), t);
            }
            if e.is_done() {
                break;
            }
            t += 1.0;
        }
        assert!(e.is_done(), "seed {seed}: every frontier failed, so the mission must end");
        assert!(e.stats().goals_sent >= 2);
    }
}

fn control(e: &mut ExplorerNode, command: &str, now_s: f64) {
    e.handle_control(&msgs::StringMsg { data: command.into() }, now_s);
}

#[test]
fn pause_cancels_the_goal_and_sends_none_until_resume_and_stop_ends_the_mission() {
    let (mut e, w) = corridor_explorer(NodeConfig::default());
    let (id1, _) = goals(&e.tick(0.0))[0];
    control(&mut e, " Pause ", 0.1);
    assert_eq!(cancels(&e.tick(0.1)), vec![id1]);
    assert_eq!(e.phase(), Phase::Paused);
    for t in [1.2, 2.4] {
        feed_pose(&mut e, w.robot, t);
        assert!(e.tick(t).is_empty(), "nothing sent while paused");
    }
    assert!(e.blacklist().entries().is_empty(), "a paused goal is not blacklisted");
    control(&mut e, "resume", 2.5);
    feed_pose(&mut e, w.robot, 2.5);
    let g = goals(&e.tick(2.5));
    assert!(g.len() == 1 && g[0].0 > id1, "{g:?}");
    control(&mut e, "jump", 2.6);
    assert!(log_has(&mut e, "control command \"jump\" ignored"));
    control(&mut e, "stop", 2.7);
    assert_eq!(e.tick(2.7), vec![Command::CancelGoal { id: g[0].0 }, Command::MissionComplete]);
    assert!(e.status(2.7).done_reason.unwrap().contains("stopped on request"));
}

#[test]
fn publish_only_ranks_and_suggests_but_sends_no_goal() {
    let (mut e, w) = corridor_explorer(NodeConfig { publish_only: true, ..NodeConfig::default() });
    let mut cmds = Vec::new();
    for t in [0.0, 1.0, 2.0] {
        feed_pose(&mut e, w.robot, t);
        cmds.extend(e.tick(t));
    }
    assert!(cmds.is_empty(), "{cmds:?}");
    assert!(e.decisions() >= 3 && e.current_goal().is_none());
    let g = e.status(2.0).suggested_goal.expect("a suggested goal");
    // The goal the default node sends first: east, where the landmarks are.
    assert!(g.x_m > w.robot.x_m + 5.0, "{g:?}");
}

#[test]
fn return_to_start_sends_a_last_goal_home_and_ends_when_it_does() {
    let (mut e, w) = corridor_explorer(NodeConfig { return_to_start: true, ..NodeConfig::default() });
    let (id1, _) = goals(&e.tick(0.0))[0];
    e.on_goal_event(id1, GoalEvent::Accepted, 0.1);
    // The robot is 3 m down the corridor when the goal ends.
    let away = Pose2::new(w.robot.x_m + 3.0, w.robot.y_m, 0.0);
    feed_pose(&mut e, away, 0.2);
    e.on_goal_event(id1, GoalEvent::Succeeded, 0.2);
    // Everything known: no frontier left.
    let mut grid = w.grid.clone();
    for v in &mut grid.data {
        if *v == UNKNOWN {
            *v = LETHAL;
        }
    }
    e.handle_map(&map_msg(&grid, 2.0), 0.3);
    let mut cmds = Vec::new();
    for t in [0.3, 1.4] {
        feed_pose(&mut e, away, t);
        cmds.extend(e.tick(t));
    }
    let home = goals(&cmds);
    assert_eq!(home.len(), 1, "{cmds:?}");
    let (id_home, goal_home) = home[0];
    assert!((goal_home.x_m - w.robot.x_m).hypot(goal_home.y_m - w.robot.y_m) < 1e-9, "{goal_home:?}");
    assert_eq!(e.phase(), Phase::Returning);
    assert!(!cmds.contains(&Command::MissionComplete));
    e.on_goal_event(id_home, GoalEvent::Accepted, 1.5);
    feed_pose(&mut e, w.robot, 1.6);
    e.on_goal_event(id_home, GoalEvent::Succeeded, 1.6);
    assert_eq!(e.tick(1.6), vec![Command::MissionComplete]);
    let reason = e.status(1.6).done_reason.unwrap();
    assert!(reason.contains("no reachable") && reason.ends_with("returned to the start"), "{reason}");
    assert_eq!(e.stats().succeeded, 2);
}
