//! ROS 2 message types used by the node, as serde structs in `.msg` field order (CDR is
//! positional). ros2-client ships none of them. Layouts are ROS 2 Jazzy's (Humble's are the
//! same for every type here except `nav2_msgs/NavigateToPose`'s result, see [`nav2`]).
//!
//! Every type implements [`RosMessage`], which names its DDS type
//! (`geometry_msgs::msg::dds_::PoseStamped_`).

pub mod builtin;
pub mod geometry;
pub mod nav;
pub mod nav2;
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
pub trait RosMessage: ros2_client::Message {
    /// ROS package, e.g. `geometry_msgs`.
    const PACKAGE: &'static str;
    /// Type name, e.g. `PoseStamped`.
    const NAME: &'static str;

    /// The type name ros2-client turns into `PACKAGE::msg::dds_::NAME_`.
    fn type_name() -> ros2_client::MessageTypeName {
        ros2_client::MessageTypeName::new(Self::PACKAGE, Self::NAME)
    }
}

macro_rules! ros_message {
    ($t:ty, $pkg:literal, $name:literal) => {
        impl ros2_client::Message for $t {}
        impl $crate::msgs::RosMessage for $t {
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
