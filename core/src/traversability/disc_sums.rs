//! Disc sums: for every cell, the raw moments of the points in its disc, kept up to date as points
//! arrive — notes §2's "over a small disc around each cell fuse the moments", made incremental.
//!
//! For cell c with centre (x_c, y_c) and reference height z_c (the first point its disc received,
//! map-local), over the points p of its disc, with d = p − (x_c, y_c, z_c):
//!   n,  Σ d,  Σ d dᵀ;   then  μ = Σd / n,  S = Σ d dᵀ − n μ μᵀ  (the centred scatter).
//! The disc is symmetric (`disc_offsets`), so a point of cell k belongs to the discs of the cells
//! k + o for every offset o: insertion costs O(disc cells) per point (29 at the defaults), and an
//! estimate reads one sum instead of fusing 29 cells' moments. Precision: |d| is bounded by the
//! disc radius horizontally and by the relief within the disc vertically, so the subtraction in S
//! loses about ε·|d|² ≈ 10⁻¹⁷ m² for decimetre-sized discs — far below any roughness of interest.
//! The sums are rebuilt from the per-cell moments ([`DiscSums::from_moments`], parallel-axis shift)
//! when the disc radius changes; built either way they agree with the per-cell fusion to rounding.
//! Memory: 96 bytes per cell, beside the cell moments' 104; the map keeps the allocation across
//! rebuilds (a re-registration drops the sums and rebuilds them from the moments).

use super::moments::{CellMoments, add_outer};
use crate::cache::prefetch;
use crate::grid::GridGeometry;

/// Raw moments of one disc (see the module doc), coordinates relative to the cell's centre and
/// `z_ref_m`. `repr(C)`: [`DiscSum::prefetch`] relies on the field order (96 bytes, `count` first,
/// `var_sum_m2` last).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub(super) struct DiscSum {
    pub(super) count: u64,
    /// Reference height, map-local metres (the first point's z).
    pub(super) z_ref_m: f64,
    sum: [f64; 3],
    /// Σ d dᵀ, upper triangle xx, xy, xz, yy, yz, zz.
    sum_sq: [f64; 6],
    /// Σ of the points' vertical noise variances, m².
    pub(super) var_sum_m2: f64,
}

impl DiscSum {
    /// Adds `count` points whose mean is `mean` and centred scatter `scatter`, all relative to the
    /// disc's reference (parallel-axis shift: Σd += n μ, Σddᵀ += S + n μμᵀ).
    #[inline]
    fn add_moments(&mut self, count: u64, mean: [f64; 3], scatter: &[f64; 6], var_sum_m2: f64) {
        let n = count as f64;
        self.var_sum_m2 += var_sum_m2;
        for (s, m) in self.sum.iter_mut().zip(mean) {
            *s += n * m;
        }
        let s = &mut self.sum_sq;
        s[0] += scatter[0] + n * mean[0] * mean[0];
        s[1] += scatter[1] + n * mean[0] * mean[1];
        s[2] += scatter[2] + n * mean[0] * mean[2];
        s[3] += scatter[3] + n * mean[1] * mean[1];
        s[4] += scatter[4] + n * mean[1] * mean[2];
        s[5] += scatter[5] + n * mean[2] * mean[2];
        self.count += count;
    }

    /// Asks the cache for this sum's lines ahead of its use: the bytes at 0, 48 and 88 of its
    /// 96 are at most 48 apart, so every 64-byte line it spans is requested.
    #[inline(always)]
    pub(super) fn prefetch(&self) {
        prefetch(self);
        prefetch(&self.sum_sq[1]);
        prefetch(&self.var_sum_m2);
    }

    /// Adds one point, `d` relative to the disc's reference, with vertical noise variance `var_m2`.
    #[inline]
    fn add_point(&mut self, d: [f64; 3], var_m2: f64) {
        self.var_sum_m2 += var_m2;
        for (s, v) in self.sum.iter_mut().zip(d) {
            *s += v;
        }
        add_outer(&mut self.sum_sq, d, 1.0);
        self.count += 1;
    }

    /// The centred moments, coordinates relative to the cell's centre and `z_ref_m` (z range left
    /// empty: the disc's cells hold it). EMPTY when no point.
    pub(super) fn moments(&self) -> CellMoments {
        if self.count == 0 {
            return CellMoments::EMPTY;
        }
        let n = self.count as f64;
        let mean = self.sum.map(|v| v / n);
        let s = &self.sum_sq;
        // S = Σddᵀ − n μμᵀ, clamped at 0 on the diagonal (rounding).
        let scatter = [
            (s[0] - n * mean[0] * mean[0]).max(0.0),
            s[1] - n * mean[0] * mean[1],
            s[2] - n * mean[0] * mean[2],
            (s[3] - n * mean[1] * mean[1]).max(0.0),
            s[4] - n * mean[1] * mean[2],
            (s[5] - n * mean[2] * mean[2]).max(0.0),
        ];
        CellMoments { count: self.count, mean, scatter, ..CellMoments::EMPTY }
    }
}

/// The disc's cell offsets, as (dx, dy) and as row-major index offsets.
#[derive(Clone, Debug)]
pub(super) struct Disc {
    pub(super) offsets: Vec<(i32, i32)>,
    /// `dy · width + dx`, valid for cells at least `r_cells` inside the grid.
    pub(super) flat: Vec<isize>,
    pub(super) r_cells: i32,
}

impl Disc {
    pub(super) fn new(radius_m: f64, g: &GridGeometry) -> Self {
        let offsets = disc_offsets(radius_m, g.resolution_m);
        let flat = offsets.iter().map(|&(dx, dy)| dy as isize * g.width as isize + dx as isize).collect();
        let r_cells = offsets.iter().map(|&(dx, dy)| dx.abs().max(dy.abs())).max().unwrap_or(0);
        Self { offsets, flat, r_cells }
    }

    /// The disc sum of cell `c` from the cell moments of its disc, in offset order.
    fn sum_of(&self, g: &GridGeometry, c: usize, moments: &[CellMoments]) -> DiscSum {
        let mut sum = DiscSum::default();
        let (x_c, y_c) = centre_local(g, c);
        self.for_each(g, c, |k, _, _| {
            let m = &moments[k];
            if m.count == 0 {
                return;
            }
            if sum.count == 0 {
                sum.z_ref_m = m.mean[2];
            }
            sum.add_moments(m.count, [m.mean[0] - x_c, m.mean[1] - y_c, m.mean[2] - sum.z_ref_m], &m.scatter, m.var_sum_m2);
        });
        sum
    }

    /// Calls `f(k, col, row)` for every cell k = (col, row) of the disc around `index` that lies
    /// in the grid, in offset order (the column and row come from the offsets, k = index + the
    /// flat offset: no division per cell; the bounds are checked only near the grid's border).
    #[inline]
    pub(super) fn for_each(&self, g: &GridGeometry, index: usize, mut f: impl FnMut(usize, i32, i32)) {
        let (w, h) = (g.width as i32, g.height as i32);
        let (col, row) = ((index % g.width) as i32, (index / g.width) as i32);
        let r = self.r_cells;
        let interior = col >= r && row >= r && col + r < w && row + r < h;
        // One call site, so that `f` is inlined.
        for (&o, &(dx, dy)) in self.flat.iter().zip(&self.offsets) {
            let (c, rr) = (col + dx, row + dy);
            if interior || (c >= 0 && rr >= 0 && c < w && rr < h) {
                f(index.wrapping_add_signed(o), c, rr);
            }
        }
    }
}

/// The disc sums of every cell of one grid, for one disc radius.
#[derive(Clone, Debug)]
pub(super) struct DiscSums {
    pub(super) radius_m: f64,
    pub(super) disc: Disc,
    pub(super) sums: Vec<DiscSum>,
}

impl DiscSums {
    /// The sums of the points summarised by `moments` (map-local coordinates), O(cells × disc).
    pub(super) fn from_moments(radius_m: f64, g: &GridGeometry, moments: &[CellMoments]) -> Self {
        Self::from_moments_in(radius_m, g, moments, Vec::new())
    }

    /// [`DiscSums::from_moments`] written into `sums` (its contents are overwritten): a map
    /// rebuilt after every re-registration reuses one allocation instead of faulting in a fresh
    /// one (96 bytes per cell) each time.
    pub(super) fn from_moments_in(radius_m: f64, g: &GridGeometry, moments: &[CellMoments], mut sums: Vec<DiscSum>) -> Self {
        let disc = Disc::new(radius_m, g);
        sums.clear();
        sums.resize(g.len(), DiscSum::default());
        for (c, sum) in sums.iter_mut().enumerate() {
            *sum = disc.sum_of(g, c, moments);
        }
        Self { radius_m, disc, sums }
    }

    /// Recomputes from `moments` the sums of every cell whose disc holds one of `cells` (after
    /// those cells' moments were rebuilt) and calls `changed` with each, once. The same sums,
    /// bit for bit, as a full [`Self::from_moments_in`]. `mark` is scratch, one flag per cell,
    /// all false on entry and on return. O(|cells| × disc cells²).
    pub(super) fn rebuild_around(
        &mut self,
        g: &GridGeometry,
        moments: &[CellMoments],
        cells: &[u32],
        mark: &mut Vec<bool>,
        mut changed: impl FnMut(usize),
    ) {
        mark.resize(g.len(), false);
        let mut around = Vec::new();
        for &c in cells {
            self.disc.for_each(g, c as usize, |k, _, _| {
                if !std::mem::replace(&mut mark[k], true) {
                    around.push(k);
                }
            });
        }
        for &k in &around {
            mark[k] = false;
            self.sums[k] = self.disc.sum_of(g, k, moments);
            changed(k);
        }
    }

    /// Prefetches ([`prefetch`]) the sums of the disc around `index` (near the grid's border the
    /// row-major offsets wrap to other cells: harmless for a hint). O(disc cells).
    #[inline]
    pub(super) fn prefetch_disc(&self, index: usize) {
        for &o in &self.disc.flat {
            if let Some(s) = self.sums.get(index.wrapping_add_signed(o)) {
                s.prefetch();
            }
        }
    }

    /// Adds a point (map-local coordinates, vertical noise variance `var_m2`) of cell `index` to
    /// the discs containing that cell and calls `changed` with each of their indices.
    #[inline]
    pub(super) fn add_point(&mut self, g: &GridGeometry, index: usize, p: [f64; 3], var_m2: f64, mut changed: impl FnMut(usize)) {
        let (sums, res) = (&mut self.sums, g.resolution_m);
        self.disc.for_each(g, index, |c, col, row| {
            // centre_local(g, c), without its division.
            let (x_c, y_c) = ((f64::from(col) + 0.5) * res, (f64::from(row) + 0.5) * res);
            let s = &mut sums[c];
            if s.count == 0 {
                s.z_ref_m = p[2];
            }
            s.add_point([p[0] - x_c, p[1] - y_c, p[2] - s.z_ref_m], var_m2);
            changed(c);
        });
    }
}

/// Centre of cell `index`, relative to the grid's lower-left corner, metres.
#[inline]
pub(super) fn centre_local(g: &GridGeometry, index: usize) -> (f64, f64) {
    let (col, row) = (index % g.width, index / g.width);
    ((col as f64 + 0.5) * g.resolution_m, (row as f64 + 0.5) * g.resolution_m)
}

/// (dx, dy) offsets of the cells whose centre lies within `radius_m` of a cell's centre
/// (always including (0, 0)), row-major order.
pub(crate) fn disc_offsets(radius_m: f64, resolution_m: f64) -> Vec<(i32, i32)> {
    let r = if radius_m.is_finite() && resolution_m > 0.0 { (radius_m / resolution_m).max(0.0) } else { 0.0 };
    // 1e-9 tolerance: a radius that is an exact multiple of the resolution includes that ring.
    let r_cells = (r + 1e-9).floor().min(10_000.0) as i32;
    let r2 = r * r + 1e-9;
    (-r_cells..=r_cells)
        .flat_map(|dy| (-r_cells..=r_cells).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| f64::from(dx * dx + dy * dy) <= r2)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reused_buffer_gives_the_fresh_sums() {
        // 4 × 3 grid of 1 m cells, disc radius 1 m; moments in three cells. A buffer holding the
        // sums of other points (and of a larger grid) must not leak into the result.
        let g = GridGeometry::new(0.0, 0.0, 1.0, 4, 3);
        let mut moments = vec![CellMoments::EMPTY; g.len()];
        for (i, z) in [(0, 1.0), (5, 2.5), (11, -0.5)] {
            moments[i] = CellMoments { count: 2, mean: [0.5, 0.5, z], var_sum_m2: 1e-4, ..CellMoments::EMPTY };
        }
        let fresh = DiscSums::from_moments(1.0, &g, &moments);
        let dirty = vec![DiscSum { count: 7, z_ref_m: 3.0, ..DiscSum::default() }; 20];
        let reused = DiscSums::from_moments_in(1.0, &g, &moments, dirty);
        assert_eq!(reused.sums, fresh.sums);
        // Cell 1's disc (itself, 0, 2, 5) holds cells 0 and 5: four points.
        assert_eq!(reused.sums[1].count, 4);
    }

    #[test]
    fn hand_derived_sums_of_two_points() {
        // A 3 × 1 grid of 1 m cells, disc radius 1 m: each cell's disc is itself and its
        // neighbours. Points (0.5, 0.5, 2) in cell 0 and (1.5, 0.5, 4) in cell 1.
        let g = GridGeometry::new(0.0, 0.0, 1.0, 3, 1);
        let mut d = DiscSums { radius_m: 1.0, disc: Disc::new(1.0, &g), sums: vec![DiscSum::default(); 3] };
        let mut changed = Vec::new();
        d.add_point(&g, 0, [0.5, 0.5, 2.0], 1e-4, |c| changed.push(c));
        d.add_point(&g, 1, [1.5, 0.5, 4.0], 0.0, |c| changed.push(c));
        changed.sort();
        assert_eq!(changed, vec![0, 0, 1, 1, 2]);
        // Cell 1 (centre 1.5, 0.5) holds both: d = (−1, 0, 0) and (0, 0, 2) (z_ref = 2).
        let m = d.sums[1].moments();
        assert_eq!((m.count, m.mean), (2, [-0.5, 0.0, 1.0]));
        // S = Σddᵀ − nμμᵀ: xx 1 − 2·0.25 = 0.5, xz 0 − 2·(−0.5)·1 = 1, zz 4 − 2·1 = 2.
        assert_eq!(m.scatter, [0.5, 0.0, 1.0, 0.0, 0.0, 2.0]);
        // Cell 2 holds only the second point, its own reference.
        assert_eq!((d.sums[2].count, d.sums[2].z_ref_m, d.sums[2].moments().mean), (1, 4.0, [-1.0, 0.0, 0.0]));
        assert_eq!((d.sums[0].var_sum_m2, d.sums[1].var_sum_m2, d.sums[2].var_sum_m2), (1e-4, 1e-4, 0.0));
        // Rebuilt from per-cell moments: the same sums.
        let mut moments = vec![CellMoments::EMPTY; 3];
        moments[0].add_with_variance([0.5, 0.5, 2.0], 1e-4);
        moments[1].add([1.5, 0.5, 4.0]);
        let r = DiscSums::from_moments(1.0, &g, &moments);
        for c in 0..3 {
            let (a, b) = (r.sums[c].moments(), d.sums[c].moments());
            assert_eq!((a.count, r.sums[c].var_sum_m2), (b.count, d.sums[c].var_sum_m2));
            // Reference heights may differ (first cell vs first point): compare absolute means.
            let za = a.mean[2] + r.sums[c].z_ref_m;
            let zb = b.mean[2] + d.sums[c].z_ref_m;
            assert!((za - zb).abs() < 1e-12 && (a.mean[0] - b.mean[0]).abs() < 1e-12);
            assert!(a.scatter.iter().zip(b.scatter).all(|(u, v)| (u - v).abs() < 1e-12));
        }
    }
}
