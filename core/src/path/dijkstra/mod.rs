//! One Dijkstra from the robot to every candidate (notes §4: the allowed optimisation that gives
//! every candidate's ρ_i at once, with the same optimum as A*).
//!
//! Dial-style bucket queue, exact for these costs: edge costs are 1 or √2 (in cells), so with
//! buckets one cell wide (bucket k holds costs in [k, k+1)) a cell expanded from bucket k can only
//! improve cells of later buckets — never one of its own — so a bucket's cells may be expanded in
//! any order, and every cost below bucket k is final when k is reached.
//!
//! Costs are **fixed-point integers**: `2 + cells · 2^shift`, with the largest shift (≤ 52) for
//! which no path in the window (fewer moves than cells, each ≤ 2 cells) can overflow a u64. Sums
//! of 1s are exact and each √2 is rounded to within 2^-(shift+1) cells, so two paths of at most
//! L moves compare with an error below 2L · 2^-(shift+1) cells. Distinct real lengths a + b√2 with
//! a, b ≤ L differ by at least 1/((1 + √2) L) (as |a² − 2b²| ≥ 1), so comparisons — and the
//! optimum — are exact whenever L² < 2^shift / 2.5: any path at all in a window of up to ~1.2
//! million cells, and paths of up to ~940,000 moves in a 2000 × 2000 window (shift 41). Integer
//! costs also make the bucket index a shift, with no float conversion in the inner loop.
//!
//! The search works on a **window**, to keep its memory small: the bounding box of the
//! passable cells (no path can leave it), padded with the grid's cells around it (impassable) so
//! no move leaves the arrays. Per window cell it keeps the cost (0 = lethal, 1 = unknown and
//! impassable, both below every cost, so one comparison tests both passability and improvement)
//! and 2 bytes of move marks (below): 10 bytes, against 4 million × 17 bytes for a whole-grid
//! layout with f64 costs and u32 parents on a 2000 × 2000 map. Parents are not stored; exact
//! integer costs let [`DistanceField::path_to`] and [`DistanceField::corners_to`] recover them.
//! Each bucket is put into block-wise memory order before it is expanded ([`BlockOrder`]), and
//! the cost rows of the cell 16 entries ahead are prefetched ([`flood::prefetch_rows`], x86-64 only).
//! With targets ([`dijkstra_to`]) the search stops as soon as all of their costs are final;
//! [`dijkstra_with_frontiers`] also collects the frontier cells.
//!
//! **Canonical ordering** (jump point search's pruning without corner cutting, applied to
//! Dijkstra): every cell has an optimal path that takes its diagonal moves first and turns only
//! at forced neighbours, so from a cell reached by a straight move only that move is worth
//! making (plus the side towards a blocked corner behind it), and from one reached diagonally
//! only the diagonal and its two components ([`flood::SUCCESSORS`]). Straight moves are therefore
//! **scanned** cell after cell without queueing ([`flood::Flood::scan`]); only diagonal steps and cells
//! with a forced neighbour enter the queue, each with the moves that reached it at its cost
//! (ties merged). The costs are the same integer sums as a plain Dijkstra's, so they and every
//! path are identical to it (measured on the decision bench: the same cost window and frontier
//! list, 0.53–0.59 of its time, docs/benchmarks.md). Since scans queue cells far ahead, the queue
//! keeps one bucket per cost unit; every cost below the bucket being settled is final. Frontier
//! cells are collected when first reached.
//!
//! O(n) in the cells reached (a cell is rescanned only when its cost improves) plus O(grid) to
//! find the window.

use super::{MOVES, PathError, check_start};
use crate::grid::{self, Cell, GridGeometry, LETHAL_THRESHOLD, OccupancyGrid};
use queue::{BlockOrder, BucketQueue};

/// Code of a lethal or off-grid cell: below every real cost.
const BLOCKED: u64 = 0;
/// Code of an unknown cell that may not be entered: below every real cost too.
const UNKNOWN: u64 = 1;
const UNREACHED: u64 = u64::MAX;
/// Cost of the start: zero path length. Real costs are ≥ this.
const START: u64 = 2;

/// The fixed-point cost scale: one cell is `2^shift`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Scale {
    shift: u32,
    orth: u64,
    diag: u64,
}

impl Scale {
    /// The finest scale at which no path through `cells` cells (each move ≤ 2 cells) overflows.
    fn for_cells(cells: usize) -> Self {
        let shift = (u64::MAX / (2 * cells as u64 + 2)).ilog2().min(52);
        let orth = 1u64 << shift;
        Self { shift, orth, diag: (std::f64::consts::SQRT_2 * orth as f64).round() as u64 }
    }

    #[inline]
    fn bucket(&self, cost: u64) -> u64 {
        cost >> self.shift
    }

    fn cells(&self, cost: u64) -> f64 {
        (cost - START) as f64 / self.orth as f64
    }
}

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

    /// Padded-index offsets of the 8 moves, in [`super::MOVES`]' order (4 orthogonal, then 4
    /// diagonal).
    fn offsets(&self) -> [isize; 8] {
        let pw = self.padded_width() as isize;
        MOVES.map(|(dc, dr, _)| dr as isize * pw + dc as isize)
    }
}

/// Shortest-path costs from one start, and the paths they imply.
#[derive(Clone, Debug)]
pub struct DistanceField {
    /// The grid's geometry.
    pub geometry: GridGeometry,
    /// The cell the costs are measured from.
    pub start: Cell,
    window: Window,
    scale: Scale,
    /// Fixed-point path cost from the start (padded window layout): [`BLOCKED`] or [`UNKNOWN`]
    /// where impassable, [`UNREACHED`] where not reached, final where settled.
    cost: Vec<u64>,
    /// Reached cells cheaper than this are settled ([`UNREACHED`]: every reachable cell is).
    settled_below: u64,
    /// The search's other storage, handed back by [`Self::into_buffers`].
    arrivals: Vec<u16>,
    queue: BucketQueue,
}

impl DistanceField {
    #[inline]
    fn settled_index(&self, cell: Cell) -> Option<usize> {
        self.geometry.index(cell)?;
        let p = self.window.index(cell)?;
        self.is_settled(self.cost[p]).then_some(p)
    }

    #[inline]
    fn is_settled(&self, cost: u64) -> bool {
        cost >= START && cost < self.settled_below
    }

    /// Path length from the start to `cell` in metres, if it was reached. After an early stop
    /// (`dijkstra_to`) cells farther than the last target are not reached.
    pub fn distance_m(&self, cell: Cell) -> Option<f64> {
        self.settled_index(cell).map(|p| self.scale.cells(self.cost[p]) * self.geometry.resolution_m)
    }

    /// Whether `cell` was reached (see [`Self::distance_m`]).
    pub fn reachable(&self, cell: Cell) -> bool {
        self.settled_index(cell).is_some()
    }

    #[cfg(test)]
    /// Whether the search settled every reachable cell (then "not reached" means unreachable).
    pub(crate) fn is_complete(&self) -> bool {
        self.settled_below == UNREACHED
    }

    /// The search's storage, for the next search to reuse (`dijkstra_to_reusing`).
    pub fn into_buffers(self) -> SearchBuffers {
        SearchBuffers { cost: self.cost, arrivals: self.arrivals, queue: self.queue }
    }

    /// Number of cells settled.
    pub fn settled_count(&self) -> usize {
        self.cost.iter().filter(|&&c| self.is_settled(c)).count()
    }

    #[cfg(test)]
    /// The shortest path from the start to `cell`, if reached (parents recovered by
    /// [`Self::walk_back`]).
    pub(crate) fn path_to(&self, cell: Cell) -> Option<super::Path> {
        let k = self.settled_index(cell)?;
        let length_m = self.scale.cells(self.cost[k]) * self.geometry.resolution_m;
        let mut cells = vec![cell];
        self.walk_back(k, cell, |at, _| cells.push(at))?;
        cells.reverse();
        Some(super::Path { cells, length_m })
    }

    /// The corner cells of [`Self::path_to`]'s path: its first and last cells and those where
    /// the move changes (the same polyline; what a planner draws and follows), without
    /// building the whole path.
    pub(crate) fn corners_to(&self, cell: Cell) -> Option<Vec<Cell>> {
        let k = self.settled_index(cell)?;
        let mut corners = vec![cell];
        let mut last_move = usize::MAX;
        let mut prev = cell;
        self.walk_back(k, cell, |at, m| {
            // `prev` is a corner if the move into it differs from the move out of it.
            if last_move != usize::MAX && m != last_move {
                corners.push(prev);
            }
            (last_move, prev) = (m, at);
        })?;
        if prev != cell {
            corners.push(prev);
        }
        corners.reverse();
        Some(corners)
    }

    /// Walks from the settled window cell `k` (grid cell `cell`) back to the start, calling
    /// `visit(parent cell, move index into MOVES)` for each step. A cell's parent is the first
    /// neighbour, in move order, whose cost plus the legal move's cost is exactly its own:
    /// parents are not stored, exact integer costs make that an optimal predecessor.
    fn walk_back(&self, mut k: usize, cell: Cell, mut visit: impl FnMut(Cell, usize)) -> Option<()> {
        let offsets = self.window.offsets();
        let open = |p: isize| self.cost[p as usize] >= START;
        let mut at = cell;
        while self.cost[k] != START {
            let ck = self.cost[k];
            let parent = offsets.iter().enumerate().find_map(|(m, &d)| {
                let j = k as isize - d;
                let (step, legal) = if m < 4 {
                    (self.scale.orth, true)
                } else {
                    // The diagonal d = dy·pw + dx from j needs j + dx and j + dy·pw open.
                    let dx = if m % 2 == 0 { 1 } else { -1 };
                    (self.scale.diag, open(j + dx) && open(j + d - dx))
                };
                (legal && ck.checked_sub(step) == Some(self.cost[j as usize])).then_some((j as usize, m))
            });
            // A settled non-start cell always has one (it was reached by such a move).
            let (j, m) = parent?;
            let (dc, dr, _) = MOVES[m];
            (k, at) = (j, Cell::new(at.col - dc, at.row - dr));
            visit(at, m);
        }
        Some(())
    }
}

/// Storage a search can reuse: the cost window, the per-cell move marks and the queue. A planner
/// that decides again and again keeps one, so that no search allocates or page-faults a
/// grid-sized buffer; its contents never carry over (every cell is written before it is read).
#[derive(Clone, Debug, Default)]
pub struct SearchBuffers {
    cost: Vec<u64>,
    arrivals: Vec<u16>,
    queue: BucketQueue,
}

/// Runs Dijkstra from `start` over every passable cell (same moves as [`super::astar`]).
pub fn dijkstra(grid: &OccupancyGrid, start: Cell, allow_unknown: bool) -> Result<DistanceField, PathError> {
    search(grid, start, allow_unknown, Goals { targets: None, frontier: None }, SearchBuffers::default())
}

#[cfg(test)]
/// Runs Dijkstra from `start` until every passable cell of `targets` is settled (or nothing is
/// left to settle): their distances and paths are exactly [`dijkstra`]'s.
pub fn dijkstra_to(grid: &OccupancyGrid, start: Cell, allow_unknown: bool, targets: &[Cell]) -> Result<DistanceField, PathError> {
    search(grid, start, allow_unknown, Goals { targets: Some(targets), frontier: None }, SearchBuffers::default())
}

/// [`dijkstra_to`] with the storage of `buffers` reused (take it back with
/// [`DistanceField::into_buffers`]).
pub fn dijkstra_to_reusing(
    grid: &OccupancyGrid,
    start: Cell,
    allow_unknown: bool,
    targets: &[Cell],
    buffers: SearchBuffers,
) -> Result<DistanceField, PathError> {
    search(grid, start, allow_unknown, Goals { targets: Some(targets), frontier: None }, buffers)
}

/// Runs Dijkstra from `start` over every cell reachable with unknown space impassable, and
/// returns with it the **WFD frontier cells** (notes §3; [`crate::frontier`]) found by the same
/// flood: reached cells with an unknown 4-neighbour inside the grid, as flat grid indices in
/// increasing order. WFD's 4-connected flood over free cells reaches exactly the cells this
/// 8-connected, no-corner-cutting search settles (a legal diagonal is two orthogonal moves), so
/// one flood gives both the frontiers and every distance. `buffers` as in `dijkstra_to_reusing`.
pub fn dijkstra_with_frontiers(
    grid: &OccupancyGrid,
    start: Cell,
    buffers: SearchBuffers,
) -> Result<(DistanceField, Vec<usize>), PathError> {
    let mut frontier = Vec::new();
    let field = search(grid, start, false, Goals { targets: None, frontier: Some(&mut frontier) }, buffers)?;
    let (win, w) = (field.window, grid.geometry.width);
    let pw = win.padded_width();
    let mut flat: Vec<usize> = frontier.into_iter().map(|p| (win.row0 + p / pw - 1) * w + win.col0 + p % pw - 1).collect();
    flat.sort_unstable();
    Ok((field, flat))
}

/// Bounding box of the passable cells (non-empty: the start is passable). Rows are scanned in
/// chunks with a branch-free minimum, which the compiler vectorises.
fn passable_window(grid: &OccupancyGrid, allow_unknown: bool, start: Cell) -> Window {
    const CHUNK: usize = 64;
    let g = grid.geometry;
    // Passable is "below the lethal threshold", signed (unknown allowed) or unsigned (unknown,
    // being negative, is then large). Flipping the sign bit maps signed order to unsigned, so in
    // both cases passable ⇔ key(v) < key(threshold), and a chunk has a passable cell iff the
    // minimum of its keys does.
    let key = |v: i8| passability_key(v, allow_unknown);
    let threshold = key(LETHAL_THRESHOLD);
    let passable = |v: &i8| key(*v) < threshold;
    let any = |chunk: &[i8]| chunk.iter().fold(u8::MAX, |m, &v| m.min(key(v))) < threshold;
    let (mut c0, mut c1, mut r0, mut r1) = (start.col as usize, start.col as usize, start.row as usize, start.row as usize);
    for (r, row) in grid.data.chunks_exact(g.width).enumerate() {
        let Some(first) = row.chunks(CHUNK).position(any) else { continue };
        let last = row.chunks(CHUNK).rposition(any).unwrap_or(first);
        let first = first * CHUNK + row[first * CHUNK..].iter().position(passable).unwrap_or(0);
        let tail = &row[last * CHUNK..(last * CHUNK + CHUNK).min(row.len())];
        let last = last * CHUNK + tail.iter().rposition(passable).unwrap_or(0);
        c0 = c0.min(first);
        c1 = c1.max(last);
        r0 = r0.min(r);
        r1 = r1.max(r);
    }
    Window { col0: c0, row0: r0, width: c1 - c0 + 1, height: r1 - r0 + 1 }
}

/// An order-preserving map of grid values to `u8` under which passable ⇔ below the key of
/// [`LETHAL_THRESHOLD`] (see [`super::passable`]): the sign bit flipped when unknown is allowed.
#[inline]
fn passability_key(v: i8, allow_unknown: bool) -> u8 {
    (v as u8) ^ (u8::from(allow_unknown) << 7)
}

/// What a search collects besides costs.
struct Goals<'a> {
    /// Stop once all of these are settled (`None`: settle every reachable cell).
    targets: Option<&'a [Cell]>,
    /// Collect the settled cells with an unknown 4-neighbour (window indices, settling order).
    frontier: Option<&'a mut Vec<usize>>,
}

/// The window's code for a grid value: passable cells start [`UNREACHED`], impassable unknown
/// cells are [`UNKNOWN`] (for frontiers), the rest [`BLOCKED`]. Branch-free.
#[inline]
fn code(v: i8, allow_unknown: bool) -> u64 {
    let passable = u64::from(super::passable(v, allow_unknown));
    let unknown = u64::from(v < 0);
    passable.wrapping_neg() | (unknown & (passable ^ 1))
}

/// Appends the codes of `cells` to `cost`. Words of 8 equal cells of the three values a thresholded
/// map holds (free, lethal, unknown: long runs in practice) are written whole; other words cell
/// by cell. About twice as fast as mapping every cell on the decision bench.
fn extend_codes(cost: &mut Vec<u64>, cells: &[i8], allow_unknown: bool) {
    const LANES: usize = 8;
    let uniform = |v: i8| u64::from_ne_bytes([v as u8; LANES]);
    let runs = [grid::FREE, grid::LETHAL, grid::UNKNOWN].map(|v| (uniform(v), [code(v, allow_unknown); LANES]));
    let (words, remainder) = cells.as_chunks::<LANES>();
    for bytes in words {
        let bits = u64::from_ne_bytes(bytes.map(|v| v as u8));
        match runs.iter().find(|(w, _)| *w == bits) {
            Some((_, codes)) => cost.extend_from_slice(codes),
            None => cost.extend(bytes.iter().map(|&v| code(v, allow_unknown))),
        }
    }
    cost.extend(remainder.iter().map(|&v| code(v, allow_unknown)));
}

/// Fills `cost` with the padded window's codes: the border holds the grid's cells around the
/// window (never passable, as the window bounds the passable cells), off-grid cells `BLOCKED`.
fn fill_window(grid: &OccupancyGrid, win: &Window, allow_unknown: bool, cost: &mut Vec<u64>) {
    let g = grid.geometry;
    let (pw, n) = (win.padded_width(), win.padded_width() * (win.height + 2));
    // The rows in one writing pass (border cells first written BLOCKED)...
    cost.clear();
    cost.reserve(n);
    cost.resize(pw + 1, BLOCKED);
    for r in 0..win.height {
        let src = (win.row0 + r) * g.width + win.col0;
        extend_codes(cost, &grid.data[src..src + win.width], allow_unknown);
        cost.extend_from_slice(&[BLOCKED, BLOCKED]);
    }
    cost.resize(n, BLOCKED);
    // ...then the border cells that are grid cells get their codes.
    let mut border = |c: usize, r: usize| {
        // Padded (c, r) is grid (col0 + c − 1, row0 + r − 1).
        if let (Some(col), Some(row)) = ((win.col0 + c).checked_sub(1), (win.row0 + r).checked_sub(1))
            && col < g.width
            && row < g.height
        {
            cost[r * pw + c] = code(grid.data[row * g.width + col], allow_unknown);
        }
    };
    for c in 0..pw {
        border(c, 0);
        border(c, win.height + 1);
    }
    for r in 1..=win.height {
        border(0, r);
        border(pw - 1, r);
    }
}

mod flood;
mod queue;

use flood::search;

#[cfg(test)]
mod unit_tests;
