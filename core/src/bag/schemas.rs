//! The ROS 2 (Jazzy) definitions of the messages a bag written here holds, in rosbag2's
//! `ros2msg` schema encoding: the type's own fields, then each type it uses after a line of 80
//! `=` and `MSG: pkg/Type`. Readers that deserialise by schema (rosbags, Foxglove, `ros2 bag
//! play`) need them; this crate's reader decodes by type name and does not.

/// `(schema name, definition)` of a type.
pub type SchemaText = (&'static str, &'static str);

/// `nav_msgs/msg/OccupancyGrid`.
pub const OCCUPANCY_GRID: SchemaText = (
    "nav_msgs/msg/OccupancyGrid",
    r#"std_msgs/Header header
nav_msgs/MapMetaData info
int8[] data
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: nav_msgs/MapMetaData
builtin_interfaces/Time map_load_time
float32 resolution
uint32 width
uint32 height
geometry_msgs/Pose origin
================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#,
);

/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: SchemaText = (
    "tf2_msgs/msg/TFMessage",
    r#"geometry_msgs/TransformStamped[] transforms
================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
geometry_msgs/Transform transform
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Transform
geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#,
);

/// `sensor_msgs/msg/PointCloud2`.
pub const POINT_CLOUD2: SchemaText = (
    "sensor_msgs/msg/PointCloud2",
    r#"std_msgs/Header header
uint32 height
uint32 width
sensor_msgs/PointField[] fields
bool is_bigendian
uint32 point_step
uint32 row_step
uint8[] data
bool is_dense
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: sensor_msgs/PointField
uint8 INT8=1
uint8 UINT8=2
uint8 INT16=3
uint8 UINT16=4
uint8 INT32=5
uint8 UINT32=6
uint8 FLOAT32=7
uint8 FLOAT64=8
string name
uint32 offset
uint8 datatype
uint32 count
"#,
);

/// `geometry_msgs/msg/PoseWithCovarianceStamped`.
pub const POSE_WITH_COVARIANCE_STAMPED: SchemaText = (
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    r#"std_msgs/Header header
geometry_msgs/PoseWithCovariance pose
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/PoseWithCovariance
geometry_msgs/Pose pose
float64[36] covariance
================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#,
);

/// `std_msgs/msg/String`.
pub const STRING: SchemaText = (
    "std_msgs/msg/String",
    r#"string data
"#,
);
