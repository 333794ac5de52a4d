//! Entropy rays from a candidate cell (paper eqs. 3–6; notes §5): the expected information gain
//! `ΔE^θ` of each ray of the fan `Θ = {kΔθ : kΔθ < 2π}`.
//!
//! Every ray leaves the *centre* of the candidate cell, so the sequence of cells a ray crosses,
//! as offsets from the origin cell, is the same for every candidate. `RayFan::new` traces each
//! ray once with the Amanatides–Woo voxel traversal (DDA) in cell units and stores its offsets;
//! `RayFan::cast` then walks those offsets on the grid. Amanatides–Woo enters the cells the ray
//! passes through in order of the parameter `t` at which it enters them, and a line meets a
//! convex cell in one segment, so each cell is visited exactly once per ray (a 4-connected
//! chain). Where the ray passes exactly through a cell corner the x-step is taken first, so the
//! cell touched at that single point is included. A cell is on the ray if the ray enters it at a
//! distance `t < max_depth_m`.
//!
//! Along a ray, from the first cell after the origin: a lethal cell stops the ray (it adds
//! nothing), the map edge stops it, a free cell adds nothing, an unknown cell `r` adds
//! `g(N_r) = 1 − H((1 + γ^{N_r})/2)` with `N_r` the number of cells strictly between the origin
//! cell and `r` (the camera sits in the origin cell; the first cell beyond it has `N = 0`).
//! `ΔE^θ` is the sum. The ray count is `⌈2π/Δθ⌉` (with a 1e-9 tolerance so that a Δθ dividing
//! 2π up to rounding does not add a ray at 2π, which would count 0 twice).
//!
//! Rays are cast on the thresholded grid *before* inflation: inflation is a planning device,
//! and inflated unknown cells would otherwise block the view.
//!
//! Complexity: building is O(R · L) for R rays of at most L cells (L ≤ 2·d_max/resolution);
//! casting is O(R · L) with no allocation (the output buffer is reused).

use super::UtilityError;
use super::entropy::GainTable;
use crate::grid::{Cell, CellClass, OccupancyGrid};
use crate::math;

/// Number of rays `⌈2π/Δθ⌉` of the fan (angles `kΔθ < 2π`).
pub(crate) fn ray_count(delta_theta_rad: f64) -> usize {
    (std::f64::consts::TAU / delta_theta_rad - 1e-9).ceil().max(1.0) as usize
}

/// A precomputed fan of rays: angles, the cell offsets each ray crosses, and `g(N)` per step.
#[derive(Clone, Debug)]
pub(crate) struct RayFan {
    angles_rad: Vec<f64>,
    /// Offsets (dcol, drow) of every ray, concatenated; ray k is `offsets[ray_start[k]..ray_start[k+1]]`.
    offsets: Vec<[i32; 2]>,
    ray_start: Vec<usize>,
    /// The largest |dcol| or |drow| of any offset: from an origin at least this far inside
    /// every edge, no ray can leave the grid.
    reach_cells: i32,
    gains: GainTable,
    /// `offsets` as flat-index offsets on a grid `flat_width` cells wide (empty: none yet).
    flat: Vec<isize>,
    flat_width: usize,
}

impl RayFan {
    /// Traces the fan for rays every `delta_theta_rad` reaching `max_depth_m` on cells of
    /// `resolution_m`, with per-cell visibility degradation `gamma`.
    pub fn new(delta_theta_rad: f64, max_depth_m: f64, resolution_m: f64, gamma: f64) -> Result<Self, UtilityError> {
        let positive = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(UtilityError::InvalidParameter { name, value: v }) }
        };
        positive("delta_theta_rad", delta_theta_rad)?;
        positive("max_depth_m", max_depth_m)?;
        positive("resolution_m", resolution_m)?;
        if !(gamma > 0.0 && gamma <= 1.0) {
            return Err(UtilityError::InvalidParameter { name: "gamma", value: gamma });
        }
        let range_cells = max_depth_m / resolution_m;
        if range_cells > 1.0e5 {
            return Err(UtilityError::InvalidParameter { name: "max_depth_m / resolution_m", value: range_cells });
        }
        let n = ray_count(delta_theta_rad);
        let angles_rad: Vec<f64> = (0..n).map(|k| k as f64 * delta_theta_rad).collect();
        let mut offsets = Vec::new();
        let mut ray_start = Vec::with_capacity(n + 1);
        let mut longest = 0;
        for &theta in &angles_rad {
            ray_start.push(offsets.len());
            trace_dda(theta, range_cells, &mut offsets);
            longest = longest.max(offsets.len() - ray_start[ray_start.len() - 1]);
        }
        ray_start.push(offsets.len());
        let reach_cells = offsets.iter().map(|o| o[0].abs().max(o[1].abs())).max().unwrap_or(0);
        Ok(Self { angles_rad, offsets, ray_start, reach_cells, gains: GainTable::new(gamma, longest), flat: Vec::new(), flat_width: 0 })
    }

    /// Precomputes the offsets as flat-index offsets for grids `width` cells wide, which
    /// [`Self::cast`] then walks from interior origins on such grids (one add per cell instead
    /// of a 2D index; 0.4 ms of a 404-candidate decision, docs/benchmarks.md).
    pub(crate) fn for_width(mut self, width: usize) -> Self {
        let w = width as isize;
        self.flat = self.offsets.iter().map(|o| o[1] as isize * w + o[0] as isize).collect();
        self.flat_width = width;
        self
    }

    /// Ray angles `kΔθ`, radians, counter-clockwise from +x.
    pub(crate) fn angles_rad(&self) -> &[f64] {
        &self.angles_rad
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.angles_rad.len()
    }

    #[cfg(test)]
    /// Cell offsets (dcol, drow) that ray `k` crosses after its origin cell, in order.
    pub(crate) fn ray_offsets(&self, k: usize) -> &[[i32; 2]] {
        &self.offsets[self.ray_start[k]..self.ray_start[k + 1]]
    }

    /// Casts every ray from `origin` on `grid` and writes `ΔE^θ` (bits) per ray into
    /// `gains_bits` (cleared first; its capacity is reused). An origin outside the grid gives
    /// zero gains.
    pub fn cast(&self, grid: &OccupancyGrid, origin: Cell, gains_bits: &mut Vec<f64>) {
        gains_bits.clear();
        let g = grid.geometry;
        let (w, h) = (g.width as i64, g.height as i64);
        let table = self.gains.as_slice();
        let (oc, or) = (i64::from(origin.col), i64::from(origin.row));
        if !g.contains(origin) {
            gains_bits.resize(self.len(), 0.0);
            return;
        }
        // From an origin at least the fan's reach inside every edge no ray can leave the grid:
        // with flat offsets for this width, one add per cell and no edge test.
        let reach = i64::from(self.reach_cells);
        let interior = oc >= reach && or >= reach && oc + reach < w && or + reach < h;
        let flat_origin = (interior && self.flat_width == g.width).then_some((or * w + oc) as usize);
        for k in 0..self.len() {
            let cells = self.ray_start[k]..self.ray_start[k + 1];
            let sum = if let Some(origin) = flat_origin {
                ray_gain(self.flat[cells].iter().map(|&off| grid.data[origin.wrapping_add_signed(off)]), table)
            } else {
                // Stops at the map's edge.
                let inside = self.offsets[cells].iter().map_while(|off| {
                    let (c, r) = (oc + i64::from(off[0]), or + i64::from(off[1]));
                    (c >= 0 && r >= 0 && c < w && r < h).then(|| grid.data[(r * w + c) as usize])
                });
                ray_gain(inside, table)
            };
            gains_bits.push(sum);
        }
    }
}

/// `ΔE^θ` of one ray given the values of the cells it crosses, in order (see the module doc).
#[inline]
fn ray_gain(values: impl Iterator<Item = i8>, table: &[f64]) -> f64 {
    let mut sum = 0.0;
    for (n, v) in values.enumerate() {
        match CellClass::of(v) {
            CellClass::Lethal => break,
            CellClass::Unknown => sum += table[n],
            CellClass::Free => {}
        }
    }
    sum
}

/// Amanatides–Woo traversal from the centre of cell (0, 0), in cell units, of the ray at `theta`
/// up to (excluding) entry distance `range_cells`. Appends the offsets of the cells entered.
fn trace_dda(theta: f64, range_cells: f64, out: &mut Vec<[i32; 2]>) {
    let (dy, dx) = math::sin_cos(theta);
    let step = |d: f64| if d > 0.0 { 1 } else { -1 };
    let (step_x, step_y) = (step(dx), step(dy));
    // From the centre, the first boundary is half a cell away on each axis.
    let (mut t_max_x, t_delta_x) = if dx != 0.0 { (0.5 / dx.abs(), 1.0 / dx.abs()) } else { (f64::INFINITY, f64::INFINITY) };
    let (mut t_max_y, t_delta_y) = if dy != 0.0 { (0.5 / dy.abs(), 1.0 / dy.abs()) } else { (f64::INFINITY, f64::INFINITY) };
    let (mut c, mut r) = (0i32, 0i32);
    loop {
        let t_enter = if t_max_x <= t_max_y {
            let t = t_max_x;
            c += step_x;
            t_max_x += t_delta_x;
            t
        } else {
            let t = t_max_y;
            r += step_y;
            t_max_y += t_delta_y;
            t
        };
        if t_enter >= range_cells || t_enter.is_nan() {
            break;
        }
        out.push([c, r]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{FREE, Grid, GridGeometry, LETHAL, UNKNOWN};
    use crate::utility::entropy::visibility_gain_bits;
    use std::collections::HashSet;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

    #[test]
    fn ray_count_does_not_count_zero_twice() {
        assert_eq!(ray_count(8.5f64.to_radians()), 43); // 360/8.5 = 42.35
        assert_eq!(ray_count(TAU / 8.0), 8);
        assert_eq!(ray_count(FRAC_PI_4), 8);
        assert_eq!(ray_count(TAU / 7.0), 7);
        assert_eq!(ray_count(1.0), 7); // 0..6 rad; 6 < 2π < 7
        let fan = RayFan::new(FRAC_PI_4, 1.0, 0.1, 0.99).unwrap();
        assert_eq!(fan.len(), 8);
        assert!(fan.angles_rad().iter().all(|&a| a < TAU - 1e-6));
    }

    #[test]
    fn axis_rays_cover_cells_up_to_max_depth() {
        // Range 1.0 m at 0.1 m: cells entered at t = 0.5, 1.5, …, 9.5 cells (< 10) → 10 cells.
        let fan = RayFan::new(FRAC_PI_2, 1.0, 0.1, 0.99).unwrap();
        assert_eq!(fan.len(), 4);
        let east: Vec<_> = fan.ray_offsets(0).to_vec();
        assert_eq!(east, (1..=10).map(|c| [c, 0]).collect::<Vec<_>>());
        let north: Vec<_> = fan.ray_offsets(1).to_vec();
        assert_eq!(north, (1..=10).map(|r| [0, r]).collect::<Vec<_>>());
        assert_eq!(fan.ray_offsets(2)[9], [-10, 0]);
        assert_eq!(fan.ray_offsets(3)[9], [0, -10]);
    }

    #[test]
    fn each_cell_once_and_4_connected() {
        let fan = RayFan::new(3f64.to_radians(), 3.0, 0.05, 0.99).unwrap();
        for k in 0..fan.len() {
            let offs = fan.ray_offsets(k);
            let set: HashSet<_> = offs.iter().collect();
            assert_eq!(set.len(), offs.len(), "ray {k} revisits a cell");
            let mut prev = [0, 0];
            for o in offs {
                assert_eq!((o[0] - prev[0]).abs() + (o[1] - prev[1]).abs(), 1, "ray {k} jumps");
                prev = *o;
            }
            // Every cell has a point within max depth (60 cells) of the origin centre, and the
            // ray reaches out to about max depth.
            let near = |o: &[i32; 2]| {
                let a = (o[0].abs() as f64 - 0.5).max(0.0);
                let b = (o[1].abs() as f64 - 0.5).max(0.0);
                (a * a + b * b).sqrt()
            };
            assert!(offs.iter().all(|o| near(o) < 60.0));
            assert!(near(&offs[offs.len() - 1]) > 57.0);
        }
    }

    fn grid(w: usize, h: usize, fill: i8) -> OccupancyGrid {
        Grid::filled(GridGeometry::new(0.0, 0.0, 0.1, w, h), fill)
    }

    #[test]
    fn gains_by_hand() {
        // 4 rays, range 0.5 m = 5 cells at 0.1 m; γ = 0.5 so g(N) = 1 − H((1 + 2^-N)/2).
        let fan = RayFan::new(FRAC_PI_2, 0.5, 0.1, 0.5).unwrap();
        let mut gm = grid(21, 21, FREE);
        let o = Cell::new(10, 10);
        // East: cells 11..15 on row 10: free, unknown, unknown, lethal, unknown.
        *gm.get_mut(Cell::new(12, 10)).unwrap() = UNKNOWN;
        *gm.get_mut(Cell::new(13, 10)).unwrap() = UNKNOWN;
        *gm.get_mut(Cell::new(14, 10)).unwrap() = LETHAL;
        *gm.get_mut(Cell::new(15, 10)).unwrap() = UNKNOWN;
        // North: all five unknown. West: free. South: first cell lethal, then unknown.
        for r in 11..=15 {
            *gm.get_mut(Cell::new(10, r)).unwrap() = UNKNOWN;
        }
        *gm.get_mut(Cell::new(10, 9)).unwrap() = LETHAL;
        *gm.get_mut(Cell::new(10, 8)).unwrap() = UNKNOWN;
        let mut out = Vec::new();
        fan.cast(&gm, o, &mut out);
        let g = |n| visibility_gain_bits(0.5, n);
        // East: unknown cells at N = 1 and 2, then the lethal cell stops the ray.
        assert!((out[0] - (g(1) + g(2))).abs() < 1e-15);
        // g(0) = 1, g(1) = ¾log₂3 − 1.
        assert!((g(1) - (0.75 * 3f64.log2() - 1.0)).abs() < 1e-15);
        assert!((out[1] - (1.0 + g(1) + g(2) + g(3) + g(4))).abs() < 1e-15);
        assert_eq!(out[2], 0.0);
        assert_eq!(out[3], 0.0);
    }

    #[test]
    fn map_edge_stops_rays_and_outside_origin_gives_zero() {
        let fan = RayFan::new(PI, 1.0, 0.1, 1.0).unwrap();
        let gm = grid(5, 1, UNKNOWN);
        let mut out = vec![7.0; 9];
        fan.cast(&gm, Cell::new(1, 0), &mut out);
        // γ = 1: each unknown cell adds 1 bit; east has 3 cells before the edge, west 1.
        assert_eq!(out, vec![3.0, 1.0]);
        fan.cast(&gm, Cell::new(-1, 0), &mut out);
        assert_eq!(out, vec![0.0, 0.0]);
    }

    #[test]
    fn interior_and_edge_origins_cast_as_the_definition() {
        // A random 40 × 30 grid; rays reach 12 cells, so only origins 12 cells inside take the
        // interior path (flat offsets when the fan was made for this width). Every origin, on
        // and off the grid, against a walk with edge tests, for a fan without flat offsets, one
        // for this width and one for another width (which must not use them).
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let mut gm = grid(40, 30, FREE);
        for v in gm.data.iter_mut() {
            *v = [FREE, FREE, UNKNOWN, UNKNOWN, LETHAL][rng.random_range(0..5)];
        }
        let plain = RayFan::new(0.3, 1.2, 0.1, 0.8).unwrap();
        assert_eq!(plain.reach_cells, 12);
        let mut out = Vec::new();
        for fan in [plain.clone(), plain.clone().for_width(40), plain.for_width(41)] {
            for row in -1..31 {
                for col in -1..41 {
                    fan.cast(&gm, Cell::new(col, row), &mut out);
                    let expect: Vec<f64> = (0..fan.len())
                        .map(|k| {
                            let mut sum = 0.0;
                            for (n, o) in fan.ray_offsets(k).iter().enumerate() {
                                let Some(&v) =
                                    gm.get(Cell::new(col + o[0], row + o[1])).filter(|_| gm.geometry.contains(Cell::new(col, row)))
                                else {
                                    break;
                                };
                                match CellClass::of(v) {
                                    CellClass::Lethal => break,
                                    CellClass::Unknown => sum += fan.gains.as_slice()[n],
                                    CellClass::Free => {}
                                }
                            }
                            sum
                        })
                        .collect();
                    assert_eq!(out, expect, "origin ({col}, {row}), flat width {}", fan.flat_width);
                }
            }
        }
    }

    #[test]
    fn invalid_parameters_are_rejected() {
        assert!(RayFan::new(0.0, 1.0, 0.1, 0.9).is_err());
        assert!(RayFan::new(0.1, f64::NAN, 0.1, 0.9).is_err());
        assert!(RayFan::new(0.1, 1.0, 0.1, 1.5).is_err());
        assert!(RayFan::new(0.1, 1.0, 0.1, 0.0).is_err());
    }
}
