//! Keyframe clouds: the sensor points of every keyframe in its body frame, and the map rebuilt
//! from them after a loop closure moved the keyframes.

use nalgebra::{Matrix6, Point3, Vector3};
use std::collections::HashSet;

use crate::grid::GridGeometry;
use crate::math;
use crate::slam::Se3;
use crate::traversability::TraversabilityMap;

/// Sensor points of every keyframe, in that keyframe's body frame (f32, flat), one per voxel
/// per keyframe.
#[derive(Clone, Debug)]
pub struct KeyframeClouds {
    voxel_m: f64,
    points: Vec<[f32; 3]>,
    /// Keyframe k's points are `starts[k]..starts[k + 1]` (the last one runs to the end).
    starts: Vec<usize>,
    /// Keyframe k's roll/pitch variance, rad² (for the points' height noise at re-registration).
    tilt_var_rad2: Vec<f64>,
    /// Voxels already holding a point of the latest keyframe (membership only, never iterated).
    occupied: HashSet<[i32; 3]>,
    /// Discs whose points stored before them [`reregister`] leaves out ([`Self::forget_disc`]).
    forgotten: Vec<ForgottenDisc>,
}

/// Points stored before `before` whose map cell's centre lies within `radius_m` of `centre_m`
/// (world frame) are forgotten.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ForgottenDisc {
    centre_m: [f64; 2],
    radius_m: f64,
    before: usize,
}

impl KeyframeClouds {
    /// No keyframe yet.
    pub fn new(voxel_m: f64) -> Self {
        Self { voxel_m, points: Vec::new(), starts: Vec::new(), tilt_var_rad2: Vec::new(), occupied: HashSet::new(), forgotten: Vec::new() }
    }

    /// Forgets, for every later `reregister`, the points stored so far that it would put in a
    /// map cell whose centre lies within `radius_m` of (`x_m`, `y_m`), world frame (as
    /// [`TraversabilityMap::forget_disc`] does to the map itself). Points stored later are kept.
    pub fn forget_disc(&mut self, x_m: f64, y_m: f64, radius_m: f64) {
        self.forgotten.push(ForgottenDisc { centre_m: [x_m, y_m], radius_m, before: self.points.len() });
    }

    /// Whether the stored point `index`, registered at world (`x_m`, `y_m`), is forgotten on the
    /// grid `g`.
    fn is_forgotten(&self, index: usize, x_m: f64, y_m: f64, g: &GridGeometry) -> bool {
        // Most points (every one before the first recovery) are older than no disc: no cell lookup.
        if !self.forgotten.iter().any(|f| index < f.before) {
            return false;
        }
        let Some(c) = g.cell_of(x_m, y_m) else { return false };
        let (cx, cy) = g.center_of(c);
        self.forgotten.iter().any(|f| index < f.before && math::hypot(cx - f.centre_m[0], cy - f.centre_m[1]) <= f.radius_m)
    }

    /// Starts the cloud of a new keyframe (later points belong to it) whose roll/pitch variance
    /// is `tilt_var_rad2`.
    pub(crate) fn start_keyframe(&mut self, tilt_var_rad2: f64) {
        self.starts.push(self.points.len());
        self.tilt_var_rad2.push(tilt_var_rad2);
        self.occupied.clear();
    }

    /// Stores a point of the latest keyframe (its body frame) unless its voxel already has one
    /// or there is no keyframe; returns whether it was stored.
    pub fn push(&mut self, point_in_keyframe: &Vector3<f64>) -> bool {
        if self.starts.is_empty() || !point_in_keyframe.iter().all(|v| v.is_finite()) {
            return false;
        }
        let key = point_in_keyframe.map(|v| (v / self.voxel_m).floor().clamp(i32::MIN as f64, i32::MAX as f64) as i32);
        if !self.occupied.insert([key.x, key.y, key.z]) {
            return false;
        }
        self.points.push([point_in_keyframe.x as f32, point_in_keyframe.y as f32, point_in_keyframe.z as f32]);
        true
    }

    /// Number of keyframes started.
    pub fn keyframes(&self) -> usize {
        self.starts.len()
    }

    /// Points stored over all keyframes.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point is stored.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Keyframe `k`'s points (empty when out of range).
    pub(crate) fn points_of(&self, k: usize) -> &[[f32; 3]] {
        let Some(&a) = self.starts.get(k) else { return &[] };
        let b = self.starts.get(k + 1).copied().unwrap_or(self.points.len());
        &self.points[a..b]
    }
}

/// Rebuilds `map` from every keyframe cloud registered with `world_from_keyframe`, less the
/// forgotten points ([`KeyframeClouds::forget_disc`]) (keyframes
/// beyond the shorter of the two are skipped), each point with its height noise
/// ([`height_variance`]); the next `update` recomputes every cell. Returns the number of points
/// inserted. O(points).
pub(crate) fn reregister(map: &mut TraversabilityMap, clouds: &KeyframeClouds, world_from_keyframe: &[Se3]) -> usize {
    map.clear();
    let mut n = 0;
    let g = map.geometry();
    for (k, pose) in world_from_keyframe.iter().enumerate().take(clouds.keyframes()) {
        let r = pose.rotation_matrix();
        let t = pose.translation;
        let tilt_var = clouds.tilt_var_rad2[k];
        let start = clouds.starts[k];
        let pts = clouds.points_of(k).iter().enumerate().filter_map(|(j, p)| {
            let q = Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            let w = r * q + t;
            (!clouds.is_forgotten(start + j, w.x, w.y, &g)).then(|| (Point3::from(w), height_variance(tilt_var, &q)))
        });
        n += map.insert_points_with_variance(pts).inserted;
    }
    n
}

/// Variance of a registered point's height from the pose's tilt uncertainty, m²: a small roll /
/// pitch error δφ moves the point `b` (body frame) by δφ × b, whose vertical part has variance
/// σ_t²·(b_x² + b_y²) for isotropic roll/pitch variance σ_t². (The pose's own height error is
/// common to the whole scan and left out: it shifts a scan, it does not make it rough.)
pub(crate) fn height_variance(tilt_var_rad2: f64, point_in_body: &Vector3<f64>) -> f64 {
    tilt_var_rad2 * (point_in_body.x * point_in_body.x + point_in_body.y * point_in_body.y)
}

/// Mean roll/pitch variance of a 6×6 body-frame covariance (ξ = (δt, δφ)), rad².
pub(super) fn tilt_variance(cov: &Matrix6<f64>) -> f64 {
    (0.5 * (cov[(3, 3)] + cov[(4, 4)])).max(0.0)
}
