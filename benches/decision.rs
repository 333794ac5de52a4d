//! One full FIT-SLAM decision on the synthetic 100 m × 100 m world at 0.05 m (2000 × 2000 cells,
//! partially explored with a ragged frontier, obstacles, 50,000 landmarks): median of several
//! runs (and the minimum, less sensitive to other processes on the machine), single-threaded,
//! with a per-stage breakdown (the one flood also split into its Dijkstra, which fills the cost
//! window and searches, and the clustering of the frontier cells it found, timed apart after the
//! decisions). The stages and the selector keep their grid-sized buffers from run
//! to run, as a selector does from decision to decision in a mission.
//!
//! `cargo bench --bench decision` (optionally `-- RUNS`).

#![allow(clippy::unwrap_used, clippy::expect_used)] // a bench: a failure should stop it

use fitslam_core::fixtures::{SyntheticWorldSpec, synthetic_world};
use fitslam_core::frontier::Blacklist;
use fitslam_core::frontier::cluster_frontier_cells;
use fitslam_core::grid::{FREE, LETHAL, UNKNOWN};
use fitslam_core::params::{Params, Strategy, Valid};
use fitslam_core::path::dijkstra_with_frontiers;
use fitslam_core::select::candidates::{PathScore, PlanBuffers, frontiers_and_distances, prepare, rank_by_u2, score_u1, score_u2};
use fitslam_core::select::{DecisionInput, FitSlam, GoalSelector};
use fitslam_core::utility::LandmarkVoxels;
use std::time::Instant;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let runs: usize = std::env::args().skip(1).find_map(|a| a.parse().ok()).unwrap_or(9);
    let t = Instant::now();
    let spec = SyntheticWorldSpec::benchmark();
    let world = synthetic_world(&spec);
    let build_world_s = t.elapsed().as_secs_f64();
    let params = Valid::<Params>::default();
    let g = world.grid.geometry;
    let count = |v: i8| world.grid.data.iter().filter(|&&x| x == v).count();
    println!(
        "world: {} x {} cells at {} m ({:.1} s to build); free {:.1} %, lethal {:.1} %, unknown {:.1} %; {} landmarks",
        g.width,
        g.height,
        g.resolution_m,
        build_world_s,
        100.0 * count(FREE) as f64 / g.len() as f64,
        100.0 * count(LETHAL) as f64 / g.len() as f64,
        100.0 * count(UNKNOWN) as f64 / g.len() as f64,
        world.landmarks.len()
    );

    let t = Instant::now();
    let voxels = LandmarkVoxels::new(&world.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m).expect("voxels");
    println!("landmark voxels: {} (built once per landmark set in {:.2} ms)", voxels.len(), 1e3 * t.elapsed().as_secs_f64());

    let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
    let input = DecisionInput::new(&world.grid, &voxels, world.robot, &blacklist);

    let names = [
        "inflate + robot cell",
        "frontiers + Dijkstra (1 flood)",
        "u1 (paths, rays, Θ*)",
        "u2 (waypoints, FIM)",
        "total (stages)",
        "FitSlam::select",
    ];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut summary = String::new();
    let mut buffers = PlanBuffers::default();
    let mut selector = FitSlam::default();
    for run in 0..runs {
        let t0 = Instant::now();
        let prepared = prepare(&input, &params, &mut buffers).expect("prepare");
        let t1 = Instant::now();
        let (clusters, field) = frontiers_and_distances(&input, &prepared, &params, &mut buffers).expect("flood");
        let t3 = Instant::now();
        let mut d = score_u1(&input, &prepared, clusters, &field, &params, Strategy::Fit).expect("u1");
        let t4 = Instant::now();
        score_u2(&mut d, &input, &params, PathScore::Fisher);
        rank_by_u2(&mut d);
        let t5 = Instant::now();
        let full = selector.select(&input, &params).expect("select");
        let t6 = Instant::now();
        assert_eq!(full.chosen, d.chosen);
        for (k, (a, b)) in [(t0, t1), (t1, t3), (t3, t4), (t4, t5), (t0, t5), (t5, t6)].iter().enumerate() {
            times[k].push(1e3 * (*b - *a).as_secs_f64());
        }
        if run == 0 {
            let scored = d.candidates.iter().filter(|c| c.is_scored()).count();
            let top: Vec<_> = d.candidates.iter().filter(|c| c.u2.is_some()).collect();
            let wps: usize = top.iter().map(|c| c.waypoints.len()).sum();
            let seen: usize = top.iter().flat_map(|c| c.waypoints.iter()).map(|w| w.voxels_seen).sum();
            let reached = field.settled_count();
            summary = format!(
                "candidates {} (scored {}), cells settled by Dijkstra {}, top-{} waypoints {} seeing {} voxels in all; chosen {:?} at ({:.2}, {:.2}) m",
                d.candidates.len(),
                scored,
                reached,
                params.u2.top_n,
                wps,
                seen,
                d.chosen,
                d.goal.map_or(f64::NAN, |p| p.x_m),
                d.goal.map_or(f64::NAN, |p| p.y_m),
            );
        }
        buffers.recycle(prepared, field);
    }
    // The one flood's two parts, timed apart after the decisions (same inputs, reused buffers).
    let prepared = prepare(&input, &params, &mut buffers).expect("prepare");
    let (mut cost, mut state) = (Default::default(), Vec::new());
    let mut parts: Vec<Vec<f64>> = vec![Vec::new(); 2];
    for _ in 0..runs {
        let t0 = Instant::now();
        let (field, frontier) = dijkstra_with_frontiers(&prepared.inflated, prepared.robot_cell, cost).expect("flood");
        let t1 = Instant::now();
        let clusters = cluster_frontier_cells(&g, &frontier, input.boundary, &params.frontier, &mut state).expect("clusters");
        let t2 = Instant::now();
        std::hint::black_box(clusters);
        cost = field.into_buffers();
        parts[0].push(1e3 * (t1 - t0).as_secs_f64());
        parts[1].push(1e3 * (t2 - t1).as_secs_f64());
    }
    times.extend(parts);
    println!("{summary}");
    println!("{runs} runs, one thread:               median        min");
    let names: Vec<&str> = names.iter().copied().chain(["  Dijkstra, fill + search", "  clustering"]).collect();
    // The flood's parts right under it.
    for k in [0, 1, 6, 7, 2, 3, 4, 5] {
        let v = &mut times[k];
        let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
        println!("  {:<30} {:>9.2} ms {:>8.2} ms", names[k], median(v), min);
    }
}
