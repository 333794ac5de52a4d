//! Grid geometry: the one type that maps between world metres and cells.
//!
//! Conventions (ROS `nav_msgs/OccupancyGrid`, REP-103): `origin` is the world position of the
//! lower-left corner of cell (0, 0); columns grow along +x, rows along +y; storage is row-major
//! with row 0 at the bottom, so `index = row * width + col`. All lookups that can fall outside
//! the grid return `Option`. O(1) per lookup.

use serde::{Deserialize, Serialize};

/// Largest number of cells a map may have (a traversability map, a loaded image), 2²³ (≈ 8.4 M:
/// 145 m × 145 m at 0.05 m). A cell of the traversability map costs ≈ 250 bytes (moments 104,
/// disc sums 96, layers), so this bounds a map at ≈ 2 GB; an absurd extent or resolution (two far-apart points of a cloud, a
/// mistyped resolution) is refused instead of exhausting memory. Larger areas need coarser cells.
pub(crate) const MAX_CELLS: usize = 1 << 23;

/// A cell address: column (x) and row (y). Signed so that neighbour arithmetic may step outside
/// the grid; [`GridGeometry::index`] says whether it is inside.
///
/// # Examples
///
/// ```
/// use fitslam_core::{Cell, GridGeometry};
///
/// let g = GridGeometry::new(0.0, 0.0, 0.5, 4, 3);
/// let c = Cell::new(3, 2); // the top-right cell
/// assert_eq!(g.index(c), Some(2 * 4 + 3));
/// // Neighbour arithmetic may step outside; the geometry says so.
/// assert_eq!(g.index(Cell::new(c.col + 1, c.row)), None);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Cell {
    /// Column, along +x from the grid's origin.
    pub col: i32,
    /// Row, along +y from the grid's origin (row 0 is the bottom).
    pub row: i32,
}

impl Cell {
    /// The cell at column `col`, row `row`.
    pub const fn new(col: i32, row: i32) -> Self {
        Self { col, row }
    }
}

/// Origin, resolution and size of a grid. Every layer of a map shares one geometry.
///
/// # Examples
///
/// ```
/// use fitslam_core::{Cell, GridGeometry};
///
/// // 4 × 3 cells of 0.5 m, lower-left corner at (−1, 0) in the map frame.
/// let g = GridGeometry::new(-1.0, 0.0, 0.5, 4, 3);
/// assert_eq!(g.len(), 12);
/// assert_eq!(g.bounds_m(), (-1.0, 0.0, 1.0, 1.5));
/// let c = g.cell_of(0.3, 1.2).ok_or("inside")?;
/// assert_eq!(c, Cell::new(2, 2));
/// assert_eq!(g.center_of(c), (0.25, 1.25));
/// assert_eq!(g.cell_of(1.2, 0.0), None); // east of the grid
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridGeometry {
    /// World x of the lower-left corner of cell (0, 0), metres.
    pub origin_x_m: f64,
    /// World y of the lower-left corner of cell (0, 0), metres.
    pub origin_y_m: f64,
    /// Edge length of a square cell, metres (> 0).
    pub resolution_m: f64,
    /// Number of columns.
    pub width: usize,
    /// Number of rows.
    pub height: usize,
}

impl GridGeometry {
    /// A geometry from its origin (lower-left corner of cell (0, 0), map frame, metres), cell
    /// edge (metres, > 0) and size in cells; not checked.
    pub fn new(origin_x_m: f64, origin_y_m: f64, resolution_m: f64, width: usize, height: usize) -> Self {
        Self { origin_x_m, origin_y_m, resolution_m, width, height }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    /// Whether the grid has no cell.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether `cell` lies inside the grid.
    #[inline]
    pub fn contains(&self, cell: Cell) -> bool {
        cell.col >= 0 && cell.row >= 0 && (cell.col as usize) < self.width && (cell.row as usize) < self.height
    }

    /// Flat row-major index of `cell`, if inside.
    #[inline]
    pub fn index(&self, cell: Cell) -> Option<usize> {
        self.contains(cell).then(|| cell.row as usize * self.width + cell.col as usize)
    }

    /// Cell of a flat index (no bounds check beyond debug).
    #[inline]
    pub fn cell_at(&self, index: usize) -> Cell {
        debug_assert!(index < self.len());
        Cell::new((index % self.width) as i32, (index / self.width) as i32)
    }

    /// The (possibly outside) cell containing world point (x, y); `None` for non-finite input.
    #[inline]
    pub fn cell_unchecked(&self, x_m: f64, y_m: f64) -> Option<Cell> {
        let c = floor_inline((x_m - self.origin_x_m) / self.resolution_m);
        let r = floor_inline((y_m - self.origin_y_m) / self.resolution_m);
        (c.is_finite() && r.is_finite() && c.abs() < i32::MAX as f64 && r.abs() < i32::MAX as f64).then(|| Cell::new(c as i32, r as i32))
    }

    /// The cell containing world point (x, y), if it is inside the grid.
    #[inline]
    pub fn cell_of(&self, x_m: f64, y_m: f64) -> Option<Cell> {
        self.cell_unchecked(x_m, y_m).filter(|c| self.contains(*c))
    }

    /// World position of the centre of `cell` (defined for outside cells too).
    #[inline]
    pub fn center_of(&self, cell: Cell) -> (f64, f64) {
        (self.origin_x_m + (cell.col as f64 + 0.5) * self.resolution_m, self.origin_y_m + (cell.row as f64 + 0.5) * self.resolution_m)
    }

    /// World extent `(min_x, min_y, max_x, max_y)` in metres.
    pub fn bounds_m(&self) -> (f64, f64, f64, f64) {
        (
            self.origin_x_m,
            self.origin_y_m,
            self.origin_x_m + self.width as f64 * self.resolution_m,
            self.origin_y_m + self.height as f64 * self.resolution_m,
        )
    }
}

/// ⌊v⌋, the same value as `f64::floor` (which the baseline x86-64 target compiles to a call into
/// the C library: a hot spot when every LiDAR point is binned) from two conversions: below 2⁵²
/// in magnitude the truncation toward zero, minus 1 where that rounded a negative up; above it
/// every float is an integer already; NaN and ±∞ pass through.
#[inline]
fn floor_inline(v: f64) -> f64 {
    if v.abs() < 4_503_599_627_370_496.0 {
        let t = v as i64 as f64;
        if t > v { t - 1.0 } else { t }
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    proptest::proptest! {
        /// The inline floor is `f64::floor` (as a value: −0.0 may come back as +0.0).
        #[test]
        fn floor_inline_is_floor(v in proptest::num::f64::ANY) {
            let (a, b) = (super::floor_inline(v), v.floor());
            proptest::prop_assert!(a == b || (a.is_nan() && b.is_nan()), "{v}: {a} vs {b}");
        }
    }

    use super::*;
    use proptest::prelude::*;

    #[test]
    fn lookups_follow_ros_convention() {
        let g = GridGeometry::new(-1.0, 2.0, 0.5, 4, 3);
        assert_eq!(g.cell_of(-1.0, 2.0), Some(Cell::new(0, 0)));
        assert_eq!(g.cell_of(0.99, 3.49), Some(Cell::new(3, 2)));
        assert_eq!(g.cell_of(1.0, 2.0), None);
        assert_eq!(g.cell_of(-1.01, 2.0), None);
        assert_eq!(g.cell_of(f64::NAN, 2.0), None);
        assert_eq!(g.index(Cell::new(1, 2)), Some(9));
        assert_eq!(g.cell_at(9), Cell::new(1, 2));
        assert_eq!(g.center_of(Cell::new(0, 0)), (-0.75, 2.25));
    }

    proptest! {
        #[test]
        fn cell_of_center_of_roundtrips(col in 0i32..500, row in 0i32..400, ox in -50.0f64..50.0, oy in -50.0f64..50.0, res in 0.01f64..1.0) {
            let g = GridGeometry::new(ox, oy, res, 500, 400);
            let c = Cell::new(col, row);
            let (x, y) = g.center_of(c);
            prop_assert_eq!(g.cell_of(x, y), Some(c));
            prop_assert_eq!(g.cell_at(g.index(c).unwrap()), c);
        }
    }
}
