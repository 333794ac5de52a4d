//! Slope, step, roughness, hazard and score per cell from the moments fused over a disc.
//!
//! Notes §2: for each cell, fuse the moments of every cell whose centre lies within
//! `disc_radius_m` of its centre (precomputed offsets), then
//! - slope = angle between the fitted plane's normal and +z, roughness = √λ_min ([`fit_plane`]);
//! - step = largest height difference within the disc. By default
//!   (`step_relative_to_plane = true`, a deliberate reading of notes §2) the heights are taken
//!   relative to the fitted plane: step = max_c (z_max,c − h(x̄_c, ȳ_c)) − min_c (z_min,c − h(x̄_c, ȳ_c))
//!   over the disc's cells c, h the plane's height at the cell's mean (x, y). Raw max z − min z
//!   counts a ramp's rise across the disc as a step (15° over a 0.3 m disc rises 8 cm, as much as
//!   a kerb), so no single `max_step_m` could accept the ramp and reject the kerb; the slope is
//!   already penalised by the slope term. With `false` the notes' literal max z − min z is used.
//!   Within a cell the plane is evaluated at one point, so a slope θ still adds up to about
//!   resolution·tan θ·√2 (1.9 cm at 15° and 5 cm cells).
//! - hazard = clamp(max(slope/max_slope, step/max_step, roughness/max_roughness), 0, 1);
//!   score = 1 − hazard; unknown (NaN) where the disc holds fewer than `min_points` points.
//! - Also unknown (not in the notes): discs whose points do not span the disc horizontally —
//!   standard deviation along their narrowest horizontal direction below
//!   `min_spread_ratio · disc_radius_m` — since the tilt across such a strip (typically the edge
//!   of the data) is undetermined: quantisation and noise alone give it any slope.
//!
//! Complexity: O(cells × disc cells) for [`TraversabilityMap::compute`] (one fusion per disc cell
//! plus one 3×3 eigendecomposition per cell), no allocation per cell;
//! [`TraversabilityMap::update`] recomputes only the cells whose disc touches a changed cell —
//! their union, each once, in row-major order so that neighbouring discs share cache lines:
//! O(changed × disc cells²) at worst, O(affected × disc cells + affected log affected) in fact.
//! The fusion runs over every cell of the disc without a data-dependent branch (empty cells add
//! exact zeros, [`MomentSum::add_branchless`]) and equals, bit for bit, the straightforward
//! gather-then-fuse of the non-empty cells (proptest `optimised_estimate_equals_straightforward_reference`).

use super::map::TraversabilityMap;
use super::moments::{CellMoments, MomentSum};
use super::plane::fit_plane;
use crate::grid::{FREE, Grid, GridGeometry, LETHAL, OccupancyGrid, UNKNOWN};
use crate::params::TraversabilityParams;

/// The traversability layers of one map, all on one geometry. Float layers are NaN where the
/// cell is unknown (fewer than `min_points` points in its disc). `PartialEq` compares floats
/// with `==`, so layers holding unknown (NaN) cells never compare equal: compare `to_bits()`.
#[derive(Clone, Debug, PartialEq)]
pub struct TraversabilityLayers {
    /// Angle between the disc's fitted plane normal and +z, radians.
    pub slope_rad: Grid<f32>,
    /// Largest height difference within the disc (see the module doc), metres.
    pub step_m: Grid<f32>,
    /// RMS distance of the disc's points to their plane, metres.
    pub roughness_m: Grid<f32>,
    /// max(slope/max_slope, step/max_step, roughness/max_roughness) clamped to [0, 1].
    pub hazard: Grid<f32>,
    /// 1 − hazard: 1 is perfectly traversable, 0 lethal.
    pub score: Grid<f32>,
    /// Points binned in the cell itself (saturating).
    pub cell_points: Grid<u32>,
    /// Points in the cell's disc (saturating).
    pub disc_points: Grid<u32>,
    /// Parameters these layers were computed with (an update with others recomputes all).
    computed_with: TraversabilityParams,
}

impl TraversabilityLayers {
    pub(super) fn unknown(geometry: GridGeometry, params: &TraversabilityParams) -> Self {
        let nan = Grid::filled(geometry, f32::NAN);
        Self {
            slope_rad: nan.clone(),
            step_m: nan.clone(),
            roughness_m: nan.clone(),
            hazard: nan.clone(),
            score: nan,
            cell_points: Grid::filled(geometry, 0),
            disc_points: Grid::filled(geometry, 0),
            computed_with: params.clone(),
        }
    }

    /// The geometry of every layer.
    pub fn geometry(&self) -> GridGeometry {
        self.score.geometry
    }

    /// The parameters the layers were computed with.
    pub fn params(&self) -> &TraversabilityParams {
        &self.computed_with
    }

    /// Number of known cells (score not NaN).
    pub fn known_cells(&self) -> usize {
        self.score.data.iter().filter(|s| !s.is_nan()).count()
    }

    /// The binary grid of notes §2: score ≥ `tau` free, below lethal, unknown stays unknown.
    pub fn to_occupancy(&self, tau: f64) -> OccupancyGrid {
        to_occupancy(&self.score, tau)
    }

    fn write(&mut self, i: usize, cell_points: u64, e: &CellEstimate) {
        self.slope_rad.data[i] = e.slope_rad as f32;
        self.step_m.data[i] = e.step_m as f32;
        self.roughness_m.data[i] = e.roughness_m as f32;
        self.hazard.data[i] = e.hazard as f32;
        self.score.data[i] = e.score as f32;
        self.cell_points.data[i] = u32::try_from(cell_points).unwrap_or(u32::MAX);
        self.disc_points.data[i] = u32::try_from(e.disc_points).unwrap_or(u32::MAX);
    }
}

/// Thresholds a score layer by the risk acceptance τ (notes §2): score ≥ τ → [`FREE`] (0),
/// below → [`LETHAL`] (100), NaN → [`UNKNOWN`] (−1). O(cells).
pub fn to_occupancy(score: &Grid<f32>, tau: f64) -> OccupancyGrid {
    let data = score
        .data
        .iter()
        .map(|&s| {
            if s.is_nan() {
                UNKNOWN
            } else if f64::from(s) >= tau {
                FREE
            } else {
                LETHAL
            }
        })
        .collect();
    Grid { geometry: score.geometry, data }
}

/// (dx, dy) offsets of the cells whose centre lies within `radius_m` of a cell's centre
/// (always including (0, 0)), row-major order.
pub fn disc_offsets(radius_m: f64, resolution_m: f64) -> Vec<(i32, i32)> {
    let r = if radius_m.is_finite() && resolution_m > 0.0 { (radius_m / resolution_m).max(0.0) } else { 0.0 };
    // 1e-9 tolerance: a radius that is an exact multiple of the resolution includes that ring.
    let r_cells = (r + 1e-9).floor().min(10_000.0) as i32;
    let r2 = r * r + 1e-9;
    (-r_cells..=r_cells)
        .flat_map(|dy| (-r_cells..=r_cells).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| f64::from(dx * dx + dy * dy) <= r2)
        .collect()
}

/// One cell's result (NaN fields when unknown).
pub(super) struct CellEstimate {
    pub(super) slope_rad: f64,
    pub(super) step_m: f64,
    pub(super) roughness_m: f64,
    pub(super) hazard: f64,
    pub(super) score: f64,
    pub(super) disc_points: u64,
}

/// x / limit, with a non-positive limit meaning "any positive x is fully hazardous".
#[inline]
fn ratio(x: f64, limit: f64) -> f64 {
    if limit > 0.0 {
        x / limit
    } else if x > 0.0 {
        1.0
    } else {
        0.0
    }
}

/// The disc's offsets, precomputed once per compute / update.
pub(super) struct Disc {
    offsets: Vec<(i32, i32)>,
    /// Row-major index offsets `dy · width + dx`, valid for cells at least `r_cells` inside.
    flat: Vec<isize>,
    r_cells: i32,
}

impl Disc {
    pub(super) fn new(radius_m: f64, g: &GridGeometry) -> Self {
        let offsets = disc_offsets(radius_m, g.resolution_m);
        let flat = offsets.iter().map(|&(dx, dy)| dy as isize * g.width as isize + dx as isize).collect();
        let r_cells = offsets.iter().map(|&(dx, dy)| dx.abs().max(dy.abs())).max().unwrap_or(0);
        Self { offsets, flat, r_cells }
    }
}

/// The estimate of cell `index`: its disc's cells (all of them for an interior cell, the ones
/// inside the grid at the border), in offset order, go to [`estimate_disc`].
#[inline]
pub(super) fn estimate_cell(
    moments: &[CellMoments],
    g: &GridGeometry,
    index: usize,
    disc: &Disc,
    p: &TraversabilityParams,
) -> CellEstimate {
    let (w, h) = (g.width as i32, g.height as i32);
    let (col, row) = ((index % g.width) as i32, (index / g.width) as i32);
    let r = disc.r_cells;
    if col >= r && row >= r && col + r < w && row + r < h {
        let base = index as isize;
        estimate_disc(disc.flat.iter().map(|&o| &moments[(base + o) as usize]), p)
    } else {
        estimate_disc(
            disc.offsets.iter().filter_map(|&(dx, dy)| {
                let (c, r) = (col + dx, row + dy);
                (c >= 0 && r >= 0 && c < w && r < h).then(|| &moments[r as usize * g.width + c as usize])
            }),
            p,
        )
    }
}

/// Slope, step, roughness, hazard and score from the moments of a disc's cells (empty cells
/// included; they contribute nothing). Three passes over the cells — the first non-empty one
/// (the fusion's shift origin), the branch-free fusion ([`MomentSum::add_branchless`]), and the
/// relative step — each O(disc cells) with no data-dependent branch in the last two.
#[inline]
fn estimate_disc<'a, I>(members: I, p: &TraversabilityParams) -> CellEstimate
where
    I: Iterator<Item = &'a CellMoments> + Clone,
{
    let unknown = |disc_points: u64| CellEstimate {
        slope_rad: f64::NAN,
        step_m: f64::NAN,
        roughness_m: f64::NAN,
        hazard: f64::NAN,
        score: f64::NAN,
        disc_points,
    };
    let Some(first) = members.clone().find(|m| m.count > 0) else {
        return unknown(0);
    };
    let mut sum = MomentSum::with_origin(first.mean);
    for m in members.clone() {
        sum.add_branchless(m);
    }
    if sum.count() == 0 || sum.count() < u64::from(p.min_points) {
        return unknown(sum.count());
    }
    let fused = sum.finish();
    // Horizontal spread: smallest eigenvalue of the 2×2 xy covariance.
    let k = 1.0 / fused.count as f64;
    let (a, b, c) = (fused.scatter[0] * k, fused.scatter[1] * k, fused.scatter[3] * k);
    let lambda_xy = 0.5 * (a + c) - (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let min_spread = p.min_spread_ratio * p.disc_radius_m;
    let spread = lambda_xy.max(0.0).sqrt();
    if min_spread > 0.0 && (spread.is_nan() || spread < min_spread) {
        return unknown(fused.count);
    }
    let Some(plane) = fit_plane(&fused) else {
        return unknown(fused.count);
    };
    let raw_step_m = fused.z_max - fused.z_min;
    let mut step_m = raw_step_m;
    if p.step_relative_to_plane && plane.height_at(0.0, 0.0).is_some() {
        // Empty cells have z_max = −∞, z_min = +∞ (and a finite mean): they change neither.
        let (mut hi, mut lo) = (f64::NEG_INFINITY, f64::INFINITY);
        for m in members {
            let z = plane.height_at(m.mean[0], m.mean[1]).unwrap_or(0.0);
            hi = hi.max(m.z_max - z);
            lo = lo.min(m.z_min - z);
        }
        // Never more than the raw height range: a steep plane's heights are ill-conditioned
        // (its slope makes the cell lethal anyway).
        if hi >= lo {
            step_m = (hi - lo).min(raw_step_m);
        }
    }
    let hazard = ratio(plane.slope_rad, p.max_slope_rad)
        .max(ratio(step_m, p.max_step_m))
        .max(ratio(plane.roughness_m, p.max_roughness_m))
        .clamp(0.0, 1.0);
    CellEstimate {
        slope_rad: plane.slope_rad,
        step_m,
        roughness_m: plane.roughness_m,
        hazard,
        score: 1.0 - hazard,
        disc_points: fused.count,
    }
}

impl TraversabilityMap {
    /// Computes every layer from scratch (notes §2). O(cells × disc cells).
    pub fn compute(&self, params: &TraversabilityParams) -> TraversabilityLayers {
        let g = self.geometry;
        let mut layers = TraversabilityLayers::unknown(g, params);
        let disc = Disc::new(params.disc_radius_m, &g);
        for i in 0..g.len() {
            let e = estimate_cell(&self.moments, &g, i, &disc, params);
            layers.write(i, self.moments[i].count, &e);
        }
        layers
    }

    /// Brings `layers` up to date with the points inserted since the last update, recomputing
    /// only the cells whose disc touches a changed cell; the result equals [`Self::compute`]
    /// bit for bit. Recomputes everything when `layers` has another geometry, was computed with
    /// other parameters, or the map was cleared. Returns the number of cells recomputed.
    pub fn update(&mut self, params: &TraversabilityParams, layers: &mut TraversabilityLayers) -> usize {
        let g = self.geometry;
        if self.all_dirty || layers.geometry() != g || layers.computed_with != *params {
            *layers = self.compute(params);
            self.take_dirty();
            return g.len();
        }
        let disc = Disc::new(params.disc_radius_m, &g);
        let (w, h) = (g.width as i32, g.height as i32);
        self.affected.clear();
        for &d in &self.dirty {
            let (col, row) = ((d as usize % g.width) as i32, (d as usize / g.width) as i32);
            for &(dx, dy) in &disc.offsets {
                let (c, r) = (col + dx, row + dy);
                if c >= 0 && r >= 0 && c < w && r < h {
                    let j = r as usize * g.width + c as usize;
                    if !self.is_affected[j] {
                        self.is_affected[j] = true;
                        self.affected.push(j as u32);
                    }
                }
            }
        }
        // Row-major order: consecutive discs overlap, so their moments stay in cache.
        self.affected.sort_unstable();
        for &j in &self.affected {
            let j = j as usize;
            let e = estimate_cell(&self.moments, &g, j, &disc, params);
            layers.write(j, self.moments[j].count, &e);
            self.is_affected[j] = false;
        }
        let n = self.affected.len();
        self.affected.clear();
        self.take_dirty();
        n
    }
}
