//! Frontiers (notes §3, paper §II-C): where the known, traversable map meets the unknown.
//!
//! Pipeline, one algorithm per file:
//! 1. `wfd` — wavefront frontier detection: a BFS over free cells from the robot finds the
//!    reachable frontier cells (free, with an unknown 4-neighbour, centre inside the [`Boundary`]).
//! 2. `cluster` — frontier cells are linked 8-connected, each linked chain is ordered along
//!    itself and split into nearly equal pieces of at most `max_cluster_cells`; pieces under
//!    `min_cluster_cells` are dropped; the median cell of a piece is its candidate goal C_i.
//! 3. `blacklist` — goals matched within a radius (no path, failed, re-selected) and the end
//!    of mission: no non-blacklisted candidate left.
//! 4. `enclosed_within` — whether a robot with no frontier left is walled in by its map
//!    (trapped) rather than done.
//!
//! `detect_frontiers` runs 1 and 2. The grid it takes is the thresholded *and inflated*
//! occupancy grid (notes §2): inflated lethal cells are not free, so candidates keep the robot's
//! footprint off obstacles.

mod blacklist;
mod boundary;
mod cluster;
mod enclosure;
mod wfd;

pub use blacklist::{Blacklist, BlacklistReason};

pub use blacklist::BlacklistEntry;

pub use boundary::Boundary;
pub(crate) use enclosure::{enclosed_within, recovery_radius_m};
pub(crate) use wfd::detect_frontiers_with;
pub use wfd::{cluster_frontier_cells, frontier_cells};

use crate::grid::Cell;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why frontiers could not be detected.
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
pub enum FrontierError {
    /// The robot's cell (given) is outside the grid.
    #[error("robot cell ({}, {}) is outside the map", .0.col, .0.row)]
    RobotOutsideMap(Cell),
    /// The robot's cell (given) is not free, so the search has nowhere to start.
    #[error("robot cell ({}, {}) is not free (lethal, inflated or unknown)", .0.col, .0.row)]
    RobotNotFree(Cell),
    /// The grid's data and geometry disagree.
    #[error("grid has {data_len} values but its geometry has {cells} cells")]
    GridSizeMismatch {
        /// Values in the grid's data.
        data_len: usize,
        /// Cells its geometry has.
        cells: usize,
    },
    /// [`crate::params::FrontierParams::max_cluster_cells`] is 0.
    #[error("frontier.max_cluster_cells must be ≥ 1")]
    ZeroMaxClusterCells,
}

/// One cluster of frontier cells and its candidate goal C_i.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrontierCluster {
    /// The cluster's cells, ordered along the frontier chain (see `cluster`).
    pub cells: Vec<Cell>,
    /// The candidate goal C_i: the median cell `cells[cells.len() / 2]`.
    pub candidate: Cell,
}

impl FrontierCluster {
    /// A cluster from cells already ordered along the chain; `None` if `cells` is empty.
    pub(crate) fn from_ordered_cells(cells: Vec<Cell>) -> Option<Self> {
        let candidate = *cells.get(cells.len() / 2)?;
        Some(Self { cells, candidate })
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether the cluster has no cell.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    #[cfg(test)]
    /// World position (metres) of the candidate's cell centre.
    pub(crate) fn candidate_m(&self, geometry: &crate::grid::GridGeometry) -> [f64; 2] {
        let (x, y) = geometry.center_of(self.candidate);
        [x, y]
    }
}

#[cfg(test)]
mod tests;
