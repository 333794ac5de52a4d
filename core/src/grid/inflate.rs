//! Inflation of lethal cells by the robot radius, so that a point robot planning on the result
//! keeps its whole footprint off untraversable ground.
//!
//! Exact Euclidean inflation: a cell becomes lethal if the distance between its centre and the
//! centre of any lethal cell is ≤ `radius_m`. Implemented as a stamp of the precomputed disc
//! offsets around each lethal cell that borders a non-lethal one (interior lethal cells cannot
//! add anything new). O(B · r²) for B boundary cells and r the radius in cells. Unknown cells
//! stay unknown unless the disc covers them (then lethal: they are within reach of an obstacle).

use super::{CellClass, LETHAL, OccupancyGrid};

/// Returns a copy of `grid` with every cell within `radius_m` of a lethal cell set to [`LETHAL`].
pub fn inflate_lethal(grid: &OccupancyGrid, radius_m: f64) -> OccupancyGrid {
    let mut out = grid.clone();
    let g = grid.geometry;
    if !(radius_m > 0.0) || g.is_empty() {
        return out;
    }
    let r_cells = (radius_m / g.resolution_m).floor() as i32;
    if r_cells == 0 {
        return out;
    }
    let r2 = (radius_m / g.resolution_m) * (radius_m / g.resolution_m) + 1e-9;
    let offsets: Vec<(i32, i32)> = (-r_cells..=r_cells)
        .flat_map(|dy| (-r_cells..=r_cells).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| ((dx * dx + dy * dy) as f64) <= r2)
        .collect();
    let (w, h) = (g.width as i32, g.height as i32);
    let lethal = |c: i32, r: i32| CellClass::of(grid.data[r as usize * g.width + c as usize]) == CellClass::Lethal;
    for r in 0..h {
        for c in 0..w {
            if !lethal(c, r) {
                continue;
            }
            let interior = [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().all(|&(dx, dy)| {
                let (nc, nr) = (c + dx, r + dy);
                nc < 0 || nr < 0 || nc >= w || nr >= h || lethal(nc, nr)
            });
            if interior {
                continue;
            }
            for &(dx, dy) in &offsets {
                let (nc, nr) = (c + dx, r + dy);
                if nc >= 0 && nr >= 0 && nc < w && nr < h {
                    out.data[nr as usize * g.width + nc as usize] = LETHAL;
                }
            }
        }
    }
    out
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
}
