//! The robot's trail: the cells its centre has driven on, which a planner may open again after
//! inflation ([`super::free_traversed`]) so that the robot can go back the way it came.
//!
//! A segment between two consecutive positions is sampled every half cell and made 4-connected
//! (a diagonal step adds the cell beside it, as the frontier flood is 4-connected); a segment
//! longer than [`MAX_TRAIL_STEP_M`] is a jump of the estimate (a loop closure, a pose gap), not
//! ground driven on, and adds only its end cell.

use super::{Cell, GridGeometry};
use crate::math;

/// Longest segment between two positions that is marked as driven, metres.
pub const MAX_TRAIL_STEP_M: f64 = 0.25;

/// Calls `visit` with the cells of the segment `from_m` → `to_m` on `g`, in order (a cell may
/// come more than once; cells off the grid are skipped).
pub fn segment_cells(g: &GridGeometry, from_m: [f64; 2], to_m: [f64; 2], mut visit: impl FnMut(Cell)) {
    let (dx, dy) = (to_m[0] - from_m[0], to_m[1] - from_m[1]);
    let d = math::hypot(dx, dy);
    let n = if d <= MAX_TRAIL_STEP_M { (2.0 * d / g.resolution_m).ceil() as usize } else { 0 };
    let mut last = if n == 0 { None } else { g.cell_of(from_m[0], from_m[1]) };
    for k in 0..=n {
        let t = if n == 0 { 1.0 } else { k as f64 / n as f64 };
        let Some(c) = g.cell_of(from_m[0] + t * dx, from_m[1] + t * dy) else { continue };
        if let Some(l) = last.filter(|l| (l.col - c.col).abs() == 1 && (l.row - c.row).abs() == 1) {
            visit(Cell::new(c.col, l.row));
        }
        visit(c);
        last = Some(c);
    }
}

/// A trail kept in world coordinates (the map frame), for a map whose geometry changes between
/// decisions (a robot's growing map): rasterised on each decision's grid with [`Self::cells`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WorldTrail {
    points_m: Vec<[f64; 2]>,
}

impl WorldTrail {
    /// Adds the position (x, y), metres, unless it lies within `min_step_m` of the last one kept
    /// (a robot standing still adds nothing) or is not finite.
    pub fn push(&mut self, x_m: f64, y_m: f64, min_step_m: f64) {
        if !(x_m.is_finite() && y_m.is_finite()) {
            return;
        }
        if self.points_m.last().is_some_and(|&[px, py]| math::hypot(x_m - px, y_m - py) < min_step_m) {
            return;
        }
        self.points_m.push([x_m, y_m]);
    }

    /// The positions kept, metres.
    pub fn points_m(&self) -> &[[f64; 2]] {
        &self.points_m
    }

    pub fn is_empty(&self) -> bool {
        self.points_m.is_empty()
    }

    /// The trail's cells on `g` (flat indices, each once, in the order first reached). O(trail +
    /// grid).
    pub fn cells(&self, g: &GridGeometry) -> Vec<usize> {
        let mut seen = vec![false; g.len()];
        let mut out = Vec::new();
        let mut add = |c: Cell| {
            if let Some(i) = g.index(c)
                && !seen[i]
            {
                seen[i] = true;
                out.push(i);
            }
        };
        if let Some(&first) = self.points_m.first()
            && let Some(c) = g.cell_of(first[0], first[1])
        {
            add(c);
        }
        for w in self.points_m.windows(2) {
            segment_cells(g, w[0], w[1], &mut add);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells_of(g: &GridGeometry, from: [f64; 2], to: [f64; 2]) -> Vec<(i32, i32)> {
        let mut v = Vec::new();
        segment_cells(g, from, to, |c| v.push((c.col, c.row)));
        v.dedup();
        v
    }

    #[test]
    fn a_diagonal_step_adds_the_cell_beside_it() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 10, 10);
        // (0.05, 0.05) → (0.15, 0.15): cell (0,0) to (1,1) through the corner; (1,0) joins them.
        assert_eq!(cells_of(&g, [0.05, 0.05], [0.15, 0.15]), vec![(0, 0), (1, 0), (1, 1)]);
        // Straight along a row: every cell once, none beside.
        assert_eq!(cells_of(&g, [0.05, 0.35], [0.25, 0.35]), vec![(0, 3), (1, 3), (2, 3)]);
    }

    #[test]
    fn a_jump_marks_only_its_end_cell() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 10, 10);
        assert_eq!(cells_of(&g, [0.05, 0.05], [0.05, 0.05 + MAX_TRAIL_STEP_M + 0.01]), vec![(0, 3)]);
        assert_eq!(cells_of(&g, [0.05, 0.05], [0.05, 0.05 + MAX_TRAIL_STEP_M - 0.01]).len(), 3);
    }

    #[test]
    fn a_world_trail_lands_on_the_same_ground_in_a_grown_map() {
        let mut t = WorldTrail::default();
        for k in 0..=40 {
            let s = f64::from(k) * 0.05;
            // A quarter cell off the lattice, so that no sample lies on a cell boundary.
            t.push(1.0125 + s, 1.0125 + 0.5 * s, 0.025);
        }
        // Standing still and a NaN add nothing.
        let n = t.points_m().len();
        t.push(3.0125, 2.0125, 0.025);
        t.push(f64::NAN, 2.0, 0.025);
        assert_eq!(t.points_m().len(), n);
        let small = GridGeometry::new(0.0, 0.0, 0.05, 80, 60);
        let grown = GridGeometry::new(-2.0, -1.0, 0.05, 140, 100);
        let centres = |g: &GridGeometry| {
            let mut v: Vec<(i64, i64)> = t
                .cells(g)
                .into_iter()
                .map(|i| {
                    let (x, y) = g.center_of(g.cell_at(i));
                    ((x * 1000.0).round() as i64, (y * 1000.0).round() as i64)
                })
                .collect();
            v.sort_unstable();
            v
        };
        let a = centres(&small);
        assert_eq!(a, centres(&grown));
        // 4-connected and each cell once.
        let cells = t.cells(&small);
        let mut sorted = cells.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), cells.len());
        for w in cells.windows(2) {
            let (p, q) = (small.cell_at(w[0]), small.cell_at(w[1]));
            assert_eq!((p.col - q.col).abs() + (p.row - q.row).abs(), 1, "{p:?} → {q:?}");
        }
        // The first and the last position are on it.
        for [x, y] in [t.points_m()[0], *t.points_m().last().unwrap()] {
            let i = small.index(small.cell_of(x, y).unwrap()).unwrap();
            assert!(cells.contains(&i));
        }
    }
}
