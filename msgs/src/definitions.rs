//! The ROS 2 (Jazzy) `.msg` definitions of the messages bags are written with, each once, and a
//! type's rosbag2 schema composed from them (`ros2msg` encoding): its own definition, then every
//! type it uses, depth first and each once, after a line of 80 `=` and `MSG: pkg/Type`, as
//! `ros2 bag record` writes it. Readers that deserialise by schema (rosbags, Foxglove, `ros2 bag
//! play`) need it; [`crate::cdr`] does not. A test checks each definition's fields against its
//! struct's.

use crate::RosMessage;

/// `(pkg/Type, definition)`.
const DEFINITIONS: &[(&str, &str)] = &[
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"),
    ("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"),
    ("std_msgs/String", "string data\n"),
    ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"),
    ("geometry_msgs/Pose", "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"),
    ("geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose pose\nfloat64[36] covariance\n"),
    ("geometry_msgs/PoseWithCovarianceStamped", "std_msgs/Header header\ngeometry_msgs/PoseWithCovariance pose\n"),
    ("geometry_msgs/Transform", "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"),
    ("geometry_msgs/TransformStamped", "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"),
    ("tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n"),
    (
        "nav_msgs/MapMetaData",
        "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\ngeometry_msgs/Pose origin\n",
    ),
    ("nav_msgs/OccupancyGrid", "std_msgs/Header header\nnav_msgs/MapMetaData info\nint8[] data\n"),
    (
        "sensor_msgs/PointField",
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\n\
         string name\nuint32 offset\nuint8 datatype\nuint32 count\n",
    ),
    (
        "sensor_msgs/PointCloud2",
        "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\n\
         uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
    ),
];

/// The `.msg` definition of `pkg/Type`, when this crate has it.
pub fn definition(pkg_type: &str) -> Option<&'static str> {
    DEFINITIONS.iter().find(|(name, _)| *name == pkg_type).map(|(_, text)| *text)
}

/// The message types a definition uses, `pkg/Type`, in field order (constants and primitives
/// left out).
fn nested(definition: &str) -> impl Iterator<Item = &str> {
    definition.lines().filter_map(|line| {
        let mut words = line.split_whitespace();
        let ty = words.next()?;
        let name = words.next()?;
        let ty = ty.split('[').next().unwrap_or(ty);
        (ty.contains('/') && !name.contains('=')).then_some(ty)
    })
}

/// The rosbag2 schema of `M`; `None` for a type without a definition here (or using one).
pub fn schema<M: RosMessage>() -> Option<String> {
    let own = format!("{}/{}", M::PACKAGE, M::NAME);
    let text = definition(&own)?;
    let mut out = text.to_owned();
    append_used(text, &mut vec![own.as_str()], &mut out)?;
    Some(out)
}

/// Appends the definition of every type `text` uses and `seen` does not hold, depth first.
fn append_used(text: &'static str, seen: &mut Vec<&str>, out: &mut String) -> Option<()> {
    for ty in nested(text) {
        if seen.contains(&ty) {
            continue;
        }
        seen.push(ty);
        let used = definition(ty)?;
        out.push_str(&format!("{}\nMSG: {ty}\n{used}", "=".repeat(80)));
        append_used(used, seen, out)?;
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::*;
    use serde::Serialize;

    /// The top-level keys of a JSON object, in the order written (default values hold no
    /// braces inside strings).
    fn keys_in_order(json: &str) -> Vec<String> {
        let (mut depth, mut keys, mut rest) = (0, Vec::new(), json);
        while let Some(c) = rest.chars().next() {
            match c {
                '{' | '[' => depth += 1,
                '}' | ']' => depth -= 1,
                '"' if depth == 1 => {
                    let end = rest[1..].find('"').unwrap() + 1;
                    if rest[end + 1..].starts_with(':') {
                        keys.push(rest[1..end].to_owned());
                    }
                    rest = &rest[end..];
                }
                _ => {}
            }
            rest = &rest[c.len_utf8()..];
        }
        keys
    }

    /// A definition's field names are its struct's, in order.
    fn fields_agree<M: RosMessage + Default + Serialize>() {
        let def = definition(&format!("{}/{}", M::PACKAGE, M::NAME)).unwrap();
        let from_def: Vec<&str> = def.lines().filter_map(|l| l.split_whitespace().nth(1)).filter(|n| !n.contains('=')).collect();
        let from_struct = keys_in_order(&serde_json::to_string(&M::default()).unwrap());
        assert_eq!(from_def, from_struct, "{}/{}", M::PACKAGE, M::NAME);
    }

    #[test]
    fn every_definition_matches_its_struct() {
        fields_agree::<Time>();
        fields_agree::<Header>();
        fields_agree::<StringMsg>();
        fields_agree::<Point>();
        fields_agree::<Vector3>();
        fields_agree::<Quaternion>();
        fields_agree::<Pose>();
        fields_agree::<PoseWithCovariance>();
        fields_agree::<PoseWithCovarianceStamped>();
        fields_agree::<Transform>();
        fields_agree::<TransformStamped>();
        fields_agree::<TFMessage>();
        fields_agree::<MapMetaData>();
        fields_agree::<OccupancyGrid>();
        fields_agree::<PointField>();
        fields_agree::<PointCloud2>();
        assert_eq!(DEFINITIONS.len(), 16);
    }

    #[test]
    fn schemas_list_every_type_used_once_depth_first() {
        let s = schema::<OccupancyGrid>().unwrap();
        let used: Vec<&str> = s.lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
        let expected = [
            "std_msgs/Header",
            "builtin_interfaces/Time",
            "nav_msgs/MapMetaData",
            "geometry_msgs/Pose",
            "geometry_msgs/Point",
            "geometry_msgs/Quaternion",
        ];
        assert_eq!(used, expected);
        assert!(s.starts_with("std_msgs/Header header\nnav_msgs/MapMetaData info\nint8[] data\n=====") && s.ends_with("float64 w\n"));
        assert_eq!(schema::<StringMsg>().unwrap(), "string data\n");
        let tf = schema::<TFMessage>().unwrap();
        let used: Vec<&str> = tf.lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
        let expected = [
            "geometry_msgs/TransformStamped",
            "std_msgs/Header",
            "builtin_interfaces/Time",
            "geometry_msgs/Transform",
            "geometry_msgs/Vector3",
            "geometry_msgs/Quaternion",
        ];
        assert_eq!(used, expected);
        assert_eq!(schema::<MarkerArray>(), None, "no definition here");
    }
}
