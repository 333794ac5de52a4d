//! Shortest paths on the thresholded, inflated grid (notes §4): 8-connected moves, octile costs,
//! no corner cutting (a diagonal step needs both orthogonal neighbours passable), unknown cells
//! impassable unless allowed. [`astar`] answers one query; [`dijkstra`] answers every goal at
//! once with the same optimal lengths. `set_back` ends a path short of unknown ground.

mod astar;
mod dijkstra;
mod setback;

pub use astar::astar;
pub use dijkstra::DistanceField;
pub(crate) use dijkstra::{SearchBuffers, dijkstra_to_reusing};
pub use dijkstra::{dijkstra, dijkstra_with_frontiers};
pub use setback::GoalSetback;
pub use setback::known_around;
pub(crate) use setback::set_back;

use crate::grid::{Cell, GridGeometry, LETHAL_THRESHOLD, OccupancyGrid};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why no path could be planned.
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
pub enum PathError {
    /// The start cell is outside the grid.
    #[error("start is outside the map")]
    StartOutsideMap,
    /// The start cell is lethal (or unknown, when unknown cells are impassable).
    #[error("start is in a lethal or unknown cell")]
    StartLethal,
    /// The goal cell is outside the grid.
    #[error("goal is outside the map")]
    GoalOutsideMap,
    /// The goal cell is lethal (or unknown, when unknown cells are impassable).
    #[error("goal is in a lethal or unknown cell")]
    GoalLethal,
    /// No passable 8-connected route joins start and goal.
    #[error("no path to the goal")]
    NoPath,
}

/// A planned path: cells from start to goal and its length in metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Path {
    /// The cells, start and goal included, each an 8-neighbour of the next.
    pub cells: Vec<Cell>,
    /// Length of the polyline through the cell centres, metres.
    pub length_m: f64,
}

impl Path {
    /// Cell centres in world metres.
    pub fn points_m(&self, geometry: &GridGeometry) -> Vec<[f64; 2]> {
        self.cells
            .iter()
            .map(|&c| {
                let (x, y) = geometry.center_of(c);
                [x, y]
            })
            .collect()
    }
}

/// Whether a cell value can be driven through.
#[inline]
pub(crate) fn passable(value: i8, allow_unknown: bool) -> bool {
    // Branch-free form of "free, or unknown if allowed" (unknown is negative), so scans vectorise.
    if allow_unknown { value < LETHAL_THRESHOLD } else { (value as u8) < LETHAL_THRESHOLD as u8 }
}

/// The 8 moves as (dcol, drow, cost in cells), orthogonal first.
pub(crate) const MOVES: [(i32, i32, f64); 8] = [
    (1, 0, 1.0),
    (-1, 0, 1.0),
    (0, 1, 1.0),
    (0, -1, 1.0),
    (1, 1, std::f64::consts::SQRT_2),
    (-1, 1, std::f64::consts::SQRT_2),
    (1, -1, std::f64::consts::SQRT_2),
    (-1, -1, std::f64::consts::SQRT_2),
];

/// Flat index of the neighbour of `index` by `mv`, if the move is legal (inside, passable, and for
/// a diagonal, both orthogonal neighbours passable).
#[inline]
pub(crate) fn step(grid: &OccupancyGrid, index: usize, mv: (i32, i32, f64), allow_unknown: bool) -> Option<usize> {
    let w = grid.geometry.width as i32;
    let h = grid.geometry.height as i32;
    let (c, r) = ((index % grid.geometry.width) as i32, (index / grid.geometry.width) as i32);
    let (nc, nr) = (c + mv.0, r + mv.1);
    if nc < 0 || nr < 0 || nc >= w || nr >= h {
        return None;
    }
    let ok = |cc: i32, rr: i32| passable(grid.data[rr as usize * grid.geometry.width + cc as usize], allow_unknown);
    if !ok(nc, nr) {
        return None;
    }
    if mv.0 != 0 && mv.1 != 0 && !(ok(nc, r) && ok(c, nr)) {
        return None;
    }
    Some(nr as usize * grid.geometry.width + nc as usize)
}

/// Validates a start cell and returns its index.
pub(crate) fn check_start(grid: &OccupancyGrid, start: Cell, allow_unknown: bool) -> Result<usize, PathError> {
    let i = grid.geometry.index(start).ok_or(PathError::StartOutsideMap)?;
    if !passable(grid.data[i], allow_unknown) {
        return Err(PathError::StartLethal);
    }
    Ok(i)
}

/// Orders non-negative finite costs in a max-heap as a min-heap, ties by index.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) struct HeapEntry {
    pub key_bits: u64,
    pub index: usize,
}

impl HeapEntry {
    #[inline]
    pub fn new(key: f64, index: usize) -> Self {
        debug_assert!(key >= 0.0);
        Self { key_bits: key.to_bits(), index }
    }
}

impl Ord for HeapEntry {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        other.key_bits.cmp(&self.key_bits).then_with(|| other.index.cmp(&self.index))
    }
}

impl PartialOrd for HeapEntry {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

#[cfg(test)]
mod tests;
