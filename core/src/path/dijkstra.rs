//! One Dijkstra from the robot to every cell (notes §4: the allowed optimisation that gives every
//! candidate's ρ_i at once, with the same optimum as A*).
//!
//! Dial-style bucket queue, exact for these costs: edge costs are 1 or √2 (in cells), so with
//! buckets one cell wide (bucket k holds costs in [k, k+1)) a node settled from bucket k can only
//! relax others into buckets k+1 or k+2 — never improve a node of its own bucket — so a bucket's
//! nodes may be settled in any order and three rotating buckets suffice. Passability lives in a
//! padded byte layer (a border of impassable cells), so the inner loop has no bounds checks.
//! O(n) in the reachable cells (each settled once, ≤ 8 relaxations).

use super::{check_start, Path, PathError};
use crate::grid::{Cell, GridGeometry, OccupancyGrid};

/// Distances (in cells) and parents from one start, over the whole grid.
#[derive(Clone, Debug)]
pub struct DistanceField {
    pub geometry: GridGeometry,
    pub start: Cell,
    /// Path cost from the start in cell units on the padded layout; infinite where unreachable.
    cost_cells: Vec<f64>,
    /// Parent (padded index) of each settled cell.
    parent: Vec<u32>,
}

impl DistanceField {
    /// Width of the padded layout.
    #[inline]
    fn padded_index(&self, cell: Cell) -> Option<usize> {
        self.geometry.index(cell)?;
        Some((cell.row as usize + 1) * (self.geometry.width + 2) + cell.col as usize + 1)
    }

    #[inline]
    fn cell_of_padded(&self, p: usize) -> Cell {
        let pw = self.geometry.width + 2;
        Cell::new((p % pw) as i32 - 1, (p / pw) as i32 - 1)
    }

    /// Path length from the start to `cell` in metres, if reachable.
    pub fn distance_m(&self, cell: Cell) -> Option<f64> {
        let c = self.cost_cells[self.padded_index(cell)?];
        c.is_finite().then(|| c * self.geometry.resolution_m)
    }

    /// Whether `cell` can be reached from the start.
    pub fn reachable(&self, cell: Cell) -> bool {
        self.distance_m(cell).is_some()
    }

    /// The shortest path from the start to `cell`, if reachable.
    pub fn path_to(&self, cell: Cell) -> Option<Path> {
        let length_m = self.distance_m(cell)?;
        let s = self.padded_index(self.start)?;
        let mut k = self.padded_index(cell)?;
        let mut cells = vec![cell];
        while k != s {
            k = self.parent[k] as usize;
            cells.push(self.cell_of_padded(k));
        }
        cells.reverse();
        Some(Path { cells, length_m })
    }
}

/// Runs Dijkstra from `start` over every passable cell (same moves as [`super::astar`]).
pub fn dijkstra(grid: &OccupancyGrid, start: Cell, allow_unknown: bool) -> Result<DistanceField, PathError> {
    let g = grid.geometry;
    check_start(grid, start, allow_unknown)?;
    let (w, h) = (g.width, g.height);
    let pw = w + 2;
    let n = pw * (h + 2);
    let mut ok = vec![false; n];
    for r in 0..h {
        let row = &grid.data[r * w..(r + 1) * w];
        let out = &mut ok[(r + 1) * pw + 1..(r + 1) * pw + 1 + w];
        for (o, &v) in out.iter_mut().zip(row) {
            *o = super::passable(v, allow_unknown);
        }
    }
    let mut cost = vec![f64::INFINITY; n];
    let mut parent = vec![u32::MAX; n];
    let mut settled = vec![false; n];
    let s = (start.row as usize + 1) * pw + start.col as usize + 1;
    let mut buckets: [Vec<u32>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    cost[s] = 0.0;
    buckets[0].push(s as u32);
    let pwi = pw as isize;
    let orth = [1isize, -1, pwi, -pwi];
    // (offset, one orthogonal, the other orthogonal): a diagonal needs both passable.
    let diag = [(pwi + 1, 1isize, pwi), (pwi - 1, -1, pwi), (-pwi + 1, 1, -pwi), (-pwi - 1, -1, -pwi)];
    let sqrt2 = std::f64::consts::SQRT_2;
    let (mut k, mut empty) = (0usize, 0);
    while empty < 3 {
        let b = k % 3;
        if buckets[b].is_empty() {
            empty += 1;
            k += 1;
            continue;
        }
        empty = 0;
        let mut bucket = std::mem::take(&mut buckets[b]);
        for &iu in &bucket {
            let i = iu as usize;
            if settled[i] || cost[i] as usize != k {
                continue;
            }
            settled[i] = true;
            let ci = cost[i];
            for &d in &orth {
                let j = (i as isize + d) as usize;
                let c = ci + 1.0;
                if ok[j] && c < cost[j] {
                    cost[j] = c;
                    parent[j] = iu;
                    buckets[c as usize % 3].push(j as u32);
                }
            }
            for &(d, dx, dy) in &diag {
                let j = (i as isize + d) as usize;
                let c = ci + sqrt2;
                if ok[j] && c < cost[j] && ok[(i as isize + dx) as usize] && ok[(i as isize + dy) as usize] {
                    cost[j] = c;
                    parent[j] = iu;
                    buckets[c as usize % 3].push(j as u32);
                }
            }
        }
        bucket.clear();
        buckets[b] = bucket;
        k += 1;
    }
    Ok(DistanceField { geometry: g, start, cost_cells: cost, parent })
}
