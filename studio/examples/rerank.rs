//! Times re-ranking after a parameter change on every built-in scene, natively:
//! `cargo run -p fitslam-studio --release --example rerank`.
//!
//! For each scene: one warm-up decision, then `ROUNDS` decisions each after moving β (the
//! slider a user drags), the same work the studio does per slider step; prints the median and
//! maximum wall-clock time of the core's `select` call and of the core stages inside it.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a example: a failure should stop it

use fitslam_core::Params;
use fitslam_core::select::DecisionInput;
use fitslam_core::select::candidates::{PathScore, PlanBuffers, frontiers_and_distances, prepare, score_u1, score_u2};
use fitslam_core::traversability::to_occupancy;
use fitslam_core::utility::LandmarkVoxels;
use fitslam_studio::pipeline::{Pipeline, Revisions};
use std::time::Instant;

const ROUNDS: usize = 41;

fn main() {
    for b in fitslam_studio::assets::builtins() {
        let scene = match b.build(0.5) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{}: {e}", b.name);
                continue;
            }
        };
        let g = scene.map.geometry();
        let mut params = Params::default();
        let mut pipeline = Pipeline::default();
        pipeline.update(&scene, Revisions::default(), &params, &Default::default());
        let mut times = Vec::with_capacity(ROUNDS);
        for k in 0..ROUNDS {
            params.u2.beta = (k % 21) as f64 / 20.0;
            let revs = Revisions::default();
            let t = Instant::now();
            pipeline.update(&scene, revs, &params, &Default::default());
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        let d = pipeline.ok_decision();
        println!(
            "{:<10} {}x{} cells, {} landmarks, {} candidates: re-rank median {:.2} ms, max {:.2} ms ({} rounds)",
            b.name,
            g.width,
            g.height,
            scene.landmarks.cloud.len(),
            d.map(|d| d.candidates.len()).unwrap_or(0),
            times[times.len() / 2],
            times[times.len() - 1],
            ROUNDS
        );
        // Where the time goes, stage by stage (same calls as the selector).
        let params = fitslam_core::params::Valid::<Params>::default();
        let grid = to_occupancy(&scene.map.score, params.traversability.tau);
        let voxels = LandmarkVoxels::new(&scene.landmarks.cloud, params.u2.voxel_m, params.u2.sigma_landmark_m).unwrap();
        let input = DecisionInput::new(&grid, &voxels, scene.robot, &scene.blacklist).with_boundary(&scene.boundary);
        let mut buffers = PlanBuffers::default();
        let t = Instant::now();
        let prepared = prepare(&input, &params, &mut buffers).unwrap();
        let t_prep = t.elapsed();
        let t = Instant::now();
        let (clusters, field) = frontiers_and_distances(&input, &prepared, &params, &mut buffers).unwrap();
        let t_flood = t.elapsed();
        let t = Instant::now();
        let mut d = score_u1(&input, &prepared, clusters, &field, &params, params.selector.strategy).unwrap();
        let t_u1 = t.elapsed();
        let t = Instant::now();
        score_u2(&mut d, &input, &params, PathScore::Fisher);
        let t_u2 = t.elapsed();
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        println!(
            "{:<10} stages: inflate+locate {:.2} ms, frontiers + dijkstra {:.2} ms, u1 {:.2} ms, u2 {:.2} ms",
            "",
            ms(t_prep),
            ms(t_flood),
            ms(t_u1),
            ms(t_u2)
        );
    }
}
