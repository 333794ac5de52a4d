//! A* on the occupancy grid (notes §4): 8-connected, octile heuristic (admissible and consistent
//! for these move costs, so the first pop of the goal is optimal). O(n log n) in the cells
//! expanded.

use super::{HeapEntry, MOVES, Path, PathError, check_start, passable, step};
use crate::grid::{Cell, OccupancyGrid};
use std::collections::BinaryHeap;

/// Shortest path from `start` to `goal`, or why there is none.
pub fn astar(grid: &OccupancyGrid, start: Cell, goal: Cell, allow_unknown: bool) -> Result<Path, PathError> {
    let g = grid.geometry;
    let s = check_start(grid, start, allow_unknown)?;
    let t = g.index(goal).ok_or(PathError::GoalOutsideMap)?;
    if !passable(grid.data[t], allow_unknown) {
        return Err(PathError::GoalLethal);
    }
    let octile = |i: usize| {
        let dc = ((i % g.width) as i64 - goal.col as i64).unsigned_abs() as f64;
        let dr = ((i / g.width) as i64 - goal.row as i64).unsigned_abs() as f64;
        let (lo, hi) = if dc < dr { (dc, dr) } else { (dr, dc) };
        hi - lo + std::f64::consts::SQRT_2 * lo
    };
    let mut cost = vec![f64::INFINITY; g.len()];
    let mut parent = vec![u32::MAX; g.len()];
    let mut closed = vec![false; g.len()];
    let mut heap = BinaryHeap::new();
    cost[s] = 0.0;
    heap.push(HeapEntry::new(octile(s), s));
    while let Some(HeapEntry { index: i, .. }) = heap.pop() {
        if closed[i] {
            continue;
        }
        closed[i] = true;
        if i == t {
            let mut cells = vec![g.cell_at(t)];
            let mut k = t;
            while k != s {
                k = parent[k] as usize;
                cells.push(g.cell_at(k));
            }
            cells.reverse();
            return Ok(Path { cells, length_m: cost[t] * g.resolution_m });
        }
        for mv in MOVES {
            if let Some(j) = step(grid, i, mv, allow_unknown) {
                let c = cost[i] + mv.2;
                if c < cost[j] {
                    cost[j] = c;
                    parent[j] = i as u32;
                    heap.push(HeapEntry::new(c + octile(j), j));
                }
            }
        }
    }
    Err(PathError::NoPath)
}
