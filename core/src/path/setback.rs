//! Goal set-back: a frontier goal sits on the last known cell before unknown ground, and a robot
//! that is unsure where it is may drive past it into ground no sensor has seen (a drop behind a
//! crest). [`set_back`] ends the path at its last point that keeps `margin_m` of known ground all
//! round, with the margin a multiple of the position's standard deviation ([`GoalSetback`]): with
//! a perfect pose the margin is 0 and the path is returned as is.
//!
//! The path is walked back from its end in steps of at most one cell; a point is clear when every
//! cell whose centre lies within `margin_m` is inside the grid and not unknown. The answer is
//! therefore quantised to the grid resolution. Cost O(path cells · (margin / resolution)²) in the
//! worst case, O((margin / resolution)²) when the end is already clear.

use crate::grid::{Cell, OccupancyGrid};
use crate::math;
use serde::{Deserialize, Serialize};

/// How far a path ends short of unknown ground, from the position's uncertainty.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GoalSetback {
    /// Standard deviations of the estimated position, sqrt(σx² + σy²). Default 2 (0 turns the
    /// set-back off).
    pub sigmas: f64,
    /// The most it sets back, metres. Default 1.
    pub max_m: f64,
}

impl Default for GoalSetback {
    fn default() -> Self {
        Self { sigmas: 2.0, max_m: 1.0 }
    }
}

impl GoalSetback {
    /// The margin for a position with variances `var_x_m2` and `var_y_m2` (world axes), metres:
    /// min(sigmas · sqrt(σx² + σy²), max_m); 0 for a non-finite or negative variance sum.
    pub(crate) fn margin_m(&self, var_x_m2: f64, var_y_m2: f64) -> f64 {
        let var = var_x_m2 + var_y_m2;
        if !(var.is_finite() && var > 0.0) {
            return 0.0;
        }
        (self.sigmas * var.sqrt()).min(self.max_m)
    }

    /// `Ok` when both fields are finite and ≥ 0; the error names the field (`max_m`).
    pub fn validate(&self) -> Result<(), crate::params::InvalidParam> {
        crate::params::check_non_negative("sigmas", self.sigmas)?;
        crate::params::check_non_negative("max_m", self.max_m)
    }
}

/// `path_m` cut at its last point (sampled at most one cell apart, from the end) whose disc of
/// radius `margin_m` holds only known cells inside the grid; the path unchanged (bit for bit) if
/// its end is clear or `margin_m` is not positive; only the start if no point is clear.
pub(crate) fn set_back(path_m: &[[f64; 2]], grid: &OccupancyGrid, margin_m: f64) -> Vec<[f64; 2]> {
    let Some(&end) = path_m.last() else { return Vec::new() };
    if margin_m.is_nan() || margin_m <= 0.0 || known_around(grid, end, margin_m) {
        return path_m.to_vec();
    }
    let step_m = grid.geometry.resolution_m;
    for k in (1..path_m.len()).rev() {
        let (a, b) = (path_m[k - 1], path_m[k]);
        let n = (math::hypot(b[0] - a[0], b[1] - a[1]) / step_m).ceil().max(1.0) as usize;
        // j = n is b itself, tested already (as the end or as the previous segment's start).
        for j in (0..n).rev() {
            let t = j as f64 / n as f64;
            let p = if j == 0 { a } else { [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])] };
            if known_around(grid, p, margin_m) {
                let mut out = path_m[..k].to_vec();
                if j > 0 {
                    out.push(p);
                }
                return out;
            }
        }
    }
    vec![path_m[0]]
}

/// Whether every cell whose centre lies within `radius_m` of `p` is inside the grid and known.
pub fn known_around(grid: &OccupancyGrid, p: [f64; 2], radius_m: f64) -> bool {
    let g = &grid.geometry;
    let Some(c) = g.cell_unchecked(p[0], p[1]) else { return false };
    let reach_cells = (radius_m / g.resolution_m).ceil();
    // A disc wider than the grid holds centres outside it (and this bounds the loop).
    if reach_cells.is_nan() || reach_cells > (g.width + g.height) as f64 {
        return false;
    }
    let reach = reach_cells as i32 + 1;
    for dr in -reach..=reach {
        for dc in -reach..=reach {
            let cell = Cell::new(c.col.saturating_add(dc), c.row.saturating_add(dr));
            let (x, y) = g.center_of(cell);
            if math::hypot(x - p[0], y - p[1]) > radius_m {
                continue;
            }
            match g.index(cell) {
                Some(i) if grid.data[i] >= 0 => {}
                _ => return false,
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{FREE, GridGeometry, UNKNOWN};
    use proptest::prelude::*;

    /// 20 × 10 cells of 1 m, free up to column 9, unknown from column 10 (centres x ≥ 10.5).
    fn half_known() -> OccupancyGrid {
        let g = GridGeometry::new(0.0, 0.0, 1.0, 20, 10);
        let mut grid = OccupancyGrid::filled(g, FREE);
        for r in 0..10 {
            for c in 10..20 {
                grid.data[r * 20 + c] = UNKNOWN;
            }
        }
        grid
    }

    #[test]
    fn the_margin_is_sigmas_standard_deviations_capped() {
        let s = GoalSetback::default();
        // σx² + σy² = 0.03² + 0.04² = 0.05²: 2 σ = 0.1 m.
        assert!((s.margin_m(9e-4, 1.6e-3) - 0.1).abs() < 1e-12);
        assert_eq!(s.margin_m(1.0, 0.0), 1.0, "capped at max_m");
        assert_eq!(s.margin_m(0.0, 0.0), 0.0);
        assert_eq!(s.margin_m(f64::NAN, 0.0), 0.0);
        assert_eq!(GoalSetback { sigmas: 0.0, ..s }.margin_m(1e-2, 1e-2), 0.0);
        assert!(GoalSetback { max_m: -1.0, ..s }.validate().unwrap_err().key == "max_m");
    }

    #[test]
    fn a_goal_at_the_edge_of_unknown_ground_is_set_back_by_the_margin() {
        let grid = half_known();
        let path = [[1.5, 5.5], [9.5, 5.5]];
        // Nearest unknown centre (10.5, 5.5): a point at x is clear iff 10.5 − x > 2, i.e.
        // x < 8.5. Samples every metre back from 9.5: 8.5 is at exactly 2 m (not clear), 7.5 is.
        assert_eq!(set_back(&path, &grid, 2.0), vec![[1.5, 5.5], [7.5, 5.5]]);
        // Margin 0.9: 9.5 is 1 m away, clear: the path comes back unchanged.
        assert_eq!(set_back(&path, &grid, 0.9), path.to_vec());
        // No margin, no change, even with the end in unknown ground.
        let into = [[1.5, 5.5], [12.5, 5.5]];
        assert_eq!(set_back(&into, &grid, 0.0), into.to_vec());
    }

    #[test]
    fn the_cut_can_fall_on_an_earlier_segment_and_the_grid_edge_counts_as_unknown() {
        let grid = half_known();
        // The last segment runs along the unknown edge; the cut lands on the first segment.
        let path = [[0.5, 5.5], [8.5, 5.5], [9.5, 6.5]];
        // Margin 3: clear iff x < 7.5 (unknown from 10.5) and more than 3 m from every centre
        // outside the grid (x = −0.5: 1 m from the start; y = −0.5 and 10.5: 6 and 5 m). The last
        // segment's points are within 2 m of unknown; the first's, sampled every metre from 8.5
        // back: 7.5 is at exactly 3 m, 6.5 is clear.
        assert_eq!(set_back(&path, &grid, 3.0), vec![[0.5, 5.5], [6.5, 5.5]]);
        // Margin 6: no point is 6 m from both the unknown half and the grid's edge.
        assert_eq!(set_back(&path, &grid, 6.0), vec![[0.5, 5.5]]);
        // Near the bottom edge: the centre (0.5, −0.5) outside the grid is 1 m from (0.5, 0.5).
        assert!(!known_around(&grid, [0.5, 0.5], 1.0));
        assert!(known_around(&grid, [0.5, 0.5], 0.99));
        // Discs wider than the grid, or infinite, hold outside centres; NaN is not a margin.
        assert!(!known_around(&grid, [5.5, 5.5], 1e12) && !known_around(&grid, [5.5, 5.5], f64::INFINITY));
        assert_eq!(set_back(&path, &grid, f64::INFINITY), vec![[0.5, 5.5]]);
        assert_eq!(set_back(&path, &grid, f64::NAN), path.to_vec());
    }

    proptest! {
        /// The cut path is a prefix of the input plus at most one point on the next segment, and
        /// its end is clear unless only the start is left.
        #[test]
        fn the_cut_path_is_a_prefix_ending_clear(
            unknown in proptest::collection::vec(any::<bool>(), 144),
            pts in proptest::collection::vec((0.0f64..12.0, 0.0f64..12.0), 1..6),
            margin in 0.0f64..3.0,
        ) {
            let g = GridGeometry::new(0.0, 0.0, 1.0, 12, 12);
            let mut grid = OccupancyGrid::filled(g, FREE);
            for (i, u) in unknown.iter().enumerate() {
                if *u && i % 3 == 0 {
                    grid.data[i] = UNKNOWN;
                }
            }
            let path: Vec<[f64; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            let out = set_back(&path, &grid, margin);
            prop_assert!(!out.is_empty() && out.len() <= path.len());
            let whole = out.len() - 1;
            prop_assert_eq!(&out[..whole], &path[..whole]);
            let end = out[whole];
            if out != path {
                // The end lies on the segment after the kept prefix.
                let (a, b) = (path[whole.max(1) - 1], path[whole.max(1)]);
                let cross = (b[0] - a[0]) * (end[1] - a[1]) - (b[1] - a[1]) * (end[0] - a[0]);
                prop_assert!(cross.abs() < 1e-9 || out.len() == 1);
            }
            if margin > 0.0 && out.len() > 1 {
                prop_assert!(known_around(&grid, end, margin));
            }
        }
    }
}
