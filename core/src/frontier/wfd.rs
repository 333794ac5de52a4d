//! Wavefront frontier detection (WFD; notes §3, paper §II-C).
//!
//! A flood fill (the paper's BFS; the order does not change the result) over free cells from the
//! robot's cell, 4-connected. With the planner's no-corner-cutting rule (a diagonal step needs
//! both orthogonal neighbours passable, see [`crate::path`]) every
//! diagonal move can be replaced by two orthogonal ones, so this is exactly the set of cells the
//! 8-connected planner reaches with `allow_unknown = false`. A reached cell is a *frontier cell*
//! when it has an unknown 4-neighbour inside the grid (the map's edge is not unknown space) and
//! its centre lies inside the exploration [`Boundary`] (the BFS itself ignores the boundary: the
//! robot may drive outside it to reach a frontier inside it).
//!
//! Flat arrays only: one `u8` state per cell and a stack of (column, row). O(N) time and memory for
//! N grid cells (the BFS touches only reachable cells; the state layer is allocated zeroed), plus
//! O(F log F) to sort the F frontier cells by index, plus O(F·V) for a boundary of V vertices.

use super::cluster::{FRONTIER, REACHED, UNREACHED, cluster_frontier};
use super::{Boundary, FrontierCluster, FrontierError};
use crate::grid::{Cell, CellClass, GridGeometry, OccupancyGrid};
use crate::params::FrontierParams;

/// Whether flat cell `i`'s centre lies inside `boundary` (no boundary: everywhere).
#[inline]
fn inside(g: &GridGeometry, boundary: Option<&Boundary>, i: usize) -> bool {
    boundary.is_none_or(|b| {
        let (x_m, y_m) = g.center_of(g.cell_at(i));
        b.contains(x_m, y_m)
    })
}

/// Rejects parameters clustering cannot use.
fn check(params: &FrontierParams) -> Result<(), FrontierError> {
    if params.max_cluster_cells == 0 {
        return Err(FrontierError::ZeroMaxClusterCells);
    }
    Ok(())
}

/// The BFS: fills `state` (every reachable free cell `REACHED` or `FRONTIER`, the rest
/// `UNREACHED`; its storage is reused) and returns the frontier cells' flat indices in
/// increasing order.
pub(super) fn wavefront(
    grid: &OccupancyGrid,
    robot: Cell,
    boundary: Option<&Boundary>,
    state: &mut Vec<u8>,
) -> Result<Vec<usize>, FrontierError> {
    let g = grid.geometry;
    if grid.data.len() != g.len() {
        return Err(FrontierError::GridSizeMismatch { data_len: grid.data.len(), cells: g.len() });
    }
    let start = g.index(robot).ok_or(FrontierError::RobotOutsideMap(robot))?;
    if CellClass::of(grid.data[start]) != CellClass::Free {
        return Err(FrontierError::RobotNotFree(robot));
    }
    let (w, h) = (g.width, g.height);
    state.clear();
    state.resize(g.len(), UNREACHED);
    // The reached set does not depend on the visiting order, so a stack will do; cells carry
    // their column and row, so no division is needed to find the map's edges.
    let mut stack = vec![(start % w, start / w)];
    let mut frontier = Vec::new();
    state[start] = REACHED;
    while let Some((c, r)) = stack.pop() {
        let i = r * w + c;
        let mut touches_unknown = false;
        let mut visit = |cc: usize, rr: usize| {
            let j = rr * w + cc;
            match CellClass::of(grid.data[j]) {
                CellClass::Free => {
                    if state[j] == UNREACHED {
                        state[j] = REACHED;
                        stack.push((cc, rr));
                    }
                }
                CellClass::Unknown => touches_unknown = true,
                CellClass::Lethal => {}
            }
        };
        if c > 0 {
            visit(c - 1, r);
        }
        if c + 1 < w {
            visit(c + 1, r);
        }
        if r > 0 {
            visit(c, r - 1);
        }
        if r + 1 < h {
            visit(c, r + 1);
        }
        if touches_unknown && inside(&g, boundary, i) {
            state[i] = FRONTIER;
            frontier.push(i);
        }
    }
    frontier.sort_unstable();
    Ok(frontier)
}

/// The reachable frontier cells (step 1 of `detect_frontiers`), in increasing flat index
/// (row-major from the bottom-left). Errors as `detect_frontiers`.
pub fn frontier_cells(grid: &OccupancyGrid, robot: Cell, boundary: Option<&Boundary>) -> Result<Vec<Cell>, FrontierError> {
    let frontier = wavefront(grid, robot, boundary, &mut Vec::new())?;
    Ok(frontier.into_iter().map(|i| grid.geometry.cell_at(i)).collect())
}

#[cfg(test)]
/// WFD: BFS over passable cells (4-connected, which is exactly the reachable set of the
/// 8-connected no-corner-cutting planner in [`crate::path`]) from `robot`; frontier cells = free
/// cells with an unknown 4-neighbour, inside `boundary` (cell centre); then linked 8-connected,
/// ordered along each chain, split into nearly equal clusters of at most `max_cluster_cells`,
/// clusters under `min_cluster_cells` dropped (see [`super::cluster`]).
///
/// `grid` is the thresholded, inflated occupancy grid. Output order is deterministic: chains by
/// their smallest flat index, then the pieces of a chain in chain order.
///
/// Errors: the robot's cell is outside the map or not free; `grid.data` does not match its
/// geometry; `params.max_cluster_cells == 0`.
pub(crate) fn detect_frontiers(
    grid: &OccupancyGrid,
    robot: Cell,
    boundary: Option<&Boundary>,
    params: &FrontierParams,
) -> Result<Vec<FrontierCluster>, FrontierError> {
    detect_frontiers_with(grid, robot, boundary, params, &mut Vec::new())
}

/// [`detect_frontiers`] with the flood's state layer in `state`, whose storage is reused (a
/// planner that decides again and again keeps one).
pub(crate) fn detect_frontiers_with(
    grid: &OccupancyGrid,
    robot: Cell,
    boundary: Option<&Boundary>,
    params: &FrontierParams,
    state: &mut Vec<u8>,
) -> Result<Vec<FrontierCluster>, FrontierError> {
    check(params)?;
    let frontier = wavefront(grid, robot, boundary, state)?;
    Ok(cluster_frontier(&grid.geometry, state, &frontier, params))
}

/// Step 2 of `detect_frontiers_with` on frontier cells found by another flood of the same
/// reachable set (the planner's [`crate::path::dijkstra_with_frontiers`], which saves the WFD
/// flood): cells whose centre is outside `boundary` are dropped, the rest clustered exactly as
/// `detect_frontiers` does. `frontier`: flat indices in increasing order (others are ignored);
/// `state` is reused storage.
pub fn cluster_frontier_cells(
    geometry: &GridGeometry,
    frontier: &[usize],
    boundary: Option<&Boundary>,
    params: &FrontierParams,
    state: &mut Vec<u8>,
) -> Result<Vec<FrontierCluster>, FrontierError> {
    check(params)?;
    let frontier: Vec<usize> = frontier.iter().copied().filter(|&i| i < geometry.len() && inside(geometry, boundary, i)).collect();
    state.clear();
    state.resize(geometry.len(), UNREACHED);
    for &i in &frontier {
        state[i] = FRONTIER;
    }
    Ok(cluster_frontier(geometry, state, &frontier, params))
}
