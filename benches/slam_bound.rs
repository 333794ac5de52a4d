//! The least the SLAM back end's exact work can cost in a whole mission, measured against the
//! mission itself. Notes §1 asks for a full optimisation on every loop closure and the true
//! marginal of the current pose; each of those needs at least one numeric Cholesky factorisation
//! of the whole information matrix (an optimisation step, or the marginal's factor). The bench
//! runs one SLAM mission step by step and, after every loop closure, factorises the whole
//! problem once more outside the mission's clock ([`GraphSlam::marginals`]: structure, AMD,
//! linearisation, one numeric factorisation), recording its time and its size and flops
//! ([`FactorStats`]). It also times faer's dense Cholesky of an n × n matrix (n = `--dense-n`,
//! default 2000), the fastest a factorisation runs per flop on this machine: the sparse one's
//! flops divided by that rate bound its time from below for this elimination order (faer's AMD;
//! `scripts/ordering_fill.py` counts other orders' flops).
//!
//! Prints the mission's own wall time (without the extra factorisations), the loop closures, the
//! summed time and flops of one factorisation per closure, the flops over the dense rate, and
//! the same for the final graph. Timing only; nothing is asserted.
//!
//! `cargo bench --bench slam_bound -- [WORLD.toml] [--seed S] [--time-s T] [--dense-n N]
//! [--solver batch|incremental] [--structure-out FILE]` (defaults: `benches/worlds/long_40m.toml`,
//! seed 1, the world's time limit, the default solver). `--structure-out` writes the final graph's structure for `scripts/ordering_fill.py`
//! (which compares the flops of other elimination orders): a line `v <var> <dim> <position>` per
//! free variable (its place in faer's AMD order) and `f <var> <var> …` per factor.
//!
//! [`GraphSlam::marginals`]: fitslam_core::slam::GraphSlam::marginals
//! [`FactorStats`]: fitslam_core::slam::FactorStats

#![allow(clippy::unwrap_used, clippy::expect_used)] // a bench: a failure should stop it

mod common;

use std::time::Instant;

use faer::{Mat, Side};
use fitslam_core::params::{Params, Strategy, Valid};
use fitslam_core::sim::{Localisation, Mission, MissionParams, StepOutcome};
use fitslam_core::slam::{Marginals, SlamSolver};

fn main() {
    let args = common::Args::from_env();
    let value = |name: &str| args.value(name);
    let world_file = args.world_file("benches/worlds/long_40m.toml");
    let seed = value("--seed").unwrap_or(1.0) as u64;
    let dense_n = value("--dense-n").unwrap_or(2000.0) as usize;

    let dense_flops_per_s = dense_cholesky_rate(dense_n);
    println!("dense Cholesky, n = {dense_n}: {:.2} GFlop/s (best of 3, one thread)", dense_flops_per_s / 1e9);

    let params = Params::default();
    let world = common::load_world(&world_file, &params);
    let mut mission_params = MissionParams { time_limit_s: value("--time-s"), ..MissionParams::default() };
    if let Some(solver) = args.text("--solver") {
        mission_params.slam.graph.solver = match solver {
            "batch" => SlamSolver::Batch,
            "incremental" => SlamSolver::Incremental,
            other => panic!("--solver {other}: batch or incremental"),
        };
    }
    let mut mission = Mission::new(
        world,
        Valid::new(params).expect("parameters"),
        Valid::new(mission_params).expect("parameters"),
        Strategy::Fit,
        seed,
        Localisation::Slam,
    )
    .expect("mission");

    let (mut mission_s, mut closures) = (0.0, 0);
    let (mut closure_s, mut closure_flops) = (0.0, 0.0);
    loop {
        let t = Instant::now();
        let outcome = mission.step();
        mission_s += t.elapsed().as_secs_f64();
        let frontend = mission.slam_frontend().expect("a SLAM mission");
        if frontend.loop_closures() > closures {
            closures = frontend.loop_closures();
            let (s, marginals) = factorise(&mission);
            closure_s += s;
            closure_flops += marginals.factor_stats().flops;
        }
        if outcome != StepOutcome::Running {
            break;
        }
    }
    let backend = mission.slam_frontend().expect("a SLAM mission").backend();
    let (final_s, marginals) = factorise(&mission);
    let last = marginals.factor_stats();
    if let Some(path) = args.text("--structure-out") {
        std::fs::write(path, structure(&mission, &marginals)).expect("structure file written");
        println!("structure written to {path}");
    }
    println!(
        "{world_file}, fit, seed {seed}: {:.0} s simulated in {mission_s:.1} s of wall time (≈ {:.0}× real time)",
        mission.time_s(),
        mission.time_s() / mission_s
    );
    println!(
        "final graph: {} keyframes, {} landmarks, {} unknowns, {} factor entries ({}), {:.2} GFlop per factorisation",
        backend.keyframe_count(),
        backend.landmark_count(),
        last.dim,
        last.factor_entries,
        if last.supernodal { "supernodal" } else { "simplicial" },
        last.flops / 1e9
    );
    println!(
        "  one factorisation: {final_s:.3} s ({:.2} GFlop/s); at the dense rate ≥ {:.3} s",
        last.flops / final_s / 1e9,
        last.flops / dense_flops_per_s
    );
    println!("loop closures (full optimisations): {closures}");
    println!(
        "  one factorisation per closure: {closure_s:.1} s, {:.1} GFlop; at the dense rate ≥ {:.1} s",
        closure_flops / 1e9,
        closure_flops / dense_flops_per_s
    );
}

/// One factorisation of the whole problem now, and its wall time.
fn factorise(mission: &Mission) -> (f64, Marginals) {
    let backend = mission.slam_frontend().expect("a SLAM mission").backend();
    let t = Instant::now();
    let marginals = backend.marginals().expect("the problem factorises");
    (t.elapsed().as_secs_f64(), marginals)
}

/// The final graph's structure (see the module doc), with `marginals`' elimination order.
fn structure(mission: &Mission, marginals: &Marginals) -> String {
    use std::fmt::Write;
    let backend = mission.slam_frontend().expect("a SLAM mission").backend();
    let mut out = String::new();
    let values = backend.estimate();
    for (id, v) in values.iter() {
        if let Some(position) = marginals.elimination_position(id) {
            writeln!(out, "v {} {} {position}", id.0, v.dim()).expect("a String takes writes");
        }
    }
    for f in 0..backend.graph().len() {
        let keys: Vec<String> = backend.graph().keys_of(f).iter().map(|k| k.0.to_string()).collect();
        writeln!(out, "f {}", keys.join(" ")).expect("a String takes writes");
    }
    out
}

/// Flops per second of faer's dense Cholesky on an n × n positive definite matrix (n³/3 flops),
/// best of three.
fn dense_cholesky_rate(n: usize) -> f64 {
    let b = Mat::<f64>::from_fn(n, n, |i, j| (((i * 7919 + j * 104729) % 1000) as f64 / 1000.0) - 0.5);
    let mut a = &b * b.transpose();
    for i in 0..n {
        a[(i, i)] += n as f64;
    }
    let best = (0..3)
        .map(|_| {
            let t = Instant::now();
            let llt = a.llt(Side::Lower).expect("positive definite");
            std::hint::black_box(&llt);
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    (n as f64).powi(3) / 3.0 / best
}
