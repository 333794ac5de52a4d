//! `nav_msgs`: OccupancyGrid and its MapMetaData.

use super::{Header, Pose, Time};
use serde::{Deserialize, Serialize};

/// `nav_msgs/msg/MapMetaData`: the size, resolution and placement of an occupancy grid.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    /// Time the map was loaded.
    pub map_load_time: Time,
    /// Cell size, metres.
    pub resolution: f32,
    /// Columns, cells along the origin's x axis.
    pub width: u32,
    /// Rows, cells along the origin's y axis.
    pub height: u32,
    /// Pose of cell (0, 0)'s lower-left corner in the map frame.
    pub origin: Pose,
}
super::ros_message!(MapMetaData, "nav_msgs", "MapMetaData");

/// `nav_msgs/msg/OccupancyGrid`: a 2D occupancy map, row-major from (0, 0), values 0–100 or −1
/// unknown.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Time of the map and its frame (`map` for a SLAM map).
    pub header: Header,
    /// Resolution, size and origin of the grid.
    pub info: MapMetaData,
    /// `width` × `height` cells, row-major from the origin cell (0, 0), x fastest: −1 unknown,
    /// 0..=100 occupancy probability in percent.
    #[serde(with = "crate::octets")]
    pub data: Vec<i8>,
}
super::ros_message!(OccupancyGrid, "nav_msgs", "OccupancyGrid");
