//! Frontier clusters and candidates (notes §3): link frontier cells 8-connected, order each
//! linked chain along itself, split it into clusters of at most `max_cluster_cells`, drop clusters
//! under `min_cluster_cells`, and take the median cell of each cluster as its candidate C_i.
//!
//! **Chain order.** Frontier chains are mostly thin curves, but ragged maps give 2–3-cell-thick
//! strips, blobs (sparse returns), branches (Y shapes) and rings (an unknown island in free
//! space). The order is built in two steps:
//! 1. *Extremity*, by a double sweep: the farthest cell (8-connected hop count, ties by smallest
//!    flat index) from the chain's smallest-index cell is e₁, the farthest from e₁ is e₂; the walk
//!    starts at whichever of e₁, e₂ has the smaller index. On a simple chain both are its ends.
//! 2. *Wave walk*: a BFS from the extremity that advances one wave (the cells one hop further)
//!    at a time and emits each wave sorted by index. When a wave falls apart into several
//!    8-connected groups (a branch point, or the two sides of a ring), the walk follows the
//!    first group (smallest index) to its end before the next one — depth first over branches,
//!    breadth first across the chain's thickness. A simple or thick chain is thus emitted end to
//!    end; a ring is walked round in one direction; a Y is emitted stem, one arm, the other arm.
//!    Every cell but the first of a branch is 8-adjacent to a cell of the wave emitted just
//!    before it, so pieces are contiguous bands of the chain, except across a jump back to a
//!    parked branch, and where a cut falls inside a two-row wave of a staircase: the piece may
//!    then start with a cell that touches the rest only through the previous piece (on the
//!    ragged synthetic map of docs/benchmarks.md, 568 of 599 pieces are 8-connected and 97% of
//!    consecutive cells are 8-adjacent).
//!
//! **Split rule.** A chain of n cells becomes k = ⌈n / max⌉ consecutive pieces of nearly equal
//! length: the first n mod k pieces have ⌊n/k⌋ + 1 cells, the others ⌊n/k⌋ (100 cells with max
//! 40 → 34, 33, 33), rather than full pieces plus a small remainder. Every piece therefore has
//! more than max/2 cells when a chain is split, so `min_cluster_cells` (≤ max/2 in practice)
//! drops only short chains. Candidate = `cells[len / 2]`.
//!
//! O(F log F) for F frontier cells (each cell is swept three times over its 8 neighbours; the
//! log is the per-wave sort), on the caller's `u8` state layer plus a few reused index buffers.

use super::FrontierCluster;
use crate::grid::GridGeometry;
use crate::params::FrontierParams;

/// Values of the state layer the frontier search ([`super::wfd`]) writes and the clustering
/// reads (and marks further).
pub(super) const UNREACHED: u8 = 0;
pub(super) const REACHED: u8 = 1;
pub(super) const FRONTIER: u8 = 2;

/// After the first sweep.
const SWEPT1: u8 = 3;
/// After the second sweep.
const SWEPT2: u8 = 4;
/// In the wave being grouped.
const NEXT: u8 = 5;
/// Assigned to a wave (emitted now or once its branch is popped).
const WAVED: u8 = 6;

/// Lengths of the consecutive pieces a chain of `n` cells is split into with at most
/// `max_cells` per piece (`max_cells == 0` is treated as 1): ⌈n / max⌉ pieces, the first
/// `n mod k` one cell longer. Sums to `n`; empty for `n == 0`.
pub(crate) fn split_lengths(n: usize, max_cells: usize) -> Vec<usize> {
    if n == 0 {
        return Vec::new();
    }
    let k = n.div_ceil(max_cells.max(1));
    let (base, extra) = (n / k, n % k);
    (0..k).map(|p| base + usize::from(p < extra)).collect()
}

/// Calls `f` on each in-grid 8-neighbour of flat index `i`.
#[inline]
fn for_each_neighbour8(i: usize, w: usize, h: usize, mut f: impl FnMut(usize)) {
    let (c, r) = (i % w, i / w);
    let (left, right) = (c > 0, c + 1 < w);
    if left {
        f(i - 1);
    }
    if right {
        f(i + 1);
    }
    if r > 0 {
        let j = i - w;
        f(j);
        if left {
            f(j - 1);
        }
        if right {
            f(j + 1);
        }
    }
    if r + 1 < h {
        let j = i + w;
        f(j);
        if left {
            f(j - 1);
        }
        if right {
            f(j + 1);
        }
    }
}

/// BFS from `start` over cells in state `from`, relabelling them `to`; returns the farthest cell
/// (largest hop count, ties by smallest index). `queue` is reused scratch.
fn farthest(state: &mut [u8], w: usize, h: usize, start: usize, from: u8, to: u8, queue: &mut Vec<usize>) -> usize {
    queue.clear();
    state[start] = to;
    queue.push(start);
    let mut layer_start = 0;
    loop {
        let layer_end = queue.len();
        let mut best = usize::MAX;
        for k in layer_start..layer_end {
            let i = queue[k];
            best = best.min(i);
            for_each_neighbour8(i, w, h, |j| {
                if state[j] == from {
                    state[j] = to;
                    queue.push(j);
                }
            });
        }
        if queue.len() == layer_end {
            return best;
        }
        layer_start = layer_end;
    }
}

/// Reused buffers of the wave walk.
#[derive(Default)]
struct Walk {
    queue: Vec<usize>,
    pending: Vec<usize>,
    scratch: Vec<usize>,
    groups: Vec<(usize, usize)>,
    stack: Vec<(usize, usize)>,
    order: Vec<usize>,
}

impl Walk {
    /// Orders the chain containing `seed` (cells in state `FRONTIER`) into `self.order`.
    fn order_chain(&mut self, state: &mut [u8], w: usize, h: usize, seed: usize) {
        let e1 = farthest(state, w, h, seed, FRONTIER, SWEPT1, &mut self.queue);
        let e2 = farthest(state, w, h, e1, SWEPT1, SWEPT2, &mut self.queue);
        let start = e1.min(e2);
        let (pending, scratch, groups, stack, order) =
            (&mut self.pending, &mut self.scratch, &mut self.groups, &mut self.stack, &mut self.order);
        pending.clear();
        stack.clear();
        order.clear();
        state[start] = WAVED;
        pending.push(start);
        stack.push((0, 1));
        while let Some((mut a, mut b)) = stack.pop() {
            loop {
                pending[a..b].sort_unstable();
                order.extend_from_slice(&pending[a..b]);
                // The next wave: unassigned neighbours of this one.
                let next_start = pending.len();
                for k in a..b {
                    let i = pending[k];
                    for_each_neighbour8(i, w, h, |j| {
                        if state[j] == SWEPT2 {
                            state[j] = NEXT;
                            pending.push(j);
                        }
                    });
                }
                let next_end = pending.len();
                if next_end == next_start {
                    break;
                }
                // Split it into 8-connected groups, seeded in index order.
                pending[next_start..next_end].sort_unstable();
                scratch.clear();
                groups.clear();
                for &s in &pending[next_start..next_end] {
                    if state[s] != NEXT {
                        continue;
                    }
                    let g0 = scratch.len();
                    state[s] = WAVED;
                    scratch.push(s);
                    let mut q = g0;
                    while q < scratch.len() {
                        let i = scratch[q];
                        q += 1;
                        for_each_neighbour8(i, w, h, |j| {
                            if state[j] == NEXT {
                                state[j] = WAVED;
                                scratch.push(j);
                            }
                        });
                    }
                    groups.push((next_start + g0, next_start + scratch.len()));
                }
                pending[next_start..next_end].copy_from_slice(scratch);
                // Follow the first group; the others wait, popping in index order.
                for &g in groups[1..].iter().rev() {
                    stack.push(g);
                }
                (a, b) = groups[0];
            }
        }
    }
}

/// Clusters the frontier cells `frontier` (flat indices, increasing; marked `FRONTIER` in
/// `state`, which this consumes). Chains in order of their smallest index, pieces in chain order.
pub(super) fn cluster_frontier(
    geometry: &GridGeometry,
    state: &mut [u8],
    frontier: &[usize],
    params: &FrontierParams,
) -> Vec<FrontierCluster> {
    let (w, h) = (geometry.width, geometry.height);
    let mut walk = Walk::default();
    let mut clusters = Vec::new();
    for &seed in frontier {
        if state[seed] != FRONTIER {
            continue;
        }
        walk.order_chain(state, w, h, seed);
        let mut offset = 0;
        for len in split_lengths(walk.order.len(), params.max_cluster_cells) {
            let piece = &walk.order[offset..offset + len];
            offset += len;
            if len < params.min_cluster_cells {
                continue;
            }
            let cells = piece.iter().map(|&i| geometry.cell_at(i)).collect();
            if let Some(c) = FrontierCluster::from_ordered_cells(cells) {
                clusters.push(c);
            }
        }
    }
    clusters
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Cell;

    #[test]
    fn split_lengths_are_nearly_equal() {
        assert_eq!(split_lengths(100, 40), vec![34, 33, 33]);
        assert_eq!(split_lengths(80, 40), vec![40, 40]);
        assert_eq!(split_lengths(81, 40), vec![27, 27, 27]);
        assert_eq!(split_lengths(83, 40), vec![28, 28, 27]);
        assert_eq!(split_lengths(40, 40), vec![40]);
        assert_eq!(split_lengths(3, 40), vec![3]);
        assert_eq!(split_lengths(0, 40), Vec::<usize>::new());
        assert_eq!(split_lengths(5, 0), vec![1; 5]);
    }

    /// Orders the chain made of `cells` on a w×h layer and returns it as cells.
    fn order_of(w: usize, h: usize, cells: &[(i32, i32)]) -> Vec<Cell> {
        let g = GridGeometry::new(0.0, 0.0, 1.0, w, h);
        let mut state = vec![0u8; g.len()];
        let mut seed = usize::MAX;
        for &(c, r) in cells {
            let i = g.index(Cell::new(c, r)).unwrap();
            state[i] = FRONTIER;
            seed = seed.min(i);
        }
        let mut walk = Walk::default();
        walk.order_chain(&mut state, w, h, seed);
        walk.order.iter().map(|&i| g.cell_at(i)).collect()
    }

    #[test]
    fn straight_chain_runs_from_its_low_end() {
        let cells: Vec<(i32, i32)> = (0..10).map(|c| (c, 2)).collect();
        let order = order_of(12, 5, &cells);
        let expect: Vec<Cell> = (0..10).map(|c| Cell::new(c, 2)).collect();
        assert_eq!(order, expect);
    }

    #[test]
    fn thick_strip_is_walked_across_then_along() {
        // Two rows, cols 0..8. Seed (0,0); e₁ = (7,0) (hop 7, smaller index than (7,1)); e₂ = (0,0)
        // → start (0,0). Wave d = cells at hop max(col, row) = d, i.e. column d (plus (0,1) in
        // wave 1), each sorted by index (row-major).
        let cells: Vec<(i32, i32)> = (0..8).flat_map(|c| [(c, 0), (c, 1)]).collect();
        let order = order_of(10, 3, &cells);
        let mut expect = vec![Cell::new(0, 0), Cell::new(1, 0), Cell::new(0, 1), Cell::new(1, 1)];
        for c in 2..8 {
            expect.extend([Cell::new(c, 0), Cell::new(c, 1)]);
        }
        assert_eq!(order, expect);
    }

    #[test]
    fn ring_is_walked_round() {
        // Boundary of the square [1,5]² (16 cells) on a 7-wide layer. Seed (1,1); e₁ = (5,5),
        // e₂ = (1,1) → start (1,1). Wave 1 = {(2,1),(1,2)} (diagonal neighbours: one group);
        // wave 2 = {(3,1)} and {(1,3)}, not adjacent: follow (3,1) (smaller index) round the
        // ring, which consumes everything but the parked (1,3), emitted last.
        let mut cells = Vec::new();
        for c in 1..=5 {
            for r in 1..=5 {
                if c == 1 || c == 5 || r == 1 || r == 5 {
                    cells.push((c, r));
                }
            }
        }
        let order = order_of(7, 7, &cells);
        let expect = [
            (1, 1),
            (2, 1),
            (1, 2),
            (3, 1),
            (4, 1),
            (5, 1),
            (5, 2),
            (5, 3),
            (5, 4),
            (4, 5),
            (5, 5),
            (3, 5),
            (2, 5),
            (1, 4),
            (1, 5),
            (1, 3),
        ];
        let expect: Vec<Cell> = expect.iter().map(|&(c, r)| Cell::new(c, r)).collect();
        assert_eq!(order, expect);
    }

    #[test]
    fn y_branch_is_stem_then_one_arm_then_the_other() {
        // Stem (5,0)..(5,4); arms from (5,4): left (4,5),(3,6),(2,7); right (6,5),(7,6),(8,7).
        let mut cells: Vec<(i32, i32)> = (0..5).map(|r| (5, r)).collect();
        cells.extend([(4, 5), (3, 6), (2, 7), (6, 5), (7, 6), (8, 7)]);
        let order = order_of(10, 9, &cells);
        // Extremity: the stem's foot (5,0) has index 5 < the arm tips' indices.
        let expect = [(5, 0), (5, 1), (5, 2), (5, 3), (5, 4), (4, 5), (3, 6), (2, 7), (6, 5), (7, 6), (8, 7)];
        let expect: Vec<Cell> = expect.iter().map(|&(c, r)| Cell::new(c, r)).collect();
        assert_eq!(order, expect);
    }
}
