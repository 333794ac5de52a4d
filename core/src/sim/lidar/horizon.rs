//! The horizon of one sweep: for the rays from one origin, the highest terrain they can still
//! reach in each direction beyond each horizontal distance, from the maximum mip-map.
//!
//! Directions are split into [`SECTORS`] sectors of a pseudo-angle (monotone in the angle, no
//! trigonometry), distances into bins of [`BIN`] samples. `beyond[s][k]` is the highest maximum of
//! the level-[`LEVEL`] nodes within the rays' reach that some direction of sector `s` crosses and
//! whose farthest corner is in bin k or beyond. Every patch a ray enters at t or later holds a point
//! of the ray at that distance or farther, in its direction, so its node is one of those: a ray
//! whose lowest z from t on (its z at t going up, at the range going down) is above the bound at
//! its distance at t passes above every patch it can still enter. The walk would skip them one by
//! one and return `None`; [`super::RayCaster`] returns `None` at once — the same answer. Likewise
//! `within[s][k]` bounds the nodes whose distances overlap bin k: up to the first bin where the ray
//! is not clearly above that bound it cannot meet the terrain, and its walk starts there. The
//! node extents are widened by a margin far above the rounding of t and of the coordinates.
//!
//! Built per sweep in O((range / node size)² · sectors a node spans); O(1) per query.

use super::RayCaster;

/// Direction sectors (5.6° each).
const SECTORS: usize = 64;
/// The horizon's nodes: level 3 (8 × 8 patches, 40 cm at 5 cm cells).
const LEVEL: usize = 3;
/// Distance bin, sample units.
const BIN: f64 = 8.0;
/// Relative margin on pseudo-angles and distances (rounding is ~1e-16).
const MARGIN: f64 = 1e-9;

/// The bounds of one sweep (see the module doc).
#[derive(Clone, Debug)]
pub(super) struct Horizon {
    /// Distance bins per direction.
    bins: usize,
    /// `SECTORS + 1` rows of `bins` bounds, metres; the last row bounds every direction (rays
    /// without a horizontal direction).
    beyond: Vec<f64>,
    /// The same rows, each bin bounding the nodes whose distances overlap it (not a suffix).
    within: Vec<f64>,
}

/// A pseudo-angle of (x, y) ≠ 0 in [0, 4): monotone in the angle from +x counter-clockwise.
#[inline]
fn pseudo_angle(x: f64, y: f64) -> f64 {
    let a = y / (x.abs() + y.abs());
    if x >= 0.0 { if y >= 0.0 { a } else { 4.0 + a } } else { 2.0 - a }
}

impl Horizon {
    /// The horizon of the rays from sample coordinates (`au`, `av`) up to `max_range_m`; `None`
    /// when the range is not a positive number.
    pub(super) fn new(caster: &RayCaster, au: f64, av: f64, max_range_m: f64) -> Option<Self> {
        if !(max_range_m > 0.0 && max_range_m.is_finite()) {
            return None;
        }
        let level = LEVEL.min(caster.levels.len() - 1);
        let nodes = &caster.levels[level];
        // Reach in sample units, with a margin for the rounding of t and a non-unit direction.
        let reach = max_range_m / caster.geometry.resolution_m * (1.0 + MARGIN) + 2.0;
        let bins = (reach / BIN) as usize + 2;
        let mut beyond = vec![f64::NEG_INFINITY; (SECTORS + 1) * bins];
        let mut within = vec![f64::NEG_INFINITY; (SECTORS + 1) * bins];
        // Node i spans patches i·2^level ..= (i + 1)·2^level − 1, i.e. u ∈ [i·2^level − 1, (i + 1)·2^level − 1].
        let size = (1usize << level) as f64;
        let node_range = |a: f64, n: usize| {
            let lo = ((a - reach + 1.0) / size).floor().max(0.0) as usize;
            let hi = (((a + reach + 1.0) / size).floor().max(0.0) as usize).min(n.saturating_sub(1));
            (lo, hi)
        };
        let (i_lo, i_hi) = node_range(au, nodes.width);
        let (j_lo, j_hi) = node_range(av, nodes.height);
        // Nearest and farthest offsets from `a` over [lo, hi].
        let span = |a: f64, lo: f64, hi: f64| ((lo - a).max(a - hi).max(0.0), (lo - a).abs().max((hi - a).abs()));
        let sector_of = |pa: f64| (pa * (SECTORS as f64 / 4.0)) as isize;
        for j in j_lo..=j_hi {
            let v0 = j as f64 * size - 1.0 - av;
            let (dv_near, dv_far) = span(0.0, v0, v0 + size);
            for i in i_lo..=i_hi {
                let u0 = i as f64 * size - 1.0 - au;
                let (du_near, du_far) = span(0.0, u0, u0 + size);
                if du_near * du_near + dv_near * dv_near > reach * reach {
                    continue;
                }
                let far = (du_far * du_far + dv_far * dv_far).sqrt() * (1.0 + MARGIN) + MARGIN;
                let near = (du_near * du_near + dv_near * dv_near).sqrt() * (1.0 - MARGIN) - MARGIN;
                let k = ((far / BIN) as usize).min(bins - 1);
                let k_near = ((near.max(0.0) / BIN) as usize).min(k);
                let m = f64::from(nodes.max_m(i, j));
                // The sectors the node's directions span: all of them when it is near the origin,
                // else the arc of its corners' pseudo-angles (under half a turn).
                let (s_lo, s_hi) = if du_near.max(dv_near) <= 1.0 {
                    (0, SECTORS as isize - 1)
                } else {
                    let mut pa = [(u0, v0), (u0 + size, v0), (u0, v0 + size), (u0 + size, v0 + size)].map(|(x, y)| pseudo_angle(x, y));
                    let (lo, hi) = pa.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &a| (l.min(a), h.max(a)));
                    let (lo, hi) = if hi - lo < 2.0 {
                        (lo, hi)
                    } else {
                        // Across +x: the angles past half a turn are the arc's start.
                        pa.iter_mut().filter(|a| **a < 2.0).for_each(|a| *a += 4.0);
                        pa.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &a| (l.min(a), h.max(a)))
                    };
                    (sector_of(lo - 4.0 * MARGIN), sector_of(hi + 4.0 * MARGIN))
                };
                let mut mark = |s: usize| {
                    let b = &mut beyond[s * bins + k];
                    *b = b.max(m);
                    for b in &mut within[s * bins + k_near..=s * bins + k] {
                        *b = b.max(m);
                    }
                };
                for s in s_lo..=s_hi.min(s_lo + SECTORS as isize - 1) {
                    mark(s.rem_euclid(SECTORS as isize) as usize);
                }
                mark(SECTORS);
            }
        }
        for row in beyond.chunks_mut(bins) {
            for k in (0..bins - 1).rev() {
                row[k] = row[k].max(row[k + 1]);
            }
        }
        Some(Self { bins, beyond, within })
    }

    /// The bounds of the rays along (`bu`, `bv`), by distance bin: at or beyond the bin, and
    /// overlapping it.
    #[inline]
    pub(super) fn along(&self, bu: f64, bv: f64) -> (&[f64], &[f64]) {
        let s = if bu == 0.0 && bv == 0.0 { SECTORS } else { ((pseudo_angle(bu, bv) * (SECTORS as f64 / 4.0)) as usize).min(SECTORS - 1) };
        let row = s * self.bins..(s + 1) * self.bins;
        (&self.beyond[row.clone()], &self.within[row])
    }

    /// Where a ray along `within` (from [`Self::along`]) can first meet the terrain: the start
    /// distance (sample units) of the first bin where the ray's lowest z, `oz + dz_per_d · d` at
    /// the bin's far end going down (near end going up), up to `d_max`, is not clearly above the
    /// bin's bound; `None` when no bin up to `d_max` is. O(bins).
    #[inline]
    pub(super) fn first_reach(within: &[f64], d_max: f64, oz: f64, dz_per_d: f64) -> Option<f64> {
        let down = dz_per_d < 0.0;
        for (k, &bound) in within.iter().enumerate() {
            let d0 = k as f64 * BIN;
            if d0 > d_max {
                return None;
            }
            let z = oz + dz_per_d * if down { (d0 + BIN).min(d_max) } else { d0 };
            if z - 1e-9 * (1.0 + z.abs() + (dz_per_d * d_max).abs()) <= bound {
                return Some(d0);
            }
        }
        None
    }

    /// The highest terrain at or beyond horizontal distance `d` (sample units, ≥ 0) in `bounds`
    /// (from [`Self::along`]), metres.
    #[inline]
    pub(super) fn max_beyond(bounds: &[f64], d: f64) -> f64 {
        let k = ((d * (1.0 - MARGIN) / BIN) as usize).min(bounds.len() - 1);
        bounds[k]
    }
}
