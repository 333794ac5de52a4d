//! A VLP-16-like 3D LiDAR (notes §8): `rings` beams evenly spread over ±`half_vfov_rad`, swept over
//! 360° at `azimuth_step_rad`, each ray-marched against the heightfield (every obstacle is in the
//! heightfield) up to `max_range_m`, with Gaussian range noise.
//!
//! Ray casting is exact against the bilinear surface and accelerated by a maximum mip-map
//! ("maximum mipmap" heightfield ray tracing, Tevs, Ihrke & Seidel 2008):
//! - the surface is split into *patches* between four neighbouring sample centres (half patches
//!   at the border, where `Heightfield::height_at` clamps), on which the height is bilinear;
//! - level 0 stores each patch's highest corner (a bilinear patch's maximum is at a corner),
//!   level k the maximum over 2^k × 2^k patches, rounded up to `f32`, each level in 4 × 4-node
//!   tiles of one cache line;
//! - the ray walks the quadtree: a node whose maximum lies below the ray's lowest z over the
//!   node is skipped whole (and the walk climbs a level), otherwise it descends; on a patch the
//!   height along the ray is a quadratic in t, so the first crossing is the smallest root of
//!   z(t) − h(t) in the patch's t interval, in closed form;
//! - the walk's crossing times are estimates (products by the direction's reciprocal), a node is
//!   skipped only when the ray clears it by far more than their rounding, and a patch is tested
//!   over its exact span (the quotients of its own sides' crossings), so the answer is the one of
//!   a walk on exact crossings, bit for bit, but for a ray through a patch corner to the last bit,
//!   where the exact walk's own entry time depends on its rounding (test
//!   `the_walk_answers_as_the_exact_node_by_node_walk_bit_for_bit`);
//! - a sweep's rays share a horizon (`horizon::Horizon`): a ray starts its walk where it can first meet
//!   the terrain and ends it once it passes above everything it can still reach;
//! - going down, the walk climbs back only into parents it has not opened (a node the ray does not
//!   clear at its exit it never clears).
//!
//! Per ray: O(levels × nodes crossed + patches near the terrain), no allocation; per scan
//! O(rings × azimuths × that), the origin's lookup and the horizon done once, ring by ring (a
//! ring's neighbouring rays end on neighbouring patches, in cache). [`RayCaster::new`] is O(cells).

mod horizon;

use super::heightfield::Heightfield;
use crate::math;
use horizon::Horizon;
use nalgebra::{Point3, Rotation3, Vector3};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// LiDAR geometry and noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarParams {
    /// Number of rings, 1..=256. Default 16 (VLP-16).
    pub rings: usize,
    /// Half the vertical field of view, radians, in [0, π/2]. Default 15°.
    pub half_vfov_rad: f64,
    /// Azimuth step, radians, in (0, 2π]. Default 2° (a VLP-16 has 0.2°; coarser keeps the simulator fast,
    /// and the map accumulates scans).
    pub azimuth_step_rad: f64,
    /// Largest range, metres, > 0. Default 10.
    pub max_range_m: f64,
    /// Smallest range, metres, in [0, `max_range_m`). Default 0.4 (the robot's own body).
    pub min_range_m: f64,
    /// Range noise σ, metres, ≥ 0. Default 0.01.
    pub range_sigma_m: f64,
    /// Sensor height above the ground along the body's z, metres, ≥ 0. Default 0.3.
    pub mount_height_m: f64,
}

impl Default for LidarParams {
    fn default() -> Self {
        Self {
            rings: 16,
            half_vfov_rad: 15f64.to_radians(),
            azimuth_step_rad: 2f64.to_radians(),
            max_range_m: 10.0,
            min_range_m: 0.4,
            range_sigma_m: 0.01,
            mount_height_m: 0.3,
        }
    }
}

/// Mip levels above the patch level (level k nodes cover 2^k × 2^k patches; 2^6 patches = 3.2 m
/// at 5 cm cells).
const MAX_LEVEL: usize = 6;

/// 4 × 4 nodes of one mip level, row-major, in one 64-byte cache line.
#[derive(Clone, Copy, Debug)]
#[repr(align(64))]
struct Tile([f32; 16]);

/// One level of the maximum mip-map: `width` × `height` nodes in 4 × 4 tiles, the tiles
/// row-major, so that a ray's successive nodes mostly share a cache line (row-major nodes put
/// every step across a row on another line).
#[derive(Clone, Debug)]
struct MaxLevel {
    tiles: Vec<Tile>,
    tiles_width: usize,
    width: usize,
    height: usize,
}

impl MaxLevel {
    /// A level of `width` × `height` nodes, all −∞.
    fn new(width: usize, height: usize) -> Self {
        let tiles_width = width.div_ceil(4);
        Self { tiles: vec![Tile([f32::NEG_INFINITY; 16]); tiles_width * height.div_ceil(4)], tiles_width, width, height }
    }

    /// The maximum of node (`i`, `j`), metres.
    #[inline]
    fn max_m(&self, i: usize, j: usize) -> f32 {
        self.tiles[(j >> 2) * self.tiles_width + (i >> 2)].0[(j & 3) * 4 + (i & 3)]
    }

    #[inline]
    fn max_m_mut(&mut self, i: usize, j: usize) -> &mut f32 {
        &mut self.tiles[(j >> 2) * self.tiles_width + (i >> 2)].0[(j & 3) * 4 + (i & 3)]
    }
}

/// `v` rounded up to an `f32` (never below `v`, so skipping on it is conservative).
fn f32_at_least(v: f64) -> f32 {
    let f = v as f32;
    if f64::from(f) < v { f.next_up() } else { f }
}

/// A ray caster over a heightfield with a maximum mip-map (see the module doc).
#[derive(Clone, Debug)]
pub struct RayCaster {
    geometry: crate::grid::GridGeometry,
    /// levels[0]: one node per patch, (width + 1) × (height + 1) patches.
    levels: Vec<MaxLevel>,
}

impl RayCaster {
    /// Builds the maximum mip-map. O(cells).
    pub fn new(field: &Heightfield) -> Self {
        let g = field.geometry;
        let (w, h) = (g.width, g.height);
        let z = |c: usize, r: usize| field.heights_m.get(r * w + c).copied().unwrap_or(f64::INFINITY);
        // Patch (p, q) spans sample columns p − 1, p and rows q − 1, q, clamped to the grid.
        let (pw, ph) = (w + 1, h + 1);
        let mut level0 = MaxLevel::new(pw, ph);
        for q in 0..ph {
            let (r0, r1) = (q.saturating_sub(1).min(h.saturating_sub(1)), q.min(h.saturating_sub(1)));
            for p in 0..pw {
                let (c0, c1) = (p.saturating_sub(1).min(w.saturating_sub(1)), p.min(w.saturating_sub(1)));
                let m = z(c0, r0).max(z(c1, r0)).max(z(c0, r1)).max(z(c1, r1));
                // NaN heights never let a ray skip: +∞.
                *level0.max_m_mut(p, q) = if m.is_nan() { f32::INFINITY } else { f32_at_least(m) };
            }
        }
        let mut levels = vec![level0];
        while levels.len() <= MAX_LEVEL {
            let below = &levels[levels.len() - 1];
            if below.width <= 1 && below.height <= 1 {
                break;
            }
            let mut next = MaxLevel::new(below.width.div_ceil(2), below.height.div_ceil(2));
            for r in 0..below.height {
                for c in 0..below.width {
                    let m = next.max_m_mut(c / 2, r / 2);
                    *m = m.max(below.max_m(c, r));
                }
            }
            levels.push(next);
        }
        Self { geometry: g, levels }
    }

    /// Distance along the unit direction `dir` from `origin` to the first terrain hit within
    /// `max_range_m` (0 when `origin` is not above the terrain); `None` if the ray leaves the map
    /// or the range first, or `origin` is outside the map.
    pub fn cast(&self, field: &Heightfield, origin: Point3<f64>, dir: Vector3<f64>, max_range_m: f64) -> Option<f64> {
        if !self.built_for(field) {
            // Built for another field: correct, if slow.
            return RayCaster::new(field).cast(field, origin, dir, max_range_m);
        }
        self.cast_from(field, self.ray_origin(field, origin), dir, max_range_m, None)
    }

    /// Whether this caster's mip-map is `field`'s.
    fn built_for(&self, field: &Heightfield) -> bool {
        field.geometry == self.geometry && field.heights_m.len() == self.geometry.len()
    }

    /// The direction-independent part of a cast from `origin` (a sweep's rays share it).
    fn ray_origin(&self, field: &Heightfield, origin: Point3<f64>) -> RayOrigin {
        let g = self.geometry;
        let (w, h) = (g.width, g.height);
        if w == 0 || h == 0 {
            return RayOrigin::Outside;
        }
        let Some(z0) = field.height_at(origin.x, origin.y) else { return RayOrigin::Outside };
        if origin.z <= z0 {
            return RayOrigin::Below;
        }
        // Sample coordinates: u = (x − x₀)/res − ½, so sample column c sits at u = c and patch p
        // spans u ∈ [p − 1, p] (clipped to the grid's u ∈ [−½, w − ½)).
        let inv_res = 1.0 / g.resolution_m;
        let (au, av) = ((origin.x - g.origin_x_m) * inv_res - 0.5, (origin.y - g.origin_y_m) * inv_res - 0.5);
        RayOrigin::Above { au, av, oz: origin.z, p: patch_index(au, w), q: patch_index(av, h) }
    }

    /// [`Self::cast`] from an origin prepared by [`Self::ray_origin`] (on `field`, which this
    /// caster was built for); `horizon`, when given, was built for this origin and `max_range_m`.
    fn cast_from(
        &self,
        field: &Heightfield,
        origin: RayOrigin,
        dir: Vector3<f64>,
        max_range_m: f64,
        horizon: Option<&Horizon>,
    ) -> Option<f64> {
        let (au, av, oz, mut p, mut q) = match origin {
            RayOrigin::Outside => return None,
            RayOrigin::Below => return Some(0.0),
            RayOrigin::Above { au, av, oz, p, q } => (au, av, oz, p, q),
        };
        if max_range_m.is_nan() || max_range_m <= 0.0 || !dir.iter().all(|v| v.is_finite()) {
            return None;
        }
        let g = self.geometry;
        let (w, h) = (g.width, g.height);
        let inv_res = 1.0 / g.resolution_m;
        let (bu, bv, dz) = (dir.x * inv_res, dir.y * inv_res, dir.z);
        let top = self.levels.len() - 1;
        let mut level = 0usize;
        let ray = [au, bu, av, bv, oz, dz];
        let origin_patch = (p, q);
        // The walk's crossing times are estimates (a product by the reciprocal instead of a
        // quotient): nodes are skipped only when the ray clears them by far more than the
        // estimates' rounding, and a patch is tested on its exact crossings ([`exact_patch_hit`]).
        let (ru, rv) = (1.0 / bu, 1.0 / bv);
        let mut t = 0.0f64;
        // Bit k: the level-k node holding the ray was entered and not skipped.
        let mut open = 0u64;
        // The horizon's bounds along this ray's direction, its horizontal distance (sample units)
        // per unit t and its lowest z over [t, max_range_m] going down: the test below ends a ray
        // that stays above every patch it can still reach, whose walk would end in `None`.
        let ahead = horizon.map(|hz| hz.along(bu, bv));
        let h_uv = (bu * bu + bv * bv).sqrt();
        let z_end = oz + dz * max_range_m;
        // Nothing can be hit before the horizon's first reachable bin: the walk starts there
        // (just before, on the patch holding the ray; its test spans the whole patch), or the ray
        // misses if it is outside the map by then.
        if let Some((_, within)) = ahead
            && h_uv > 0.0
        {
            let d_max = max_range_m * h_uv * (1.0 + SLACK);
            let d = Horizon::first_reach(within, d_max, oz, dz / h_uv)?;
            if d > 0.0 {
                let t_start = d / h_uv * (1.0 - SLACK);
                let (u, v) = (au + bu * t_start, av + bv * t_start);
                let inside = |x: f64, n: usize| x > -0.5 + 1e-6 && x < n as f64 - 0.5 - 1e-6;
                let outside = |x: f64, n: usize| !(x > -0.5 - 1e-6 && x < n as f64 - 0.5 + 1e-6);
                if outside(u, w) || outside(v, h) {
                    return None;
                }
                if inside(u, w) && inside(v, h) {
                    t = t_start;
                    (p, q) = (patch_index(u, w), patch_index(v, h));
                }
            }
        }
        loop {
            if let Some((beyond, _)) = ahead {
                let z_floor = if dz < 0.0 { z_end } else { oz + dz * t };
                if z_floor - slack(z_floor, dz * t) > Horizon::max_beyond(beyond, t * h_uv) {
                    return None;
                }
            }
            let (ni, nj) = (p >> level, q >> level);
            // The node's patch range and its u, v extent, clipped to the grid.
            let (p_lo, p_hi) = (ni << level, (((ni + 1) << level) - 1).min(w));
            let (q_lo, q_hi) = (nj << level, (((nj + 1) << level) - 1).min(h));
            let (u_lo, u_hi) = ((p_lo as f64 - 1.0).max(-0.5), (p_hi as f64).min(w as f64 - 0.5));
            let (v_lo, v_hi) = ((q_lo as f64 - 1.0).max(-0.5), (q_hi as f64).min(h as f64 - 0.5));
            let tx = if bu > 0.0 {
                (u_hi - au) * ru
            } else if bu < 0.0 {
                (u_lo - au) * ru
            } else {
                f64::INFINITY
            };
            let ty = if bv > 0.0 {
                (v_hi - av) * rv
            } else if bv < 0.0 {
                (v_lo - av) * rv
            } else {
                f64::INFINITY
            };
            let t_exit = tx.min(ty).max(t);
            let seg_end = t_exit.min(max_range_m);
            let z_low = oz + dz * if dz < 0.0 { seg_end } else { t };
            let node_max = f64::from(self.levels[level].max_m(ni, nj));
            if z_low - slack(z_low, dz * seg_end) <= node_max {
                if level > 0 {
                    open |= 1 << level;
                    level -= 1;
                    continue;
                }
                match exact_patch_hit(field, (p, q), origin_patch, ray, max_range_m) {
                    PatchHit::Hit(hit) => return Some(hit),
                    PatchHit::BeyondRange => return None,
                    PatchHit::Miss => {}
                }
            }
            if t_exit > max_range_m * (1.0 + SLACK) {
                return None;
            }
            // Step into the next node along the exit side(s); the other index follows the ray,
            // kept inside this node's range against rounding.
            t = t_exit;
            let (p_was, q_was) = (p, q);
            p = next_patch(tx <= ty, p, (p_lo, p_hi), au + bu * t, bu, w)?;
            q = next_patch(ty <= tx, q, (q_lo, q_hi), av + bv * t, bv, h)?;
            // Going down, a node that was not skipped never will be (its lowest z is at its exit):
            // the walk climbs back only into a parent it has not opened.
            let moved = (p_was ^ p) | (q_was ^ q);
            open &= !(u64::MAX >> (moved.leading_zeros() + u64::BITS - usize::BITS).min(63));
            if dz >= 0.0 || open & (1 << (level + 1)) == 0 {
                level = (level + 1).min(top);
            }
        }
    }
}

/// Relative margin of the walk's estimated crossing times (their rounding is ~1e-16).
const SLACK: f64 = 1e-9;

/// How far below its estimate `z` (= a + `dz_t`) a height computed from an estimated crossing
/// time can truly be, with room to spare.
#[inline]
fn slack(z: f64, dz_t: f64) -> f64 {
    SLACK * (1.0 + z.abs() + dz_t.abs())
}

/// What [`exact_patch_hit`] found.
enum PatchHit {
    /// The first hit, at this distance.
    Hit(f64),
    /// No hit in the patch.
    Miss,
    /// The ray enters the patch at or past its range: no hit here or further on.
    BeyondRange,
}

/// [`patch_hit`] on patch (`p`, `q`) over the ray's exact span in it: entering at 0 in the
/// origin's patch, else at the later of its crossings of the patch's entry sides, and leaving at
/// the earlier of its crossings of the exit sides (or `max_range_m`). These are the crossing
/// times, quotient for quotient, of a walk that steps patch by patch (or node by node: a node's
/// side is a side of the patches along it). O(1).
#[inline]
fn exact_patch_hit(field: &Heightfield, (p, q): (usize, usize), origin: (usize, usize), ray: [f64; 6], max_range_m: f64) -> PatchHit {
    let [au, bu, av, bv, ..] = ray;
    let g = &field.geometry;
    let (w, h) = (g.width as f64, g.height as f64);
    let (u_lo, u_hi) = ((p as f64 - 1.0).max(-0.5), (p as f64).min(w - 0.5));
    let (v_lo, v_hi) = ((q as f64 - 1.0).max(-0.5), (q as f64).min(h - 0.5));
    // (entry, exit) crossing of one axis's sides.
    let crossings = |lo: f64, hi: f64, a: f64, b: f64| {
        if b > 0.0 {
            ((lo - a) / b, (hi - a) / b)
        } else if b < 0.0 {
            ((hi - a) / b, (lo - a) / b)
        } else {
            (f64::NEG_INFINITY, f64::INFINITY)
        }
    };
    let (u_in, u_out) = crossings(u_lo, u_hi, au, bu);
    let (v_in, v_out) = crossings(v_lo, v_hi, av, bv);
    let t0 = if (p, q) == origin { 0.0 } else { u_in.max(v_in) };
    if t0 >= max_range_m {
        return PatchHit::BeyondRange;
    }
    let seg_end = u_out.min(v_out).max(t0).min(max_range_m);
    match patch_hit(field, p, q, ray, t0, seg_end) {
        Some(t) => PatchHit::Hit(t),
        None => PatchHit::Miss,
    }
}

/// Where a ray starts, relative to the terrain ([`RayCaster::cast`]).
#[derive(Clone, Copy, Debug)]
enum RayOrigin {
    /// Outside the map (or an empty map): no hit.
    Outside,
    /// At or below the terrain: a hit at 0.
    Below,
    /// Above the terrain at sample coordinates (`au`, `av`), height `oz`, in patch (`p`, `q`).
    Above { au: f64, av: f64, oz: f64, p: usize, q: usize },
}

/// One axis of the walk's step to the next node: the patch index after the node spanning
/// `lo..=hi` (`n` patches along the axis). When the ray `exits` across this axis it moves one past
/// the node's side, `None` past the grid; otherwise the index follows the ray's coordinate `u`
/// (slope `b`), kept in the node's range and monotone along the ray so the walk always progresses.
#[inline]
fn next_patch(exits: bool, index: usize, (lo, hi): (usize, usize), u: f64, b: f64, n: usize) -> Option<usize> {
    if exits {
        return if b > 0.0 { Some(hi + 1).filter(|&i| i <= n) } else { lo.checked_sub(1) };
    }
    if b == 0.0 {
        return Some(index);
    }
    let along = patch_index(u, n).clamp(lo, hi);
    Some(if b > 0.0 { along.max(index) } else { along.min(index) })
}

/// Patch index of a coordinate inside the grid (u ≥ −½, so u + 1 > 0 truncates = floor).
#[inline]
fn patch_index(u: f64, n: usize) -> usize {
    ((u + 1.0).max(0.0) as usize).min(n)
}

/// The first t in [t0, t1] where the ray `[au, bu, av, bv, oz, dz]` (u = au + bu·t,
/// v = av + bv·t, z = oz + dz·t) is at or below the bilinear surface of patch (p, q), if any.
/// With s, r the patch-local coordinates, h = h₀₀ + (h₁₀ − h₀₀)s + (h₀₁ − h₀₀)r + e·s·r, so
/// f(τ) = z − h = c₀ + c₁τ + c₂τ² with τ = t − t0. O(1).
#[inline]
fn patch_hit(field: &Heightfield, p: usize, q: usize, ray: [f64; 6], t0: f64, t1: f64) -> Option<f64> {
    let [au, bu, av, bv, oz, dz] = ray;
    let g = &field.geometry;
    let (w, h) = (g.width, g.height);
    let (c0, c1) = (p.saturating_sub(1).min(w - 1), p.min(w - 1));
    let (r0, r1) = (q.saturating_sub(1).min(h - 1), q.min(h - 1));
    let z = |c: usize, r: usize| field.heights_m[r * w + c];
    let (h00, h10, h01, h11) = (z(c0, r0), z(c1, r0), z(c0, r1), z(c1, r1));
    let (gx, gy, e) = (h10 - h00, h01 - h00, h11 - h10 - h01 + h00);
    // Patch-local coordinates at t0 (the border half patches have gx = e = 0 or gy = e = 0).
    let s0 = au + bu * t0 - (p as f64 - 1.0);
    let r0f = av + bv * t0 - (q as f64 - 1.0);
    let k0 = oz + dz * t0 - (h00 + gx * s0 + gy * r0f + e * s0 * r0f);
    if k0 <= 0.0 {
        return Some(t0);
    }
    let k1 = dz - (gx * bu + gy * bv + e * (s0 * bv + r0f * bu));
    let k2 = -e * bu * bv;
    let len = t1 - t0;
    let f = |x: f64| k0 + x * (k1 + x * k2);
    // Bracket [0, b] with f(0) > 0 ≥ f(b) holding exactly one root.
    let b = if f(len) <= 0.0 {
        len
    } else if k2 > 0.0 {
        // Both ends above: a crossing needs the (convex) f to dip below 0 in between.
        let vertex = -k1 / (2.0 * k2);
        if !(vertex > 0.0 && vertex < len && f(vertex) <= 0.0) {
            return None;
        }
        vertex
    } else {
        return None;
    };
    Some(t0 + first_root(k0, k1, k2, b))
}

/// The root of c₀ + c₁x + c₂x² in [0, b], given f(0) > 0 ≥ f(b) (so there is exactly one):
/// the numerically stable quadratic formula, with bisection if rounding put it outside.
fn first_root(c0: f64, c1: f64, c2: f64, b: f64) -> f64 {
    let f = |x: f64| c0 + x * (c1 + x * c2);
    let roots = if c2.abs() * b <= 1e-12 * c1.abs() {
        [-c0 / c1, f64::NAN]
    } else {
        let disc = (c1 * c1 - 4.0 * c0 * c2).max(0.0);
        let qf = -0.5 * (c1 + disc.sqrt().copysign(c1));
        [qf / c2, c0 / qf]
    };
    // The smallest root in [0, b]; else one within rounding of it.
    let tol = 1e-9 * b + 1e-12;
    let smallest_within = |lo: f64, hi: f64| roots.iter().copied().filter(|&x| x >= lo && x <= hi).reduce(f64::min);
    if let Some(x) = smallest_within(0.0, b).or_else(|| smallest_within(-tol, b + tol)) {
        return x.clamp(0.0, b);
    }
    let (mut lo, mut hi) = (0.0, b);
    for _ in 0..64 {
        let m = 0.5 * (lo + hi);
        if f(m) > 0.0 { lo = m } else { hi = m }
    }
    hi
}

/// Elevation angle of ring `k`, radians: evenly spaced from −half to +half.
pub(crate) fn ring_elevation_rad(params: &LidarParams, k: usize) -> f64 {
    if params.rings <= 1 {
        return 0.0;
    }
    -params.half_vfov_rad + 2.0 * params.half_vfov_rad * k as f64 / (params.rings - 1) as f64
}

/// One sweep from a sensor at `world_from_sensor` (position, rotation): appends the hit points
/// (world frame, with range noise) to `out`. Returns the number of rays cast.
pub fn scan(
    field: &Heightfield,
    caster: &RayCaster,
    sensor_m: Point3<f64>,
    world_from_sensor: &Rotation3<f64>,
    params: &LidarParams,
    rng: &mut ChaCha8Rng,
    out: &mut Vec<Point3<f64>>,
) -> usize {
    let n_az = (std::f64::consts::TAU / params.azimuth_step_rad).round().max(1.0) as usize;
    // cos/sin of each azimuth once per sweep instead of once per ray.
    let azimuths: Vec<(f64, f64)> = (0..n_az)
        .map(|a| {
            let az = a as f64 * params.azimuth_step_rad;
            (math::cos(az), math::sin(az))
        })
        .collect();
    let owned;
    let caster = if caster.built_for(field) {
        caster
    } else {
        owned = RayCaster::new(field);
        &owned
    };
    let origin = caster.ray_origin(field, sensor_m);
    let horizon = match origin {
        RayOrigin::Above { au, av, .. } => Horizon::new(caster, au, av, params.max_range_m),
        _ => None,
    };
    let mut rays = 0;
    for k in 0..params.rings {
        let el = ring_elevation_rad(params, k);
        let (ce, se) = (math::cos(el), math::sin(el));
        for &(ca, sa) in &azimuths {
            let dir = world_from_sensor * Vector3::new(ce * ca, ce * sa, se);
            rays += 1;
            if let Some(r) = caster.cast_from(field, origin, dir, params.max_range_m, horizon.as_ref()) {
                let noisy = r + params.range_sigma_m * gaussian(rng);
                if r >= params.min_range_m {
                    out.push(sensor_m + dir * noisy);
                }
            }
        }
    }
    rays
}

/// A standard normal sample ([`math::standard_normal`]).
pub(crate) fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    math::standard_normal(rng)
}

#[cfg(test)]
mod tests;
