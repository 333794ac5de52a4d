//! `nav_msgs`: OccupancyGrid and its MapMetaData.

use super::{Header, Pose, Time};
use serde::{Deserialize, Serialize};

/// `nav_msgs/MapMetaData`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    pub map_load_time: Time,
    /// Cell size, metres.
    pub resolution: f32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Pose of cell (0, 0)'s lower-left corner in the map frame.
    pub origin: Pose,
}
super::ros_message!(MapMetaData, "nav_msgs", "MapMetaData");

/// `nav_msgs/OccupancyGrid`: row-major from (0, 0), values 0–100 or −1 unknown.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    pub header: Header,
    pub info: MapMetaData,
    #[serde(with = "crate::octets")]
    pub data: Vec<i8>,
}
super::ros_message!(OccupancyGrid, "nav_msgs", "OccupancyGrid");
