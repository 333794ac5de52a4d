//! Second-level utility u2 (paper eqs. 10–14; notes §6, which this follows where they differ).
//!
//! 1. Waypoints: along the path polyline (from the robot's cell to the candidate), one every
//!    `d_max` of arc length (`Params::waypoint_spacing_m`, by default the camera's max depth),
//!    starting at `d_max` (the robot already sees what it sees from where it is), plus the goal.
//!    A waypoint closer than 1 mm to the goal is merged with it.
//! 2. Camera pose at a waypoint (`CameraGround`): where the map knows the ground under the
//!    waypoint (the fitted plane's height and gradient, [`GroundModel`]), the body stands on that
//!    plane, its z axis along the plane's normal, and the camera sits `camera_height_m` up that
//!    axis (pitch and roll from the local plane, as the simulated robot's); elsewhere, or with
//!    `follow_terrain` off (the paper), at `ground_z_m + camera_height_m`, level. Yaw along the
//!    path tangent. A grid path is a chain of 8-connected cells whose segment
//!    directions are quantised to 45°, so the tangent is taken as the chord over
//!    ±0.5 m of arc length (clamped to the path). At the goal the yaw is Θ*.
//!    Body frame REP-103 (x forward, y left, z up) → camera optical frame (z forward, x right,
//!    y down).
//! 3. Frustum: a voxel centroid `p_c` in the optical frame is seen when
//!    `min_depth ≤ z ≤ max_depth`, `|x| ≤ z·tan(Φ/2)`, `|y| ≤ z·tan(Φ_v/2)` (depth along the optical
//!    axis, as a depth camera reports it). With `occlusion` on, a voxel whose line of sight dips
//!    below the known ground is hidden (not in the paper; optional in the notes).
//! 4. `I_{w_k} = Σ_{voxels seen from w_k} tr(I_i)` (T-optimality, `fim`);
//!    `I_{p_i} = Σ_k I_{w_k}`; normalised over the N candidates by the max (paper eq. 12) or the
//!    mean; `u2 = β · u1 + (1 − β) · I_p,normalised`.
//!
//! Cost per candidate: O(P + K · V) for P path vertices, K waypoints and V voxels in the
//! buckets under a frustum's footprint (`LandmarkVoxels::for_each_in_box`).

use super::fim::{trace_information, trace_information_general};
use super::voxels::LandmarkVoxels;
use crate::math;
use crate::params::{CameraParams, InfoNormalisation};
pub use crate::traversability::GroundModel;
#[cfg(test)]
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// Half-length of the chord that estimates a path's tangent, metres.
pub(crate) const TANGENT_HALF_WINDOW_M: f64 = 0.5;
const MERGE_WITH_GOAL_M: f64 = 1e-3;
/// An occluding ground must rise this far above the line of sight, metres (a landmark on the
/// ground is not hidden by the ground it lies on).
const OCCLUSION_TOLERANCE_M: f64 = 0.02;
/// The line of sight is checked up to this short of the voxel, metres.
const OCCLUSION_MARGIN_M: f64 = 0.1;

/// Where u2's cameras stand (module doc, step 2).
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraGround<'a> {
    /// Height of the flat ground assumed where the map does not know it, map frame, metres.
    pub flat_z_m: f64,
    /// The map's known ground; `None`: flat ground everywhere (the paper).
    pub known: Option<GroundModel<'a>>,
    /// Whether the known ground hides the voxels behind it.
    pub occlusion: bool,
}

impl CameraGround<'_> {
    #[cfg(test)]
    /// Flat ground at `flat_z_m`, no occlusion (the paper).
    pub fn flat(flat_z_m: f64) -> Self {
        Self { flat_z_m, known: None, occlusion: false }
    }

    /// The body at (`x_m`, `y_m`) heading `yaw_rad`: its origin on the ground and
    /// `world_from_body` (z along the ground's normal, x the heading projected onto the ground).
    pub(crate) fn body_at(&self, x_m: f64, y_m: f64, yaw_rad: f64) -> (Point3<f64>, Rotation3<f64>) {
        let level = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw_rad);
        let Some((z, [gx, gy])) = self.known.and_then(|g| g.at(x_m, y_m)) else {
            return (Point3::new(x_m, y_m, self.flat_z_m), level);
        };
        let n = Vector3::new(-gx, -gy, 1.0).normalize();
        let (sin, cos) = math::sin_cos(yaw_rad);
        let f = Vector3::new(cos, sin, 0.0);
        let x = (f - n * f.dot(&n)).normalize();
        let y = n.cross(&x);
        (Point3::new(x_m, y_m, z), Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, n])))
    }
}

/// A waypoint on a path (map frame).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Waypoint {
    pub x_m: f64,
    pub y_m: f64,
    /// Camera (and body) yaw, radians, counter-clockwise from +x.
    pub yaw_rad: f64,
    /// Arc length from the start of the path, metres.
    pub arc_length_m: f64,
    /// Whether this is the goal (yaw Θ*).
    pub is_goal: bool,
}

/// A waypoint with what the camera would see there.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WaypointReport {
    /// Position, map frame, metres.
    pub x_m: f64,
    /// Position, map frame, metres.
    pub y_m: f64,
    /// Camera height in the map frame, metres.
    pub z_m: f64,
    /// Camera (and body) yaw, radians, counter-clockwise from +x.
    pub yaw_rad: f64,
    /// Arc length from the start of the path, metres.
    pub arc_length_m: f64,
    /// Whether this is the goal (yaw Θ*).
    pub is_goal: bool,
    /// Landmark voxels inside the frustum.
    pub voxels_seen: usize,
    /// `I_w`: summed `tr(I)` of those voxels (rad⁻² + m⁻², as the paper's score).
    pub info: f64,
}

/// Waypoints along `path_m` (at least one vertex) every `spacing_m`, plus the goal (the last
/// vertex) with yaw `goal_yaw_rad`. Writes into `out` (cleared).
pub(crate) fn waypoints_along(path_m: &[[f64; 2]], spacing_m: f64, goal_yaw_rad: f64, out: &mut Vec<Waypoint>) {
    out.clear();
    let Some(&goal) = path_m.last() else { return };
    // Cumulative arc length per vertex.
    let mut cum = Vec::with_capacity(path_m.len());
    let mut total = 0.0;
    cum.push(0.0);
    for w in path_m.windows(2) {
        total += ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt();
        cum.push(total);
    }
    let point_at = |s: f64| -> [f64; 2] {
        let s = s.clamp(0.0, total);
        // First vertex with cum ≥ s.
        let k = cum.partition_point(|&c| c < s);
        if k == 0 {
            return path_m[0];
        }
        let (a, b) = (path_m[k - 1], path_m[k]);
        let seg = cum[k] - cum[k - 1];
        let t = if seg > 0.0 { (s - cum[k - 1]) / seg } else { 1.0 };
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
    };
    if spacing_m.is_finite() && spacing_m > 0.0 {
        let mut k = 1.0;
        loop {
            let s = k * spacing_m;
            if s > total - MERGE_WITH_GOAL_M {
                break;
            }
            let p = point_at(s);
            let a = point_at(s - TANGENT_HALF_WINDOW_M);
            let b = point_at(s + TANGENT_HALF_WINDOW_M);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let yaw_rad = if dx != 0.0 || dy != 0.0 { math::atan2(dy, dx) } else { goal_yaw_rad };
            out.push(Waypoint { x_m: p[0], y_m: p[1], yaw_rad, arc_length_m: s, is_goal: false });
            k += 1.0;
        }
    }
    out.push(Waypoint { x_m: goal[0], y_m: goal[1], yaw_rad: goal_yaw_rad, arc_length_m: total, is_goal: true });
}

/// The heading at the end of `path_m`: the chord to its end from the last vertex at least
/// [`TANGENT_HALF_WINDOW_M`] of arc length before it (the first vertex when the path is shorter);
/// `None` for a path of no length.
pub(crate) fn arrival_heading_rad(path_m: &[[f64; 2]]) -> Option<f64> {
    let &end = path_m.last()?;
    let mut from = end;
    let mut s = 0.0;
    for w in path_m.windows(2).rev() {
        from = w[0];
        s += math::hypot(w[1][0] - w[0][0], w[1][1] - w[0][1]);
        if s >= TANGENT_HALF_WINDOW_M {
            break;
        }
    }
    let (dx, dy) = (end[0] - from[0], end[1] - from[1]);
    (dx != 0.0 || dy != 0.0).then(|| math::atan2(dy, dx))
}

#[cfg(test)]
/// `world_from_camera` (optical frame: z forward, x right, y down) for a camera at
/// (`x_m`, `y_m`, `z_m`) with body yaw `yaw_rad`, pitch and roll 0.
pub(crate) fn camera_pose(x_m: f64, y_m: f64, z_m: f64, yaw_rad: f64) -> Isometry3<f64> {
    let world_from_body = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw_rad);
    Isometry3::from_parts(Translation3::new(x_m, y_m, z_m), UnitQuaternion::from_rotation_matrix(&optical_rotation(&world_from_body)))
}

/// `world_from_optical` of a camera looking along the body's x: the optical axes in the body
/// frame are x_opt = −y_body, y_opt = −z_body, z_opt = x_body.
pub(crate) fn optical_rotation(world_from_body: &Rotation3<f64>) -> Rotation3<f64> {
    let body_from_optical = Rotation3::from_matrix_unchecked(Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0));
    world_from_body * body_from_optical
}

/// The camera frustum in the optical frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frustum {
    pub tan_half_hfov: f64,
    pub tan_half_vfov: f64,
    pub min_depth_m: f64,
    pub max_depth_m: f64,
}

impl Frustum {
    /// From the camera parameters (a horizontal FOV ≥ π leaves x unbounded).
    pub(crate) fn from_params(camera: &CameraParams) -> Self {
        let tan_half = |fov: f64| if fov < std::f64::consts::PI { math::tan(0.5 * fov) } else { f64::INFINITY };
        Self {
            tan_half_hfov: tan_half(camera.hfov_rad),
            tan_half_vfov: tan_half(camera.vfov_rad),
            min_depth_m: camera.min_depth_m,
            max_depth_m: camera.max_depth_m,
        }
    }

    /// Whether the optical-frame point (x, y, z) is inside.
    #[inline]
    pub fn contains(&self, x: f64, y: f64, z: f64) -> bool {
        z >= self.min_depth_m && z <= self.max_depth_m && z > 0.0 && x.abs() <= z * self.tan_half_hfov && y.abs() <= z * self.tan_half_vfov
    }
}

/// What a camera at `camera_m` on a body with `world_from_body` (the camera looks along the body's
/// x) sees: (voxels in the frustum and, with `occluder`, in line of sight over its ground;
/// `I_w = Σ tr(I_i)`).
pub(crate) fn waypoint_information(
    voxels: &LandmarkVoxels,
    camera_m: [f64; 3],
    world_from_body: &Rotation3<f64>,
    frustum: &Frustum,
    sigma_bearing_rad: f64,
    occluder: Option<&GroundModel>,
) -> (usize, f64) {
    let m = world_from_body.matrix();
    let (xb, yb, zb) = (m.column(0).into_owned(), m.column(1).into_owned(), m.column(2).into_owned());
    let cam = Vector3::from(camera_m);
    // x–y footprint: the box around the frustum's eight corners, or everything if unbounded.
    let (mut x0, mut y0, mut x1, mut y1) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    if frustum.tan_half_hfov.is_finite() && frustum.tan_half_vfov.is_finite() {
        for depth in [frustum.min_depth_m, frustum.max_depth_m] {
            for sx in [-1.0, 1.0] {
                for sy in [-1.0, 1.0] {
                    // Optical (x, y, z) → world: z along x_b, x along −y_b, y along −z_b.
                    let (ox, oy) = (sx * depth * frustum.tan_half_hfov, sy * depth * frustum.tan_half_vfov);
                    let p = cam + xb * depth - yb * ox - zb * oy;
                    x0 = x0.min(p.x);
                    x1 = x1.max(p.x);
                    y0 = y0.min(p.y);
                    y1 = y1.max(p.y);
                }
            }
        }
    } else {
        (x0, y0, x1, y1) = (f64::MIN, f64::MIN, f64::MAX, f64::MAX);
    }
    let camera_from_world_rotation = optical_rotation(world_from_body).inverse().into_inner();
    let sigma_b = sigma_bearing_rad;
    let mut seen = 0;
    let mut info = 0.0;
    voxels.for_each_in_box(x0, y0, x1, y1, |i| {
        let p = voxels.centroid_m(i);
        let d = Vector3::new(p[0] - camera_m[0], p[1] - camera_m[1], p[2] - camera_m[2]);
        let (z, x, y) = (xb.dot(&d), -yb.dot(&d), -zb.dot(&d));
        if !frustum.contains(x, y, z) {
            return;
        }
        if occluder.is_some_and(|g| hidden_by_ground(g, &cam, &d)) {
            return;
        }
        seen += 1;
        info += match voxels.isotropic_variance_m2(i) {
            Some(var) => trace_information((x * x + y * y + z * z).sqrt(), sigma_b, var),
            None => trace_information_general(&Vector3::new(x, y, z), &camera_from_world_rotation, voxels.covariance_m2(i), sigma_b)
                .unwrap_or(0.0),
        };
    });
    (seen, info)
}

/// Whether the segment from `cam` along `d` (up to [`OCCLUSION_MARGIN_M`] short of its end)
/// passes more than [`OCCLUSION_TOLERANCE_M`] below the known ground, sampled every cell.
fn hidden_by_ground(ground: &GroundModel, cam: &Vector3<f64>, d: &Vector3<f64>) -> bool {
    let len = d.norm();
    let step = ground.z_m.geometry.resolution_m;
    let u = d / len.max(1e-12);
    let mut t = step;
    while t < len - OCCLUSION_MARGIN_M {
        let q = cam + u * t;
        if ground.at(q.x, q.y).is_some_and(|(z, _)| z > q.z + OCCLUSION_TOLERANCE_M) {
            return true;
        }
        t += step;
    }
    false
}

/// How u2 looks along a path (module doc): what there is to see, the camera, where it stands.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathView<'a> {
    /// The mapped landmarks.
    pub voxels: &'a LandmarkVoxels,
    pub camera: &'a CameraParams,
    /// Height of the camera above the ground, metres.
    pub camera_height_m: f64,
    pub ground: CameraGround<'a>,
    /// Waypoint spacing d_max, metres.
    pub spacing_m: f64,
    /// σ of a landmark bearing, radians (eq. 10).
    pub sigma_bearing_rad: f64,
}

/// `I_p = Σ_k I_{w_k}` along `path_m` (map frame, metres; from the robot's cell to the candidate),
/// with the goal's yaw `goal_yaw_rad` (Θ*), seen as `view` says. Writes one report per waypoint
/// into `out` (cleared) and returns `I_p`.
pub(crate) fn path_information(path_m: &[[f64; 2]], goal_yaw_rad: f64, view: &PathView, out: &mut Vec<WaypointReport>) -> f64 {
    out.clear();
    let mut wps = Vec::new();
    waypoints_along(path_m, view.spacing_m, goal_yaw_rad, &mut wps);
    let frustum = Frustum::from_params(view.camera);
    let ground = &view.ground;
    let occluder = ground.known.as_ref().filter(|_| ground.occlusion);
    let mut total = 0.0;
    for w in &wps {
        let (body, world_from_body) = ground.body_at(w.x_m, w.y_m, w.yaw_rad);
        let cam = body + world_from_body * Vector3::new(0.0, 0.0, view.camera_height_m);
        let (voxels_seen, info) =
            waypoint_information(view.voxels, cam.coords.into(), &world_from_body, &frustum, view.sigma_bearing_rad, occluder);
        total += info;
        out.push(WaypointReport {
            x_m: w.x_m,
            y_m: w.y_m,
            z_m: cam.z,
            yaw_rad: w.yaw_rad,
            arc_length_m: w.arc_length_m,
            is_goal: w.is_goal,
            voxels_seen,
            info,
        });
    }
    total
}

/// The share of `path_m`'s views (every `view.spacing_m` and the goal with yaw `goal_yaw_rad`, as
/// [`path_information`] takes them) that hold at least `min_voxels` landmark voxels: how much of
/// the path a visual front end needing that many landmarks in view would track. In [0, 1]; 0 for
/// an empty path. Writes one report per view into `out` (cleared).
pub(crate) fn path_tracked_share(
    path_m: &[[f64; 2]],
    goal_yaw_rad: f64,
    view: &PathView,
    min_voxels: usize,
    out: &mut Vec<WaypointReport>,
) -> f64 {
    path_information(path_m, goal_yaw_rad, view, out);
    if out.is_empty() {
        return 0.0;
    }
    out.iter().filter(|w| w.voxels_seen >= min_voxels).count() as f64 / out.len() as f64
}

/// Normalises path informations over the candidates (paper eq. 12: divide by the max; or by the
/// mean). All zeros (or an empty slice) stay zeros.
pub(crate) fn normalise_path_information(raw: &[f64], mode: InfoNormalisation, out: &mut Vec<f64>) {
    out.clear();
    let scale = match mode {
        InfoNormalisation::Max => raw.iter().cloned().fold(0.0, f64::max),
        InfoNormalisation::Mean if !raw.is_empty() => raw.iter().sum::<f64>() / raw.len() as f64,
        InfoNormalisation::Mean => 0.0,
    };
    out.extend(raw.iter().map(|&v| if scale > 0.0 && scale.is_finite() { v / scale } else { 0.0 }));
}

/// `u2 = β · u1 + (1 − β) · I_p,normalised` (paper eq. 14).
#[inline]
pub(crate) fn u2_score(u1: f64, path_info_normalised: f64, beta: f64) -> f64 {
    beta * u1 + (1.0 - beta) * path_info_normalised
}

#[cfg(test)]
mod tests;
