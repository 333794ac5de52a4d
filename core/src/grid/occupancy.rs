//! The ROS `nav_msgs/OccupancyGrid` convention: 0 free, 100 lethal, −1 unknown (values in
//! between are occupancy probabilities in percent; at or above [`LETHAL_THRESHOLD`] is lethal).

use super::{Grid, GridGeometry};
use crate::math;

/// A traversable (free) cell.
pub const FREE: i8 = 0;
/// An untraversable (lethal) cell.
pub const LETHAL: i8 = 100;
/// A cell never observed.
pub const UNKNOWN: i8 = -1;
/// Values at or above this are lethal; non-negative values below it are free.
pub(crate) const LETHAL_THRESHOLD: i8 = 50;

/// An occupancy layer in the ROS convention.
///
/// # Examples
///
/// ```
/// use fitslam_core::grid::{inflate_lethal, CellClass, FREE, LETHAL, UNKNOWN};
/// use fitslam_core::{Cell, GridGeometry, OccupancyGrid};
///
/// let mut map = OccupancyGrid::filled(GridGeometry::new(0.0, 0.0, 0.1, 5, 5), FREE);
/// *map.get_mut(Cell::new(2, 2)).ok_or("inside")? = LETHAL;
/// *map.get_mut(Cell::new(0, 0)).ok_or("inside")? = UNKNOWN;
/// assert_eq!(CellClass::of(map.data[0]), CellClass::Unknown);
///
/// // Inflating by a 0.15 m robot radius makes the lethal cell's neighbours lethal too.
/// let inflated = inflate_lethal(&map, 0.15);
/// assert_eq!(inflated.get(Cell::new(3, 3)).map(|&v| CellClass::of(v)), Some(CellClass::Lethal));
/// assert_eq!(inflated.get(Cell::new(4, 4)).map(|&v| CellClass::of(v)), Some(CellClass::Free));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub type OccupancyGrid = Grid<i8>;

/// The three classes a planner distinguishes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CellClass {
    /// Values 0 to 49: drivable.
    Free,
    /// Values 50 and above (100 by convention): an obstacle.
    Lethal,
    /// Negative values (−1 by convention): not observed.
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

/// Sets every cell whose centre lies within `radius_m` of (`x_m`, `y_m`) to `value`; returns how
/// many changed. Used to clear a robot's footprint — the ground it stands on is traversable, as
/// costmaps' footprint clearing assumes. O(radius² / resolution²).
pub fn fill_disc(grid: &mut OccupancyGrid, x_m: f64, y_m: f64, radius_m: f64, value: i8) -> usize {
    let mut changed = 0;
    for (i, _) in cells_in_disc(&grid.geometry, x_m, y_m, radius_m) {
        if grid.data[i] != value {
            grid.data[i] = value;
            changed += 1;
        }
    }
    changed
}

/// The flat indices of the grid cells whose centre lies within `radius_m` of (`x_m`, `y_m`), each
/// with that distance in metres, row by row. None for a negative or NaN radius or a non-finite
/// centre. O(radius² / resolution²).
pub(crate) fn cells_in_disc(g: &GridGeometry, x_m: f64, y_m: f64, radius_m: f64) -> impl Iterator<Item = (usize, f64)> + '_ {
    let valid = radius_m >= 0.0 && x_m.is_finite() && y_m.is_finite() && !g.is_empty();
    // The cell range covering the disc, clipped to the grid (in f64: no overflow far away).
    let span = |lo_m: f64, origin_m: f64, n: usize| ((lo_m - origin_m) / g.resolution_m).floor().clamp(0.0, n as f64) as usize;
    let (cols, rows) = if valid {
        let (c0, c1) = (span(x_m - radius_m, g.origin_x_m, g.width), span(x_m + radius_m, g.origin_x_m, g.width - 1));
        let (r0, r1) = (span(y_m - radius_m, g.origin_y_m, g.height), span(y_m + radius_m, g.origin_y_m, g.height - 1));
        (c0..c1 + 1, r0..r1.min(g.height - 1) + 1)
    } else {
        (0..0, 0..0)
    };
    rows.flat_map(move |row| cols.clone().map(move |col| (col, row))).filter_map(move |(col, row)| {
        let (cx, cy) = g.center_of(super::Cell::new(col as i32, row as i32));
        let d = math::hypot(cx - x_m, cy - y_m);
        (d <= radius_m).then_some((row * g.width + col, d))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;

    #[test]
    fn fill_disc_sets_the_cells_whose_centre_is_within_the_radius() {
        // 1 m cells, centres at (c + ½, r + ½). A disc of radius 1 m around (2, 2) holds the four
        // centres (1.5|2.5, 1.5|2.5), each √0.5 ≈ 0.71 m away; (0.5, 2.5) is 1.58 m away.
        let mut grid = Grid::filled(GridGeometry::new(0.0, 0.0, 1.0, 4, 4), LETHAL);
        assert_eq!(fill_disc(&mut grid, 2.0, 2.0, 1.0, FREE), 4);
        let free: Vec<usize> = grid.data.iter().enumerate().filter(|(_, v)| **v == FREE).map(|(i, _)| i).collect();
        assert_eq!(free, vec![5, 6, 9, 10]);
        assert_eq!(fill_disc(&mut grid, 2.0, 2.0, 1.0, FREE), 0, "already free");
        // Partly outside the map, or a non-finite centre: no panic.
        assert_eq!(fill_disc(&mut grid, -0.2, -0.2, 1.0, UNKNOWN), 1); // (0.5, 0.5) is 0.99 m away
        assert_eq!(fill_disc(&mut grid, 1e12, 0.0, 1e13, FREE), 12); // every other cell
        assert_eq!(fill_disc(&mut grid, -1e300, 0.0, 1.0, FREE), 0);
        assert_eq!(fill_disc(&mut grid, f64::NAN, 0.0, 1.0, FREE), 0);
    }
}
