//! `geometry_msgs`: points, poses, transforms, polygons.

use super::Header;
use serde::{Deserialize, Serialize};

/// `geometry_msgs/msg/Point`: a position in space, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// Along the frame's x axis, metres.
    pub x: f64,
    /// Along the frame's y axis, metres.
    pub y: f64,
    /// Along the frame's z axis, metres.
    pub z: f64,
}
super::ros_message!(Point, "geometry_msgs", "Point");

/// `geometry_msgs/msg/Point32`: a position in space in single precision, metres (the vertex
/// type of [`Polygon`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point32 {
    /// Along the frame's x axis, metres.
    pub x: f32,
    /// Along the frame's y axis, metres.
    pub y: f32,
    /// Along the frame's z axis, metres.
    pub z: f32,
}
super::ros_message!(Point32, "geometry_msgs", "Point32");

/// `geometry_msgs/msg/Vector3`: a free vector; its unit is the using field's (metres in
/// [`Transform::translation`] and `Marker::scale`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// Component along the frame's x axis.
    pub x: f64,
    /// Component along the frame's y axis.
    pub y: f64,
    /// Component along the frame's z axis.
    pub z: f64,
}
super::ros_message!(Vector3, "geometry_msgs", "Vector3");

/// `geometry_msgs/msg/Quaternion`: an orientation as a unit quaternion (x, y, z, w order on
/// the wire).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// Vector part, x component (`sin(θ/2)·axis.x` for a rotation by θ about `axis`).
    pub x: f64,
    /// Vector part, y component.
    pub y: f64,
    /// Vector part, z component (`sin(yaw/2)` for a pure yaw).
    pub z: f64,
    /// Scalar part, `cos(θ/2)`.
    pub w: f64,
}
super::ros_message!(Quaternion, "geometry_msgs", "Quaternion");

impl Default for Quaternion {
    /// The identity rotation, as `geometry_msgs/msg/Quaternion` declares it (`float64 w 1`).
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

/// `geometry_msgs/msg/Pose`: a position and an orientation in some frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Origin of the posed body in the frame, metres.
    pub position: Point,
    /// Rotation of the posed body relative to the frame's axes.
    pub orientation: Quaternion,
}
super::ros_message!(Pose, "geometry_msgs", "Pose");

/// `geometry_msgs/msg/PoseStamped`: a pose with its time and frame (goals, robot poses).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Time of the pose and the frame it is expressed in.
    pub header: Header,
    /// The pose, in `header.frame_id`.
    pub pose: Pose,
}
super::ros_message!(PoseStamped, "geometry_msgs", "PoseStamped");

/// `geometry_msgs/msg/PoseWithCovariance`: a pose estimate and its uncertainty, a row-major 6×6
/// covariance over (x, y, z, rot x, rot y, rot z).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The estimated pose.
    pub pose: Pose,
    /// Row-major 6×6 covariance of (x, y, z, rotation about fixed x, y, z): m², rad² and m·rad.
    #[serde(with = "super::fixed_array")]
    pub covariance: [f64; 36],
}
super::ros_message!(PoseWithCovariance, "geometry_msgs", "PoseWithCovariance");

impl Default for PoseWithCovariance {
    /// The default pose with an all-zero covariance.
    fn default() -> Self {
        Self { pose: Pose::default(), covariance: [0.0; 36] }
    }
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped`: a pose estimate with its uncertainty, time
/// and frame (AMCL's `amcl_pose`, RTAB-Map's `localization_pose`, `initialpose`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    /// Time of the estimate and the frame it is expressed in.
    pub header: Header,
    /// The estimate, in `header.frame_id`.
    pub pose: PoseWithCovariance,
}
super::ros_message!(PoseWithCovarianceStamped, "geometry_msgs", "PoseWithCovarianceStamped");

/// `geometry_msgs/msg/Transform`: a rigid transform between two frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// The child frame's origin in the parent frame, metres.
    pub translation: Vector3,
    /// The child frame's orientation in the parent frame.
    pub rotation: Quaternion,
}
super::ros_message!(Transform, "geometry_msgs", "Transform");

/// `geometry_msgs/msg/TransformStamped`: `header.frame_id` is the parent, `child_frame_id` the child;
/// the transform maps child coordinates into the parent frame (`parent_from_child`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Time of the transform and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child frame's pose in the parent frame.
    pub transform: Transform,
}
super::ros_message!(TransformStamped, "geometry_msgs", "TransformStamped");

/// `geometry_msgs/msg/Polygon`: a closed polygon (footprints, boundaries).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Polygon {
    /// Vertices in order, metres; the last connects back to the first.
    pub points: Vec<Point32>,
}
super::ros_message!(Polygon, "geometry_msgs", "Polygon");

/// `geometry_msgs/msg/PolygonStamped`: a polygon with its time and frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PolygonStamped {
    /// Time of the polygon and the frame its vertices are in.
    pub header: Header,
    /// The polygon, in `header.frame_id`.
    pub polygon: Polygon,
}
super::ros_message!(PolygonStamped, "geometry_msgs", "PolygonStamped");
