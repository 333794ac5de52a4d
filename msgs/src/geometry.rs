//! `geometry_msgs`: points, poses, transforms, polygons.

use super::Header;
use serde::{Deserialize, Serialize};

/// `geometry_msgs/Point`, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}
super::ros_message!(Point, "geometry_msgs", "Point");

/// `geometry_msgs/Point32`, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point32 {
    pub x: f32,
    pub y: f32,
    pub z: f32,
}
super::ros_message!(Point32, "geometry_msgs", "Point32");

/// `geometry_msgs/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}
super::ros_message!(Vector3, "geometry_msgs", "Vector3");

/// `geometry_msgs/Quaternion` (x, y, z, w order on the wire).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}
super::ros_message!(Quaternion, "geometry_msgs", "Quaternion");

impl Default for Quaternion {
    /// The identity rotation (the ROS default is all zeros, which is not a rotation).
    fn default() -> Self {
        Self { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

impl Quaternion {
    /// Rotation by `yaw_rad` about +z.
    pub fn from_yaw(yaw_rad: f64) -> Self {
        let h = 0.5 * yaw_rad;
        Self { x: 0.0, y: 0.0, z: libm::sin(h), w: libm::cos(h) }
    }
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}
super::ros_message!(Pose, "geometry_msgs", "Pose");

/// `geometry_msgs/PoseStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    pub header: Header,
    pub pose: Pose,
}
super::ros_message!(PoseStamped, "geometry_msgs", "PoseStamped");

/// `geometry_msgs/PoseWithCovariance`: row-major 6×6 covariance over (x, y, z, rot x, rot y,
/// rot z).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    pub pose: Pose,
    #[serde(with = "super::fixed_array")]
    pub covariance: [f64; 36],
}
super::ros_message!(PoseWithCovariance, "geometry_msgs", "PoseWithCovariance");

impl Default for PoseWithCovariance {
    fn default() -> Self {
        Self { pose: Pose::default(), covariance: [0.0; 36] }
    }
}

/// `geometry_msgs/PoseWithCovarianceStamped` (AMCL's and RTAB-Map's `localization_pose`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    pub header: Header,
    pub pose: PoseWithCovariance,
}
super::ros_message!(PoseWithCovarianceStamped, "geometry_msgs", "PoseWithCovarianceStamped");

/// `geometry_msgs/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}
super::ros_message!(Transform, "geometry_msgs", "Transform");

/// `geometry_msgs/TransformStamped`: `header.frame_id` is the parent, `child_frame_id` the child;
/// the transform maps child coordinates into the parent frame (`parent_from_child`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}
super::ros_message!(TransformStamped, "geometry_msgs", "TransformStamped");

/// `geometry_msgs/Polygon`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Polygon {
    pub points: Vec<Point32>,
}
super::ros_message!(Polygon, "geometry_msgs", "Polygon");

/// `geometry_msgs/PolygonStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PolygonStamped {
    pub header: Header,
    pub polygon: Polygon,
}
super::ros_message!(PolygonStamped, "geometry_msgs", "PolygonStamped");
