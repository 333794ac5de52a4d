//! SLAM consistency: does the pose covariance the SLAM reports match its real errors? Runs SLAM
//! missions and, at every metrics row (1 s), takes the error ξ = (R̂ᵀ(t − t̂), log(R̂ᵀR)) of the
//! estimated body pose (R̂, t̂) against the true one (R, t) — the right perturbation the 6×6
//! covariance Σ is expressed in — and averages the normalised estimation error squared
//! ξᵀΣ⁻¹ξ over rows and seeds, for the whole pose and for its blocks. A consistent estimator
//! gives the block's dimension (6, 3, 2, 1); more means over-confident.
//!
//! `cargo bench --bench slam_consistency -- [WORLD.toml] [--seeds N] [--time-s T]
//! [--gravity-sigma-rad S] [--tilt-gyro-sigma S] [--marginal-every K] [--window K]
//! [--feature-budget N] [--outlier-rate R] [--detection-probability P]` (defaults: the paper
//! world, 3 seeds, 400 s, the simulator's `SlamParams` and `VisionParams`; `--window 100000`
//! makes every update a full optimisation, `--detection-probability 0` drops the landmark
//! factors).

#![allow(clippy::unwrap_used, clippy::expect_used)] // a bench: a failure should stop it

mod common;

use fitslam_core::params::{Params, Strategy, Valid};
use fitslam_core::sim::StampedPose;
use fitslam_core::sim::{Localisation, Mission, MissionParams, StepOutcome};
use nalgebra::{DMatrix, DVector, Quaternion, UnitQuaternion, Vector3, Vector6};

fn main() {
    let args = common::Args::from_env();
    let value = |name: &str| args.value(name);
    let world_file = args.world_file("assets/worlds/paper_unstructured_20m.toml");
    let seeds = value("--seeds").unwrap_or(3.0) as u64;
    let params = Params::default();
    let world = common::load_world(&world_file, &params);
    let mut mp = MissionParams { time_limit_s: Some(value("--time-s").unwrap_or(400.0)), ..MissionParams::default() };
    if let Some(s) = value("--gravity-sigma-rad") {
        mp.slam.gravity_sigma_rad = s;
    }
    if let Some(k) = value("--marginal-every") {
        mp.slam.marginal_every_keyframes = k as usize;
    }
    if let Some(s) = value("--tilt-gyro-sigma") {
        mp.slam.tilt_gyro_sigma_per_sqrt_s = s;
    }
    if let Some(k) = value("--window") {
        mp.slam.graph.window_keyframes = k as usize;
    }
    if let Some(k) = value("--feature-budget") {
        mp.vision.feature_budget = k as usize;
    }
    if let Some(r) = value("--outlier-rate") {
        mp.vision.outlier_rate = r;
    }
    if let Some(p) = value("--detection-probability") {
        mp.vision.detection_probability = p;
    }

    // Blocks of ξ = (δt, δφ): whole, position, roll/pitch, yaw.
    let blocks: [(&str, &[usize]); 4] = [("6-DoF", &[0, 1, 2, 3, 4, 5]), ("position", &[0, 1, 2]), ("roll/pitch", &[3, 4]), ("yaw", &[5])];
    let mut nees = [0.0; 4];
    let (mut tilt_err2, mut tilt_var, mut rows) = (0.0, 0.0, 0usize);
    for seed in 1..=seeds {
        let mut m = Mission::new(
            world.clone(),
            Valid::new(params.clone()).expect("parameters"),
            Valid::new(mp.clone()).expect("parameters"),
            Strategy::Fit,
            seed,
            Localisation::Slam,
        )
        .expect("mission");
        let mut seen = 0;
        loop {
            let out = m.step();
            if m.trajectory_est().len() > seen {
                seen = m.trajectory_est().len();
                let xi = right_error(&m.trajectory_est()[seen - 1], &m.trajectory_gt()[seen - 1]);
                let cov6 = m.covariance().full6.expect("SLAM gives the 6×6 marginal");
                for (k, (_, idx)) in blocks.iter().enumerate() {
                    let e = DVector::from_iterator(idx.len(), idx.iter().map(|&i| xi[i]));
                    let c = DMatrix::from_fn(idx.len(), idx.len(), |a, b| cov6[(idx[a], idx[b])]);
                    nees[k] += c.try_inverse().map_or(f64::NAN, |ci| (e.transpose() * ci * &e)[0]);
                }
                tilt_err2 += 0.5 * (xi[3] * xi[3] + xi[4] * xi[4]);
                tilt_var += 0.5 * (cov6[(3, 3)] + cov6[(4, 4)]);
                rows += 1;
            }
            if !matches!(out, StepOutcome::Running) {
                break;
            }
        }
    }
    let n = rows as f64;
    println!(
        "{world_file}: {seeds} seeds, {rows} rows; gravity σ {} rad, exact marginal every {} keyframes",
        mp.slam.gravity_sigma_rad, mp.slam.marginal_every_keyframes
    );
    for (k, (name, idx)) in blocks.iter().enumerate() {
        println!("  mean NEES {name:<10} {:>6.2}   (consistent: {})", nees[k] / n, idx.len());
    }
    println!("  roll/pitch: RMS error {:.2} mrad, RMS marginal σ {:.2} mrad", 1e3 * (tilt_err2 / n).sqrt(), 1e3 * (tilt_var / n).sqrt());
}

/// ξ = (R̂ᵀ(t − t̂), log(R̂ᵀR)) of the true pose against the estimate.
fn right_error(est: &StampedPose, gt: &StampedPose) -> Vector6<f64> {
    let q = |p: &StampedPose| {
        let [x, y, z, w] = p.quaternion_xyzw;
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
    };
    let (re, rg) = (q(est), q(gt));
    let dt = re.inverse() * (Vector3::from(gt.position_m) - Vector3::from(est.position_m));
    let dphi = (re.inverse() * rg).scaled_axis();
    Vector6::new(dt.x, dt.y, dt.z, dphi.x, dphi.y, dphi.z)
}
