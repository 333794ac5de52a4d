//! One full FIT-SLAM decision on the synthetic 100 m × 100 m world at 0.05 m (2000 × 2000 cells,
//! partially explored with a ragged frontier, obstacles, 50,000 landmarks): median of several
//! runs, single-threaded, with a per-stage breakdown.
//!
//! `cargo bench --bench decision` (optionally `-- RUNS`).

use fitslam_core::fixtures::{synthetic_world, SyntheticWorldSpec};
use fitslam_core::frontier::Blacklist;
use fitslam_core::grid::{FREE, LETHAL, UNKNOWN};
use fitslam_core::params::{Params, Strategy};
use fitslam_core::select::candidates::{distances, frontier_clusters, prepare, rank_and_choose, score_u1, score_u2};
use fitslam_core::select::{DecisionInput, FitSlam, GoalSelector};
use fitslam_core::utility::LandmarkVoxels;
use std::time::Instant;

// PROTOTYPE (not wired): exact Dijkstra for 8-connected octile grids with costs {1, √2}, using a
// bucket queue of width 1 cell (= the smallest edge cost): a node popped from bucket k = ⌊cost⌋
// cannot be improved by another node of the same bucket (any edge adds ≥ 1), so buckets can be
// processed in any internal order; √2 < 2 so three rotating buckets suffice. O(n).
// Same move rules as path::step (inside, passable, diagonal needs both orthogonals passable).
pub fn bucket_dijkstra(grid: &fitslam_core::OccupancyGrid, start: fitslam_core::Cell, allow_unknown: bool) -> (Vec<f64>, Vec<u32>) {
    use fitslam_core::path::passable;
    let g = grid.geometry;
    let (w, h) = (g.width, g.height);
    let pw = w + 2;
    // Padded passability: border cells impassable, so no bounds checks in the loop.
    let mut ok = vec![false; pw * (h + 2)];
    for r in 0..h {
        for c in 0..w {
            ok[(r + 1) * pw + c + 1] = passable(grid.data[r * w + c], allow_unknown);
        }
    }
    let mut cost = vec![f64::INFINITY; pw * (h + 2)];
    let mut parent = vec![u32::MAX; pw * (h + 2)];
    let mut done = vec![false; pw * (h + 2)];
    let s = (start.row as usize + 1) * pw + start.col as usize + 1;
    let mut buckets: [Vec<u32>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    cost[s] = 0.0;
    buckets[0].push(s as u32);
    let mut k = 0usize;
    let pwi = pw as isize;
    let orth = [1isize, -1, pwi, -pwi];
    let diag = [(pwi + 1, 1isize, pwi), (pwi - 1, -1, pwi), (-pwi + 1, 1, -pwi), (-pwi - 1, -1, -pwi)];
    let mut empty_rounds = 0;
    while empty_rounds < 3 {
        let b = k % 3;
        if buckets[b].is_empty() {
            empty_rounds += 1;
            k += 1;
            continue;
        }
        empty_rounds = 0;
        while let Some(i) = buckets[b].pop() {
            let i = i as usize;
            if done[i] || (cost[i] as usize) != k {
                continue;
            }
            done[i] = true;
            let ci = cost[i];
            for &d in &orth {
                let j = (i as isize + d) as usize;
                if ok[j] && ci + 1.0 < cost[j] {
                    cost[j] = ci + 1.0;
                    parent[j] = i as u32;
                    buckets[(cost[j] as usize) % 3].push(j as u32);
                }
            }
            for &(d, dx, dy) in &diag {
                let j = (i as isize + d) as usize;
                let c = ci + std::f64::consts::SQRT_2;
                if ok[j] && ok[(i as isize + dx) as usize] && ok[(i as isize + dy) as usize] && c < cost[j] {
                    cost[j] = c;
                    parent[j] = i as u32;
                    buckets[(c as usize) % 3].push(j as u32);
                }
            }
        }
        k += 1;
    }
    (cost, parent)
}

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
    let params = Params::default();
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

    let names = ["inflate + robot cell", "frontiers (WFD + clusters)", "Dijkstra", "u1 (paths, rays, Θ*)", "u2 (waypoints, FIM)", "total (stages)", "FitSlam::select"];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut summary = String::new();
    for run in 0..runs {
        let t0 = Instant::now();
        let prepared = prepare(&input, &params).expect("prepare");
        let t1 = Instant::now();
        let clusters = frontier_clusters(&input, &prepared, &params).expect("frontiers");
        let t2 = Instant::now();
        let field = distances(&prepared, &params).expect("dijkstra");
        let t3 = Instant::now();
        let mut d = score_u1(&input, &prepared, clusters, &field, &params, Strategy::Fit).expect("u1");
        let t4 = Instant::now();
        score_u2(&mut d, &input, &params);
        let ranked: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].u2.is_some()).collect();
        rank_and_choose(&mut d, &ranked, |c| -c.u2.unwrap_or(f64::NEG_INFINITY));
        let t5 = Instant::now();
        let full = FitSlam.select(&input, &params).expect("select");
        let t6 = Instant::now();
        assert_eq!(full.chosen, d.chosen);
        for (k, (a, b)) in [(t0, t1), (t1, t2), (t2, t3), (t3, t4), (t4, t5), (t0, t5), (t5, t6)].iter().enumerate() {
            times[k].push(1e3 * (*b - *a).as_secs_f64());
        }
        if run == 0 {
            let scored = d.candidates.iter().filter(|c| c.is_scored()).count();
            let top: Vec<_> = d.candidates.iter().filter(|c| c.u2.is_some()).collect();
            let wps: usize = top.iter().map(|c| c.waypoints.len()).sum();
            let seen: usize = top.iter().flat_map(|c| c.waypoints.iter()).map(|w| w.voxels_seen).sum();
            let reached = (0..g.len()).filter(|&i| field.reachable(g.cell_at(i))).count();
            summary = format!(
                "candidates {} (scored {}), reachable cells {}, top-{} waypoints {} seeing {} voxels in all; chosen {:?} at ({:.2}, {:.2}) m",
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
    }
    println!("{summary}");
    {
        let prepared = prepare(&input, &params).expect("prepare");
        let field = distances(&prepared, &params).expect("dijkstra");
        let mut ts = Vec::new();
        let mut res = None;
        for _ in 0..runs { let t = Instant::now(); res = Some(bucket_dijkstra(&prepared.inflated, prepared.robot_cell, false)); ts.push(1e3 * t.elapsed().as_secs_f64()); }
        let (cost, _) = res.unwrap();
        let pw = g.width + 2;
        let mut maxdiff: f64 = 0.0; let mut mism = 0;
        for i in 0..g.len() { let c = g.cell_at(i); let a = field.distance_m(c); let b = cost[(c.row as usize + 1) * pw + c.col as usize + 1]; match a { Some(a) => maxdiff = maxdiff.max((a - b * g.resolution_m).abs()), None => if b.is_finite() { mism += 1 } } }
        println!("PROTO bucket dijkstra {:.2} ms, max |diff| {:.3e} m, reachability mismatches {}", median(&mut ts), maxdiff, mism);
    }
    println!("median of {runs} runs, one thread:");
    for (name, v) in names.iter().zip(times.iter_mut()) {
        println!("  {name:<28} {:>9.2} ms", median(v));
    }
}
