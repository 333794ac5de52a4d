//! Enclosure: whether every free cell the robot can reach lies within a disc around it. A robot
//! that finds no frontier has finished exploring only if it could get somewhere: walled in by its
//! own map (a ring of lethal registration speckle on ground that is traversable in truth) it is
//! trapped, and "no frontier" would misreport the end of its mission. To recover, it forgets its
//! map within [`recovery_radius_m`] and maps that ground again (the caller's part).
//!
//! The same flood as [`super::wfd`] (4-connected over free cells of the inflated grid from the
//! robot's cell, so exactly what the planner reaches without crossing unknown cells), stopped at
//! the first reached cell whose centre lies farther than `radius_m` from the robot's cell centre.
//! A window of flags around the robot, no per-cell allocation. O((radius / resolution)²).

use crate::grid::{Cell, CellClass, OccupancyGrid};
use crate::math;
use crate::params::Params;

/// Whether every free cell 4-connected to `robot` through free cells of `grid` has its centre
/// within `radius_m` of `robot`'s centre. The robot's own cell counts as reached whatever its
/// value; a robot outside the grid reaches nothing (enclosed). A negative or NaN radius is
/// never enclosing; one wider than the grid always is unless a reached cell lies beyond it.
pub(crate) fn enclosed_within(grid: &OccupancyGrid, robot: Cell, radius_m: f64) -> bool {
    let g = &grid.geometry;
    if radius_m.is_nan() || radius_m < 0.0 {
        return false;
    }
    if !g.contains(robot) {
        return true;
    }
    // Window of cells whose centre can be within the radius, clipped to the grid.
    let reach = (radius_m / g.resolution_m).ceil().min((g.width + g.height) as f64) as i64;
    let (c0, r0) = ((robot.col as i64 - reach).max(0), (robot.row as i64 - reach).max(0));
    let (c1, r1) = ((robot.col as i64 + reach).min(g.width as i64 - 1), (robot.row as i64 + reach).min(g.height as i64 - 1));
    let w = (c1 - c0 + 1) as usize;
    let mut seen = vec![false; w * (r1 - r0 + 1) as usize];
    let local = |c: i64, r: i64| (r - r0) as usize * w + (c - c0) as usize;
    let (rx, ry) = g.center_of(robot);
    let mut stack = vec![(robot.col as i64, robot.row as i64)];
    seen[local(robot.col as i64, robot.row as i64)] = true;
    while let Some((c, r)) = stack.pop() {
        for (dc, dr) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (nc, nr) = (c + dc, r + dr);
            let cell = Cell::new(nc as i32, nr as i32);
            let Some(i) = g.index(cell) else { continue };
            if CellClass::of(grid.data[i]) != CellClass::Free {
                continue;
            }
            let (x, y) = g.center_of(cell);
            if math::hypot(x - rx, y - ry) > radius_m {
                return false;
            }
            // Within the radius, so within the window.
            let k = local(nc, nr);
            if !seen[k] {
                seen[k] = true;
                stack.push((nc, nr));
            }
        }
    }
    true
}

/// How far around itself a robot walled in within `trapped_radius_m` forgets its map to recover
/// (a clear-costmap recovery), metres: the pocket, plus the robot's radius (the inflation that
/// closed it) and the traversability disc radius (the points that shape a cell's estimate).
pub(crate) fn recovery_radius_m(trapped_radius_m: f64, params: &Params) -> f64 {
    trapped_radius_m + params.robot.radius_m + params.traversability.disc_radius_m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{FREE, GridGeometry, LETHAL, UNKNOWN};
    use proptest::prelude::*;

    #[test]
    fn the_recovery_forgets_the_pocket_the_inflation_and_a_disc() {
        // Defaults: 2 m pocket + 0.25 m robot radius + 0.15 m disc radius.
        assert!((recovery_radius_m(2.0, &Params::default()) - 2.4).abs() < 1e-12);
    }

    /// 21 × 21 free cells of 0.1 m with the robot at the centre cell (10, 10), centre (1.05, 1.05).
    fn free() -> OccupancyGrid {
        OccupancyGrid::filled(GridGeometry::new(0.0, 0.0, 0.1, 21, 21), FREE)
    }

    /// Sets the cells whose centre is at distance in [lo, hi) cells from the centre cell's.
    fn ring(grid: &mut OccupancyGrid, lo: f64, hi: f64, value: i8) {
        for r in 0..21i32 {
            for c in 0..21i32 {
                let d = (((c - 10).pow(2) + (r - 10).pow(2)) as f64).sqrt();
                if d >= lo && d < hi {
                    grid.data[r as usize * 21 + c as usize] = value;
                }
            }
        }
    }

    #[test]
    fn a_ring_of_lethal_or_unknown_cells_encloses_the_robot() {
        let robot = Cell::new(10, 10);
        let mut grid = free();
        // Open ground: the free space reaches the grid's edge, 1 m away.
        assert!(!enclosed_within(&grid, robot, 0.5));
        assert!(enclosed_within(&grid, robot, 1.5), "the whole grid lies within 1.5 m (corner 1.41 m)");
        // A 2-cell-thick ring from 4 to 6 cells: the reachable cells are those within 4 cells,
        // the farthest (±3, ±2) / (±2, ±3) at sqrt(13) = 3.61 cells = 0.361 m (4 cells straight
        // out is in the ring).
        ring(&mut grid, 4.0, 6.0, LETHAL);
        assert!(enclosed_within(&grid, robot, 0.37));
        assert!(!enclosed_within(&grid, robot, 0.35));
        // Unknown cells enclose as well (the planner does not cross them).
        ring(&mut grid, 4.0, 6.0, UNKNOWN);
        assert!(enclosed_within(&grid, robot, 0.37));
        // A gap in the ring lets the robot out.
        for c in 14..17 {
            grid.data[10 * 21 + c] = FREE;
        }
        assert!(!enclosed_within(&grid, robot, 0.8));
        // Outside the grid: nothing reached; a NaN radius encloses nothing.
        assert!(enclosed_within(&grid, Cell::new(-5, 3), 0.1));
        assert!(!enclosed_within(&grid, robot, f64::NAN));
    }

    proptest! {
        /// The windowed, early-stopping flood agrees with the definition: a flood over the whole
        /// grid, then the farthest reached centre compared with the radius.
        #[test]
        fn agrees_with_a_whole_grid_flood(
            blocked in proptest::collection::vec(0u8..4, 21 * 21),
            col in 0i32..21, row in 0i32..21, radius in 0.0f64..2.5,
        ) {
            let mut grid = free();
            for (v, b) in grid.data.iter_mut().zip(&blocked) {
                *v = match b { 0 => LETHAL, 1 => UNKNOWN, _ => FREE };
            }
            let g = grid.geometry;
            let robot = Cell::new(col, row);
            let (rx, ry) = g.center_of(robot);
            let mut reached = vec![false; g.len()];
            let start = g.index(robot).unwrap();
            reached[start] = true;
            let mut stack = vec![start];
            let mut farthest: f64 = 0.0;
            while let Some(i) = stack.pop() {
                let c = g.cell_at(i);
                for (dc, dr) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                    let n = Cell::new(c.col + dc, c.row + dr);
                    if let Some(j) = g.index(n) && grid.data[j] == FREE && !reached[j] {
                        reached[j] = true;
                        let (x, y) = g.center_of(n);
                        farthest = farthest.max(math::hypot(x - rx, y - ry));
                        stack.push(j);
                    }
                }
            }
            prop_assert_eq!(enclosed_within(&grid, robot, radius), farthest <= radius);
        }
    }
}
