//! The exploration policy on small hand-built maps: each step of the retry chain, goal keeping,
//! reached goals, failures and the end of a mission.

use super::*;
use crate::GridGeometry;
use crate::fixtures::corridor_two_frontiers;
use crate::grid::{FREE, Grid, LETHAL, OccupancyGrid, UNKNOWN};
use crate::params::Params;
use crate::params::{Valid, Validate};
use crate::pose::Pose2;
use crate::utility::LandmarkVoxels;

fn valid<T: Validate>(value: T) -> Valid<T> {
    Valid::new(value).unwrap()
}

fn situation(landmarks: &LandmarkVoxels, robot: Pose2) -> Situation<'_> {
    Situation {
        landmarks,
        robot,
        boundary: None,
        ground_z_m: 0.0,
        ground: None,
        position_var_m2: 0.0,
        replanning: false,
        can_forget_map: true,
    }
}

fn greedy() -> Params {
    let mut p = Params::default();
    p.selector.strategy = crate::params::Strategy::Greedy;
    p
}

/// A 4 m × 2 m room of free ground, unknown beyond x = 3 m: one frontier east.
fn room_open_east() -> OccupancyGrid {
    let g = GridGeometry::new(0.0, 0.0, 0.05, 100, 40);
    let mut grid = Grid::filled(g, FREE);
    for (i, v) in grid.data.iter_mut().enumerate() {
        let (c, r) = (i % 100, i / 100);
        if c >= 60 {
            *v = UNKNOWN;
        } else if c == 0 || r == 0 || r == 39 {
            *v = LETHAL;
        }
    }
    grid
}

#[test]
fn a_goal_is_the_chosen_candidate_and_its_path_is_set_back_by_the_position_uncertainty() {
    let w = corridor_two_frontiers(true);
    let params = Params::default();
    let voxels = LandmarkVoxels::new(&w.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m).unwrap();
    let mut e = Explorer::new(valid(ExploreParams::default()), valid(params));
    let mut grid = w.grid.clone();
    let Action::Goal(plan) = e.decide(&mut grid, &situation(&voxels, w.robot)) else { panic!("a goal") };
    let d = e.last_decision().unwrap();
    let c = &d.candidates[d.chosen.unwrap()];
    assert_eq!(plan.candidate, d.chosen.unwrap());
    assert_eq!(plan.goal.goal, d.goal.unwrap());
    assert_eq!(plan.path_m, c.path_m, "no uncertainty: no set-back");
    assert_eq!(plan.rho_m, c.rho_m.unwrap());
    assert_eq!(e.goal(), Some(plan.goal));
    // σx² + σy² = 0.09 m²: 2 σ = 0.6 m, within the 1 m cap: the path ends ≥ 0.6 m short of unknown.
    let mut e = Explorer::new(valid(ExploreParams::default()), valid(Params::default()));
    let s = Situation { position_var_m2: 0.09, ..situation(&voxels, w.robot) };
    let Action::Goal(set_back) = e.decide(&mut w.grid.clone(), &s) else { panic!("a goal") };
    let end = *set_back.path_m.last().unwrap();
    assert_ne!(Some(&end), c.path_m.last(), "the path was cut");
    assert!(crate::path::known_around(&w.grid, end, 0.6));
    assert_eq!(set_back.target().yaw_rad, set_back.goal.goal.yaw_rad);
}

#[test]
fn a_goal_reached_and_chosen_again_is_blacklisted_and_another_one_chosen() {
    let w = corridor_two_frontiers(false);
    let voxels = LandmarkVoxels::empty(0.25);
    let mut e = Explorer::new(valid(ExploreParams::default()), valid(greedy()));
    let Action::Goal(first) = e.decide(&mut w.grid.clone(), &situation(&voxels, w.robot)) else { panic!() };
    e.goal_reached();
    assert_eq!((e.goal(), e.stats().goals_reached), (None, 1));
    // Same map, same robot: the same candidate comes first, is blacklisted as reselected.
    let Action::Goal(second) = e.decide(&mut w.grid.clone(), &situation(&voxels, w.robot)) else { panic!() };
    assert_ne!(first.goal.goal, second.goal.goal);
    let [entry] = e.blacklist().entries() else { panic!("{:?}", e.blacklist().entries()) };
    assert_eq!(entry.reason, crate::frontier::BlacklistReason::Reselected);
    assert_eq!((entry.x_m, entry.y_m), (first.goal.goal.x_m, first.goal.goal.y_m));
}

#[test]
fn a_failed_goal_is_blacklisted_and_a_dropped_one_is_not() {
    let w = corridor_two_frontiers(false);
    let voxels = LandmarkVoxels::empty(0.25);
    let mut e = Explorer::new(valid(ExploreParams::default()), valid(greedy()));
    let Action::Goal(first) = e.decide(&mut w.grid.clone(), &situation(&voxels, w.robot)) else { panic!() };
    e.goal_dropped();
    assert!(e.blacklist().is_empty());
    let Action::Goal(again) = e.decide(&mut w.grid.clone(), &situation(&voxels, w.robot)) else { panic!() };
    assert_eq!(again.goal.goal, first.goal.goal);
    e.goal_failed();
    assert_eq!((e.blacklist().len(), e.stats().goals_failed), (1, 1));
    let Action::Goal(other) = e.decide(&mut w.grid.clone(), &situation(&voxels, w.robot)) else { panic!() };
    assert_ne!(other.goal.goal, first.goal.goal);
}

#[test]
fn replanning_keeps_the_current_goal_while_it_is_still_a_candidate() {
    let w = corridor_two_frontiers(false);
    let voxels = LandmarkVoxels::empty(0.25);
    let mut e = Explorer::new(valid(ExploreParams::default()), valid(greedy()));
    let Action::Goal(first) = e.decide(&mut w.grid.clone(), &situation(&voxels, w.robot)) else { panic!() };
    // The robot moved a little towards the other end: greedy would now choose the other frontier.
    let s = Situation { replanning: true, ..situation(&voxels, w.robot) };
    let Action::Keep(kept) = e.decide(&mut w.grid.clone(), &s) else { panic!("kept") };
    assert_eq!(kept.goal.goal, first.goal.goal);
    // Its frontier explored (known ground there now): replaced.
    let mut explored = w.grid.clone();
    let g = explored.geometry;
    for (i, v) in explored.data.iter_mut().enumerate() {
        let (x, _) = g.center_of(g.cell_at(i));
        if (x - first.goal.goal.x_m).abs() < 1.0 && *v == UNKNOWN {
            *v = FREE;
        }
    }
    match e.decide(&mut explored, &s) {
        Action::Goal(p) => assert_ne!(p.goal.goal, first.goal.goal),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_blocked_robot_decides_again_on_its_cleared_footprint() {
    let mut grid = room_open_east();
    let robot = Pose2::new(1.0, 1.0, 0.0);
    // Speckle all around the robot's cell.
    crate::grid::fill_disc(&mut grid, robot.x_m, robot.y_m, 0.12, LETHAL);
    let voxels = LandmarkVoxels::empty(0.25);
    let off = ExploreParams { clear_footprint: false, max_failed_decisions: 2, ..ExploreParams::default() };
    let mut e = Explorer::new(valid(off), valid(greedy()));
    assert!(matches!(e.decide(&mut grid.clone(), &situation(&voxels, robot)), Action::Wait(WaitReason::NoPlan(_))));
    assert_eq!(e.decide(&mut grid.clone(), &situation(&voxels, robot)), Action::Done(EndReason::Stuck));
    let mut e = Explorer::new(valid(ExploreParams::default()), valid(greedy()));
    let mut planned_on = grid.clone();
    assert!(matches!(e.decide(&mut planned_on, &situation(&voxels, robot)), Action::Goal(_)));
    assert_eq!((e.stats().footprint_clearings, e.stats().decisions), (1, 2));
    let at = |g: &OccupancyGrid| *g.at_world(robot.x_m, robot.y_m).unwrap();
    assert_eq!((at(&grid), at(&planned_on)), (LETHAL, FREE), "the grid it planned on has the footprint cleared");
}

/// A room whose only way out is a gap that the robot drove through, then lethal cells were
/// mapped beside it: the inflation shuts it, the trail opens it again.
#[test]
fn a_robot_shut_in_by_inflation_goes_back_along_its_trail() {
    let g = GridGeometry::new(0.0, 0.0, 0.05, 120, 40);
    let mut grid = Grid::filled(g, FREE);
    for (i, v) in grid.data.iter_mut().enumerate() {
        let (c, r) = (i % 120, i / 120);
        if c >= 100 {
            *v = UNKNOWN;
        } else if c == 0 || r == 0 || r == 39 || (c == 40 && !(18..=21).contains(&r)) {
            // A wall at x = 2 m with a 0.2 m gap: shut by the 0.25 m inflation.
            *v = LETHAL;
        }
    }
    let robot = Pose2::new(1.0, 1.0, 0.0);
    let voxels = LandmarkVoxels::empty(0.25);
    let no_tight = ExploreParams { tight_inflations_m: vec![], trapped_radius_m: 0.0, ..ExploreParams::default() };
    let mut e = Explorer::new(valid(no_tight.clone()), valid(greedy()));
    assert_eq!(e.decide(&mut grid.clone(), &situation(&voxels, robot)), Action::Done(EndReason::NoFrontier));
    let mut e = Explorer::new(valid(no_tight), valid(greedy()));
    // It came in through the gap, from the frontier side.
    for k in 0..=60 {
        e.record_position(2.8 - 0.03 * f64::from(k), 1.0);
    }
    let Action::Goal(plan) = e.decide(&mut grid.clone(), &situation(&voxels, robot)) else { panic!("out along the trail") };
    assert!(plan.goal.on_trail && plan.goal.goal.x_m > 2.0, "{plan:?}");
    // With the trail off it stays shut.
    let off = ExploreParams { reuse_trail: false, tight_inflations_m: vec![], trapped_radius_m: 0.0, ..ExploreParams::default() };
    let mut e = Explorer::new(valid(off), valid(greedy()));
    for k in 0..=60 {
        e.record_position(2.8 - 0.03 * f64::from(k), 1.0);
    }
    assert!(e.trail().is_empty());
    assert_eq!(e.decide(&mut grid.clone(), &situation(&voxels, robot)), Action::Done(EndReason::NoFrontier));
}

/// A 0.5 m door in a wall: shut at the 0.25 m inflation, passed at the 0.20 m tight one.
#[test]
fn a_door_the_full_inflation_shuts_is_passed_at_a_tight_inflation() {
    let g = GridGeometry::new(0.0, 0.0, 0.05, 120, 40);
    let mut grid = Grid::filled(g, FREE);
    for (i, v) in grid.data.iter_mut().enumerate() {
        let (c, r) = (i % 120, i / 120);
        if c >= 100 {
            *v = UNKNOWN;
        } else if c == 0 || r == 0 || r == 39 || (c == 40 && !(15..25).contains(&r)) {
            *v = LETHAL;
        }
    }
    let robot = Pose2::new(1.0, 1.0, 0.0);
    let voxels = LandmarkVoxels::empty(0.25);
    let base = ExploreParams { trapped_radius_m: 0.0, ..ExploreParams::default() };
    let mut e = Explorer::new(valid(ExploreParams { tight_inflations_m: vec![], ..base.clone() }), valid(greedy()));
    assert_eq!(e.decide(&mut grid.clone(), &situation(&voxels, robot)), Action::Done(EndReason::NoFrontier));
    let mut e = Explorer::new(valid(base), valid(greedy()));
    let Action::Goal(plan) = e.decide(&mut grid.clone(), &situation(&voxels, robot)) else { panic!("through the door") };
    assert!(plan.tight && plan.goal.inflation_m == 0.20 && plan.goal.goal.x_m > 2.0, "{plan:?}");
    assert_eq!(e.stats().tight_plans, 1);
}

/// A robot in a 1 m pocket of free ground with unknown beyond lethal walls: trapped, it
/// recovers (the adapter forgets its map) at most `trap_recoveries` times, then the mission ends
/// trapped; an adapter that cannot forget its map waits.
#[test]
fn a_trapped_robot_recovers_then_ends_trapped() {
    let g = GridGeometry::new(0.0, 0.0, 0.05, 80, 80);
    let mut grid = Grid::filled(g, UNKNOWN);
    crate::grid::fill_disc(&mut grid, 2.0, 2.0, 0.9, LETHAL);
    crate::grid::fill_disc(&mut grid, 2.0, 2.0, 0.75, FREE);
    let robot = Pose2::new(2.0, 2.0, 0.0);
    let voxels = LandmarkVoxels::empty(0.25);
    let params = ExploreParams { trap_recoveries: 1, ..ExploreParams::default() };
    let mut e = Explorer::new(valid(params.clone()), valid(greedy()));
    e.goal_failed(); // no goal: nothing happens
    let Action::Recover { radius_m } = e.decide(&mut grid.clone(), &situation(&voxels, robot)) else { panic!("recover") };
    assert_eq!(radius_m, crate::frontier::recovery_radius_m(params.trapped_radius_m, &greedy()));
    assert_eq!(e.decide(&mut grid.clone(), &situation(&voxels, robot)), Action::Done(EndReason::Trapped));
    let mut e = Explorer::new(valid(params), valid(greedy()));
    let s = Situation { can_forget_map: false, ..situation(&voxels, robot) };
    assert_eq!(e.decide(&mut grid.clone(), &s), Action::Wait(WaitReason::Trapped));
    assert_eq!(e.stats().trap_recoveries, 0);
}
