//! Per-cell point moments — count, mean, centred scatter, z range — and their exact fusion.
//!
//! Notes §2: "per cell keep moments (count, sum, centred scatter; use a local origin for
//! precision)". Points are added one at a time with Welford's update
//!   n ← n + 1,  δ = p − μ,  μ ← μ + δ/n,  S ← S + (n − 1)/n · δδᵀ,
//! and two moment sets A, B are fused with the parallel-axis combination (Chan, Golub & LeVeque)
//!   n = n_A + n_B,  δ = μ_B − μ_A,  μ = μ_A + δ·n_B/n,  S = S_A + S_B + δδᵀ·n_A·n_B/n,
//! which equals the moments of the union of the two point sets exactly in real arithmetic (to
//! rounding in floating point). Coordinates are relative to the owning map's local origin and the
//! mean plus *centred* scatter are stored instead of raw sums Σp, Σppᵀ, so large (UTM-sized)
//! coordinates never cancel catastrophically. O(1) per point and per fusion, no allocation.

/// Moments of the points binned in one cell (or fused over several cells).
///
/// Coordinates (`mean`, `z_min`, `z_max`) are metres relative to the owning map's local origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CellMoments {
    /// Number of points.
    pub count: u64,
    /// Mean position (x, y, z), metres; zero when `count == 0`.
    pub mean: [f64; 3],
    /// Centred scatter Σ (p − μ)(p − μ)ᵀ, upper triangle in the order xx, xy, xz, yy, yz, zz, m².
    pub scatter: [f64; 6],
    /// Lowest z, metres; +∞ when empty.
    pub z_min: f64,
    /// Highest z, metres; −∞ when empty.
    pub z_max: f64,
    /// Sum of the points' vertical noise variances, m² (0 for points inserted without one).
    pub var_sum_m2: f64,
}

impl Default for CellMoments {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl CellMoments {
    /// Moments of no point.
    pub(crate) const EMPTY: Self =
        Self { count: 0, mean: [0.0; 3], scatter: [0.0; 6], z_min: f64::INFINITY, z_max: f64::NEG_INFINITY, var_sum_m2: 0.0 };

    #[cfg(test)]
    /// Adds one point (Welford). The caller guarantees finite coordinates.
    #[inline]
    pub fn add(&mut self, p: [f64; 3]) {
        self.add_with_variance(p, 0.0);
    }

    /// Adds one point whose height has noise variance `var_m2` (see [`Self::var_sum_m2`]).
    #[inline]
    pub(crate) fn add_with_variance(&mut self, p: [f64; 3], var_m2: f64) {
        self.var_sum_m2 += var_m2;
        let n = self.count + 1;
        let d = [p[0] - self.mean[0], p[1] - self.mean[1], p[2] - self.mean[2]];
        let inv_n = 1.0 / n as f64;
        self.mean = [self.mean[0] + d[0] * inv_n, self.mean[1] + d[1] * inv_n, self.mean[2] + d[2] * inv_n];
        let w = (n - 1) as f64 * inv_n;
        add_outer(&mut self.scatter, d, w);
        self.count = n;
        self.z_min = self.z_min.min(p[2]);
        self.z_max = self.z_max.max(p[2]);
    }

    #[cfg(test)]
    /// Fuses `other` into `self` (parallel-axis combination): afterwards `self` holds the
    /// moments of the union of both point sets.
    #[inline]
    pub(crate) fn merge(&mut self, other: &CellMoments) {
        if other.count == 0 {
            return;
        }
        if self.count == 0 {
            *self = *other;
            return;
        }
        let (na, nb) = (self.count as f64, other.count as f64);
        let n = na + nb;
        let d = [other.mean[0] - self.mean[0], other.mean[1] - self.mean[1], other.mean[2] - self.mean[2]];
        let fb = nb / n;
        self.mean = [self.mean[0] + d[0] * fb, self.mean[1] + d[1] * fb, self.mean[2] + d[2] * fb];
        for (s, o) in self.scatter.iter_mut().zip(other.scatter) {
            *s += o;
        }
        add_outer(&mut self.scatter, d, na * fb);
        self.count = self.count.saturating_add(other.count);
        self.z_min = self.z_min.min(other.z_min);
        self.z_max = self.z_max.max(other.z_max);
        self.var_sum_m2 += other.var_sum_m2;
    }

    /// Population covariance S/n (m²) as a symmetric 3×3 matrix; zero when empty.
    pub fn covariance(&self) -> [[f64; 3]; 3] {
        if self.count == 0 {
            return [[0.0; 3]; 3];
        }
        let k = 1.0 / self.count as f64;
        let s = self.scatter.map(|v| v * k);
        [[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]]
    }
}

/// scatter += w · d dᵀ (upper triangle).
#[inline]
pub(super) fn add_outer(s: &mut [f64; 6], d: [f64; 3], w: f64) {
    let wd = [w * d[0], w * d[1], w * d[2]];
    s[0] += wd[0] * d[0];
    s[1] += wd[0] * d[1];
    s[2] += wd[0] * d[2];
    s[3] += wd[1] * d[1];
    s[4] += wd[1] * d[2];
    s[5] += wd[2] * d[2];
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Two-pass reference: mean, then Σ (p − μ)(p − μ)ᵀ.
    fn two_pass(points: &[[f64; 3]]) -> ([f64; 3], [f64; 6]) {
        let n = points.len() as f64;
        let mut m = [0.0; 3];
        for p in points {
            for k in 0..3 {
                m[k] += p[k] / n;
            }
        }
        let mut s = [0.0; 6];
        for p in points {
            add_outer(&mut s, [p[0] - m[0], p[1] - m[1], p[2] - m[2]], 1.0);
        }
        (m, s)
    }

    fn of(points: &[[f64; 3]]) -> CellMoments {
        let mut m = CellMoments::EMPTY;
        for p in points {
            m.add(*p);
        }
        m
    }

    fn assert_close(a: &CellMoments, b: &CellMoments, tol: f64) {
        assert_eq!(a.count, b.count);
        for k in 0..3 {
            assert!((a.mean[k] - b.mean[k]).abs() <= tol, "mean {:?} vs {:?}", a.mean, b.mean);
        }
        for k in 0..6 {
            assert!((a.scatter[k] - b.scatter[k]).abs() <= tol, "scatter {:?} vs {:?}", a.scatter, b.scatter);
        }
        assert_eq!(a.z_min, b.z_min);
        assert_eq!(a.z_max, b.z_max);
    }

    #[test]
    fn hand_derived_moments_of_four_points() {
        // Square corners at z = 0 and 2: mean (0.5, 0.5, 1), Sxx = 4·0.25 = 1, Szz = 4·1 = 4,
        // Sxz = Σ(x − .5)(z − 1) = (−.5)(−1) + (.5)(−1) + (−.5)(1) + (.5)(1) = 0 for this layout.
        let m = of(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 2.0], [1.0, 1.0, 2.0]]);
        assert_eq!(m.count, 4);
        assert_eq!(m.mean, [0.5, 0.5, 1.0]);
        // Syz = 4·(.5·1) = 2 (Welford divides by 3 on the way: equal to rounding).
        for (s, e) in m.scatter.iter().zip([1.0, 0.0, 0.0, 1.0, 2.0, 4.0]) {
            assert!((s - e).abs() < 1e-12, "{:?}", m.scatter);
        }
        assert_eq!((m.z_min, m.z_max), (0.0, 2.0));
        let c = m.covariance();
        assert!((c[1][2] - 0.5).abs() < 1e-12);
        assert_eq!(c[1][2], c[2][1]);
    }

    #[test]
    fn merging_with_empty_is_identity() {
        let a = of(&[[1.0, 2.0, 3.0], [2.0, 2.0, 1.0]]);
        let mut b = a;
        b.merge(&CellMoments::EMPTY);
        assert_eq!(a, b);
        let mut e = CellMoments::EMPTY;
        e.merge(&a);
        assert_eq!(a, e);
        assert_eq!(CellMoments::EMPTY.covariance(), [[0.0; 3]; 3]);
    }

    #[test]
    fn utm_sized_coordinates_keep_centimetre_scatter() {
        // Points 5e6 m from the origin with ±1 cm z offsets: raw sums would lose the scatter
        // (x² ≈ 2.5e13, f64 spacing there ≈ 4e-3); Welford keeps it.
        let pts: Vec<[f64; 3]> =
            (0..1000).map(|i| [5.0e6 + (i % 10) as f64 * 0.01, 4.0e6, 100.0 + if i % 2 == 0 { 0.01 } else { -0.01 }]).collect();
        let m = of(&pts);
        let var_z = m.scatter[5] / m.count as f64;
        assert!((var_z - 1e-4).abs() < 1e-12, "{var_z}");
    }

    proptest! {
        /// Fusing per-cell moments equals the moments of the union of the points.
        #[test]
        fn fusion_equals_moments_of_union(
            pts in proptest::collection::vec((-50.0f64..50.0, -50.0f64..50.0, -5.0f64..5.0), 1..200),
            cells in proptest::collection::vec(0usize..5, 200),
        ) {
            let pts: Vec<[f64; 3]> = pts.into_iter().map(|(x, y, z)| [x, y, z]).collect();
            let mut per_cell = [CellMoments::EMPTY; 5];
            for (i, p) in pts.iter().enumerate() {
                per_cell[cells[i]].add(*p);
            }
            let mut fused = CellMoments::EMPTY;
            for c in &per_cell {
                fused.merge(c);
            }
            let (m, s) = two_pass(&pts);
            let reference = CellMoments {
                count: pts.len() as u64,
                mean: m,
                scatter: s,
                z_min: pts.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min),
                z_max: pts.iter().map(|p| p[2]).fold(f64::NEG_INFINITY, f64::max),
                var_sum_m2: 0.0,
            };
            let scale = 1e-9 * (1.0 + s.iter().fold(0.0f64, |a, v| a.max(v.abs())));
            assert_close(&fused, &reference, scale);
            assert_close(&of(&pts), &reference, scale);
        }
    }
}
