//! LeoRover-like differential drive following a planned path (notes §8): a carrot (look-ahead
//! point) controller — turn in place when the carrot is more than `turn_in_place_rad` off the
//! heading, otherwise drive at up to `max_speed_mps` with a turn rate proportional to the heading
//! error, bounded by `max_turn_rate_radps`. Attitude (roll, pitch) and height come from the
//! terrain under the body. O(path vertices) per step (the carrot search starts at the last
//! vertex reached).

use super::heightfield::Heightfield;
use crate::math;
use crate::pose::{Pose2, wrap_pi};
use nalgebra::{Point3, Rotation3};
use serde::{Deserialize, Serialize};

/// Drive limits and controller gains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DriveParams {
    /// Largest forward speed, m/s, > 0. Default 0.4 (LeoRover).
    pub max_speed_mps: f64,
    /// Largest turn rate, rad/s, > 0. Default 1.0.
    pub max_turn_rate_radps: f64,
    /// Look-ahead distance of the carrot along the path, metres, > 0. Default 0.4.
    pub lookahead_m: f64,
    /// Heading error above which the robot turns in place, radians, in (0, π] (π: never).
    /// Default 0.6.
    pub turn_in_place_rad: f64,
    /// Proportional gain from heading error to turn rate, 1/s, > 0. Default 2.
    pub heading_gain: f64,
    /// Distance to the last path point at which the goal is reached, metres, in
    /// (0, 5]. Default 0.15.
    pub goal_tolerance_m: f64,
    /// Half of the body's length/width used to read roll and pitch from the terrain, metres, in
    /// (0, 5]. Default 0.2.
    pub body_half_m: f64,
}

impl Default for DriveParams {
    fn default() -> Self {
        Self {
            max_speed_mps: 0.4,
            max_turn_rate_radps: 1.0,
            lookahead_m: 0.4,
            turn_in_place_rad: 0.6,
            heading_gain: 2.0,
            goal_tolerance_m: 0.15,
            body_half_m: 0.2,
        }
    }
}

/// A velocity command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Twist {
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Turn rate, rad/s, counter-clockwise.
    pub omega_radps: f64,
}

/// Follows a polyline path; remembers how far along it is.
#[derive(Clone, Debug, Default)]
pub(crate) struct PathFollower {
    pub path_m: Vec<[f64; 2]>,
    /// Index of the path segment the robot is on.
    segment: usize,
}

impl PathFollower {
    pub fn new(path_m: Vec<[f64; 2]>) -> Self {
        Self { path_m, segment: 0 }
    }

    /// The path still ahead of the robot: its projection on the current segment, then the
    /// segment ends after it (the whole path before the first [`Self::command`]).
    pub(crate) fn remaining(&self, pose: Pose2) -> impl Iterator<Item = [f64; 2]> + '_ {
        let rest = self.path_m.get(self.segment + 1..).unwrap_or(&[]);
        let start = match (self.path_m.get(self.segment), rest.first()) {
            (Some(&a), Some(&b)) => {
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let len2 = dx * dx + dy * dy;
                let t = if len2 > 0.0 { (((pose.x_m - a[0]) * dx + (pose.y_m - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
                Some([a[0] + t * dx, a[1] + t * dy])
            }
            (a, _) => a.copied(),
        };
        start.into_iter().chain(rest.iter().copied())
    }

    /// Whether the robot is within `tolerance` of the last point.
    pub fn arrived(&self, pose: Pose2, tolerance_m: f64) -> bool {
        match self.path_m.last() {
            Some(p) => math::hypot(p[0] - pose.x_m, p[1] - pose.y_m) <= tolerance_m,
            None => true,
        }
    }

    /// The command toward the carrot `lookahead_m` ahead of the robot's projection on the path.
    pub fn command(&mut self, pose: Pose2, p: &DriveParams) -> Twist {
        let n = self.path_m.len();
        if n == 0 || self.arrived(pose, p.goal_tolerance_m) {
            return Twist { v_mps: 0.0, omega_radps: 0.0 };
        }
        // Advance the segment while the robot is past its end.
        while self.segment + 1 < n {
            let (a, b) = (self.path_m[self.segment], self.path_m[self.segment + 1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 { ((pose.x_m - a[0]) * dx + (pose.y_m - a[1]) * dy) / len2 } else { 1.0 };
            if t >= 1.0 || math::hypot(b[0] - pose.x_m, b[1] - pose.y_m) < p.lookahead_m * 0.5 {
                self.segment += 1;
            } else {
                break;
            }
        }
        // Carrot: first point along the path from the current segment at distance ≥ lookahead.
        let mut carrot = self.path_m[n - 1];
        for k in self.segment + 1..n {
            let q = self.path_m[k];
            let d = math::hypot(q[0] - pose.x_m, q[1] - pose.y_m);
            if d >= p.lookahead_m {
                let a = self.path_m[k - 1];
                // Point on segment a→q at the look-ahead distance (or q itself).
                carrot = lookahead_point(a, q, [pose.x_m, pose.y_m], p.lookahead_m).unwrap_or(q);
                break;
            }
        }
        let heading = math::atan2(carrot[1] - pose.y_m, carrot[0] - pose.x_m);
        let err = wrap_pi(heading - pose.yaw_rad);
        let omega = (p.heading_gain * err).clamp(-p.max_turn_rate_radps, p.max_turn_rate_radps);
        if err.abs() > p.turn_in_place_rad {
            return Twist { v_mps: 0.0, omega_radps: omega };
        }
        let dist = math::hypot(carrot[0] - pose.x_m, carrot[1] - pose.y_m);
        let v = (p.max_speed_mps * math::cos(err)).min(dist.max(0.05)).clamp(0.0, p.max_speed_mps);
        Twist { v_mps: v, omega_radps: omega }
    }
}

/// The point on segment a→b at distance `r` from `c` (the far intersection), if any.
fn lookahead_point(a: [f64; 2], b: [f64; 2], c: [f64; 2], r: f64) -> Option<[f64; 2]> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (fx, fy) = (a[0] - c[0], a[1] - c[1]);
    let qa = dx * dx + dy * dy;
    if qa == 0.0 {
        return None;
    }
    let qb = 2.0 * (fx * dx + fy * dy);
    let qc = fx * fx + fy * fy - r * r;
    let disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 {
        return None;
    }
    let t = (-qb + disc.sqrt()) / (2.0 * qa);
    (0.0..=1.0).contains(&t).then(|| [a[0] + t * dx, a[1] + t * dy])
}

/// Integrates a unicycle for `dt_s` (exact arc). Returns the new pose.
pub(crate) fn integrate(pose: Pose2, cmd: Twist, dt_s: f64) -> Pose2 {
    let dth = cmd.omega_radps * dt_s;
    let ds = cmd.v_mps * dt_s;
    let (x, y) = if dth.abs() < 1e-9 {
        (pose.x_m + ds * math::cos(pose.yaw_rad), pose.y_m + ds * math::sin(pose.yaw_rad))
    } else {
        let r = ds / dth;
        (
            pose.x_m + r * (math::sin(pose.yaw_rad + dth) - math::sin(pose.yaw_rad)),
            pose.y_m - r * (math::cos(pose.yaw_rad + dth) - math::cos(pose.yaw_rad)),
        )
    };
    Pose2 { x_m: x, y_m: y, yaw_rad: wrap_pi(pose.yaw_rad + dth) }
}

/// The body's 3D pose on the terrain: position on the ground under (x, y) and the rotation
/// Rz(yaw)·Ry(pitch)·Rx(roll) with pitch and roll from the heights `body_half_m` ahead/behind and
/// left/right (REP-103: nose up is negative pitch, left side up is positive roll).
pub(crate) fn body_on_terrain(field: &Heightfield, pose: Pose2, body_half_m: f64) -> (Point3<f64>, Rotation3<f64>) {
    let (c, s) = (math::cos(pose.yaw_rad), math::sin(pose.yaw_rad));
    let z = field.height_at(pose.x_m, pose.y_m).unwrap_or(0.0);
    let h = |dx: f64, dy: f64| field.height_at(pose.x_m + dx, pose.y_m + dy).unwrap_or(z);
    let b = body_half_m;
    let pitch = -math::atan((h(b * c, b * s) - h(-b * c, -b * s)) / (2.0 * b));
    let roll = math::atan((h(-b * s, b * c) - h(b * s, -b * c)) / (2.0 * b));
    (Point3::new(pose.x_m, pose.y_m, z), Rotation3::from_euler_angles(roll, pitch, pose.yaw_rad))
}

/// The ground under the body (proprioceptive: where the wheels are, the terrain is known), every
/// `spacing_m` over the `body_half_m` square footprint at `body_m` with attitude
/// `world_from_body`, appended to `out`. O((body_half_m / spacing_m)²).
pub(crate) fn footprint_points(
    field: &Heightfield,
    body_m: Point3<f64>,
    world_from_body: &Rotation3<f64>,
    body_half_m: f64,
    spacing_m: f64,
    out: &mut Vec<Point3<f64>>,
) {
    let n = (body_half_m / spacing_m).round() as i32;
    for i in -n..=n {
        for j in -n..=n {
            let local = nalgebra::Vector3::new(i as f64 * spacing_m, j as f64 * spacing_m, 0.0);
            let w = world_from_body * local + body_m.coords;
            if let Some(z) = field.height_at(w.x, w.y) {
                out.push(Point3::new(w.x, w.y, z));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;

    #[test]
    fn the_path_ahead_starts_at_the_robots_projection_on_its_segment() {
        let p = DriveParams::default();
        let mut f = PathFollower::new(vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]]);
        let pose = |x_m, y_m| Pose2 { x_m, y_m, yaw_rad: 0.0 };
        assert_eq!(f.remaining(pose(1.0, 0.3)).collect::<Vec<_>>(), [[1.0, 0.0], [2.0, 0.0], [2.0, 2.0]]);
        // On the second segment once the robot has passed the first one's end.
        f.command(pose(2.1, 0.5), &p);
        assert_eq!(f.remaining(pose(2.1, 0.5)).collect::<Vec<_>>(), [[2.0, 0.5], [2.0, 2.0]]);
        // Clamped to the segment; one point alone; nothing.
        assert_eq!(f.remaining(pose(2.0, 3.0)).collect::<Vec<_>>(), [[2.0, 2.0], [2.0, 2.0]]);
        assert_eq!(PathFollower::new(vec![[1.0, 1.0]]).remaining(pose(0.0, 0.0)).collect::<Vec<_>>(), [[1.0, 1.0]]);
        assert_eq!(PathFollower::default().remaining(pose(0.0, 0.0)).count(), 0);
    }

    #[test]
    fn straight_path_is_followed_at_max_speed_and_reached() {
        let p = DriveParams::default();
        let mut f = PathFollower::new(vec![[0.0, 0.0], [2.0, 0.0]]);
        let mut pose = Pose2 { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let cmd = f.command(pose, &p);
        assert_eq!(cmd.v_mps, 0.4);
        let mut steps = 0;
        while !f.arrived(pose, p.goal_tolerance_m) && steps < 1000 {
            let c = f.command(pose, &p);
            assert!(c.v_mps <= p.max_speed_mps && c.omega_radps.abs() <= p.max_turn_rate_radps);
            pose = integrate(pose, c, 0.1);
            steps += 1;
        }
        // 1.85 m at 0.4 m/s ≈ 4.6 s (the last few centimetres slower).
        assert!((45..=60).contains(&steps), "{steps}");
    }

    #[test]
    fn behind_goal_turns_in_place() {
        let p = DriveParams::default();
        let mut f = PathFollower::new(vec![[0.0, 0.0], [-2.0, 0.0]]);
        let c = f.command(Pose2 { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, &p);
        assert_eq!(c.v_mps, 0.0);
        assert_eq!(c.omega_radps.abs(), p.max_turn_rate_radps);
    }

    #[test]
    fn arc_integration_matches_the_circle() {
        // v = 1, ω = 1 for π/2 s: quarter circle of radius 1 from the origin heading +x.
        let q = integrate(Pose2 { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Twist { v_mps: 1.0, omega_radps: 1.0 }, std::f64::consts::FRAC_PI_2);
        assert!((q.x_m - 1.0).abs() < 1e-12 && (q.y_m - 1.0).abs() < 1e-12);
    }

    #[test]
    fn attitude_from_a_slope() {
        // z = 0.5·x: nose up when heading +x (pitch = −atan 0.5), level roll.
        let f = Heightfield::from_fn(GridGeometry::new(0.0, 0.0, 0.05, 100, 100), |x, _| 0.5 * x);
        let (_, r) = body_on_terrain(&f, Pose2 { x_m: 2.5, y_m: 2.5, yaw_rad: 0.0 }, 0.2);
        let (roll, pitch, _) = r.euler_angles();
        assert!((pitch + 0.5f64.atan()).abs() < 1e-9 && roll.abs() < 1e-9);
        // Heading +y on the same slope: the left side (−x) is lower → negative roll.
        let (_, r) = body_on_terrain(&f, Pose2 { x_m: 2.5, y_m: 2.5, yaw_rad: std::f64::consts::FRAC_PI_2 }, 0.2);
        let (roll, pitch, _) = r.euler_angles();
        assert!((roll + 0.5f64.atan()).abs() < 1e-9 && pitch.abs() < 1e-9);
    }
}
