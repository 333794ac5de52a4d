//! # fitslam-msgs
//!
//! The ROS 2 vocabulary of fitslam, written once: every message the robot node, the bag reader
//! and writer and the simulator's recorder exchange, as plain serde structs with their fields in
//! `.msg` order (CDR is positional). Layouts are ROS 2 Jazzy's (Humble's are the same for every
//! type here except `nav2_msgs/NavigateToPose`'s result, see [`nav2`]). ros2-client ships none
//! of them. [`cdr`] reads and writes any of them as ROS 2 serialises it (XCDR1), with no code
//! per type.
//!
//! Pure and small (serde, thiserror, libm): it builds for `wasm32-unknown-unknown`. With the
//! feature `ros2` every type is also a `ros2_client::Message`, and `RosMessage::type_name`
//! names its DDS type (`geometry_msgs::msg::dds_::PoseStamped_`); the robot node turns it on,
//! the core and the studio never build DDS.
//!
//! | module | what |
//! |---|---|
//! | [`builtin`] | `builtin_interfaces`: Time, Duration |
//! | [`std_msgs`] | Header, String, ColorRGBA |
//! | [`geometry`] | points, poses (with covariance), transforms, polygons |
//! | [`nav`] | OccupancyGrid and its MapMetaData |
//! | [`sensor`] | PointCloud2 and PointField |
//! | [`tf2`] | TFMessage (`/tf`, `/tf_static`) |
//! | [`visualization`] | Marker, MarkerArray |
//! | [`nav2`] | the NavigateToPose action's goal, result and feedback |
//! | [`cdr`] | the CDR codec: [`cdr::to_vec`], [`cdr::from_bytes`], typed errors, never a panic |
//! | [`definitions`] | the `.msg` definitions of the messages bags hold, and a type's rosbag2 schema |
//! | [`octets`] | `uint8[]` / `int8[]` fields as one byte buffer (fast in CDR, numbers in JSON) |
//!
//! Conversions to and from the core's types (grids, points, poses, boundaries) live in
//! `fitslam_core::ros`, which depends on this crate.
//!
//! ```
//! use fitslam_msgs::{Header, Pose, PoseStamped, Quaternion, Time, cdr};
//!
//! let goal = PoseStamped {
//!     header: Header::new(Time::from_secs_f64(1.5), "map"),
//!     pose: Pose { orientation: Quaternion::from_yaw(0.5), ..Pose::default() },
//! };
//! let bytes = cdr::to_vec(&goal)?;
//! assert_eq!(&bytes[..4], &[0, 1, 0, 0]); // little-endian CDR encapsulation
//! assert_eq!(cdr::from_bytes::<PoseStamped>(&bytes)?, goal);
//! # Ok::<(), fitslam_msgs::cdr::CdrError>(())
//! ```

#![deny(missing_docs)]

pub mod builtin;
pub mod cdr;
pub mod definitions;
pub mod geometry;
pub mod nav;
pub mod nav2;
pub mod octets;
pub mod sensor;
pub mod std_msgs;
pub mod tf2;
pub mod visualization;

pub use builtin::{Duration, Time};
pub use geometry::{
    Point, Point32, Polygon, PolygonStamped, Pose, PoseStamped, PoseWithCovariance, PoseWithCovarianceStamped, Quaternion, Transform,
    TransformStamped, Vector3,
};
pub use nav::{MapMetaData, OccupancyGrid};
pub use nav2::{NavigateToPoseFeedback, NavigateToPoseGoal, NavigateToPoseResult};
pub use sensor::{PointCloud2, PointField};
pub use std_msgs::{ColorRGBA, Header, StringMsg};
pub use tf2::TFMessage;
pub use visualization::{Marker, MarkerArray};

/// A ROS 2 message with its package and type name.
pub trait RosMessage: serde::Serialize + serde::de::DeserializeOwned {
    /// ROS package, e.g. `geometry_msgs`.
    const PACKAGE: &'static str;
    /// Type name, e.g. `PoseStamped`.
    const NAME: &'static str;

    /// The name rosbag2 and `ros2 topic` give the type, `PACKAGE/msg/NAME`.
    fn ros_type() -> String {
        format!("{}/msg/{}", Self::PACKAGE, Self::NAME)
    }

    /// The type name ros2-client turns into `PACKAGE::msg::dds_::NAME_`.
    #[cfg(feature = "ros2")]
    fn type_name() -> ros2_client::MessageTypeName {
        ros2_client::MessageTypeName::new(Self::PACKAGE, Self::NAME)
    }
}

/// Implements [`RosMessage`] (and, with the feature `ros2`, `ros2_client::Message`).
macro_rules! ros_message {
    ($t:ty, $pkg:literal, $name:literal) => {
        #[cfg(feature = "ros2")]
        impl ros2_client::Message for $t {}
        impl $crate::RosMessage for $t {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
        }
    };
}
pub(crate) use ros_message;

/// Serde for fixed-size arrays longer than serde's built-in 32 (`float64[36]`): a CDR array has
/// no length prefix, which is what serde's tuple encoding gives.
pub(crate) mod fixed_array {
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserializer, Serializer};
    use std::fmt;

    pub fn serialize<S: Serializer, const N: usize>(a: &[f64; N], s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(N)?;
        for v in a {
            t.serialize_element(v)?;
        }
        t.end()
    }

    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for V<N> {
            type Value = [f64; N];
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "an array of {N} float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = [0.0; N];
                for (i, slot) in out.iter_mut().enumerate() {
                    *slot = seq.next_element()?.ok_or_else(|| A::Error::invalid_length(i, &self))?;
                }
                Ok(out)
            }
        }
        d.deserialize_tuple(N, V::<N>)
    }
}

#[cfg(test)]
mod tests;
