//! `sensor_msgs`: PointCloud2 and PointField.

use super::Header;
use serde::{Deserialize, Serialize};

/// `sensor_msgs/msg/PointField`: the name, type and place of one field of a point record.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointField {
    /// Field name, e.g. `x`, `y`, `z`, `intensity`, `rgb`.
    pub name: String,
    /// Byte offset within the point record.
    pub offset: u32,
    /// One of the `PointField::*` datatype constants.
    pub datatype: u8,
    /// Number of elements (1 for x, y, z).
    pub count: u32,
}
super::ros_message!(PointField, "sensor_msgs", "PointField");

impl PointField {
    /// `datatype` `int8`, 1 byte.
    pub const INT8: u8 = 1;
    /// `datatype` `uint8`, 1 byte.
    pub const UINT8: u8 = 2;
    /// `datatype` `int16`, 2 bytes.
    pub const INT16: u8 = 3;
    /// `datatype` `uint16`, 2 bytes.
    pub const UINT16: u8 = 4;
    /// `datatype` `int32`, 4 bytes.
    pub const INT32: u8 = 5;
    /// `datatype` `uint32`, 4 bytes.
    pub const UINT32: u8 = 6;
    /// `datatype` `float32`, 4 bytes.
    pub const FLOAT32: u8 = 7;
    /// `datatype` `float64`, 8 bytes.
    pub const FLOAT64: u8 = 8;
}

/// `sensor_msgs/msg/PointCloud2`: a point cloud as packed binary point records described by
/// [`PointField`]s.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Acquisition time and the frame the points are in.
    pub header: Header,
    /// Rows of an organised cloud; 1 for an unordered cloud.
    pub height: u32,
    /// Points per row (the number of points of an unordered cloud).
    pub width: u32,
    /// Layout of one point record.
    pub fields: Vec<PointField>,
    /// Whether multi-byte values in `data` are big-endian.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The point records, `row_step` × `height` bytes.
    #[serde(with = "crate::octets")]
    pub data: Vec<u8>,
    /// True if no point is invalid (invalid points have NaN coordinates).
    pub is_dense: bool,
}
super::ros_message!(PointCloud2, "sensor_msgs", "PointCloud2");
