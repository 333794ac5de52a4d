//! `sensor_msgs`: PointCloud2 and PointField.

use super::Header;
use serde::{Deserialize, Serialize};

/// `sensor_msgs/PointField`: one field of a point record.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointField {
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
    pub const INT8: u8 = 1;
    pub const UINT8: u8 = 2;
    pub const INT16: u8 = 3;
    pub const UINT16: u8 = 4;
    pub const INT32: u8 = 5;
    pub const UINT32: u8 = 6;
    pub const FLOAT32: u8 = 7;
    pub const FLOAT64: u8 = 8;
}

/// `sensor_msgs/PointCloud2`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub fields: Vec<PointField>,
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    #[serde(with = "crate::octets")]
    pub data: Vec<u8>,
    pub is_dense: bool,
}
super::ros_message!(PointCloud2, "sensor_msgs", "PointCloud2");
