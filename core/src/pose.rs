//! Planar robot pose in the map frame (REP-103: yaw counter-clockwise from +x).

use serde::{Deserialize, Serialize};

/// `map_from_robot` in the plane: position in metres, yaw in radians.
///
/// # Examples
///
/// ```
/// use fitslam_core::pose::wrap_pi;
/// use fitslam_core::Pose2;
/// use std::f64::consts::PI;
///
/// let robot = Pose2::new(2.0, -1.0, 1.5 * PI); // facing −y
/// assert!(robot.is_finite());
/// assert!((wrap_pi(robot.yaw_rad) + 0.5 * PI).abs() < 1e-12); // the same heading in (−π, π]
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose2 {
    /// Position along the map's x axis, metres.
    pub x_m: f64,
    /// Position along the map's y axis, metres.
    pub y_m: f64,
    /// Heading, radians, counter-clockwise from the map's +x (not wrapped by `new`).
    pub yaw_rad: f64,
}

impl Pose2 {
    /// A pose from its position (metres) and heading (radians).
    pub const fn new(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        Self { x_m, y_m, yaw_rad }
    }

    /// Whether every field is finite.
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.yaw_rad.is_finite()
    }
}

/// Wraps an angle to [0, 2π).
pub fn wrap_tau(angle_rad: f64) -> f64 {
    let a = angle_rad.rem_euclid(std::f64::consts::TAU);
    if a >= std::f64::consts::TAU { 0.0 } else { a }
}

/// Wraps an angle to (−π, π].
pub fn wrap_pi(angle_rad: f64) -> f64 {
    let a = wrap_tau(angle_rad);
    if a > std::f64::consts::PI { a - std::f64::consts::TAU } else { a }
}
