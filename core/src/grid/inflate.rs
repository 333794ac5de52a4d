//! Inflation of lethal cells by the robot radius, so that a point robot planning on the result
//! keeps its whole footprint off untraversable ground.
//!
//! Exact Euclidean inflation: a cell becomes lethal if the distance between its centre and the
//! centre of any lethal cell is ≤ `radius_m`. Implemented as a stamp of the precomputed disc (one
//! horizontal span per row offset) around each horizontal run of lethal cells: the discs of the
//! cells a..b of a run cover, at row offset dy, exactly the span [a − h(dy), b + h(dy)], so a run
//! costs 2r + 1 fills whatever its length. O(cells / 64 + R · r) fills for R runs and r the
//! radius in cells. Unknown cells stay unknown unless a disc covers them (then lethal: they are
//! within reach of an obstacle).

use super::{LETHAL, LETHAL_THRESHOLD, OccupancyGrid};

/// Returns a copy of `grid` with every cell within `radius_m` of a lethal cell set to [`LETHAL`].
pub fn inflate_lethal(grid: &OccupancyGrid, radius_m: f64) -> OccupancyGrid {
    let mut out = OccupancyGrid { geometry: grid.geometry, data: Vec::new() };
    inflate_lethal_into(grid, radius_m, &mut out);
    out
}

/// [`inflate_lethal`] into `out`, reusing its storage (a planner that decides again and again
/// keeps one, so the copy does not allocate and page-fault a fresh grid each time).
pub fn inflate_lethal_into(grid: &OccupancyGrid, radius_m: f64, out: &mut OccupancyGrid) {
    out.geometry = grid.geometry;
    out.data.clear();
    out.data.extend_from_slice(&grid.data);
    let g = grid.geometry;
    if radius_m.is_nan() || radius_m <= 0.0 || g.is_empty() {
        return;
    }
    let r_cells = (radius_m / g.resolution_m).floor() as i32;
    if r_cells == 0 {
        return;
    }
    let r2 = (radius_m / g.resolution_m) * (radius_m / g.resolution_m) + 1e-9;
    // The disc as one horizontal span per row offset: (dy, half-width in cells).
    let spans: Vec<(i32, i32)> = (-r_cells..=r_cells)
        .map(|dy| (dy, (0..=r_cells).take_while(|&dx| ((dx * dx + dy * dy) as f64) <= r2).last().unwrap_or(0)))
        .collect();
    let (w, h) = (g.width, g.height as i32);
    let stamp = |out: &mut OccupancyGrid, r: i32, a: usize, b: usize| {
        for &(dy, half) in &spans {
            let nr = r + dy;
            if (0..h).contains(&nr) {
                let half = half as usize;
                let (c0, c1) = (a.saturating_sub(half), (b + half).min(w - 1));
                let row = nr as usize * w;
                out.data[row + c0..=row + c1].fill(LETHAL);
            }
        }
    };
    const CHUNK: usize = 64;
    for (r, row) in grid.data.chunks_exact(w).enumerate() {
        // Most of a map has no lethal cell: skip 64 cells at a time on their (vectorised) maximum.
        let lethal_cols = row
            .chunks(CHUNK)
            .enumerate()
            .filter(|(_, chunk)| chunk.iter().copied().max().is_some_and(|v| v >= LETHAL_THRESHOLD))
            .flat_map(|(k, chunk)| (k * CHUNK..k * CHUNK + chunk.len()).filter(|&c| row[c] >= LETHAL_THRESHOLD));
        // Stamp each run of consecutive lethal cells at once.
        let mut run: Option<(usize, usize)> = None;
        for c in lethal_cols {
            run = match run {
                Some((a, b)) if b + 1 == c => Some((a, c)),
                Some((a, b)) => {
                    stamp(out, r as i32, a, b);
                    Some((c, c))
                }
                None => Some((c, c)),
            };
        }
        if let Some((a, b)) = run {
            stamp(out, r as i32, a, b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Cell, FREE, Grid, GridGeometry};

    #[test]
    fn single_obstacle_inflates_to_a_disc() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 11, 11);
        let mut grid = Grid::filled(g, FREE);
        *grid.get_mut(Cell::new(5, 5)).unwrap() = LETHAL;
        let out = inflate_lethal(&grid, 0.2);
        let n = out.data.iter().filter(|&&v| v == LETHAL).count();
        // cells with dx²+dy² ≤ 4: 13 cells
        assert_eq!(n, 13);
        assert_eq!(*out.get(Cell::new(7, 5)).unwrap(), LETHAL);
        assert_eq!(*out.get(Cell::new(7, 6)).unwrap(), FREE);
    }

    proptest::proptest! {
        /// The span stamp agrees with the definition: lethal iff lethal before or within
        /// `radius_m` (centre to centre) of a lethal cell.
        #[test]
        fn inflation_matches_the_definition(
            cells in proptest::collection::vec(proptest::prop_oneof![8 => proptest::strategy::Just(FREE), 1 => proptest::strategy::Just(LETHAL), 1 => proptest::strategy::Just(crate::grid::UNKNOWN)], 24 * 17),
            radius_cells in 0.0f64..4.5,
        ) {
            let g = GridGeometry::new(0.0, 0.0, 0.05, 24, 17);
            let grid = Grid { geometry: g, data: cells };
            let out = inflate_lethal(&grid, radius_cells * 0.05);
            for r in 0..17i32 {
                for c in 0..24i32 {
                    let near = (0..17i32).any(|rr| (0..24i32).any(|cc| {
                        let d2 = ((cc - c) * (cc - c) + (rr - r) * (rr - r)) as f64;
                        *grid.get(Cell::new(cc, rr)).unwrap() == LETHAL && d2 <= radius_cells * radius_cells + 1e-9
                    }));
                    let expected = if near { LETHAL } else { *grid.get(Cell::new(c, r)).unwrap() };
                    proptest::prop_assert_eq!(*out.get(Cell::new(c, r)).unwrap(), expected, "cell ({}, {})", c, r);
                }
            }
        }
    }
}
