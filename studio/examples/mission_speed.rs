//! Simulated seconds per real second of the Mission mode's runner, natively and without drawing:
//! `cargo run -p fitslam-studio --release --example mission_speed [world] [seconds]`.
//!
//! Runs the studio's `SimRunner` "as fast as possible" with the default 8 ms budget per frame,
//! frames back to back (so the budget is the whole frame: an upper bound on what a window
//! gets), for three lanes (fit, greedy, random) and then one (fit), each for the given wall-clock
//! seconds (default 10), and prints the simulated time per lane per real second. The browser's
//! figure comes from `studio/web-test/browser-test.mjs` (`mission_speed.json`).

#![allow(clippy::unwrap_used, clippy::expect_used)] // a example: a failure should stop it

use fitslam_core::Params;
use fitslam_core::params::Strategy;
use fitslam_core::sim::Localisation;
use fitslam_studio::sim_runner::{MissionConfig, SimRunner, now_ms};

fn main() {
    let world = std::env::args().nth(1).unwrap_or_else(|| "paper_unstructured_20m".into());
    let seconds: f64 = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(10.0);
    for strategies in [vec![Strategy::Fit, Strategy::Greedy, Strategy::Random], vec![Strategy::Fit]] {
        let n = strategies.len();
        let config = MissionConfig {
            world: world.clone(),
            strategies,
            seed: 0,
            localisation: Localisation::GroundTruth,
            ..MissionConfig::default()
        };
        let mut r = match SimRunner::new(config, &Params::default()) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        r.speed = f64::INFINITY;
        r.play();
        let t0 = now_ms();
        let mut frames = 0u64;
        while now_ms() - t0 < seconds * 1e3 && !r.finished() {
            r.advance(1.0 / 60.0, now_ms);
            frames += 1;
        }
        let wall_s = (now_ms() - t0) * 1e-3;
        println!(
            "{world}: {n} lane(s): {:.1} s simulated per lane in {wall_s:.1} s = {:.1} sim s / s per lane ({} ticks, {frames} frames{})",
            r.time_s(),
            r.time_s() / wall_s,
            r.ticks,
            if r.finished() { ", all ended" } else { "" }
        );
    }
}
