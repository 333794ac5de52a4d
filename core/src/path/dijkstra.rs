//! One Dijkstra from the robot to every candidate (notes §4: the allowed optimisation that gives
//! every candidate's ρ_i at once, with the same optimum as A*).
//!
//! Dial-style bucket queue, exact for these costs: edge costs are 1 or √2 (in cells), so with
//! buckets one cell wide (bucket k holds costs in [k, k+1)) a node settled from bucket k can only
//! relax others into buckets k+1 or k+2 — never improve a node of its own bucket — so a bucket's
//! nodes may be settled in any order and three rotating buckets suffice.
//!
//! Memory is what costs here, not arithmetic, so the search works on a **window**: the bounding
//! box of the passable cells (no path can leave it), padded with a border of impassable cells so
//! the inner loop has no bounds checks. Per window cell it keeps an f64 cost, one flag byte
//! (passable, settled, target) and one parent byte (the move that reached it): 10 bytes, not the
//! 4 million × 17 bytes a whole-grid layout with u32 parents would touch on a 2000 × 2000 map.
//! With targets ([`dijkstra_to`]) the search stops as soon as all of them are settled.
//!
//! O(n) in the cells settled (each once, ≤ 8 relaxations) plus O(grid) to find the window.

use super::{Path, PathError, check_start};
use crate::grid::{Cell, GridGeometry, OccupancyGrid};

const PASSABLE: u8 = 1;
const SETTLED: u8 = 2;
const TARGET: u8 = 4;
const NO_PARENT: u8 = u8::MAX;

/// The searched part of the grid: columns `col0..col0 + width`, rows `row0..row0 + height`, stored
/// with a one-cell border (padded width `width + 2`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Window {
    col0: usize,
    row0: usize,
    width: usize,
    height: usize,
}

impl Window {
    #[inline]
    fn padded_width(&self) -> usize {
        self.width + 2
    }

    /// Padded index of a grid cell inside the window.
    #[inline]
    fn index(&self, cell: Cell) -> Option<usize> {
        let (c, r) = (usize::try_from(cell.col).ok()?, usize::try_from(cell.row).ok()?);
        if c < self.col0 || r < self.row0 || c >= self.col0 + self.width || r >= self.row0 + self.height {
            return None;
        }
        Some((r - self.row0 + 1) * self.padded_width() + (c - self.col0 + 1))
    }

    #[inline]
    fn cell(&self, p: usize) -> Cell {
        let pw = self.padded_width();
        Cell::new((p % pw + self.col0) as i32 - 1, (p / pw + self.row0) as i32 - 1)
    }

    /// Padded-index offsets of the 8 moves: 4 orthogonal, then 4 diagonal.
    fn offsets(&self) -> [isize; 8] {
        let pw = self.padded_width() as isize;
        [1, -1, pw, -pw, pw + 1, pw - 1, -pw + 1, -pw - 1]
    }
}

/// Distances (in cells) and parents from one start.
#[derive(Clone, Debug)]
pub struct DistanceField {
    pub geometry: GridGeometry,
    pub start: Cell,
    window: Window,
    /// Path cost from the start in cell units (padded window layout); exact where settled.
    cost_cells: Vec<f64>,
    flags: Vec<u8>,
    /// Move (index into [`Window::offsets`]) by which each settled cell was reached.
    parent_move: Vec<u8>,
    /// Whether every reachable cell was settled (no early stop).
    complete: bool,
}

impl DistanceField {
    #[inline]
    fn settled_index(&self, cell: Cell) -> Option<usize> {
        self.geometry.index(cell)?;
        let p = self.window.index(cell)?;
        (self.flags[p] & SETTLED != 0).then_some(p)
    }

    /// Path length from the start to `cell` in metres, if it was reached. After an early stop
    /// ([`dijkstra_to`]) cells farther than the last target are not reached.
    pub fn distance_m(&self, cell: Cell) -> Option<f64> {
        self.settled_index(cell).map(|p| self.cost_cells[p] * self.geometry.resolution_m)
    }

    /// Whether `cell` was reached (see [`Self::distance_m`]).
    pub fn reachable(&self, cell: Cell) -> bool {
        self.settled_index(cell).is_some()
    }

    /// Whether the search settled every reachable cell (then "not reached" means unreachable).
    pub fn is_complete(&self) -> bool {
        self.complete
    }

    /// Number of cells settled.
    pub fn settled_count(&self) -> usize {
        self.flags.iter().filter(|&&f| f & SETTLED != 0).count()
    }

    /// The shortest path from the start to `cell`, if reached.
    pub fn path_to(&self, cell: Cell) -> Option<Path> {
        let mut k = self.settled_index(cell)?;
        let length_m = self.cost_cells[k] * self.geometry.resolution_m;
        let offsets = self.window.offsets();
        let mut cells = vec![cell];
        loop {
            let m = self.parent_move[k];
            if m == NO_PARENT {
                break;
            }
            k = (k as isize - offsets[usize::from(m)]) as usize;
            cells.push(self.window.cell(k));
        }
        cells.reverse();
        Some(Path { cells, length_m })
    }
}

/// Runs Dijkstra from `start` over every passable cell (same moves as [`super::astar`]).
pub fn dijkstra(grid: &OccupancyGrid, start: Cell, allow_unknown: bool) -> Result<DistanceField, PathError> {
    search(grid, start, allow_unknown, None)
}

/// Runs Dijkstra from `start` until every passable cell of `targets` is settled (or nothing is
/// left to settle): their distances and paths are exactly [`dijkstra`]'s.
pub fn dijkstra_to(grid: &OccupancyGrid, start: Cell, allow_unknown: bool, targets: &[Cell]) -> Result<DistanceField, PathError> {
    search(grid, start, allow_unknown, Some(targets))
}

/// Bounding box of the passable cells (non-empty: the start is passable).
fn passable_window(grid: &OccupancyGrid, allow_unknown: bool, start: Cell) -> Window {
    let g = grid.geometry;
    let (mut c0, mut c1, mut r0, mut r1) = (start.col as usize, start.col as usize, start.row as usize, start.row as usize);
    for r in 0..g.height {
        let row = &grid.data[r * g.width..(r + 1) * g.width];
        if let Some(first) = row.iter().position(|&v| super::passable(v, allow_unknown)) {
            let last = row.iter().rposition(|&v| super::passable(v, allow_unknown)).unwrap_or(first);
            c0 = c0.min(first);
            c1 = c1.max(last);
            r0 = r0.min(r);
            r1 = r1.max(r);
        }
    }
    Window { col0: c0, row0: r0, width: c1 - c0 + 1, height: r1 - r0 + 1 }
}

fn search(grid: &OccupancyGrid, start: Cell, allow_unknown: bool, targets: Option<&[Cell]>) -> Result<DistanceField, PathError> {
    let g = grid.geometry;
    check_start(grid, start, allow_unknown)?;
    let win = passable_window(grid, allow_unknown, start);
    let pw = win.padded_width();
    let n = pw * (win.height + 2);
    let mut flags = vec![0u8; n];
    for r in 0..win.height {
        let src = (win.row0 + r) * g.width + win.col0;
        let row = &grid.data[src..src + win.width];
        let out = &mut flags[(r + 1) * pw + 1..(r + 1) * pw + 1 + win.width];
        for (o, &v) in out.iter_mut().zip(row) {
            *o = u8::from(super::passable(v, allow_unknown));
        }
    }
    let mut targets_left = usize::MAX;
    if let Some(targets) = targets {
        targets_left = 0;
        for &t in targets {
            if let Some(p) = win.index(t).filter(|_| g.index(t).is_some())
                && flags[p] & (PASSABLE | TARGET) == PASSABLE
            {
                flags[p] |= TARGET;
                targets_left += 1;
            }
        }
    }
    let mut cost = vec![f64::INFINITY; n];
    let mut parent_move = vec![NO_PARENT; n];
    let s = win.index(start).ok_or(PathError::StartOutsideMap)?;
    let mut buckets: [Vec<u32>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    cost[s] = 0.0;
    buckets[0].push(s as u32);
    let off = win.offsets();
    let sqrt2 = std::f64::consts::SQRT_2;
    let (mut k, mut empty) = (0usize, 0);
    // Targets given but none passable: nothing to search for.
    let mut complete = targets_left != 0;
    if !complete {
        empty = 3;
    }
    'search: while empty < 3 {
        let b = k % 3;
        if buckets[b].is_empty() {
            empty += 1;
            k += 1;
            continue;
        }
        empty = 0;
        let mut bucket = std::mem::take(&mut buckets[b]);
        // Memory order: neighbouring cells of the wavefront share cache lines.
        bucket.sort_unstable();
        for &iu in &bucket {
            let i = iu as usize;
            if flags[i] & SETTLED != 0 || cost[i] as usize != k {
                continue;
            }
            flags[i] |= SETTLED;
            if flags[i] & TARGET != 0 {
                targets_left -= 1;
                if targets_left == 0 {
                    complete = false;
                    break 'search;
                }
            }
            let ci = cost[i];
            for (m, &d) in off[..4].iter().enumerate() {
                let j = (i as isize + d) as usize;
                let c = ci + 1.0;
                if flags[j] & PASSABLE != 0 && c < cost[j] {
                    cost[j] = c;
                    parent_move[j] = m as u8;
                    buckets[c as usize % 3].push(j as u32);
                }
            }
            for (m, &d) in off.iter().enumerate().skip(4) {
                let j = (i as isize + d) as usize;
                let c = ci + sqrt2;
                // No corner cutting: both orthogonal neighbours must be passable. The diagonal
                // d = dy·pw + dx splits into the orthogonal moves dx and dy·pw.
                let (dx, dy) = if m % 2 == 0 { (1, d - 1) } else { (-1, d + 1) };
                if flags[j] & PASSABLE != 0
                    && c < cost[j]
                    && flags[(i as isize + dx) as usize] & PASSABLE != 0
                    && flags[(i as isize + dy) as usize] & PASSABLE != 0
                {
                    cost[j] = c;
                    parent_move[j] = m as u8;
                    buckets[c as usize % 3].push(j as u32);
                }
            }
        }
        bucket.clear();
        buckets[b] = bucket;
        k += 1;
    }
    Ok(DistanceField { geometry: g, start, window: win, cost_cells: cost, flags, parent_move, complete })
}
