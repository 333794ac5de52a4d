//! The simulated visual front end between the camera and the SLAM: which of the landmarks in
//! view ([`super::camera::observe_landmarks`]) a feature detector finds, which of those the
//! per-frame budget keeps, and which are matched to the wrong landmark.
//!
//! - **Detection**: landmark i is found with probability p = p₀ · f_d(d) · f_θ(θ), d its range
//!   and θ the angle between the line of sight and its surface normal: f_d = 1 up to
//!   `full_range_m`, falling linearly to `far_factor` at the camera's maximum depth (features
//!   shrink to fewer pyramid levels and the D435's depth error grows as d²); f_θ = 1 up to
//!   `full_angle_rad`, falling linearly to 0 at `max_angle_rad` (descriptors do not survive a
//!   grazing view). A landmark standing off the ground (a stone, a bush) has no single surface:
//!   f_θ = 1.
//! - **Budget**: at most `feature_budget` features per frame, spread over a `grid` of image
//!   cells as ORB's extractor spreads its corners: within a cell by decreasing response (the
//!   landmark's fixed corner strength × its detection probability), taken one per cell in turn.
//! - **Wrong associations**: each kept feature is, with probability `outlier_rate`, matched to
//!   another landmark in the frustum (a descriptor that looks alike); the measurement stays the
//!   true one. The SLAM's robust kernel ([`crate::slam::GraphSlamParams::observation_kernel`])
//!   is what stands between such a match and the estimate.
//!
//! Cost per frame: O(landmarks in view · log) plus the frustum's candidates for the outliers.

use super::heightfield::Heightfield;
use super::noise::hash_unit;
use crate::math;
use crate::params::{CameraParams, InvalidParam, check_non_negative, check_positive};
use crate::slam::keyframes::CameraObservation;
use nalgebra::{Point3, Vector3};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The visual front end's parameters; see the module doc. Sources: ORB-SLAM3 (Campos et al.
/// 2021) and the D435 datasheet.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VisionParams {
    /// p₀, the probability of finding a landmark close by and head-on, in [0, 1]. Default 0.9
    /// (ORB's repeatability under small viewpoint changes, Rublee et al. 2011).
    pub detection_probability: f64,
    /// Range up to which detection is at p₀, metres, > 0. Default 1.5 (half the D435's ideal
    /// 3 m range).
    pub full_range_m: f64,
    /// Detection at the camera's maximum depth, as a fraction of p₀, in [0, 1]. Default 0.3.
    pub far_factor: f64,
    /// View angle to the surface normal up to which detection is at p₀, radians. Default 45°.
    pub full_angle_rad: f64,
    /// View angle at which detection reaches 0, radians, > `full_angle_rad`, ≤ 90°. Default 75°
    /// (ORB-SLAM drops a map point viewed more than 60° off its mean view; a wider margin for
    /// the simulator's ground points, seen from 0.3 m up).
    pub max_angle_rad: f64,
    /// Features kept per frame, ≥ 1. Default 30.
    pub feature_budget: usize,
    /// Image cells (columns, rows) the budget is spread over, each ≥ 1. Default 4 × 3.
    pub grid: [usize; 2],
    /// Share of kept features matched to the wrong landmark, in [0, 1). Default 0.05 (the
    /// fraction ORB-SLAM's pose optimisation typically flags as outliers).
    pub outlier_rate: f64,
    /// Visual tracking is lost at a keyframe that matches fewer mapped landmarks than this.
    /// Default 6 (ORB-SLAM3's tracking needs 30 inliers of ~200 tracked points: 15 %, here of a
    /// 30-feature budget, with a floor that keeps a 6-DoF pose over-determined under outliers).
    pub min_tracked: usize,
    /// Lost tracking relocalises at a keyframe that matches at least this many mapped
    /// landmarks. Default 10 (ORB-SLAM3 relocalises with 50 inliers, 5/3 of its tracking
    /// threshold).
    pub relocalise_min: usize,
    /// … or starts a new map segment (joined to the old one by the wheel odometry across the
    /// loss, and to the old landmarks at their first re-observation, as ORB-SLAM3's atlas with
    /// an inertial link) at a keyframe with at least this many features. Default 15 (half the
    /// budget; ORB-SLAM3 initialises an RGB-D map with 500 of its 1000 features).
    pub new_map_min: usize,
}

impl Default for VisionParams {
    fn default() -> Self {
        Self {
            detection_probability: 0.9,
            full_range_m: 1.5,
            far_factor: 0.3,
            full_angle_rad: 45f64.to_radians(),
            max_angle_rad: 75f64.to_radians(),
            feature_budget: 30,
            grid: [4, 3],
            outlier_rate: 0.05,
            min_tracked: 6,
            relocalise_min: 10,
            new_map_min: 15,
        }
    }
}

/// Largest feature budget (a real extractor's 1000–2000 with a wide margin).
pub(crate) const MAX_FEATURE_BUDGET: usize = 100_000;

impl VisionParams {
    /// Every field finite and in its documented range; the error names the first bad one.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let unit = |name: &str, v: f64, max_excl: bool| {
            let ok = v >= 0.0 && if max_excl { v < 1.0 } else { v <= 1.0 };
            if ok {
                Ok(())
            } else {
                let range = if max_excl { "[0, 1)" } else { "[0, 1]" };
                Err(InvalidParam::new(format!("vision.{name}"), format!("must be in {range} (got {})", crate::params::Num(v))))
            }
        };
        unit("detection_probability", self.detection_probability, false)?;
        unit("far_factor", self.far_factor, false)?;
        unit("outlier_rate", self.outlier_rate, true)?;
        check_positive("vision.full_range_m", self.full_range_m)?;
        check_non_negative("vision.full_angle_rad", self.full_angle_rad)?;
        if !(self.max_angle_rad > self.full_angle_rad && self.max_angle_rad <= std::f64::consts::FRAC_PI_2) {
            return Err(InvalidParam::new(
                "vision.max_angle_rad",
                format!("must be in (full_angle_rad, π/2] (got {})", crate::params::Num(self.max_angle_rad)),
            ));
        }
        let count = |name: &str, v: usize, max: usize| {
            if (1..=max).contains(&v) {
                Ok(())
            } else {
                Err(InvalidParam::new(format!("vision.{name}"), format!("must be in 1..={max} (got {v})")))
            }
        };
        count("feature_budget", self.feature_budget, MAX_FEATURE_BUDGET)?;
        count("grid[0]", self.grid[0], 1000)?;
        count("grid[1]", self.grid[1], 1000)?;
        count("min_tracked", self.min_tracked, MAX_FEATURE_BUDGET)?;
        count("relocalise_min", self.relocalise_min, MAX_FEATURE_BUDGET)?;
        count("new_map_min", self.new_map_min, MAX_FEATURE_BUDGET)?;
        Ok(())
    }

    /// f_d · f_θ · p₀ for a landmark at `range_m` seen `angle_rad` off its normal (`None`: no
    /// single surface), with the camera's maximum depth `max_depth_m`.
    pub(crate) fn detection_probability_at(&self, range_m: f64, angle_rad: Option<f64>, max_depth_m: f64) -> f64 {
        let f_d = if range_m <= self.full_range_m || max_depth_m <= self.full_range_m {
            1.0
        } else {
            let t = ((range_m - self.full_range_m) / (max_depth_m - self.full_range_m)).min(1.0);
            1.0 - t * (1.0 - self.far_factor)
        };
        let f_a = match angle_rad {
            None => 1.0,
            Some(a) if a <= self.full_angle_rad => 1.0,
            Some(a) => (1.0 - (a - self.full_angle_rad) / (self.max_angle_rad - self.full_angle_rad)).max(0.0),
        };
        self.detection_probability * f_d * f_a
    }
}

/// A landmark on the ground stands within this of the terrain, metres; higher ones have no
/// single surface normal.
const ON_SURFACE_M: f64 = 0.02;

/// The surface normal under each landmark: the terrain's (rock sides and walls are steps of the
/// heightfield, so their normal comes out horizontal), `None` for one standing off the ground.
/// O(landmarks).
pub(crate) fn landmark_normals(field: &Heightfield, landmarks: &[Point3<f64>]) -> Vec<Option<Vector3<f64>>> {
    let h = field.geometry.resolution_m;
    landmarks
        .iter()
        .map(|p| {
            let ground = field.height_at(p.x, p.y)?;
            if p.z > ground + ON_SURFACE_M {
                return None;
            }
            let z = |dx: f64, dy: f64| field.height_at(p.x + dx, p.y + dy).unwrap_or(ground);
            let gx = (z(h, 0.0) - z(-h, 0.0)) / (2.0 * h);
            let gy = (z(0.0, h) - z(0.0, -h)) / (2.0 * h);
            Some(Vector3::new(-gx, -gy, 1.0).normalize())
        })
        .collect()
}

/// What the front end did to one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct FrameCounts {
    /// Landmarks in view (before detection).
    pub in_view: usize,
    pub detected: usize,
    pub kept: usize,
    /// Kept features matched to the wrong landmark.
    pub wrong: usize,
}

/// A frame's view of the world for [`select_features`].
pub(crate) struct FrameView<'a> {
    pub landmarks: &'a [Point3<f64>],
    pub normals: &'a [Option<Vector3<f64>>],
    pub camera_m: Point3<f64>,
    pub camera: &'a CameraParams,
    /// Where the camera sits in the body frame.
    pub camera_in_body: Vector3<f64>,
}

/// Reduces `observations` (every landmark in view, as [`super::camera::observe_landmarks`]
/// gives them) to what the front end reports, in increasing id order; `candidates` are the
/// landmark ids in the frustum a wrong match may pick. Draws from `rng`.
pub(crate) fn select_features(
    observations: &mut Vec<CameraObservation>,
    candidates: &[usize],
    view: &FrameView,
    params: &VisionParams,
    rng: &mut ChaCha8Rng,
) -> FrameCounts {
    let mut counts = FrameCounts { in_view: observations.len(), ..FrameCounts::default() };
    let (th, tv) = (math::tan(view.camera.hfov_rad / 2.0), math::tan(view.camera.vfov_rad / 2.0));
    let [gc, gr] = params.grid;
    // (cell, −response, id) of each detected feature.
    let mut ranked: Vec<(usize, f64, usize)> = Vec::with_capacity(observations.len());
    for (k, o) in observations.iter().enumerate() {
        let id = o.landmark_id as usize;
        let lw = view.landmarks[id];
        let ray = view.camera_m - lw;
        let range = ray.norm();
        let angle = view.normals[id].map(|n| math::acos((n.dot(&ray) / range.max(1e-12)).clamp(-1.0, 1.0)));
        let p = params.detection_probability_at(range, angle, view.camera.max_depth_m);
        // One draw per landmark in view, detected or not: the stream does not depend on p.
        let u: f64 = rng.random();
        if u >= p {
            continue;
        }
        // The image cell from the measured point (camera-centred, body axes; x forward).
        let v = o.point_in_robot - view.camera_in_body;
        let depth = v.x.max(1e-9);
        let col = (((1.0 - v.y / (th * depth)) / 2.0 * gc as f64).floor().max(0.0) as usize).min(gc - 1);
        let row = (((1.0 - v.z / (tv * depth)) / 2.0 * gr as f64).floor().max(0.0) as usize).min(gr - 1);
        let strength = 0.5 + 0.5 * hash_unit(id as i64, 0, 0xC0_44E4);
        ranked.push((row * gc + col, -(strength * p), k));
    }
    counts.detected = ranked.len();
    ranked.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
    // Round robin over the cells, best first in each.
    let mut starts: Vec<usize> = Vec::with_capacity(gc * gr + 1);
    let mut i = 0;
    for cell in 0..gc * gr {
        starts.push(i);
        while i < ranked.len() && ranked[i].0 == cell {
            i += 1;
        }
    }
    starts.push(ranked.len());
    let mut keep: Vec<usize> = Vec::with_capacity(params.feature_budget.min(ranked.len()));
    let mut depth_in_cell = 0;
    while keep.len() < params.feature_budget.min(ranked.len()) {
        for cell in 0..gc * gr {
            let at = starts[cell] + depth_in_cell;
            if at < starts[cell + 1] && keep.len() < params.feature_budget {
                keep.push(ranked[at].2);
            }
        }
        depth_in_cell += 1;
    }
    keep.sort_unstable();
    let mut kept: Vec<CameraObservation> = keep.iter().map(|&k| observations[k]).collect();
    counts.kept = kept.len();
    // Wrong associations: another landmark of the frustum not matched in this frame.
    if params.outlier_rate > 0.0 {
        let used: std::collections::BTreeSet<u64> = kept.iter().map(|o| o.landmark_id).collect();
        let mut free: Vec<usize> = candidates.iter().copied().filter(|c| !used.contains(&(*c as u64))).collect();
        for o in kept.iter_mut() {
            let u: f64 = rng.random();
            if u >= params.outlier_rate || free.is_empty() {
                continue;
            }
            o.landmark_id = free.swap_remove(rng.random_range(0..free.len())) as u64;
            counts.wrong += 1;
        }
    }
    kept.sort_by_key(|o| o.landmark_id);
    *observations = kept;
    counts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;
    use nalgebra::Matrix3;
    use rand::SeedableRng;

    #[test]
    fn detection_probability_hand_values() {
        let p = VisionParams::default();
        let close = p.detection_probability_at(1.0, Some(0.1), 3.0);
        assert!((close - 0.9).abs() < 1e-15);
        // Halfway from 1.5 m to 3 m: 1 − 0.5 · (1 − 0.3) = 0.65.
        assert!((p.detection_probability_at(2.25, None, 3.0) - 0.9 * 0.65).abs() < 1e-15);
        // Halfway from 45° to 75°: 0.5; beyond 75°: 0.
        assert!((p.detection_probability_at(1.0, Some(60f64.to_radians()), 3.0) - 0.45).abs() < 1e-12);
        assert_eq!(p.detection_probability_at(1.0, Some(80f64.to_radians()), 3.0), 0.0);
        // At and past the maximum depth: the far factor.
        assert!((p.detection_probability_at(3.0, None, 3.0) - 0.27).abs() < 1e-15);
        assert!((p.detection_probability_at(9.0, None, 3.0) - 0.27).abs() < 1e-15);
    }

    #[test]
    fn normals_follow_the_terrain_and_raised_landmarks_have_none() {
        // z = 0.5 x: normal ∝ (−0.5, 0, 1).
        let field = Heightfield::from_fn(GridGeometry::new(0.0, 0.0, 0.1, 50, 50), |x, _| 0.5 * x);
        let pts = [Point3::new(2.0, 2.0, 1.0), Point3::new(2.0, 2.0, 1.3)];
        let n = landmark_normals(&field, &pts);
        let expected = Vector3::new(-0.5, 0.0, 1.0).normalize();
        assert!((n[0].unwrap() - expected).norm() < 1e-9, "{:?}", n[0]);
        assert_eq!(n[1], None);
    }

    /// `count` landmarks 1 m ahead of a camera at the origin looking along +x, spread over the
    /// image's left half (y > 0) except `right` of them on the right half.
    fn frame(count: usize, right: usize) -> (Vec<Point3<f64>>, Vec<CameraObservation>) {
        let mut landmarks = Vec::new();
        let mut obs = Vec::new();
        for i in 0..count {
            let y = if i < right { -0.3 - 0.001 * i as f64 } else { 0.3 + 0.001 * i as f64 };
            let p = Point3::new(1.0, y, 0.0);
            landmarks.push(p);
            obs.push(CameraObservation { landmark_id: i as u64, point_in_robot: p.coords, covariance: Matrix3::identity() * 1e-4 });
        }
        (landmarks, obs)
    }

    fn run(count: usize, right: usize, params: &VisionParams, seed: u64) -> (Vec<CameraObservation>, FrameCounts) {
        let (landmarks, mut obs) = frame(count, right);
        let normals = vec![None; count];
        let camera = CameraParams::default();
        let view = FrameView {
            landmarks: &landmarks,
            normals: &normals,
            camera_m: Point3::origin(),
            camera: &camera,
            camera_in_body: Vector3::zeros(),
        };
        let candidates: Vec<usize> = (0..count).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let counts = select_features(&mut obs, &candidates, &view, params, &mut rng);
        (obs, counts)
    }

    #[test]
    fn the_budget_is_spread_over_the_image() {
        // 200 features on the left, 3 on the right, all detected: a budget of 10 takes the 3 on
        // the right (one per cell in turn).
        let params =
            VisionParams { detection_probability: 1.0, outlier_rate: 0.0, feature_budget: 10, grid: [2, 1], ..VisionParams::default() };
        let (kept, counts) = run(203, 3, &params, 1);
        assert_eq!((counts.in_view, counts.detected, counts.kept, counts.wrong), (203, 203, 10, 0));
        assert_eq!(kept.iter().filter(|o| o.landmark_id < 3).count(), 3);
        assert!(kept.windows(2).all(|w| w[0].landmark_id < w[1].landmark_id));
        // Same seed, same frame.
        assert_eq!(kept, run(203, 3, &params, 1).0);
    }

    #[test]
    fn detection_and_wrong_matches_happen_at_their_rates() {
        let params = VisionParams { detection_probability: 0.6, outlier_rate: 0.2, feature_budget: 1000, ..VisionParams::default() };
        let (mut detected, mut wrong, mut kept_n, frames) = (0, 0, 0, 200);
        for seed in 0..frames {
            let (kept, counts) = run(100, 50, &params, seed);
            detected += counts.detected;
            wrong += counts.wrong;
            kept_n += kept.len();
            // A wrong match names a landmark the frame did not match otherwise: ids stay distinct.
            assert!(kept.windows(2).all(|w| w[0].landmark_id < w[1].landmark_id));
            // Its measurement is of the true landmark, so it sits away from the one it names.
            let (landmarks, _) = frame(100, 50);
            let off = kept.iter().filter(|o| (landmarks[o.landmark_id as usize].coords - o.point_in_robot).norm() > 1e-12).count();
            assert_eq!(off, counts.wrong);
        }
        let p_detect = detected as f64 / (100.0 * frames as f64);
        let p_wrong = wrong as f64 / kept_n as f64;
        assert!((p_detect - 0.6).abs() < 0.02, "{p_detect}");
        assert!((p_wrong - 0.2).abs() < 0.02, "{p_wrong}");
    }
}
