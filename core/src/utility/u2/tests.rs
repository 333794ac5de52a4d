//! Tests of u2 (paper eqs. 10–14): waypoints, camera frames, frusta and path information by hand.

use super::*;
use crate::cloud::PointCloud;
use crate::grid::{Grid, GridGeometry};
use std::f64::consts::{FRAC_PI_2, PI};

fn level(yaw_rad: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), yaw_rad)
}

/// A ground of height `z(x, y)` and its gradient, on 5 cm cells over [−5, 15] × [−5, 5] m.
fn ground(z: impl Fn(f64, f64) -> f64, gradient: impl Fn(f64, f64) -> [f64; 2]) -> (Grid<f32>, Grid<[f32; 2]>) {
    let g = GridGeometry::new(-5.0, -5.0, 0.05, 400, 200);
    let at = |i: usize| g.center_of(g.cell_at(i));
    let zs = (0..g.len()).map(at).map(|(x, y)| z(x, y) as f32).collect();
    let gs = (0..g.len()).map(at).map(|(x, y)| gradient(x, y)).map(|[a, b]| [a as f32, b as f32]).collect();
    (Grid { geometry: g, data: zs }, Grid { geometry: g, data: gs })
}

#[test]
fn a_camera_on_a_slope_looks_up_it() {
    // Ground z = x tan 30°: the body at x = 1 stands on it (origin z = tan 30°), its x axis
    // (cos 30°, 0, sin 30°) up the slope, its z axis the normal (−sin 30°, 0, cos 30°).
    let t = math::tan(30f64.to_radians());
    let (z, grad) = ground(|x, _| x * t, |_, _| [t, 0.0]);
    let known = GroundModel { z_m: &z, gradient: &grad };
    let g = CameraGround { flat_z_m: 0.0, known: Some(known), occlusion: false };
    let (body, r) = g.body_at(1.0, 0.0, 0.0);
    let (s30, c30) = (0.5, 0.75f64.sqrt());
    assert!((body.coords - Vector3::new(1.0, 0.0, t)).norm() < 1e-6);
    assert!((r * Vector3::x() - Vector3::new(c30, 0.0, s30)).norm() < 1e-6);
    assert!((r * Vector3::z() - Vector3::new(-s30, 0.0, c30)).norm() < 1e-6);
    // A landmark 2.5 m ahead on the optical axis of a camera 0.2 m up the normal: seen on
    // the slope, with the closed-form tr(I) at d = 2.5; a level camera 0.2 m above z = 0 sees
    // it 41° up, above its 29° half field of view.
    let cam = body + r * Vector3::new(0.0, 0.0, 0.2);
    let p = cam + r * Vector3::new(2.5, 0.0, 0.0);
    let v = LandmarkVoxels::new(&PointCloud::from_points(vec![p]), 0.01, 0.05).unwrap();
    let f = Frustum::from_params(&CameraParams::default());
    let (n, info) = waypoint_information(&v, cam.coords.into(), &r, &f, 0.01, None);
    let d: f64 = 2.5;
    let expected = 2.0 * (1.0 + 1.0 / (d * d)) / (1e-4 + 0.0025 / (d * d));
    assert_eq!(n, 1);
    assert!((info - expected).abs() < 1e-6 * expected, "{info} vs {expected}");
    assert_eq!(waypoint_information(&v, [1.0, 0.0, 0.2], &level(0.0), &f, 0.01, None).0, 0);
    // Unknown ground under the waypoint: flat and level.
    let (body, r) = g.body_at(20.0, 0.0, 0.3);
    assert_eq!((body, r), (Point3::new(20.0, 0.0, 0.0), level(0.3)));
}

#[test]
fn a_ridge_hides_what_lies_behind_it_with_occlusion_on() {
    // Flat ground with a 0.5 m ridge across x ∈ [1.4, 1.6]; a landmark on the ground at
    // x = 2.5, 0.05 m up, seen from a camera 0.2 m up at x = 0 (5.7° down, inside the view).
    let (z, grad) = ground(|x, _| if (1.4..=1.6).contains(&x) { 0.5 } else { 0.0 }, |_, _| [0.0, 0.0]);
    let known = GroundModel { z_m: &z, gradient: &grad };
    let v = LandmarkVoxels::new(&PointCloud::from_points(vec![Point3::new(2.5, 0.0, 0.05)]), 0.01, 0.05).unwrap();
    let f = Frustum::from_params(&CameraParams::default());
    assert_eq!(waypoint_information(&v, [0.0, 0.0, 0.2], &level(0.0), &f, 0.01, None).0, 1);
    assert_eq!(waypoint_information(&v, [0.0, 0.0, 0.2], &level(0.0), &f, 0.01, Some(&known)).0, 0);
    // Without the ridge, the ground it lies on does not hide it.
    let (z0, grad0) = ground(|_, _| 0.0, |_, _| [0.0, 0.0]);
    let flat = GroundModel { z_m: &z0, gradient: &grad0 };
    assert_eq!(waypoint_information(&v, [0.0, 0.0, 0.2], &level(0.0), &f, 0.01, Some(&flat)).0, 1);
}

#[test]
fn waypoints_on_a_straight_path() {
    let path: Vec<[f64; 2]> = (0..=70).map(|k| [k as f64 * 0.1, 1.0]).collect();
    let mut w = Vec::new();
    waypoints_along(&path, 3.0, 0.7, &mut w);
    assert_eq!(w.len(), 3);
    assert!((w[0].x_m - 3.0).abs() < 1e-9 && (w[1].x_m - 6.0).abs() < 1e-9 && (w[2].x_m - 7.0).abs() < 1e-9);
    assert!(w[0].yaw_rad.abs() < 1e-12 && w[1].yaw_rad.abs() < 1e-12);
    assert_eq!(w[2].yaw_rad, 0.7);
    assert!(w[2].is_goal && !w[0].is_goal);
    // Exactly 6 m: the waypoint at 6 m is the goal.
    waypoints_along(&path[..61], 3.0, 0.0, &mut w);
    assert_eq!(w.len(), 2);
    // A single-vertex path (robot on the candidate): only the goal.
    waypoints_along(&path[..1], 3.0, 1.0, &mut w);
    assert_eq!(w.len(), 1);
    assert!(w[0].is_goal && w[0].arc_length_m == 0.0);
}

#[test]
fn waypoints_follow_the_tangent() {
    // Along +x for 2 m then along +y for 4 m: waypoint at s = 3 is at (2, 1), heading +y;
    // the chord ±0.5 m there is (2, 0.5)→(2, 1.5): yaw π/2.
    let path = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 4.0]];
    let mut w = Vec::new();
    waypoints_along(&path, 3.0, 0.0, &mut w);
    assert_eq!(w.len(), 2);
    assert!((w[0].x_m - 2.0).abs() < 1e-12 && (w[0].y_m - 1.0).abs() < 1e-12);
    assert!((w[0].yaw_rad - FRAC_PI_2).abs() < 1e-12);
    // At s = 2.25 (spacing 2.25) the chord is s = 1.75 → 2.75: (1.75, 0)→(2, 0.75): yaw atan2(0.75, 0.25).
    waypoints_along(&path, 2.25, 0.0, &mut w);
    assert!((w[0].yaw_rad - 0.75f64.atan2(0.25)).abs() < 1e-12);
}

#[test]
fn arrival_heading_is_the_last_half_metre() {
    // East 2 m, then north 0.3 m: the last vertex ≥ 0.5 m back along the path is (1, 0), so
    // the chord runs from (1, 0) to (2, 0.3).
    let path = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 0.1], [2.0, 0.2], [2.0, 0.3]];
    let yaw = arrival_heading_rad(&path).unwrap();
    assert!((yaw - math::atan2(0.3, 1.0)).abs() < 1e-12, "{yaw}");
    assert_eq!(arrival_heading_rad(&[[1.0, 1.0]]), None);
    assert_eq!(arrival_heading_rad(&[]), None);
    assert!((arrival_heading_rad(&[[0.0, 0.0], [0.0, -0.2]]).unwrap() + std::f64::consts::FRAC_PI_2).abs() < 1e-15);
}

#[test]
fn camera_frame_is_optical() {
    let x = camera_pose(1.0, 2.0, 0.2, FRAC_PI_2); // looking along +y
    let c = x.inverse();
    // 2 m ahead (world +y) at camera height → optical (0, 0, 2).
    let p = c * Point3::new(1.0, 4.0, 0.2);
    assert!((p.coords - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-12);
    // To the robot's left (world −x when facing +y) → optical x negative; above → y negative.
    let p = c * Point3::new(0.0, 4.0, 0.7);
    assert!((p.coords - Vector3::new(-1.0, -0.5, 2.0)).norm() < 1e-12);
}

#[test]
fn frustum_by_hand() {
    let cam = CameraParams { hfov_rad: FRAC_PI_2, vfov_rad: FRAC_PI_2, min_depth_m: 0.3, max_depth_m: 3.0 };
    let f = Frustum::from_params(&cam);
    assert!(f.contains(0.0, 0.0, 1.0));
    assert!(f.contains(0.99, -0.99, 1.0)); // 45° half-angles: |x| ≤ z
    assert!(!f.contains(1.01, 0.0, 1.0));
    assert!(!f.contains(0.0, 0.0, 0.2)); // closer than min depth
    assert!(!f.contains(0.0, 0.0, 3.1));
    assert!(!f.contains(0.0, 0.0, -1.0));
    let wide = Frustum::from_params(&CameraParams { hfov_rad: 1.5 * PI, ..cam });
    assert!(wide.contains(100.0, 0.0, 1.0));
}

#[test]
fn waypoint_information_by_hand() {
    // Camera at (0, 0, 0.2) facing +x. Voxel A at (2, 0, 0.2): d = 2, seen.
    // Voxel B at (−2, 0, 0.2): behind. Voxel C at (2, 3, 0.2): 56° off-axis > 43.5°.
    let cloud = PointCloud::from_points(vec![Point3::new(2.0, 0.0, 0.2), Point3::new(-2.0, 0.0, 0.2), Point3::new(2.0, 3.0, 0.2)]);
    let v = LandmarkVoxels::new(&cloud, 0.01, 0.05).unwrap();
    let f = Frustum::from_params(&CameraParams::default());
    let (n, info) = waypoint_information(&v, [0.0, 0.0, 0.2], &level(0.0), &f, 0.01, None);
    assert_eq!(n, 1);
    let d = 2.0; // the voxel centroid is the point itself
    let expected = 2.0 * (1.0 + 1.0 / (d * d)) / (1e-4 + 0.0025 / (d * d));
    assert!((info - expected).abs() < 1e-9 * expected);
    // Turned round (yaw π), B is seen instead.
    let (n, _) = waypoint_information(&v, [0.0, 0.0, 0.2], &level(PI), &f, 0.01, None);
    assert_eq!(n, 1);
}

#[test]
fn general_covariance_path_agrees_with_isotropic_when_q_is_isotropic_in_disguise() {
    // A Q that is isotropic but stored off the fast path (tiny off-diagonal noise) gives
    // the same information up to that noise.
    let mut cloud = PointCloud::from_points(vec![Point3::new(2.0, 0.5, 0.4)]);
    let mut q = Matrix3::identity() * 0.0025;
    q[(0, 1)] = 1e-12;
    q[(1, 0)] = 1e-12;
    cloud.covariances = Some(vec![q]);
    let general = LandmarkVoxels::new(&cloud, 0.25, 0.05).unwrap();
    assert!(general.isotropic_variance_m2(0).is_none());
    let iso = LandmarkVoxels::new(&PointCloud::from_points(cloud.points.clone()), 0.25, 0.05).unwrap();
    let f = Frustum::from_params(&CameraParams::default());
    let (_, a) = waypoint_information(&general, [0.0, 0.0, 0.2], &level(0.1), &f, 0.01, None);
    let (_, b) = waypoint_information(&iso, [0.0, 0.0, 0.2], &level(0.1), &f, 0.01, None);
    assert!(a > 0.0 && (a - b).abs() < 1e-6 * b);
}

/// A level camera 0.2 m above flat ground at z = 0, views every `spacing_m`.
fn level_view<'a>(v: &'a LandmarkVoxels, cam: &'a CameraParams, spacing_m: f64) -> PathView<'a> {
    PathView { voxels: v, camera: cam, camera_height_m: 0.2, ground: CameraGround::flat(0.0), spacing_m, sigma_bearing_rad: 0.01 }
}

#[test]
fn tracked_share_by_hand() {
    // Three landmark voxels side by side at x = 3.6 m, 0.1 m below a level camera 0.2 m up.
    let points = [-0.3, 0.0, 0.3].map(|y| Point3::new(3.6, y, 0.1));
    let v = LandmarkVoxels::new(&PointCloud::from_points(points.to_vec()), 0.25, 0.05).unwrap();
    assert_eq!(v.len(), 3);
    let path: Vec<[f64; 2]> = (0..=60).map(|k| [k as f64 * 0.1, 0.0]).collect();
    let cam = CameraParams::default();
    let view = level_view(&v, &cam, 1.0);
    let mut rep = Vec::new();
    // Views at x = 1, 2, 3, 4, 5 and the goal at 6, all facing +x. From x = 1, 2, 3 the three
    // lie 2.6, 1.6 and 0.6 m deep (in [0.3, 3]), 0.3 m aside (≤ depth · tan 43.5°) and 0.1 m
    // down (≤ depth · tan 29°); from x ≥ 4 they are behind.
    assert_eq!(path_tracked_share(&path, 0.0, &view, 3, &mut rep), 0.5);
    assert_eq!(rep.iter().map(|r| r.voxels_seen).collect::<Vec<_>>(), vec![3, 3, 3, 0, 0, 0]);
    assert_eq!(path_tracked_share(&path, 0.0, &view, 4, &mut rep), 0.0);
    // Facing back (−x) at the goal sees them 2.4 m deep: 4 of 6 views.
    assert!((path_tracked_share(&path, std::f64::consts::PI, &view, 3, &mut rep) - 4.0 / 6.0).abs() < 1e-15);
    assert_eq!(path_tracked_share(&[], 0.0, &view, 1, &mut rep), 0.0);
}

#[test]
fn path_information_sums_waypoints() {
    let cloud = PointCloud::from_points(vec![Point3::new(4.0, 0.0, 0.2), Point3::new(7.5, 0.0, 0.2)]);
    let v = LandmarkVoxels::new(&cloud, 0.25, 0.05).unwrap();
    let path: Vec<[f64; 2]> = (0..=60).map(|k| [k as f64 * 0.1, 0.0]).collect();
    let mut rep = Vec::new();
    let cam = CameraParams::default();
    let view = level_view(&v, &cam, 3.0);
    let ip = path_information(&path, 0.0, &view, &mut rep);
    assert_eq!(rep.len(), 2); // s = 3 and the goal at 6
    let sum: f64 = rep.iter().map(|r| r.info).sum();
    assert_eq!(ip, sum);
    // From x = 3 both voxels lie within 3 m depth only for the first (1 m); the second is 4.5 m.
    assert_eq!(rep[0].voxels_seen, 1);
    // From the goal at x = 6 facing +x: the second at 1.5 m is seen; the first is behind.
    assert_eq!(rep[1].voxels_seen, 1);
    assert!((rep[0].z_m - 0.2).abs() < 1e-15);
}

#[test]
fn normalisation_by_hand() {
    let mut out = Vec::new();
    normalise_path_information(&[2.0, 4.0, 0.0], InfoNormalisation::Max, &mut out);
    assert_eq!(out, vec![0.5, 1.0, 0.0]);
    normalise_path_information(&[2.0, 4.0, 0.0], InfoNormalisation::Mean, &mut out);
    assert_eq!(out, vec![1.0, 2.0, 0.0]);
    normalise_path_information(&[0.0, 0.0], InfoNormalisation::Max, &mut out);
    assert_eq!(out, vec![0.0, 0.0]);
    assert!((u2_score(0.5, 1.0, 0.4) - 0.8).abs() < 1e-15);
}
