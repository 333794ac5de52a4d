//! The robot's trail: the cells its centre has driven on, which the explorer opens to the planner
//! again after inflation (`free_traversed`) so that the robot can go back the way it
//! came ([`super::ExploreParams::reuse_trail`]).
//!
//! Positions are kept in world coordinates (the map frame), so the trail lands on the same ground
//! in a map whose geometry changes between decisions (a robot's growing map). A segment between
//! two consecutive positions is sampled every half cell and made 4-connected (a diagonal step adds
//! the cell beside it, as the frontier flood is 4-connected); a segment longer than
//! 0.25 m is a jump of the estimate (a loop closure, a pose gap), not ground driven
//! on, and adds only its end cell.
//!
//! Cost: O(1) per position; the cells on one geometry are kept and extended incrementally
//! (O(new segments) per query), rebuilt only when the geometry changes (O(trail + grid)).

use crate::grid::{Cell, GridGeometry};
use crate::math;

/// Longest segment between two positions that is marked as driven, metres.
pub(crate) const MAX_TRAIL_STEP_M: f64 = 0.25;

/// Calls `visit` with the cells of the segment `from_m` → `to_m` on `g`, in order (a cell may
/// come more than once; cells off the grid are skipped).
pub(crate) fn segment_cells(g: &GridGeometry, from_m: [f64; 2], to_m: [f64; 2], mut visit: impl FnMut(Cell)) {
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

/// The trail's cells on one geometry, extended as positions arrive.
#[derive(Clone, Debug, Default, PartialEq)]
struct TrailCells {
    geometry: Option<GridGeometry>,
    /// Flat indices, each once, in the order first reached.
    cells: Vec<usize>,
    /// Membership of `cells`, per cell of `geometry`.
    on: Vec<bool>,
    /// Positions already rasterised.
    upto: usize,
}

/// One position of the trail, and whether the robot drove there from the position before.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TrailPoint {
    at_m: [f64; 2],
    driven: bool,
}

/// A trail kept in world coordinates: strokes of positions driven through, rasterised on the
/// geometry asked for.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trail {
    points: Vec<TrailPoint>,
    cache: TrailCells,
}

impl Trail {
    /// The robot drove from `from_m` to `to_m` (map frame, metres). When `from_m` is not where
    /// the trail ends (the estimate jumped in between: a loop closure), a new stroke starts
    /// there. Positions that are not finite are ignored.
    pub fn drove(&mut self, from_m: [f64; 2], to_m: [f64; 2]) {
        if !from_m.iter().chain(&to_m).all(|v| v.is_finite()) {
            return;
        }
        let last = self.points.last().map(|p| p.at_m);
        if last != Some(from_m) {
            self.points.push(TrailPoint { at_m: from_m, driven: false });
        } else if to_m == from_m {
            // Standing still at the trail's end adds nothing.
            return;
        }
        self.points.push(TrailPoint { at_m: to_m, driven: true });
    }

    /// The robot is at (x, y): driven there from where the trail ends (or the trail starts).
    pub fn push(&mut self, x_m: f64, y_m: f64) {
        let from = self.points.last().map_or([x_m, y_m], |p| p.at_m);
        self.drove(from, [x_m, y_m]);
    }

    /// The positions kept, metres.
    pub fn points_m(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.points.iter().map(|p| p.at_m)
    }

    /// Whether no position is kept.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The trail's cells on `g` (flat indices, each once, in the order first reached).
    pub fn cells(&mut self, g: &GridGeometry) -> &[usize] {
        self.update(g);
        &self.cache.cells
    }

    /// Per cell of `g`, whether it is on the trail.
    pub fn mask(&mut self, g: &GridGeometry) -> &[bool] {
        self.update(g);
        &self.cache.on
    }

    /// Brings the cells on `g` up to date with the positions.
    fn update(&mut self, g: &GridGeometry) {
        let c = &mut self.cache;
        if c.geometry != Some(*g) {
            *c = TrailCells { geometry: Some(*g), cells: Vec::new(), on: vec![false; g.len()], upto: 0 };
        }
        let (cells, on) = (&mut c.cells, &mut c.on);
        let mut add = |cell: Cell| {
            if let Some(i) = g.index(cell)
                && !on[i]
            {
                on[i] = true;
                cells.push(i);
            }
        };
        for k in c.upto.max(1)..self.points.len() {
            if self.points[k].driven {
                segment_cells(g, self.points[k - 1].at_m, self.points[k].at_m, &mut add);
            }
        }
        c.upto = self.points.len();
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
    fn a_trail_lands_on_the_same_ground_in_a_grown_map() {
        let mut t = Trail::default();
        for k in 0..=40 {
            let s = f64::from(k) * 0.05;
            // A quarter cell off the lattice, so that no sample lies on a cell boundary.
            t.push(1.0125 + s, 1.0125 + 0.5 * s);
        }
        // Standing still and a NaN add nothing.
        let n = t.points_m().count();
        t.push(3.0125, 2.0125);
        t.push(f64::NAN, 2.0);
        assert_eq!(t.points_m().count(), n);
        let small = GridGeometry::new(0.0, 0.0, 0.05, 80, 60);
        let grown = GridGeometry::new(-2.0, -1.0, 0.05, 140, 100);
        let centres = |t: &mut Trail, g: &GridGeometry| {
            let mut v: Vec<(i64, i64)> = t
                .cells(g)
                .iter()
                .map(|&i| {
                    let (x, y) = g.center_of(g.cell_at(i));
                    ((x * 1000.0).round() as i64, (y * 1000.0).round() as i64)
                })
                .collect();
            v.sort_unstable();
            v
        };
        let a = centres(&mut t, &small);
        assert_eq!(a, centres(&mut t, &grown));
        // 4-connected and each cell once.
        let cells = t.cells(&small).to_vec();
        let mut sorted = cells.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), cells.len());
        for w in cells.windows(2) {
            let (p, q) = (small.cell_at(w[0]), small.cell_at(w[1]));
            assert_eq!((p.col - q.col).abs() + (p.row - q.row).abs(), 1, "{p:?} → {q:?}");
        }
        // The first and the last position are on it.
        let ends = [t.points_m().next().unwrap(), t.points_m().last().unwrap()];
        for [x, y] in ends {
            let i = small.index(small.cell_of(x, y).unwrap()).unwrap();
            assert!(cells.contains(&i));
        }
    }

    #[test]
    fn cells_extended_as_positions_arrive_equal_cells_built_at_once() {
        let g = GridGeometry::new(0.0, 0.0, 0.05, 60, 60);
        let path: Vec<[f64; 2]> = (0..200)
            .map(|k| {
                let s = f64::from(k) * 0.013;
                [0.3 + s, 0.4 + 0.7 * s + 0.1 * crate::math::sin(3.0 * s)]
            })
            .collect();
        let mut incremental = Trail::default();
        for (k, p) in path.iter().enumerate() {
            incremental.push(p[0], p[1]);
            if k % 7 == 0 {
                let _ = incremental.cells(&g);
            }
        }
        let mut at_once = Trail::default();
        for p in &path {
            at_once.push(p[0], p[1]);
        }
        assert_eq!(incremental.cells(&g), at_once.cells(&g));
        let mask = at_once.mask(&g).to_vec();
        let cells = at_once.cells(&g).to_vec();
        assert_eq!(mask.iter().filter(|&&b| b).count(), cells.len());
        assert!(cells.iter().all(|&i| mask[i]));
    }

    #[test]
    fn a_jump_between_strokes_is_not_driven_on() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 20, 20);
        let mut t = Trail::default();
        t.drove([0.05, 0.05], [0.15, 0.05]);
        // The estimate jumped from (0.15, 0.05) to (0.15, 0.45) (a loop closure): driven on from there.
        t.drove([0.15, 0.45], [0.25, 0.45]);
        let mut cells: Vec<(i32, i32)> = t.cells(&g).iter().map(|&i| (g.cell_at(i).col, g.cell_at(i).row)).collect();
        cells.sort_unstable();
        assert_eq!(cells, vec![(0, 0), (1, 0), (1, 4), (2, 4)]);
        // Standing still, alone, marks the cell stood on.
        let mut still = Trail::default();
        still.drove([0.55, 0.55], [0.55, 0.55]);
        assert_eq!(still.cells(&g).len(), 1);
    }
}
