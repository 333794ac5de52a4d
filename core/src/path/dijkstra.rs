//! One Dijkstra from the robot to every cell (notes §4: the allowed optimisation that gives every
//! candidate's ρ_i at once, with the same optimum as A*). O(n log n) over the reachable cells.

use super::{check_start, step, HeapEntry, Path, PathError, MOVES};
use crate::grid::{Cell, GridGeometry, OccupancyGrid};
use std::collections::BinaryHeap;

/// Distances (in cells) and parents from one start, over the whole grid.
#[derive(Clone, Debug)]
pub struct DistanceField {
    pub geometry: GridGeometry,
    pub start: Cell,
    /// Path cost from the start in cell units; infinite where unreachable.
    cost_cells: Vec<f64>,
    parent: Vec<u32>,
}

impl DistanceField {
    /// Path length from the start to `cell` in metres, if reachable.
    pub fn distance_m(&self, cell: Cell) -> Option<f64> {
        let i = self.geometry.index(cell)?;
        let c = self.cost_cells[i];
        c.is_finite().then(|| c * self.geometry.resolution_m)
    }

    /// Whether `cell` can be reached from the start.
    pub fn reachable(&self, cell: Cell) -> bool {
        self.distance_m(cell).is_some()
    }

    /// The shortest path from the start to `cell`, if reachable.
    pub fn path_to(&self, cell: Cell) -> Option<Path> {
        let length_m = self.distance_m(cell)?;
        let g = self.geometry;
        let s = g.index(self.start)?;
        let mut k = g.index(cell)?;
        let mut cells = vec![cell];
        while k != s {
            k = self.parent[k] as usize;
            cells.push(g.cell_at(k));
        }
        cells.reverse();
        Some(Path { cells, length_m })
    }
}

/// Runs Dijkstra from `start` over every passable cell.
pub fn dijkstra(grid: &OccupancyGrid, start: Cell, allow_unknown: bool) -> Result<DistanceField, PathError> {
    let g = grid.geometry;
    let s = check_start(grid, start, allow_unknown)?;
    let mut cost = vec![f64::INFINITY; g.len()];
    let mut parent = vec![u32::MAX; g.len()];
    let mut heap = BinaryHeap::new();
    cost[s] = 0.0;
    heap.push(HeapEntry::new(0.0, s));
    while let Some(HeapEntry { key_bits, index: i }) = heap.pop() {
        if f64::from_bits(key_bits) > cost[i] {
            continue;
        }
        for mv in MOVES {
            if let Some(j) = step(grid, i, mv, allow_unknown) {
                let c = cost[i] + mv.2;
                if c < cost[j] {
                    cost[j] = c;
                    parent[j] = i as u32;
                    heap.push(HeapEntry::new(c, j));
                }
            }
        }
    }
    Ok(DistanceField { geometry: g, start, cost_cells: cost, parent })
}
