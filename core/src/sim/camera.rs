//! A D435-like depth camera observing point landmarks (notes §8): a landmark is seen when it lies
//! in the frustum (horizontal Φ, vertical Φ_v, depth in [min, max]) and the straight line from the
//! optical centre clears the terrain. Each observation is the landmark's point in the robot
//! (body) frame, perturbed by bearing noise σ_b (perpendicular to the line of sight) and depth
//! noise σ_d = `depth_sigma_coeff` · d² (structured-light stereo: error grows with depth squared).
//! O(landmarks in a bucket box × line-of-sight steps).

use super::heightfield::Heightfield;
use super::lidar::{RayCaster, gaussian};
use super::scan::line_of_sight;
use crate::math;
use crate::params::CameraParams;
pub use crate::slam::keyframes::CameraObservation;
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Camera noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraNoise {
    /// Bearing noise σ_b, radians, ≥ 0. Default 0.01 (the planner's σ_b).
    pub bearing_sigma_rad: f64,
    /// Depth noise σ_d = coeff · d², 1/m, ≥ 0. Default 0.005 (5 mm at 1 m, 4.5 cm at 3 m).
    pub depth_sigma_coeff: f64,
}

impl Default for CameraNoise {
    fn default() -> Self {
        Self { bearing_sigma_rad: 0.01, depth_sigma_coeff: 0.005 }
    }
}

/// Landmarks bucketed on a coarse grid for frustum queries.
#[derive(Clone, Debug)]
pub struct LandmarkIndex {
    bucket_m: f64,
    origin: [f64; 2],
    nx: usize,
    ny: usize,
    buckets: Vec<Vec<u32>>,
}

impl LandmarkIndex {
    /// An index of `landmarks` (world frame) on square buckets of `bucket_m` metres covering
    /// `bounds_m` = (min_x, min_y, max_x, max_y); landmarks outside go to the border buckets.
    pub fn new(landmarks: &[Point3<f64>], bounds_m: (f64, f64, f64, f64), bucket_m: f64) -> Self {
        let nx = (((bounds_m.2 - bounds_m.0) / bucket_m).ceil() as usize).max(1);
        let ny = (((bounds_m.3 - bounds_m.1) / bucket_m).ceil() as usize).max(1);
        let mut buckets = vec![Vec::new(); nx * ny];
        for (i, p) in landmarks.iter().enumerate() {
            let c = (((p.x - bounds_m.0) / bucket_m).floor().max(0.0) as usize).min(nx - 1);
            let r = (((p.y - bounds_m.1) / bucket_m).floor().max(0.0) as usize).min(ny - 1);
            buckets[r * nx + c].push(i as u32);
        }
        Self { bucket_m, origin: [bounds_m.0, bounds_m.1], nx, ny, buckets }
    }

    /// Calls `f` with every landmark index in buckets overlapping the square of half-side `r`.
    pub(crate) fn for_each_near(&self, x: f64, y: f64, r: f64, mut f: impl FnMut(usize)) {
        let idx = |v: f64, o: f64, n: usize| (((v - o) / self.bucket_m).floor().max(0.0) as usize).min(n - 1);
        let (c0, c1) = (idx(x - r, self.origin[0], self.nx), idx(x + r, self.origin[0], self.nx));
        let (r0, r1) = (idx(y - r, self.origin[1], self.ny), idx(y + r, self.origin[1], self.ny));
        for row in r0..=r1 {
            for col in c0..=c1 {
                for &i in &self.buckets[row * self.nx + col] {
                    f(i as usize);
                }
            }
        }
    }
}

/// Whether `v` (camera-centred, body axes, x forward) is inside the frustum; `th`, `tv` are the
/// tangents of the half fields of view.
fn in_frustum(v: &Vector3<f64>, params: &CameraParams, th: f64, tv: f64) -> bool {
    let depth = v.x;
    depth >= params.min_depth_m && depth <= params.max_depth_m && v.y.abs() <= th * depth && v.z.abs() <= tv * depth
}

/// What a camera looks at: the terrain (for the line of sight) and the landmarks with their
/// frustum index.
#[derive(Clone, Copy, Debug)]
pub struct LandmarkScene<'a> {
    /// The terrain that can hide a landmark.
    pub field: &'a Heightfield,
    /// Landmark positions, world frame, metres (the index is the id).
    pub landmarks: &'a [Point3<f64>],
    /// `landmarks` bucketed ([`LandmarkIndex::new`] on the same slice).
    pub index: &'a LandmarkIndex,
}

/// Where a camera stands, world frame: its optical centre and its body's origin and rotation
/// (the camera looks along the body's +x).
#[derive(Clone, Copy, Debug)]
pub struct CameraPose {
    /// The optical centre, world frame, metres.
    pub camera_m: Point3<f64>,
    /// The body's origin, world frame, metres.
    pub body_m: Point3<f64>,
    /// The body's attitude.
    pub world_from_body: Rotation3<f64>,
}

/// The landmarks of `scene` seen from `pose`, in increasing id order, into `out`; the ids of
/// every landmark in the frustum, in line of sight or not, into `in_frustum_out` (both cleared
/// first).
pub fn observe_landmarks(
    scene: &LandmarkScene,
    pose: &CameraPose,
    params: &CameraParams,
    noise: &CameraNoise,
    rng: &mut ChaCha8Rng,
    out: &mut Vec<CameraObservation>,
    in_frustum_out: &mut Vec<usize>,
) {
    let LandmarkScene { field, landmarks, index } = *scene;
    let CameraPose { camera_m, body_m, world_from_body } = *pose;
    out.clear();
    in_frustum_out.clear();
    let (th, tv) = (math::tan(params.hfov_rad / 2.0), math::tan(params.vfov_rad / 2.0));
    let step = field.geometry.resolution_m * 0.5;
    let mut ids = Vec::new();
    index.for_each_near(camera_m.x, camera_m.y, params.max_depth_m, |i| ids.push(i));
    ids.sort_unstable();
    let body_from_world = world_from_body.inverse();
    for i in ids {
        let lw = landmarks[i];
        let v = body_from_world * (lw - camera_m); // camera-centred, body axes
        if !in_frustum(&v, params, th, tv) {
            continue;
        }
        in_frustum_out.push(i);
        if !line_of_sight(field, camera_m, lw + Vector3::new(0.0, 0.0, 0.02), step) {
            continue;
        }
        // Noise: depth along the ray, bearing across it.
        let d = v.norm();
        let u = v / d;
        let sd = noise.depth_sigma_coeff * d * d;
        let sb = noise.bearing_sigma_rad * d;
        let a = if u.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
        let e1 = u.cross(&a).normalize();
        let e2 = u.cross(&e1);
        let noisy = v + u * (sd * gaussian(rng)) + e1 * (sb * gaussian(rng)) + e2 * (sb * gaussian(rng));
        let cov = u * u.transpose() * (sd * sd) + (Matrix3::identity() - u * u.transpose()) * (sb * sb);
        let cam_in_body = body_from_world * (camera_m - body_m);
        out.push(CameraObservation { landmark_id: i as u64, point_in_robot: cam_in_body + noisy, covariance: cov });
    }
}

/// The depth camera's ground hits: a `rays[0]` × `rays[1]` (columns × rows) grid of rays spread
/// evenly over the field of view from `camera_m`, looking along the body's +x; calls
/// `on_hit(direction_in_world, depth_m)` for each ray that hits within the depth range, row by
/// row. O(rays × ray march).
pub(crate) fn depth_ground_hits(
    field: &Heightfield,
    caster: &RayCaster,
    camera_m: Point3<f64>,
    world_from_body: &Rotation3<f64>,
    params: &CameraParams,
    rays: [usize; 2],
    mut on_hit: impl FnMut(Vector3<f64>, f64),
) {
    let [nc, nr] = rays;
    let (hf, vf) = (params.hfov_rad, params.vfov_rad);
    for r in 0..nr {
        let el = -vf / 2.0 + vf * (r as f64 + 0.5) / nr as f64;
        for c in 0..nc {
            let az = -hf / 2.0 + hf * (c as f64 + 0.5) / nc as f64;
            let dir = world_from_body * Vector3::new(math::cos(el) * math::cos(az), math::cos(el) * math::sin(az), math::sin(el));
            if let Some(d) = caster.cast(field, camera_m, dir, params.max_depth_m).filter(|&d| d >= params.min_depth_m) {
                on_hit(dir, d);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;
    use rand::SeedableRng;

    #[test]
    fn frustum_and_occlusion() {
        // Flat ground with a 1 m wall at 4.0 ≤ x ≤ 4.2.
        let field =
            Heightfield::from_fn(GridGeometry::new(0.0, 0.0, 0.05, 200, 200), |x, _| if (4.0..=4.2).contains(&x) { 1.0 } else { 0.0 });
        let lms = vec![
            Point3::new(3.0, 5.0, 0.1),  // ahead, 2 m: seen
            Point3::new(1.0, 5.0, 0.1),  // behind: no
            Point3::new(3.0, 7.5, 0.1),  // 2 m ahead, 2.5 m left: outside 43.5°
            Point3::new(4.8, 5.0, 0.1),  // behind the wall (3.8 m, also > 3 m): no
            Point3::new(3.9, 5.3, 0.15), // 2.9 m ahead in front of the wall: seen
        ];
        let idx = LandmarkIndex::new(&lms, (0.0, 0.0, 10.0, 10.0), 1.0);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut out = Vec::new();
        let cam = Point3::new(1.0, 5.0, 0.2);
        let noise = CameraNoise { bearing_sigma_rad: 0.0, depth_sigma_coeff: 0.0 };
        let scene = LandmarkScene { field: &field, landmarks: &lms, index: &idx };
        let pose = CameraPose { camera_m: cam, body_m: Point3::new(1.0, 5.0, 0.0), world_from_body: Rotation3::identity() };
        observe_landmarks(&scene, &pose, &CameraParams::default(), &noise, &mut rng, &mut out, &mut Vec::new());
        let ids: Vec<u64> = out.iter().map(|o| o.landmark_id).collect();
        assert_eq!(ids, vec![0, 4]);
        // Noise-free: the point in the body frame is exact.
        assert!((out[0].point_in_robot - Vector3::new(2.0, 0.0, 0.1)).norm() < 1e-12);
    }

    #[test]
    fn depth_noise_grows_with_depth_squared() {
        let field = Heightfield::from_fn(GridGeometry::new(0.0, 0.0, 0.05, 200, 200), |_, _| 0.0);
        let noise = CameraNoise::default();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut out = Vec::new();
        let mut spread = |d: f64, rng: &mut ChaCha8Rng| {
            let lms = vec![Point3::new(1.0 + d, 5.0, 0.2)];
            let idx = LandmarkIndex::new(&lms, (0.0, 0.0, 10.0, 10.0), 1.0);
            let mut s2 = 0.0;
            let n = 4000;
            for _ in 0..n {
                let scene = LandmarkScene { field: &field, landmarks: &lms, index: &idx };
                let at = Point3::new(1.0, 5.0, 0.2);
                let pose = CameraPose { camera_m: at, body_m: at, world_from_body: Rotation3::identity() };
                observe_landmarks(&scene, &pose, &CameraParams::default(), &noise, rng, &mut out, &mut Vec::new());
                s2 += (out[0].point_in_robot.x - d).powi(2);
            }
            (s2 / n as f64).sqrt()
        };
        let (s1, s2) = (spread(1.0, &mut rng), spread(2.0, &mut rng));
        // σ_d(1 m) = 5 mm, σ_d(2 m) = 20 mm: ratio 4 (sampling error ~2 % each).
        assert!((s1 - 0.005).abs() < 0.0005, "{s1}");
        assert!((s2 / s1 - 4.0).abs() < 0.4, "{}", s2 / s1);
    }
}
