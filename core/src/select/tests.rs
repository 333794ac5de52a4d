use super::candidates::{PlanBuffers, frontiers_and_distances, prepare, score_u1};
use super::*;
use crate::params::Valid;

/// The parameters checked, as the selectors take them.
fn valid(p: &Params) -> Valid<Params> {
    Valid::new(p.clone()).unwrap()
}
use crate::fixtures::{SyntheticWorldSpec, corridor_two_frontiers, synthetic_world};
use crate::frontier::{BlacklistReason, FrontierCluster};
use crate::grid::{FREE, Grid, GridGeometry, LETHAL, UNKNOWN};
use crate::pose::wrap_pi;
use std::f64::consts::PI;

fn params() -> Params {
    let mut p = Params::default();
    p.grid.resolution_m = 0.1;
    p
}

fn voxels(w: &crate::fixtures::SyntheticWorld, p: &Params) -> LandmarkVoxels {
    LandmarkVoxels::new(&w.landmarks, p.u2.voxel_m, p.u2.sigma_landmark_m).unwrap()
}

/// The corridor's two candidates: (west index, east index).
fn ends(d: &Decision) -> (usize, usize) {
    assert_eq!(d.candidates.len(), 2, "{:?}", d.candidates.iter().map(|c| c.cell).collect::<Vec<_>>());
    if d.candidates[0].x_m < d.candidates[1].x_m { (0, 1) } else { (1, 0) }
}

#[test]
fn fit_slam_and_greedy_differ_for_a_stated_reason() {
    // Two frontiers at the corridor's ends, 7.5 m west and 8.0 m east; landmarks only along
    // the east half. Greedy takes the nearer (west). FIT-SLAM's u1 is nearly tied (same
    // unknown beyond each end, path term 1 vs 7.5/8), but only the east path sees landmarks,
    // so I_p,west = 0 and I_p,east = 1 after normalisation: u2 picks east.
    let w = corridor_two_frontiers(true);
    let p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(p.frontier.blacklist_radius_m);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);

    let g = Greedy::default().select(&input, &valid(&p)).unwrap();
    let (west, east) = ends(&g);
    assert_eq!(g.chosen, Some(west));
    assert!((g.candidates[west].rho_m.unwrap() - 7.5).abs() < 1e-9);
    assert!((g.candidates[east].rho_m.unwrap() - 8.0).abs() < 1e-9);
    assert_eq!(g.candidates[west].rank, Some(1));
    assert_eq!(g.candidates[east].rank, Some(2));

    let f = FitSlam::default().select(&input, &valid(&p)).unwrap();
    let (west, east) = ends(&f);
    assert_eq!(f.chosen, Some(east));
    let (cw, ce) = (&f.candidates[west], &f.candidates[east]);
    assert_eq!(cw.path_info_raw, Some(0.0));
    assert!(ce.path_info_raw.unwrap() > 0.0);
    assert_eq!(ce.path_info, Some(1.0));
    assert!(ce.waypoints.iter().any(|wp| wp.voxels_seen > 0));
    // u2 = β u1 + (1 − β) I_p, by hand from the reported u1 and I_p.
    let beta = p.u2.beta;
    assert!((cw.u2.unwrap() - beta * cw.u1.unwrap()).abs() < 1e-12);
    assert!((ce.u2.unwrap() - (beta * ce.u1.unwrap() + (1.0 - beta))).abs() < 1e-12);
    // Θ* looks into the unknown: west for the west end, east for the east end.
    assert!(wrap_pi(cw.theta_star_rad.unwrap() - PI).abs() <= 0.5 * p.camera.hfov_rad);
    assert!(wrap_pi(ce.theta_star_rad.unwrap()).abs() <= 0.5 * p.camera.hfov_rad);
    assert_eq!(f.goal.unwrap().x_m, ce.x_m);
    assert_eq!(f.goal.unwrap().yaw_rad, ce.theta_star_rad.unwrap());
    // Waypoints: every d_max = 3 m from the robot, then the goal: 3, 6 and 8 m east.
    let arcs: Vec<f64> = ce.waypoints.iter().map(|w| w.arc_length_m).collect();
    assert_eq!(arcs.len(), 3);
    assert!((arcs[0] - 3.0).abs() < 1e-9 && (arcs[1] - 6.0).abs() < 1e-9 && (arcs[2] - 8.0).abs() < 1e-9);

    // Without landmarks both paths carry no information and FIT-SLAM follows u1.
    let w0 = corridor_two_frontiers(false);
    let lv0 = voxels(&w0, &p);
    let f0 = FitSlam::default().select(&DecisionInput::new(&w0.grid, &lv0, w0.robot, &bl), &valid(&p)).unwrap();
    let best_u1 = (0..2).max_by(|&a, &b| f0.candidates[a].u1.partial_cmp(&f0.candidates[b].u1).unwrap().then(b.cmp(&a))).unwrap();
    assert_eq!(f0.chosen, Some(best_u1));
}

#[test]
fn baselines_arrive_as_they_drive_unless_told_to_turn_to_theta_star() {
    // The corridor runs east–west: greedy's path to the west end arrives heading west (π).
    let w = corridor_two_frontiers(true);
    let mut p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(p.frontier.blacklist_radius_m);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let g = Greedy::default().select(&input, &valid(&p)).unwrap();
    assert!(wrap_pi(g.goal.unwrap().yaw_rad - PI).abs() < 1e-9, "{:?}", g.goal);
    let r = RandomSelector::new(3).select(&input, &valid(&p)).unwrap();
    let c = r.chosen_candidate().unwrap();
    let heading = if c.x_m < w.robot.x_m { PI } else { 0.0 };
    assert!(wrap_pi(r.goal.unwrap().yaw_rad - heading).abs() < 1e-9, "{:?}", r.goal);
    // With `theta_star` they take u1's best view, as FIT-SLAM does.
    p.selector.baseline_heading = crate::params::GoalHeading::ThetaStar;
    let g = Greedy::default().select(&input, &valid(&p)).unwrap();
    assert_eq!(g.goal.unwrap().yaw_rad, g.chosen_candidate().unwrap().theta_star_rad.unwrap());
    let f = FitSlam::default().select(&input, &valid(&params())).unwrap();
    assert_eq!(f.goal.unwrap().yaw_rad, f.chosen_candidate().unwrap().theta_star_rad.unwrap());
}

/// The ablation of Θ*'s turn: with `fit_heading = arrival`, `fit` and `u1` choose the same
/// candidates and set their goals with the heading their paths arrive with (the chord over the
/// last half metre, `arrival_heading_is_the_last_half_metre`), as the baselines do.
#[test]
fn fit_heading_arrival_keeps_the_choice_and_drops_the_turn() {
    let mut ablated = params();
    ablated.selector.fit_heading = crate::params::GoalHeading::Arrival;
    let mut turns = 0;
    for seed in 1..=4 {
        let w = synthetic_world(&SyntheticWorldSpec::small(seed));
        let lv = voxels(&w, &params());
        let bl = Blacklist::new(0.5);
        let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
        for (with, without) in [
            (FitSlam::default().select(&input, &valid(&params())).unwrap(), FitSlam::default().select(&input, &valid(&ablated)).unwrap()),
            (U1Only::default().select(&input, &valid(&params())).unwrap(), U1Only::default().select(&input, &valid(&ablated)).unwrap()),
        ] {
            assert_eq!(with.chosen, without.chosen, "world {seed}");
            let Some(c) = with.chosen_candidate() else { continue };
            assert_eq!(with.goal.unwrap().yaw_rad, c.theta_star_rad.unwrap(), "world {seed}");
            let yaw = without.goal.unwrap().yaw_rad;
            assert_eq!(Some(yaw), crate::utility::u2::arrival_heading_rad(&c.path_m), "world {seed}");
            if wrap_pi(yaw - c.theta_star_rad.unwrap()).abs() > 0.1 {
                turns += 1;
            }
        }
    }
    assert!(turns > 0, "in some world Θ* differs from the arrival heading, so the ablation changes the goal");
}

#[test]
fn u1_only_and_top_n() {
    let w = corridor_two_frontiers(true);
    let mut p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(0.5);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let u = U1Only::default().select(&input, &valid(&p)).unwrap();
    let top = u.candidates.iter().position(|c| c.u1_rank == Some(1)).unwrap();
    assert_eq!(u.chosen, Some(top));
    assert!(u.candidates.iter().all(|c| c.u2.is_none() && c.waypoints.is_empty()));
    // N = 1: FIT-SLAM only scores u1's best, the other is dropped NotInTopN.
    p.u2.top_n = 1;
    let f = FitSlam::default().select(&input, &valid(&p)).unwrap();
    assert_eq!(f.chosen, Some(top));
    assert_eq!(f.candidates[1 - top].dropped, Some(DropReason::NotInTopN));
    assert_eq!(f.candidates[1 - top].rank, None);
    // With N = 1, the single normalised I_p is 1 (or 0 if it saw nothing).
    assert!(matches!(f.candidates[top].path_info, Some(v) if v == 1.0 || v == 0.0));
}

#[test]
fn blacklisted_candidates_are_dropped_with_their_reason() {
    let w = corridor_two_frontiers(true);
    let p = params();
    let lv = voxels(&w, &p);
    let mut bl = Blacklist::new(0.5);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let first = FitSlam::default().select(&input, &valid(&p)).unwrap();
    let (west, east) = ends(&first);
    let ce = &first.candidates[east];
    bl.add(ce.x_m + 0.3, ce.y_m, BlacklistReason::Failed);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let d = FitSlam::default().select(&input, &valid(&p)).unwrap();
    assert_eq!(d.candidates[east].dropped, Some(DropReason::Blacklisted(BlacklistReason::Failed)));
    assert_eq!(d.candidates[east].u1, None);
    assert_eq!(d.chosen, Some(west));
    // Blacklist both: end of mission, not an error.
    let cw = &first.candidates[west];
    bl.add(cw.x_m, cw.y_m, BlacklistReason::Reselected);
    let d = FitSlam::default().select(&DecisionInput::new(&w.grid, &lv, w.robot, &bl), &valid(&p)).unwrap();
    assert_eq!(d.chosen, None);
    assert_eq!(d.goal, None);
}

#[test]
fn unreachable_candidates_are_reported_for_the_blacklist() {
    // A sealed room's frontier cannot be reached: feed it to score_u1 by hand.
    let w = corridor_two_frontiers(false);
    let p = params();
    let mut grid = w.grid.clone();
    // A free pocket at columns 5..15, rows 15..25 in the unknown west part, walled off.
    for r in 15..25 {
        for c in 5..15 {
            grid.data[r * 240 + c] = FREE;
        }
    }
    let lv = LandmarkVoxels::empty(0.25);
    let bl = Blacklist::new(0.5);
    let input = DecisionInput::new(&grid, &lv, w.robot, &bl);
    let mut buffers = PlanBuffers::default();
    let prepared = prepare(&input, &valid(&p), &mut buffers).unwrap();
    let (mut clusters, field) = frontiers_and_distances(&input, &prepared, &p, &mut buffers).unwrap();
    assert_eq!(clusters.len(), 2);
    clusters.insert(0, FrontierCluster::from_ordered_cells(vec![Cell::new(10, 20)]).unwrap());
    let d = score_u1(&input, &prepared, clusters, &field, &p, Strategy::Fit).unwrap();
    assert_eq!(d.candidates[0].dropped, Some(DropReason::NoPath));
    assert_eq!(d.candidates[0].rho_m, None);
    assert!(d.candidates[0].path_m.is_empty());
    let u = d.unreachable_m();
    assert_eq!(u.len(), 1);
    assert!((u[0][0] - 1.05).abs() < 1e-12 && (u[0][1] - 2.05).abs() < 1e-12);
    assert!(d.candidates[1..].iter().all(|c| c.u1.is_some()));
}

#[test]
fn random_is_reproducible_per_seed() {
    let w = synthetic_world(&SyntheticWorldSpec::small(11));
    let p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(0.5);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let draw = |seed: u64| {
        let mut s = RandomSelector::new(seed);
        (0..12).map(|_| s.select(&input, &valid(&p)).unwrap().chosen.unwrap()).collect::<Vec<_>>()
    };
    let n = Greedy::default().select(&input, &valid(&p)).unwrap().candidates.iter().filter(|c| c.is_scored()).count();
    assert!(n >= 3, "only {n} candidates");
    let a = draw(5);
    assert_eq!(a, draw(5));
    assert_ne!(a, draw(6));
    // Each draw is a scored candidate ranked 1, and nothing else is ranked.
    let mut s = make_selector(&SelectorParams { strategy: Strategy::Random, seed: 5, ..SelectorParams::default() });
    assert_eq!(s.strategy(), Strategy::Random);
    let d = s.select(&input, &valid(&p)).unwrap();
    assert_eq!(d.chosen, Some(a[0]));
    assert_eq!(d.candidates.iter().filter(|c| c.rank.is_some()).count(), 1);
    assert!(d.candidates[a[0]].is_scored());
}

/// The corridor's ends are 7.5 m (west) and 8.0 m (east) away and FIT-SLAM goes east: both lie
/// within ±20 % of 8.0 m ([6.4, 9.6] m), so the length-matched draw takes either, by its seed.
/// With the band at 5 % ([7.6, 8.4] m) only the east end would qualify.
#[test]
fn length_matched_random_draws_among_candidates_at_fit_slams_distance() {
    assert_eq!(super::matched::LENGTH_TOLERANCE, 0.2);
    let w = corridor_two_frontiers(true);
    let p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(p.frontier.blacklist_radius_m);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let mut s = LengthMatched::new(3, MatchPool::Reachable);
    let draws: Vec<usize> = (0..40).map(|_| s.select(&input, &valid(&p)).unwrap().chosen.unwrap()).collect();
    let d = LengthMatched::new(3, MatchPool::Reachable).select(&input, &valid(&p)).unwrap();
    let (west, east) = ends(&d);
    assert!(draws.contains(&west) && draws.contains(&east), "{draws:?}");
    assert_eq!(d.chosen, Some(draws[0]), "same seed, same draw");
    assert_eq!(d.candidates.iter().filter(|c| c.rank.is_some()).count(), 1);
    assert!(d.candidates.iter().all(|c| c.u2.is_some()), "u2 stays reported");

    // On a bigger world: every draw at FIT-SLAM's distance, not always FIT-SLAM's goal.
    let w = synthetic_world(&SyntheticWorldSpec::small(11));
    let lv = voxels(&w, &p);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let fit = FitSlam::default().select(&input, &valid(&p)).unwrap();
    let rho_fit = fit.chosen_candidate().unwrap().rho_m.unwrap();
    let mut s = make_selector(&SelectorParams { strategy: Strategy::Matched, seed: 9, ..SelectorParams::default() });
    assert_eq!(s.strategy(), Strategy::Matched);
    let mut others = 0;
    for _ in 0..30 {
        let d = s.select(&input, &valid(&p)).unwrap();
        let rho = d.chosen_candidate().unwrap().rho_m.unwrap();
        assert!((rho - rho_fit).abs() <= 0.2 * rho_fit + 1e-12, "{rho} vs FIT-SLAM's {rho_fit}");
        others += usize::from(d.chosen != fit.chosen);
    }
    let pool = fit.candidates.iter().filter(|c| c.rho_m.is_some_and(|r| (r - rho_fit).abs() <= 0.2 * rho_fit)).count();
    assert!(pool >= 2 && others > 0, "{pool} candidates in the band, {others} draws not FIT-SLAM's");
}

#[test]
fn ranks_are_complete_and_deterministic_on_a_bigger_world() {
    let w = synthetic_world(&SyntheticWorldSpec::small(2));
    let p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(0.5);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let d = FitSlam::default().select(&input, &valid(&p)).unwrap();
    let d2 = FitSlam::default().select(&input, &valid(&p)).unwrap();
    assert_eq!(d, d2);
    // Candidates sorted by flat cell index.
    let g = w.grid.geometry;
    assert!(d.candidates.windows(2).all(|c| g.index(c[0].cell) <= g.index(c[1].cell)));
    // Exactly min(N, scored) candidates carry u2, ranked 1..=N by decreasing u2.
    let scored = d.candidates.iter().filter(|c| c.is_scored()).count();
    let ranked = d.ranking();
    assert_eq!(ranked.len(), scored.min(p.u2.top_n));
    assert!(ranked.windows(2).all(|r| d.candidates[r[0]].u2 >= d.candidates[r[1]].u2));
    assert_eq!(d.chosen, ranked.first().copied());
    // The top N by u2 are the top N by u1.
    assert!(ranked.iter().all(|&i| d.candidates[i].u1_rank.unwrap() <= p.u2.top_n));
    // Greedy ranks every scored candidate by increasing ρ.
    let gr = Greedy::default().select(&input, &valid(&p)).unwrap();
    let order = gr.ranking();
    assert_eq!(order.len(), scored);
    assert!(order.windows(2).all(|r| gr.candidates[r[0]].rho_m <= gr.candidates[r[1]].rho_m));
}

#[test]
fn robot_cell_errors_and_snapping() {
    let w = corridor_two_frontiers(false);
    let p = params();
    let lv = LandmarkVoxels::empty(0.25);
    let bl = Blacklist::new(0.5);
    let at = |x: f64, y: f64| DecisionInput::new(&w.grid, &lv, Pose2::new(x, y, 0.0), &bl);
    assert_eq!(Greedy::default().select(&at(f64::NAN, 1.0), &valid(&p)).unwrap_err(), SelectError::RobotPoseNotFinite);
    assert!(matches!(Greedy::default().select(&at(-1.0, 1.0), &valid(&p)).unwrap_err(), SelectError::RobotOutsideMap { .. }));
    // Row 11 (y = 1.15) is within 0.25 m of the wall on row 9: lethal after inflation (rows
    // 10–11). The nearest free cell within 0.25 + 0.1 m is on row 12, straight up.
    let d = Greedy::default().select(&at(11.55, 1.15), &valid(&p)).unwrap();
    assert!(d.start_snapped);
    assert_eq!(d.requested_robot_cell, Cell::new(115, 11));
    assert_eq!(d.robot_cell, Cell::new(115, 12));
    // Deep inside unknown space: no free cell within reach.
    assert!(matches!(Greedy::default().select(&at(1.0, 1.0), &valid(&p)).unwrap_err(), SelectError::RobotBlocked { .. }));
    // Out-of-range parameters never reach a selector: they take only checked ones.
    let mut bad = p.clone();
    bad.u1.alpha = 2.0;
    assert_eq!(Valid::new(bad).unwrap_err().key, "u1.alpha");
    // What depends on the map is checked against it: a waypoint spacing under its cell.
    let mut fine = p.clone();
    fine.u2.waypoint_spacing_m = Some(p.grid.resolution_m * 2.0);
    let coarse = Grid::filled(GridGeometry::new(0.0, 0.0, p.grid.resolution_m * 5.0, 30, 30), FREE);
    let input = DecisionInput::new(&coarse, &lv, Pose2::new(1.5, 1.5, 0.0), &bl);
    assert!(matches!(Greedy::default().select(&input, &valid(&fine)).unwrap_err(), SelectError::InvalidParams(_)));
}

#[test]
fn no_frontier_is_not_an_error() {
    let g = Grid::filled(GridGeometry::new(0.0, 0.0, 0.1, 30, 30), FREE);
    let lv = LandmarkVoxels::empty(0.25);
    let bl = Blacklist::new(0.5);
    let d = FitSlam::default().select(&DecisionInput::new(&g, &lv, Pose2::new(1.5, 1.5, 0.0), &bl), &valid(&params())).unwrap();
    assert!(d.candidates.is_empty());
    assert_eq!(d.chosen, None);
    let _ = (LETHAL, UNKNOWN);
}

#[test]
fn decision_json_has_the_keys() {
    let w = corridor_two_frontiers(true);
    let p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(0.5);
    let mut sel = make_selector(&p.selector);
    assert_eq!(sel.strategy(), Strategy::Fit);
    let d = sel.select(&DecisionInput::new(&w.grid, &lv, w.robot, &bl), &valid(&p)).unwrap();
    let v = serde_json::to_value(&d).unwrap();
    for k in ["strategy", "chosen", "goal", "robot", "robot_cell", "requested_robot_cell", "start_snapped", "ray_angles_rad", "candidates"]
    {
        assert!(v.get(k).is_some(), "decision lacks {k}");
    }
    assert_eq!(v["strategy"], "fit");
    let c = &v["candidates"][0];
    for k in [
        "cell",
        "x_m",
        "y_m",
        "cluster_size",
        "cluster_cells",
        "rho_m",
        "path_m",
        "delta_e_bits",
        "theta_star_rad",
        "ray_gains_bits",
        "u1",
        "u1_rank",
        "waypoints",
        "path_info_raw",
        "path_info",
        "u2",
        "rank",
        "dropped",
    ] {
        assert!(c.get(k).is_some(), "candidate lacks {k}");
    }
    let wp = &v["candidates"][d.chosen.unwrap()]["waypoints"][0];
    for k in ["x_m", "y_m", "z_m", "yaw_rad", "arc_length_m", "is_goal", "voxels_seen", "info"] {
        assert!(wp.get(k).is_some(), "waypoint lacks {k}");
    }
    assert_eq!(
        serde_json::to_value(DropReason::Blacklisted(BlacklistReason::NoPath)).unwrap(),
        serde_json::json!({"blacklisted": "no_path"})
    );
    assert_eq!(serde_json::to_value(DropReason::NotInTopN).unwrap(), serde_json::json!("not_in_top_n"));
}

#[test]
fn a_selector_reusing_its_buffers_decides_as_a_fresh_one() {
    // Maps of different sizes and contents, in turn, with unknown space impassable (one flood)
    // and passable (WFD, then Dijkstra): the buffers carry capacity over, never content, so every
    // decision equals a fresh selector's.
    let p = params();
    let mut p_unknown = p.clone();
    p_unknown.planner.allow_unknown = true;
    let corridor = corridor_two_frontiers(true);
    let worlds = [synthetic_world(&SyntheticWorldSpec::small(5)), corridor, synthetic_world(&SyntheticWorldSpec::small(6))];
    let bl = Blacklist::new(0.5);
    let all =
        || -> Vec<Box<dyn GoalSelector>> { vec![Box::new(FitSlam::default()), Box::new(Greedy::default()), Box::new(U1Only::default())] };
    let mut reused = all();
    for w in worlds.iter().chain(worlds.iter().rev()) {
        let lv = voxels(w, &p);
        let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
        for p in [&p, &p_unknown, &p] {
            let p = &valid(p);
            for (a, mut b) in reused.iter_mut().zip(all()) {
                let d = a.select(&input, p).unwrap();
                assert!(d.candidates.len() >= 2);
                let allow = p.planner.allow_unknown;
                assert_eq!(d, b.select(&input, p).unwrap(), "{:?} on a {:?} map, allow_unknown {allow}", a.strategy(), w.grid.geometry);
            }
        }
    }
}

#[test]
fn a_robot_goes_back_through_a_doorway_it_drove_through() {
    // 4 m × 2 m at 0.1 m: a wall on column 20 with a 0.3 m doorway (rows 9–11), the room on
    // the left, free ground to column 30 on the right and unknown beyond (the frontier).
    let geometry = GridGeometry::new(0.0, 0.0, 0.1, 40, 20);
    let mut grid = Grid::filled(geometry, FREE);
    for row in 0..20 {
        for col in 31..40 {
            grid.data[row * 40 + col] = UNKNOWN;
        }
        if !(9..=11).contains(&row) {
            grid.data[row * 40 + 20] = LETHAL;
        }
    }
    let (lv, bl, p) = (LandmarkVoxels::empty(0.25), Blacklist::new(0.5), params());
    let robot = Pose2::new(1.05, 1.05, 0.0);
    // Inflated by 0.25 m the doorway is shut: no frontier reachable.
    let d = Greedy::default().select(&DecisionInput::new(&grid, &lv, robot, &bl), &valid(&p)).unwrap();
    assert_eq!(d.chosen, None);
    // The robot came in along row 10: its trail keeps the doorway's cells open.
    let trail: Vec<usize> = (10..=30).map(|col| 10 * 40 + col).collect();
    let input = DecisionInput { traversed: &trail, ..DecisionInput::new(&grid, &lv, robot, &bl) };
    let d = Greedy::default().select(&input, &valid(&p)).unwrap();
    let c = &d.candidates[d.chosen.expect("a frontier beyond the doorway")];
    assert!(c.x_m > 3.0);
    // Every cell the path's polyline crosses (sampled every 1 cm) is free after inflation or a
    // trail cell free before it, and the path goes through the doorway.
    let inflated = crate::grid::inflate_lethal(&grid, p.robot.radius_m);
    let mut crossed = Vec::new();
    for w in c.path_m.windows(2) {
        let n = (((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])) / 0.01).ceil().max(1.0) as usize;
        crossed.extend((0..=n).map(|k| {
            let t = k as f64 / n as f64;
            geometry.index(geometry.cell_of(w[0][0] + t * (w[1][0] - w[0][0]), w[0][1] + t * (w[1][1] - w[0][1])).unwrap()).unwrap()
        }));
    }
    assert!(crossed.iter().all(|&i| inflated.data[i] == FREE || (trail.contains(&i) && grid.data[i] == FREE)));
    assert!(crossed.contains(&(10 * 40 + 20)), "through the doorway");
    // A trail cell outside the grid is an error.
    let bad = [800];
    let input = DecisionInput { traversed: &bad, ..DecisionInput::new(&grid, &lv, robot, &bl) };
    assert_eq!(Greedy::default().select(&input, &valid(&p)).unwrap_err(), SelectError::TraversedOutsideGrid { index: 800, cells: 800 });
}

/// `matched_top` draws only among u1's N best, at FIT-SLAM's distance: every draw has a u1 rank
/// ≤ N and a path length within ±20 % of FIT-SLAM's, and with N = 1 it is FIT-SLAM's goal.
#[test]
fn length_matched_among_the_top_n_draws_from_u2s_own_candidates() {
    let w = synthetic_world(&SyntheticWorldSpec::small(11));
    let mut p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(p.frontier.blacklist_radius_m);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let fit = FitSlam::default().select(&input, &valid(&p)).unwrap();
    let rho_fit = fit.chosen_candidate().unwrap().rho_m.unwrap();
    let mut s = make_selector(&SelectorParams { strategy: Strategy::MatchedTop, seed: 9, ..SelectorParams::default() });
    assert_eq!(s.strategy(), Strategy::MatchedTop);
    for _ in 0..30 {
        let d = s.select(&input, &valid(&p)).unwrap();
        assert_eq!(d.strategy, Strategy::MatchedTop);
        let c = d.chosen_candidate().unwrap();
        assert!(c.u1_rank.unwrap() <= p.u2.top_n, "u1 rank {:?}", c.u1_rank);
        assert!((c.rho_m.unwrap() - rho_fit).abs() <= 0.2 * rho_fit + 1e-12);
    }
    p.u2.top_n = 1;
    let fit = FitSlam::default().select(&input, &valid(&p)).unwrap();
    let d = LengthMatched::new(4, MatchPool::TopN).select(&input, &valid(&p)).unwrap();
    assert_eq!(d.chosen, fit.chosen, "one candidate in the pool: FIT-SLAM's");
}

/// `u2_length`: u2 = β u1 + (1 − β) ρ / max ρ over the N best (the default `max` normalisation),
/// computed here from the reported u1 and ρ; the goal is its argmax, no waypoint is computed.
#[test]
fn u2_with_path_length_ranks_by_beta_u1_plus_normalised_length() {
    let w = synthetic_world(&SyntheticWorldSpec::small(2));
    let p = params();
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(p.frontier.blacklist_radius_m);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let d =
        make_selector(&SelectorParams { strategy: Strategy::U2Length, ..SelectorParams::default() }).select(&input, &valid(&p)).unwrap();
    assert_eq!(d.strategy, Strategy::U2Length);
    let top: Vec<&CandidateReport> = d.candidates.iter().filter(|c| c.u2.is_some()).collect();
    assert_eq!(top.len(), p.u2.top_n.min(d.candidates.iter().filter(|c| c.is_scored()).count()));
    let max_rho = top.iter().map(|c| c.rho_m.unwrap()).fold(0.0, f64::max);
    let beta = p.u2.beta;
    let mut best = (f64::NEG_INFINITY, usize::MAX);
    for (i, c) in d.candidates.iter().enumerate().filter(|(_, c)| c.u2.is_some()) {
        let expected = beta * c.u1.unwrap() + (1.0 - beta) * c.rho_m.unwrap() / max_rho;
        assert!((c.u2.unwrap() - expected).abs() < 1e-12, "u2 {} vs {expected}", c.u2.unwrap());
        assert_eq!(c.path_info_raw, c.rho_m);
        assert!(c.waypoints.is_empty());
        if expected > best.0 {
            best = (expected, i);
        }
    }
    assert_eq!(d.chosen, Some(best.1));
    // The same candidates and u1 as FIT-SLAM; only u2's second term differs.
    let fit = FitSlam::default().select(&input, &valid(&p)).unwrap();
    assert_eq!(fit.candidates.iter().map(|c| c.u1).collect::<Vec<_>>(), d.candidates.iter().map(|c| c.u1).collect::<Vec<_>>());
}

/// `u2_truth`: u2 = β u1 + (1 − β) s / max s over the N best, s the share of views (every
/// `tracked_spacing_m` and the goal) that hold at least `tracked_min_voxels` voxels; in the
/// corridor with landmarks only to the east it goes east, where greedy goes west.
#[test]
fn u2_truth_ranks_by_the_share_of_tracked_views() {
    let w = corridor_two_frontiers(true);
    let mut p = params();
    p.u2.tracked_min_voxels = 3;
    let lv = voxels(&w, &p);
    let bl = Blacklist::new(p.frontier.blacklist_radius_m);
    let input = DecisionInput::new(&w.grid, &lv, w.robot, &bl);
    let d = make_selector(&SelectorParams { strategy: Strategy::U2Truth, ..SelectorParams::default() }).select(&input, &valid(&p)).unwrap();
    assert_eq!(d.strategy, Strategy::U2Truth);
    let top: Vec<&CandidateReport> = d.candidates.iter().filter(|c| c.u2.is_some()).collect();
    assert_eq!(top.len(), 2);
    let share = |c: &CandidateReport| c.waypoints.iter().filter(|w| w.voxels_seen >= 3).count() as f64 / c.waypoints.len() as f64;
    let max_share = top.iter().map(|c| share(c)).fold(0.0, f64::max);
    for c in &top {
        // Views 0.5 m apart along the path, then the goal.
        for pair in c.waypoints.windows(2).filter(|w| !w[1].is_goal) {
            assert!((pair[1].arc_length_m - pair[0].arc_length_m - 0.5).abs() < 1e-9);
        }
        assert_eq!(c.path_info_raw, Some(share(c)));
        let expected = p.u2.beta * c.u1.unwrap() + (1.0 - p.u2.beta) * share(c) / max_share;
        assert!((c.u2.unwrap() - expected).abs() < 1e-12);
    }
    let west = top.iter().find(|c| c.x_m < w.robot.x_m).unwrap();
    let east = top.iter().find(|c| c.x_m > w.robot.x_m).unwrap();
    assert_eq!(share(west), 0.0, "no landmark to the west");
    assert!(share(east) > 0.5, "most views east see the walls' landmarks: {}", share(east));
    assert!(d.goal.unwrap().x_m > w.robot.x_m);
    let greedy = Greedy::default().select(&input, &valid(&p)).unwrap();
    assert!(greedy.goal.unwrap().x_m < w.robot.x_m);
}
