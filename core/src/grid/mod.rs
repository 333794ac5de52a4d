//! Layered grid maps: one [`GridGeometry`], many flat row-major layers ([`Grid<T>`]).

mod geometry;
mod inflate;
mod occupancy;

pub use geometry::{Cell, GridGeometry};

pub(crate) use geometry::MAX_CELLS;
pub use inflate::inflate_lethal;
pub(crate) use inflate::{free_traversed, inflate_lethal_into};
pub use occupancy::{CellClass, FREE, LETHAL, OccupancyGrid, UNKNOWN, fill_disc};
pub(crate) use occupancy::{LETHAL_THRESHOLD, cells_in_disc};

use serde::{Deserialize, Serialize};

/// One layer: a value per cell on flat row-major storage (`data.len() == geometry.len()`).
///
/// # Examples
///
/// ```
/// use fitslam_core::{Cell, Grid, GridGeometry};
///
/// let g = GridGeometry::new(0.0, 0.0, 0.1, 3, 2);
/// let mut height_m = Grid::filled(g, 0.0f32);
/// *height_m.get_mut(Cell::new(1, 1)).ok_or("inside")? = 0.4;
/// assert_eq!(height_m.data[1 * 3 + 1], 0.4); // row-major from the bottom row
/// assert_eq!(height_m.at_world(0.15, 0.15), Some(&0.4));
/// assert_eq!(height_m.get(Cell::new(3, 0)), None);
/// assert!(Grid::from_vec(g, vec![0u8; 5]).is_none()); // 5 values for 6 cells
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid<T> {
    /// Where the cells are.
    pub geometry: GridGeometry,
    /// One value per cell, row-major from the bottom row (`row * width + col`).
    pub data: Vec<T>,
}

impl<T: Clone> Grid<T> {
    /// A layer filled with `value`.
    pub fn filled(geometry: GridGeometry, value: T) -> Self {
        Self { data: vec![value; geometry.len()], geometry }
    }
}

impl<T> Grid<T> {
    /// Wraps `data`; `None` if its length does not match the geometry.
    pub fn from_vec(geometry: GridGeometry, data: Vec<T>) -> Option<Self> {
        (data.len() == geometry.len()).then_some(Self { geometry, data })
    }

    /// The value at `cell`, if inside.
    #[inline]
    pub fn get(&self, cell: Cell) -> Option<&T> {
        self.geometry.index(cell).map(|i| &self.data[i])
    }

    /// Mutable value at `cell`, if inside.
    #[inline]
    pub fn get_mut(&mut self, cell: Cell) -> Option<&mut T> {
        self.geometry.index(cell).map(|i| &mut self.data[i])
    }

    /// The value under world point (x, y), if inside.
    #[inline]
    pub fn at_world(&self, x_m: f64, y_m: f64) -> Option<&T> {
        self.geometry.cell_of(x_m, y_m).and_then(|c| self.get(c))
    }
}
