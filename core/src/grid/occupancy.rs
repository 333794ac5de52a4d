//! The ROS `nav_msgs/OccupancyGrid` convention: 0 free, 100 lethal, −1 unknown (values in
//! between are occupancy probabilities in percent; at or above [`LETHAL_THRESHOLD`] is lethal).

use super::Grid;

/// A traversable (free) cell.
pub const FREE: i8 = 0;
/// An untraversable (lethal) cell.
pub const LETHAL: i8 = 100;
/// A cell never observed.
pub const UNKNOWN: i8 = -1;
/// Values at or above this are lethal; non-negative values below it are free.
pub const LETHAL_THRESHOLD: i8 = 50;

/// An occupancy layer in the ROS convention.
pub type OccupancyGrid = Grid<i8>;

/// The three classes a planner distinguishes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CellClass {
    Free,
    Lethal,
    Unknown,
}

impl CellClass {
    /// Class of an OccupancyGrid value.
    #[inline]
    pub fn of(value: i8) -> Self {
        if value < 0 {
            CellClass::Unknown
        } else if value >= LETHAL_THRESHOLD {
            CellClass::Lethal
        } else {
            CellClass::Free
        }
    }
}
