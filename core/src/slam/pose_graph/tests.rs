//! Tests of the pose graph (see the module doc) on synthetic drives: landmarks on a lattice,
//! observations with known Gaussian noise, wheel odometry with a scale error.

use super::*;
use crate::slam::{CovarianceTraces, Marginals};
use nalgebra::Matrix3;

const SIGMA_M: f64 = 0.01;

/// Landmarks every 0.7 m on the ground plane and 0.5 m up, over a 20 m × 20 m area.
fn lattice() -> Vec<(u64, Vector3<f64>)> {
    let mut out = Vec::new();
    for i in 0..29 {
        for j in 0..29 {
            let z = if (i + j) % 2 == 0 { 0.0 } else { 0.5 };
            out.push(((i * 29 + j) as u64, Vector3::new(-10.0 + 0.7 * f64::from(i), -10.0 + 0.7 * f64::from(j), z)));
        }
    }
    out
}

/// What a camera at `pose` sees: landmarks 0.3–3 m ahead within ±45°, with isotropic noise σ.
fn observe(pose: &Se3, landmarks: &[(u64, Vector3<f64>)], rng: &mut ChaCha8Rng) -> Vec<LandmarkObservation> {
    let mut out = Vec::new();
    for (id, p) in landmarks {
        let q = pose.inverse_transform_point(p);
        let d = q.norm();
        if q.x > 0.0 && (0.3..3.0).contains(&d) && q.y.abs() < q.x {
            let n = Vector3::from_fn(|_, _| SIGMA_M * crate::math::standard_normal(rng));
            out.push(LandmarkObservation { landmark_id: *id, point_in_robot: q + n, covariance: Matrix3::identity() * SIGMA_M * SIGMA_M });
        }
    }
    out
}

fn planar(x: f64, y: f64, yaw: f64) -> Se3 {
    Se3::new(UnitQuaternion::from_euler_angles(0.0, 0.0, yaw), Vector3::new(x, y, 0.0))
}

/// The true keyframe poses of a drive around a 6 m square from (−3, −3), 0.5 m per keyframe,
/// with a 90° turn in place (two keyframes) at each corner; ends back at the start.
fn square() -> Vec<Se3> {
    let mut poses = vec![planar(-3.0, -3.0, 0.0)];
    let mut yaw = 0.0;
    let (mut x, mut y) = (-3.0, -3.0);
    for _ in 0..4 {
        for _ in 0..12 {
            x += 0.5 * crate::math::cos(yaw);
            y += 0.5 * crate::math::sin(yaw);
            poses.push(planar(x, y, yaw));
        }
        for _ in 0..2 {
            yaw += std::f64::consts::FRAC_PI_4;
            poses.push(planar(x, y, yaw));
        }
    }
    poses
}

/// Runs the pose graph over `truth` with wheel odometry 3 % long (σ 1 cm, 0.01 rad per link);
/// returns it and the RMS position error of its keyframes.
fn run(params: PoseGraphParams, truth: &[Se3], seed: u64) -> (PoseGraphSlam, f64) {
    let landmarks = lattice();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut slam = PoseGraphSlam::new(params, truth[0], &observe(&truth[0], &landmarks, &mut rng), seed).unwrap();
    for w in truth.windows(2) {
        let rel = w[0].between(&w[1]);
        let wheel = Se3::new(rel.rotation, rel.translation * 1.03);
        let cov = Matrix6::from_diagonal(&Vector6::new(1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4));
        let odometry = Odometry { previous_from_current: wheel, covariance: cov, gravity: None };
        slam.add_keyframe(&odometry, &observe(&w[1], &landmarks, &mut rng)).unwrap();
    }
    let est = slam.keyframe_poses();
    let sq: f64 = est.iter().zip(truth).map(|(e, t)| (e.translation - t.translation).norm_squared()).sum();
    (slam, (sq / truth.len() as f64).sqrt())
}

#[test]
fn visual_odometry_beats_biased_wheels_and_the_return_closes_the_loop() {
    let truth = square();
    let (slam, ate) = run(PoseGraphParams { false_closure_rate: 0.0, ..PoseGraphParams::default() }, &truth, 1);
    let s = slam.link_stats();
    // The wheels alone: 3 % of up to 24 m of path.
    let no_camera =
        PoseGraphParams { min_inliers: usize::MAX, loop_min_inliers: usize::MAX, false_closure_rate: 0.0, ..PoseGraphParams::default() };
    let (_, ate_wheels) = run(no_camera, &truth, 1);
    // Visual odometry everywhere but across some 45° turns in place (a ±45° field of view).
    assert!(s.wheel_links <= 4 && s.visual_links >= 50, "{s:?}");
    assert!(s.closures_accepted >= 1, "{s:?}");
    assert!(ate < 0.5 * ate_wheels && ate_wheels > 0.1, "visual {ate:.4} m, wheels {ate_wheels:.4} m");
}

/// The current keyframe's covariance is the exact marginal of the whole pose graph (an
/// independent sparse factorisation at the linearisation point), and the landmark map's
/// covariances are the anchored form `R C Rᵀ + G Σ Gᵀ` with the anchor's exact marginal.
#[test]
fn covariances_are_the_exact_marginal_and_the_anchored_landmark_form() {
    let truth = square();
    let (slam, _) = run(PoseGraphParams { false_closure_rate: 0.0, ..PoseGraphParams::default() }, &truth, 2);
    let theta = slam.linearization_point();
    let marginals = Marginals::new(slam.graph(), &theta, Factorisation::default()).unwrap();
    let exact = marginals.covariance(slam.current_variable()).unwrap();
    let ours = slam.current_pose_covariance().unwrap();
    let err = (0..6).flat_map(|r| (0..6).map(move |c| (r, c))).map(|(r, c)| (ours[(r, c)] - exact[(r, c)]).abs()).fold(0.0, f64::max);
    assert!(err <= 1e-6 * exact.amax(), "{err:e}");
    assert!(CovarianceTraces::of(&ours).pos_cov_trace > 0.0);
    let landmarks = slam.landmarks().unwrap();
    assert_eq!(landmarks.len(), slam.landmark_count());
    let l = landmarks.iter().find(|l| l.landmark_id == slam.anchors.keys().copied().nth(40).unwrap()).unwrap();
    let a = slam.anchors[&l.landmark_id];
    let pose = slam.pose(a.keyframe);
    let sigma = marginals.covariance(VarId(a.keyframe)).unwrap();
    let sigma = Matrix6::from_fn(|r, c| sigma[(r, c)]);
    // G = R [I, −[p]×] by hand, R the anchor's rotation.
    let r = pose.rotation_matrix();
    let p = a.point_in_robot;
    let cross = Matrix3::new(0.0, -p.z, p.y, p.z, 0.0, -p.x, -p.y, p.x, 0.0);
    let mut g = nalgebra::Matrix3x6::zeros();
    g.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    g.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-r * cross));
    let expected = r * a.covariance * r.transpose() + g * sigma * g.transpose();
    assert!((l.covariance - expected).amax() <= 1e-6 * expected.amax(), "{} vs {}", l.covariance, expected);
    assert!((l.position_in_world - pose.transform_point(&p)).norm() < 1e-12);
}

#[test]
fn the_link_covariance_is_consistent_with_its_error() {
    // NEES of the visual-odometry links over many seeds: E[ξᵀ Σ⁻¹ ξ] = 6 for a consistent one.
    let landmarks = lattice();
    let (a, b) = (planar(0.0, 0.0, 0.2), planar(0.5, 0.1, 0.35));
    let (mut sum, n) = (0.0, 200);
    for seed in 0..n {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (oa, ob) = (observe(&a, &landmarks, &mut rng), observe(&b, &landmarks, &mut rng));
        let mut slam = PoseGraphSlam::new(PoseGraphParams::default(), a, &oa, seed).unwrap();
        slam.views[0].sort_by_key(|o| o.landmark_id);
        let mut ob_sorted = ob.clone();
        ob_sorted.sort_by_key(|o| o.landmark_id);
        let (alignment, _) = slam.visual_odometry(&ob_sorted, &Se3::identity()).expect("tracked");
        let xi = a.between(&b).local(&alignment.a_from_b);
        sum += xi.dot(&alignment.covariance.cholesky().unwrap().solve(&xi));
    }
    let nees = sum / n as f64;
    assert!((4.5..7.5).contains(&nees), "NEES {nees:.2}");
}
