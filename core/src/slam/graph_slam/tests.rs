//! The keyframe SLAM back end on simulated keyframes: gravity, loop closures, consistency, both solvers.

use super::*;
use crate::slam::Isam2Params;
use crate::slam::backend::{CovarianceTraces, Gravity};
use crate::slam::lie::so3_exp;
use nalgebra::{DMatrix, Vector6};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    crate::math::standard_normal(rng)
}

/// A sample of N(0, diag(sigmas²)).
fn sample<const D: usize>(rng: &mut ChaCha8Rng, sigmas: [f64; D]) -> nalgebra::SVector<f64, D> {
    nalgebra::SVector::<f64, D>::from_fn(|i, _| sigmas[i] * gaussian(rng))
}

/// Ground truth: a rover driving a 40 m loop (40 keyframes, 1 m apart) on gently rolling
/// ground, 12 landmarks around it, seen within 4 m; odometry and observations corrupted with
/// known noise.
struct World {
    truth: Vec<Se3>,
    landmarks: Vec<Vector3<f64>>,
}

const ODOM_SIGMAS: [f64; 6] = [0.02, 0.02, 0.01, 0.005, 0.005, 0.01];
const OBS_SIGMA_M: f64 = 0.05;
const RANGE_M: f64 = 4.0;

fn world(keyframes: usize) -> World {
    let radius = 40.0 / std::f64::consts::TAU;
    let truth = (0..keyframes)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / keyframes as f64;
            let yaw = a + std::f64::consts::FRAC_PI_2;
            let rot = so3_exp(&Vector3::new(0.02 * a.sin(), 0.03 * a.cos(), yaw));
            Se3::new(rot, Vector3::new(radius * a.cos(), radius * a.sin(), 0.1 * (2.0 * a).sin()))
        })
        .collect();
    let landmarks = (0..12)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 12.0 + 0.1;
            let r = if i % 2 == 0 { radius + 1.5 } else { radius - 1.0 };
            Vector3::new(r * a.cos(), r * a.sin(), 0.3 + 0.1 * i as f64)
        })
        .collect();
    World { truth, landmarks }
}

fn observations(w: &World, k: usize, rng: &mut ChaCha8Rng) -> Vec<LandmarkObservation> {
    w.landmarks
        .iter()
        .enumerate()
        .filter_map(|(i, m)| {
            let p = w.truth[k].inverse_transform_point(m);
            (p.norm() < RANGE_M).then(|| LandmarkObservation {
                landmark_id: i as u64 * 10 + 3,
                point_in_robot: p + sample(rng, [OBS_SIGMA_M; 3]),
                covariance: Matrix3::identity() * OBS_SIGMA_M * OBS_SIGMA_M,
            })
        })
        .collect()
}

fn odometry(prev: &Se3, current: &Se3, rng: &mut ChaCha8Rng) -> Odometry {
    let rel = prev.between(current);
    let noise: Vector6<f64> = sample(rng, ODOM_SIGMAS);
    Odometry {
        previous_from_current: rel.retract(&noise),
        covariance: Matrix6::from_diagonal(&Vector6::from_row_slice(&ODOM_SIGMAS).map(|s| s * s)),
        gravity: None,
    }
}

/// Runs the loop (and 5 keyframes of a second lap, closing the loop).
fn run(seed: u64, params: GraphSlamParams) -> (World, GraphSlam, Vec<KeyframeUpdate>) {
    let n = 40;
    let w = world(n);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut slam = GraphSlam::new(params, w.truth[0], &observations(&w, 0, &mut rng)).unwrap();
    let mut updates = Vec::new();
    let mut truth = w.truth.clone();
    for k in 1..n + 5 {
        let kk = k % n;
        let rel = odometry(&w.truth[(k - 1) % n], &w.truth[kk], &mut rng);
        let obs = observations(&w, kk, &mut rng);
        updates.push(slam.add_keyframe(&rel, &obs).unwrap());
        if k >= n {
            truth.push(w.truth[kk]);
        }
    }
    (World { truth, landmarks: w.landmarks }, slam, updates)
}

fn mahalanobis2<const D: usize>(err: &nalgebra::SVector<f64, D>, cov: &nalgebra::SMatrix<f64, D, D>) -> f64 {
    let inv = cov.try_inverse().unwrap();
    (err.transpose() * inv * err)[(0, 0)]
}

/// Tilt from gravity: odometry whose roll drifts by 5 mrad per keyframe (a biased gyro),
/// no landmarks. Without the IMU's gravity factors the roll error grows with the chain;
/// with them (σ 3 mrad) it stays at the gravity noise level.
#[test]
fn gravity_factors_hold_the_absolute_tilt() {
    let level = Se3::new(so3_exp(&Vector3::zeros()), Vector3::zeros());
    let step = Se3::new(so3_exp(&Vector3::new(0.0, 0.0, 0.05)), Vector3::new(0.5, 0.0, 0.0));
    let biased = Se3::new(so3_exp(&Vector3::new(0.005, 0.0, 0.05)), Vector3::new(0.5, 0.0, 0.0));
    let cov = Matrix6::from_diagonal(&Vector6::new(1e-4, 1e-4, 1e-4, 1e-5, 1e-5, 1e-5));
    let last_roll = |gravity: bool| {
        let mut slam = GraphSlam::new(GraphSlamParams::default(), level, &[]).unwrap();
        let mut truth = level;
        for _ in 0..30 {
            truth = truth * step;
            let up_in_body = truth.rotation_matrix().transpose() * Vector3::z();
            let g = gravity.then_some(Gravity { up_in_body, sigma_rad: 0.003 });
            slam.add_keyframe(&Odometry { previous_from_current: biased, covariance: cov, gravity: g }, &[]).unwrap();
        }
        slam.optimize_full().unwrap();
        let r = slam.current_pose().rotation_matrix();
        // Roll error: the body's y axis against the level plane.
        (r * Vector3::y()).z.asin().abs()
    };
    let (without, with) = (last_roll(false), last_roll(true));
    assert!(without > 0.05, "30 × 5 mrad of drift: {without}");
    assert!(with < 0.01, "held by gravity: {with}");
}

#[test]
fn loop_closure_is_detected_and_triggers_full_optimisation() {
    let (_, slam, updates) = run(7, GraphSlamParams::default());
    // Landmarks are seen for a few metres: no landmark returns before the loop comes round.
    assert!(updates.iter().take(29).all(|u| !u.full), "no loop closure during the first 30 m");
    let closing: Vec<&KeyframeUpdate> = updates.iter().filter(|u| u.full).collect();
    assert!(!closing.is_empty(), "coming back to the start closes the loop");
    assert!(closing.iter().all(|u| !u.loop_closures.is_empty() && u.keyframe >= 30));
    // After a full optimisation the graph is at a minimum: another full run barely moves χ².
    let mut slam = slam;
    let before = slam.graph().chi2(&slam.estimate()).unwrap();
    let again = slam.optimize_full().unwrap();
    assert!(again.final_chi2 <= before * (1.0 + 1e-9));
}

#[test]
fn estimate_is_consistent_with_reported_covariance() {
    const SEEDS: u64 = 40;
    // Several seeds; each normalised error is χ²-distributed if the covariance is right.
    let mut pose_d2 = Vec::new();
    let mut lm_d2 = Vec::new();
    for seed in 0..SEEDS {
        let (w, mut slam, _) = run(seed, GraphSlamParams::default());
        slam.optimize_full().unwrap();
        let est = slam.current_pose();
        let truth = w.truth[w.truth.len() - 1];
        let err = truth.local(&est);
        pose_d2.push(mahalanobis2(&err, &slam.current_pose_covariance().unwrap()));
        for lm in slam.landmarks().unwrap() {
            let i = ((lm.landmark_id - 3) / 10) as usize;
            lm_d2.push(mahalanobis2(&(lm.position_in_world - w.landmarks[i]), &lm.covariance));
        }
    }
    // Per sample: χ²(6) 99.99 % quantile 27.9, χ²(3) 99.998 % ≈ 24.5. The means of 40 χ²(6)
    // and 480 χ²(3) samples are 6 ± 0.55 and 3 ± 0.11 (one σ); the bounds are ±5σ.
    assert!(pose_d2.iter().all(|&d| d < 27.9), "{pose_d2:?}");
    assert!(lm_d2.iter().all(|&d| d < 24.5), "{lm_d2:?}");
    let mean_pose = pose_d2.iter().sum::<f64>() / pose_d2.len() as f64;
    let mean_lm = lm_d2.iter().sum::<f64>() / lm_d2.len() as f64;
    eprintln!("mean Mahalanobis²: pose {mean_pose:.2} (6 dof), landmarks {mean_lm:.2} (3 dof)");
    assert!((3.0..9.0).contains(&mean_pose), "mean pose Mahalanobis² {mean_pose}");
    assert!((2.4..3.6).contains(&mean_lm), "mean landmark Mahalanobis² {mean_lm}");
}

/// A keyframe with one bad input (a NaN point, a covariance that is not positive definite,
/// a zero gravity direction, a NaN odometry) is rejected before the map changes: the run
/// goes on, and ends where the same run without the rejected keyframes ends, bit for bit.
#[test]
fn a_rejected_keyframe_leaves_the_map_as_it_was() {
    for params in [GraphSlamParams::default(), batch()] {
        let n = 12;
        let w = world(n);
        let run = |reject: bool| {
            let mut rng = ChaCha8Rng::seed_from_u64(5);
            let mut slam = GraphSlam::new(params.clone(), w.truth[0], &observations(&w, 0, &mut rng)).unwrap();
            for k in 1..n {
                let rel = odometry(&w.truth[k - 1], &w.truth[k], &mut rng);
                let obs = observations(&w, k, &mut rng);
                if reject && k % 3 == 0 && !obs.is_empty() {
                    let mut nan_point = obs.clone();
                    nan_point[obs.len() / 2].point_in_robot.y = f64::NAN;
                    let mut not_pd = obs.clone();
                    not_pd[obs.len() - 1].covariance[(2, 2)] = -1.0;
                    let zero_up = Odometry { gravity: Some(Gravity { up_in_body: Vector3::zeros(), sigma_rad: 0.01 }), ..rel };
                    let mut nan_odometry = rel;
                    nan_odometry.previous_from_current = Se3::new(so3_exp(&Vector3::zeros()), Vector3::new(f64::NAN, 0.0, 0.0));
                    assert!(slam.add_keyframe(&rel, &nan_point).is_err());
                    assert!(slam.add_keyframe(&rel, &not_pd).is_err());
                    assert!(slam.add_keyframe(&zero_up, &obs).is_err());
                    assert!(slam.add_keyframe(&nan_odometry, &obs).is_err());
                }
                slam.add_keyframe(&rel, &obs).unwrap();
            }
            (slam.keyframe_poses(), slam.landmark_positions(), slam.current_pose_covariance().unwrap())
        };
        let (clean, rejected) = (run(false), run(true));
        assert_eq!(clean.0.len(), n);
        assert_eq!(clean, rejected, "{:?}", params.solver);
    }
}

fn batch() -> GraphSlamParams {
    GraphSlamParams { solver: SlamSolver::Batch, ..GraphSlamParams::default() }
}

/// Scalar offset of `var` in the information matrix of the full problem (only the first
/// keyframe fixed): poses are pushed in order with landmarks in between.
fn free_offset(values: &Values, var: VarId) -> usize {
    values.iter().take_while(|(id, _)| *id != var).filter(|(id, _)| !values.is_fixed(*id)).map(|(_, v)| v.dim()).sum()
}

/// Both solvers' current-pose marginal is the block of the dense inverse of the full
/// problem's information (an independent nalgebra inverse). The incremental one's is at its
/// linearisation point, so the comparison is after convergence.
#[test]
fn current_pose_covariance_is_the_dense_inverse() {
    for params in [GraphSlamParams { window_keyframes: 5, ..batch() }, GraphSlamParams::default()] {
        let (_, mut slam, _) = run(3, params.clone());
        let tolerance = match params.solver {
            SlamSolver::Batch => 1e-9,
            SlamSolver::Incremental => {
                slam.optimize_full().unwrap();
                1e-6
            }
        };
        let cov = slam.current_pose_covariance().unwrap();
        let inv: DMatrix<f64> = slam.marginals().unwrap().dense_information().try_inverse().unwrap();
        let offset = free_offset(&slam.estimate(), *slam.keyframes.last().unwrap());
        let block = inv.view((offset, offset), (6, 6));
        let rel = (cov - block).amax() / block.amax();
        assert!(rel < tolerance, "{:?}: relative difference {rel:e}", params.solver);
        let traces = CovarianceTraces::of(&cov);
        assert!((traces.cov_trace - cov.trace()).abs() < 1e-15 && traces.pos_cov_trace > 0.0 && traces.rot_cov_trace > 0.0);
    }
}

/// The two solvers on the same measurements (the loop, closed), with least squares and with
/// the default robust kernel on the observations: after a full optimisation the same
/// keyframes, landmarks and marginals to 1e-6; before it, after one update per keyframe,
/// the least-squares incremental estimate is within 2 mm (and mrad) of the optimum.
#[test]
fn incremental_and_batch_solvers_agree() {
    for observation_kernel in [RobustKernel::None, GraphSlamParams::default().observation_kernel] {
        // Relinearised at every update from 1 cm / 10 mrad (GTSAM's defaults, 0.1 every 10th
        // update, leave it ~4 mm off here, as one Gauss-Newton step per update from a stale
        // linearisation point does).
        let isam2 = Isam2Params { relinearize_threshold: 0.01, relinearize_skip: 1, ..Isam2Params::default() };
        let (_, mut inc, updates) = run(5, GraphSlamParams { isam2, observation_kernel, ..GraphSlamParams::default() });
        assert!(updates.iter().any(|u| u.full) && updates.iter().all(|u| u.summary.is_none()));
        let before = inc.keyframe_poses();
        let (_, mut bat, _) = run(5, GraphSlamParams { observation_kernel, ..batch() });
        let batch_online = bat.keyframe_poses();
        bat.optimize_full().unwrap();
        let optimum = bat.keyframe_poses();
        let off = |poses: &[Se3]| poses.iter().zip(&optimum).map(|(a, b)| b.local(a).amax()).fold(0.0, f64::max);
        eprintln!("{observation_kernel:?} online: incremental {:e}, batch {:e} from the optimum", off(&before), off(&batch_online));
        if observation_kernel == RobustKernel::None {
            assert!(off(&before) < 2e-3, "one update per keyframe: {:e} from the optimum", off(&before));
        }
        inc.optimize_full().unwrap();
        for (k, (a, b)) in inc.keyframe_poses().iter().zip(&optimum).enumerate() {
            assert!(b.local(a).amax() < 1e-6, "{observation_kernel:?} keyframe {k}: {:e}", b.local(a).amax());
        }
        let rel = |a: &Matrix3<f64>, b: &Matrix3<f64>| (a - b).amax() / b.amax();
        for (a, b) in inc.landmarks().unwrap().iter().zip(bat.landmarks().unwrap()) {
            assert_eq!(a.landmark_id, b.landmark_id);
            assert!((a.position_in_world - b.position_in_world).amax() < 1e-6);
            assert!(rel(&a.covariance, &b.covariance) < 1e-6, "landmark {}: {:e}", a.landmark_id, rel(&a.covariance, &b.covariance));
        }
        let (ci, cb) = (inc.current_pose_covariance().unwrap(), bat.current_pose_covariance().unwrap());
        assert!((ci - cb).amax() / cb.amax() < 1e-6);
        let recent = inc.recent_landmarks(30).unwrap();
        assert!(!recent.is_empty() && recent.iter().all(|l| inc.landmarks.get(&l.landmark_id).unwrap().last_seen_keyframe >= 30));
    }
}

#[test]
fn window_update_leaves_old_keyframes_fixed() {
    let w = world(40);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let params = GraphSlamParams { window_keyframes: 3, ..batch() };
    let mut slam = GraphSlam::new(params, w.truth[0], &observations(&w, 0, &mut rng)).unwrap();
    for k in 1..8 {
        let before = slam.keyframe_poses();
        let u = slam.add_keyframe(&odometry(&w.truth[k - 1], &w.truth[k], &mut rng), &observations(&w, k, &mut rng)).unwrap();
        assert!(!u.full);
        let after = slam.keyframe_poses();
        // Keyframes older than the window did not move.
        for j in 0..(k + 1).saturating_sub(3) {
            assert_eq!(before[j], after[j], "keyframe {j} moved at update {k}");
        }
    }
    assert_eq!(slam.keyframe_count(), 8);
    assert_eq!(slam.keyframe_poses()[0], w.truth[0]);
}

/// The exported graph, written and read back, replays as the same updates: one per
/// keyframe, the same factors (the anchor re-made by the replay's prior of the same σ), so
/// the same estimate.
#[test]
fn the_g2o_export_replays_as_the_same_updates() {
    let params = GraphSlamParams { observation_kernel: RobustKernel::None, ..GraphSlamParams::default() };
    let (_, slam, _) = run(7, params.clone());
    let (file, left_out) = slam.to_g2o();
    assert_eq!(left_out, 1, "only the anchor has no g2o form here");
    assert_eq!(file.edges.len(), slam.graph().len() - 1);
    let text = crate::slam::g2o::write_g2o(&file);
    let read = crate::slam::g2o::read_g2o(text.as_bytes()).unwrap();
    assert_eq!(read.vertices.len(), slam.estimate().len());
    let mut replay = crate::slam::G2oReplay::new(&read, crate::slam::Se2Residual::default(), ANCHOR_SIGMA).unwrap();
    assert_eq!(replay.len(), slam.keyframe_count());
    let mut isam = Isam2::new(params.isam2);
    while replay.step(&mut isam).unwrap().is_some() {}
    let estimate = slam.estimate();
    for v in &read.vertices {
        let ours = replay.var_of(v.id()).and_then(|r| isam.estimate_of(r)).unwrap();
        let theirs = match *v {
            crate::slam::g2o::G2oVertex::Se3 { pose, .. } => Variable::Se3(pose),
            crate::slam::g2o::G2oVertex::Point3 { point, .. } => Variable::Point3(point),
            _ => unreachable!("the export writes SE(3) poses and 3-D points"),
        };
        let gap = match (ours, theirs) {
            (Variable::Se3(a), Variable::Se3(b)) => a.between(&b).log().norm(),
            (Variable::Point3(a), Variable::Point3(b)) => (a - b).norm(),
            _ => panic!("vertex {} changed kind", v.id()),
        };
        assert!(gap < 1e-6, "vertex {}: {gap}", v.id());
    }
    // The vertices are the estimate, in replay order: the first keyframe after its landmarks.
    let first_pose = read.vertices.iter().position(|v| matches!(v, crate::slam::g2o::G2oVertex::Se3 { .. })).unwrap();
    assert_eq!(
        read.vertices[first_pose],
        crate::slam::g2o::G2oVertex::Se3 { id: first_pose as u64, pose: estimate.se3(VarId(0)).unwrap() }
    );
}
