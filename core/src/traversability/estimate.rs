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
//! - Registration noise (not in the notes): with σ̄² the mean vertical noise variance of the
//!   disc's points (0 unless inserted with one) and k = `noise_discount_sigmas`, the hazard uses
//!   √max(0, roughness² − k²σ̄²) and max(0, step − k√2·σ̄): offsets between scans registered
//!   with slightly different poses are not terrain. The layers keep the measured values.
//! - Also unknown (not in the notes): discs whose points do not span the disc horizontally —
//!   standard deviation along their narrowest horizontal direction below
//!   `min_spread_ratio · disc_radius_m` — since the tilt across such a strip (typically the edge
//!   of the data) is undetermined: quantisation and noise alone give it any slope.
//!
//! Complexity: slope and roughness come from the cell's disc sum ([`super::disc_sums`], kept up to
//! date at insertion), the step from one pass over the disc's cells: O(disc cells) per cell, no
//! allocation, and O(cells × disc cells) for [`TraversabilityMap::compute`].
//! [`TraversabilityMap::update`] recomputes only the cells whose disc changed, in row-major order;
//! [`TraversabilityMap::refresh_cells`] a few cells; [`TraversabilityMap::refresh_known`] keeps the
//! known/unknown flags without estimating. Against the straightforward gather-then-fuse of notes
//! §2 the disc sums agree to rounding (proptest `optimised_estimate_agrees_with_straightforward_reference`).

use super::disc_sums::{DiscSum, DiscSums, centre_local};
use super::map::TraversabilityMap;
use super::moments::CellMoments;
use super::plane::fit_plane;
use crate::cache::prefetch;
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
    /// Height of the disc's fitted plane above the cell's centre, map frame, metres (NaN where
    /// unknown or the plane is vertical): the ground a camera stands on (u2, notes §6).
    pub ground_z_m: Grid<f32>,
    /// The plane's gradient (∂z/∂x, ∂z/∂y) there: its normal is (−∂z/∂x, −∂z/∂y, 1) normalised.
    pub ground_gradient: Grid<[f32; 2]>,
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
            score: nan.clone(),
            cell_points: Grid::filled(geometry, 0),
            disc_points: Grid::filled(geometry, 0),
            ground_z_m: nan,
            ground_gradient: Grid::filled(geometry, [f32::NAN; 2]),
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

    /// The ground model of u2's terrain-following camera ([`GroundModel`]).
    pub fn ground(&self) -> GroundModel<'_> {
        GroundModel { z_m: &self.ground_z_m, gradient: &self.ground_gradient }
    }

    /// Writes cell `i`'s estimate; `z_origin_m` is the map's local origin height.
    fn write(&mut self, i: usize, cell_points: u64, e: &CellEstimate, z_origin_m: f64) {
        self.ground_z_m.data[i] = (z_origin_m + e.ground_z_local_m) as f32;
        self.ground_gradient.data[i] = [e.gradient[0] as f32, e.gradient[1] as f32];
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

/// The known ground under the map's cells: the fitted plane's height and gradient per cell
/// ([`TraversabilityLayers::ground_z_m`], [`TraversabilityLayers::ground_gradient`]).
#[derive(Clone, Copy, Debug)]
pub struct GroundModel<'a> {
    /// Ground height per cell, map frame, metres (NaN where unknown).
    pub z_m: &'a Grid<f32>,
    /// Ground gradient (∂z/∂x, ∂z/∂y) per cell (NaN where unknown).
    pub gradient: &'a Grid<[f32; 2]>,
}

impl GroundModel<'_> {
    /// (height, gradient) of the ground under (x, y), where the map knows it: the plane of the
    /// cell holding (x, y), evaluated at (x, y).
    pub fn at(&self, x_m: f64, y_m: f64) -> Option<(f64, [f64; 2])> {
        let g = self.z_m.geometry;
        let cell = g.cell_of(x_m, y_m)?;
        let i = g.index(cell)?;
        let (z, [gx, gy]) = (self.z_m.data[i], self.gradient.data[i]);
        if !(z.is_finite() && gx.is_finite() && gy.is_finite()) {
            return None;
        }
        let (cx, cy) = g.center_of(cell);
        let (gx, gy) = (f64::from(gx), f64::from(gy));
        Some((f64::from(z) + gx * (x_m - cx) + gy * (y_m - cy), [gx, gy]))
    }
}

/// One cell's result (NaN fields when unknown).
pub(super) struct CellEstimate {
    /// Plane height above the cell's centre relative to the map's local origin, metres.
    pub(super) ground_z_local_m: f64,
    /// Plane gradient (∂z/∂x, ∂z/∂y).
    pub(super) gradient: [f64; 2],
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

/// The centred moments of a disc (relative to its cell's centre and reference height) when they
/// make the cell known: at least `min_points` points (and one), finite, and spread horizontally
/// (standard deviation along the narrowest horizontal direction ≥ `min_spread_ratio ·
/// disc_radius_m`). Shared by the estimate and [`TraversabilityMap::refresh_known`], so a known
/// flag is exactly "score not NaN"; O(1).
pub(super) fn known_moments(sum: &DiscSum, p: &TraversabilityParams) -> Option<CellMoments> {
    if sum.count == 0 || sum.count < u64::from(p.min_points) {
        return None;
    }
    let fused = sum.moments();
    if !fused.mean.iter().chain(&fused.scatter).all(|v| v.is_finite()) {
        return None;
    }
    // Horizontal spread: smallest eigenvalue of the 2×2 xy covariance.
    let k = 1.0 / fused.count as f64;
    let (a, b, c) = (fused.scatter[0] * k, fused.scatter[1] * k, fused.scatter[3] * k);
    let lambda_xy = 0.5 * (a + c) - (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let min_spread = p.min_spread_ratio * p.disc_radius_m;
    let spread = lambda_xy.max(0.0).sqrt();
    if min_spread > 0.0 && (spread.is_nan() || spread < min_spread) {
        return None;
    }
    Some(fused)
}

/// The estimate of cell `index` from its disc sum (slope, roughness) and its disc's non-empty
/// cells (step): O(disc cells), no allocation.
#[inline]
pub(super) fn estimate_cell(
    sums: &DiscSums,
    moments: &[CellMoments],
    g: &GridGeometry,
    index: usize,
    p: &TraversabilityParams,
) -> CellEstimate {
    let unknown = |disc_points: u64| CellEstimate {
        ground_z_local_m: f64::NAN,
        gradient: [f64::NAN; 2],
        slope_rad: f64::NAN,
        step_m: f64::NAN,
        roughness_m: f64::NAN,
        hazard: f64::NAN,
        score: f64::NAN,
        disc_points,
    };
    let sum = &sums.sums[index];
    let Some(fused) = known_moments(sum, p) else {
        return unknown(sum.count);
    };
    // Known moments are finite with count ≥ 1, so the fit exists.
    let Some(plane) = fit_plane(&fused) else {
        return unknown(fused.count);
    };
    let (x_c, y_c) = centre_local(g, index);
    let z_ref = sum.z_ref_m;
    let relative = p.step_relative_to_plane && plane.height_at(0.0, 0.0).is_some();
    let (mut raw_hi, mut raw_lo, mut hi, mut lo) = (f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
    // The extremes as plain comparisons: the accumulators start infinite and never become NaN, so
    // `a.max(x)` is `x > a ? x : a` (and min alike) without its NaN test on `a`. The plane's height
    // is `PlaneFit::height_at` written out (`relative` checked it exists), the same operations.
    let ([cx, cy, cz], [nx, ny, nz]) = (plane.centroid, plane.normal);
    sums.disc.for_each(g, index, |k, _, _| {
        let m = &moments[k];
        // Empty cells (z_max = −∞, z_min = +∞) would change nothing: skipped, with their
        // plane-height division.
        if m.count == 0 {
            return;
        }
        raw_hi = if m.z_max > raw_hi { m.z_max } else { raw_hi };
        raw_lo = if m.z_min < raw_lo { m.z_min } else { raw_lo };
        if relative {
            let z = z_ref + (cz - (nx * ((m.mean[0] - x_c) - cx) + ny * ((m.mean[1] - y_c) - cy)) / nz);
            let (above, below) = (m.z_max - z, m.z_min - z);
            hi = if above > hi { above } else { hi };
            lo = if below < lo { below } else { lo };
        }
    });
    let raw_step_m = raw_hi - raw_lo;
    let mut step_m = raw_step_m;
    // Never more than the raw height range: a steep plane's heights are ill-conditioned (its
    // slope makes the cell lethal anyway).
    if relative && hi >= lo {
        step_m = (hi - lo).min(raw_step_m);
    }
    // What the points' registration noise explains does not count (TraversabilityParams::
    // noise_discount_sigmas); exact no-op when they carry no variance.
    let (mut step_h, mut roughness_h) = (step_m, plane.roughness_m);
    if sum.var_sum_m2 > 0.0 && p.noise_discount_sigmas > 0.0 {
        let k2_var = p.noise_discount_sigmas * p.noise_discount_sigmas * sum.var_sum_m2 / fused.count as f64;
        roughness_h = (roughness_h * roughness_h - k2_var).max(0.0).sqrt();
        step_h = (step_h - (2.0 * k2_var).sqrt()).max(0.0);
    }
    let hazard =
        ratio(plane.slope_rad, p.max_slope_rad).max(ratio(step_h, p.max_step_m)).max(ratio(roughness_h, p.max_roughness_m)).clamp(0.0, 1.0);
    let [nx, ny, nz] = plane.normal;
    let (ground_z_local_m, gradient) = match plane.height_at(0.0, 0.0) {
        Some(h) => (z_ref + h, [-nx / nz, -ny / nz]),
        None => (f64::NAN, [f64::NAN; 2]),
    };
    CellEstimate {
        ground_z_local_m,
        gradient,
        slope_rad: plane.slope_rad,
        step_m,
        roughness_m: plane.roughness_m,
        hazard,
        score: 1.0 - hazard,
        disc_points: fused.count,
    }
}

impl TraversabilityMap {
    /// Computes every layer from scratch (notes §2) from the map's disc sums (built from the cell
    /// moments first when the map has none for this disc radius). O(cells × disc cells).
    pub fn compute(&self, params: &TraversabilityParams) -> TraversabilityLayers {
        let g = self.geometry;
        let owned;
        let sums = match &self.discs {
            Some(d) if d.radius_m.to_bits() == params.disc_radius_m.to_bits() => d,
            _ => {
                owned = DiscSums::from_moments(params.disc_radius_m, &g, &self.moments);
                &owned
            }
        };
        let mut layers = TraversabilityLayers::unknown(g, params);
        for i in 0..g.len() {
            let e = estimate_cell(sums, &self.moments, &g, i, params);
            layers.write(i, self.moments[i].count, &e, self.z_origin_m.unwrap_or(0.0));
        }
        layers
    }

    /// Brings `layers` up to date with the points inserted since their cells were last
    /// estimated, recomputing only the cells whose disc changed, in row-major order (neighbouring
    /// discs share cache lines); the result equals [`Self::compute`] bit for bit. Recomputes
    /// everything when `layers` has another geometry, was computed with other parameters, or the
    /// map was cleared. Returns the number of cells recomputed.
    pub fn update(&mut self, params: &TraversabilityParams, layers: &mut TraversabilityLayers) -> usize {
        let g = self.geometry;
        self.ensure_discs(params.disc_radius_m);
        if self.stale_estimate.all || layers.geometry() != g || layers.computed_with != *params {
            *layers = self.compute(params);
            self.stale_estimate.clear();
            return g.len();
        }
        let Some(sums) = &self.discs else { unreachable!("ensure_discs built them") };
        let mut n = 0;
        // A cell refreshed on its own since it was listed (Self::refresh_cells) is skipped.
        let moments = &self.moments;
        let ahead = |a: usize| {
            sums.sums[a].prefetch();
            for &o in &sums.disc.flat {
                if let Some(m) = moments.get(a.wrapping_add_signed(o)) {
                    prefetch(m);
                    prefetch(&m.var_sum_m2);
                }
            }
        };
        self.stale_estimate.drain_in_order(ahead, |j| {
            let e = estimate_cell(sums, &self.moments, &g, j, params);
            layers.write(j, self.moments[j].count, &e, self.z_origin_m.unwrap_or(0.0));
            n += 1;
        });
        n
    }

    /// Re-estimates the cells `indices` whose disc changed since their last estimate — for lazy
    /// users that need a few cells now (a path corridor) and the whole map later. Does a full
    /// [`Self::update`] instead when `layers` does not match the map or its parameters (checked
    /// once per call). O(disc cells) per stale cell, O(1) per other index; indices outside the
    /// grid are ignored.
    pub(crate) fn refresh_cells(
        &mut self,
        indices: impl IntoIterator<Item = usize>,
        params: &TraversabilityParams,
        layers: &mut TraversabilityLayers,
    ) {
        let g = self.geometry;
        self.ensure_discs(params.disc_radius_m);
        if self.stale_estimate.all || layers.geometry() != g || layers.computed_with != *params {
            self.update(params, layers);
            return;
        }
        let Some(sums) = &self.discs else { unreachable!("ensure_discs built them") };
        let flag = &mut self.stale_estimate.flag;
        for index in indices {
            if index < g.len() && std::mem::take(&mut flag[index]) {
                let e = estimate_cell(sums, &self.moments, &g, index, params);
                layers.write(index, self.moments[index].count, &e, self.z_origin_m.unwrap_or(0.0));
            }
        }
    }

    /// Brings the per-cell "known" flags up to date without estimating anything: a cell is known
    /// when its score would not be NaN ([`known_moments`]: enough points in its disc, spread out
    /// horizontally). Calls `changed(index, known)` for every flag that flipped since the last
    /// call, in row-major order (all cells the first time, or when the disc radius, `min_points` or
    /// `min_spread_ratio` changed). O(cells whose disc changed), O(1) each, plus ordering them.
    pub(crate) fn refresh_known(&mut self, params: &TraversabilityParams, mut changed: impl FnMut(usize, bool)) {
        self.ensure_discs(params.disc_radius_m);
        let key = (params.disc_radius_m.to_bits(), params.min_points, params.min_spread_ratio.to_bits());
        if self.known_with != Some(key) {
            self.known_with = Some(key);
            self.stale_known.mark_all();
        }
        let Some(sums) = &self.discs else { unreachable!("ensure_discs built them") };
        let mut check = |j: usize, known: &mut [bool]| {
            let k = known_moments(&sums.sums[j], params).is_some();
            if k != known[j] {
                known[j] = k;
                changed(j, k);
            }
        };
        let stale = &mut self.stale_known;
        if stale.all {
            for j in 0..self.known.len() {
                check(j, &mut self.known);
            }
            stale.clear();
        } else {
            stale.drain_in_order(|a| sums.sums[a].prefetch(), |j| check(j, &mut self.known));
        }
    }
}
