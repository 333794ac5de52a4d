//! Small statistics for `fitslam compare`: percentiles and the two-sided Mann–Whitney U test.
//!
//! Percentiles use linear interpolation between order statistics (Hyndman & Fan type 7, numpy's
//! default): for sorted x₀ ≤ … ≤ x_{n−1}, h = (n − 1)·q, Q(q) = x_⌊h⌋ + (h − ⌊h⌋)(x_⌊h⌋+1 − x_⌊h⌋).
//!
//! Mann–Whitney U (two-sided, normal approximation with tie and continuity corrections, as
//! scipy's `mannwhitneyu(method="asymptotic")`): pool the samples, rank them (ties get their mean
//! rank), R₁ = sum of the first sample's ranks, U₁ = R₁ − n₁(n₁+1)/2, μ = n₁n₂/2,
//! σ² = n₁n₂/12 · ((n+1) − Σ(t³−t)/(n(n−1))) over tie groups of size t, n = n₁+n₂,
//! z = (|U₁ − μ| − ½)/σ, p = 2·(1 − Φ(z)) = erfc(z/√2). O(n log n).

/// The q-quantile (0 ≤ q ≤ 1) of `values`, type 7; `None` when empty or any value is NaN.
pub fn percentile(values: &[f64], q: f64) -> Option<f64> {
    if values.is_empty() || values.iter().any(|v| v.is_nan()) {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let h = (v.len() - 1) as f64 * q.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(v.len() - 1);
    Some(v[lo] + (h - lo as f64) * (v[hi] - v[lo]))
}

/// Median, quartiles and range of a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    pub median: f64,
    pub q25: f64,
    pub q75: f64,
    pub min: f64,
    pub max: f64,
}

impl Spread {
    /// `None` when empty or any value is NaN.
    pub fn of(values: &[f64]) -> Option<Self> {
        Some(Self {
            median: percentile(values, 0.5)?,
            q25: percentile(values, 0.25)?,
            q75: percentile(values, 0.75)?,
            min: percentile(values, 0.0)?,
            max: percentile(values, 1.0)?,
        })
    }
}

/// The result of a Mann–Whitney U test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MannWhitney {
    /// U of the first sample (the number of pairs where it is larger, ties counting ½).
    pub u1: f64,
    /// z score (with continuity correction, ≥ 0).
    pub z: f64,
    /// Two-sided p-value.
    pub p: f64,
}

/// Two-sided Mann–Whitney U test of `x` against `y` (see the module doc). `None` if a sample is
/// empty or holds NaN. When every value is tied (σ = 0) there is no evidence of a difference:
/// z = 0, p = 1.
pub fn mann_whitney_u(x: &[f64], y: &[f64]) -> Option<MannWhitney> {
    if x.is_empty() || y.is_empty() || x.iter().chain(y).any(|v| v.is_nan()) {
        return None;
    }
    let (n1, n2) = (x.len() as f64, y.len() as f64);
    let n = n1 + n2;
    // (value, from x)
    let mut pooled: Vec<(f64, bool)> = x.iter().map(|&v| (v, true)).chain(y.iter().map(|&v| (v, false))).collect();
    pooled.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut r1 = 0.0;
    let mut tie_sum = 0.0;
    let mut i = 0;
    while i < pooled.len() {
        let mut j = i + 1;
        while j < pooled.len() && pooled[j].0 == pooled[i].0 {
            j += 1;
        }
        // Ranks i+1 ..= j share their mean.
        let rank = (i + 1 + j) as f64 / 2.0;
        let t = (j - i) as f64;
        tie_sum += t * t * t - t;
        r1 += rank * pooled[i..j].iter().filter(|p| p.1).count() as f64;
        i = j;
    }
    let u1 = r1 - n1 * (n1 + 1.0) / 2.0;
    let mu = n1 * n2 / 2.0;
    let var = n1 * n2 / 12.0 * ((n + 1.0) - tie_sum / (n * (n - 1.0)));
    if var <= 0.0 || !var.is_finite() {
        return Some(MannWhitney { u1, z: 0.0, p: 1.0 });
    }
    let z = ((u1 - mu).abs() - 0.5).max(0.0) / var.sqrt();
    let p = erfc(z / std::f64::consts::SQRT_2).min(1.0);
    Some(MannWhitney { u1, z, p })
}

/// Complementary error function, Chebyshev fit (Numerical Recipes `erfcc`): fractional error
/// below 1.2·10⁻⁷ everywhere.
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07 + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b}");
    }

    #[test]
    fn percentiles_are_type_7() {
        // Sorted: 1 1 2 3 4 5 6 9; h = 7q. q=0.25: h=1.75 → 1 + 0.75·(2−1) = 1.75;
        // q=0.5: h=3.5 → 3 + 0.5·1 = 3.5; q=0.75: h=5.25 → 5 + 0.25·1 = 5.25.
        let v = [3.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0, 6.0];
        close(percentile(&v, 0.25).unwrap(), 1.75, 1e-12);
        close(percentile(&v, 0.5).unwrap(), 3.5, 1e-12);
        close(percentile(&v, 0.75).unwrap(), 5.25, 1e-12);
        assert_eq!(percentile(&v, 0.0), Some(1.0));
        assert_eq!(percentile(&v, 1.0), Some(9.0));
        assert_eq!(percentile(&[7.0], 0.3), Some(7.0));
        assert_eq!(percentile(&[], 0.5), None);
        assert_eq!(percentile(&[1.0, f64::NAN], 0.5), None);
    }

    #[test]
    fn erfc_known_values() {
        close(erfc(0.0), 1.0, 1e-7);
        close(erfc(1.0), 0.157_299_207_050_285_1, 1e-7);
        close(erfc(-1.0), 1.842_700_792_949_715, 1e-7);
        close(erfc(2.0), 0.004_677_734_981_047_266, 1e-9);
    }

    #[test]
    fn mann_whitney_hand_example_without_ties() {
        // x = 1 2 3, y = 4 5 6: x's ranks 1 2 3, R₁ = 6, U₁ = 6 − 6 = 0, μ = 4.5,
        // σ² = 9·7/12 = 5.25, z = (4.5 − 0.5)/√5.25 = 1.745743, p = erfc(z/√2) = 0.080856.
        let r = mann_whitney_u(&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0]).unwrap();
        assert_eq!(r.u1, 0.0);
        close(r.z, 4.0 / 5.25f64.sqrt(), 1e-12);
        close(r.p, 0.080_855_598_370_052_24, 1e-6); // scipy 1.17 mannwhitneyu(asymptotic)
        // Symmetric: swapping the samples gives U₂ = n₁n₂ − U₁ and the same p.
        let s = mann_whitney_u(&[4.0, 5.0, 6.0], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(s.u1, 9.0);
        close(s.p, r.p, 1e-15);
    }

    #[test]
    fn mann_whitney_hand_example_with_ties() {
        // x = 1 2 2, y = 2 3 4: pooled 1 2 2 2 3 4, ranks 1 | 3 3 3 | 5 | 6. R₁ = 1+3+3 = 7,
        // U₁ = 7 − 6 = 1. One tie group t = 3: Σ(t³−t) = 24. σ² = 9/12·(7 − 24/30) = 4.65,
        // z = (3.5 − 0.5)/√4.65 = 1.391212, p = 0.164160.
        let r = mann_whitney_u(&[1.0, 2.0, 2.0], &[2.0, 3.0, 4.0]).unwrap();
        assert_eq!(r.u1, 1.0);
        close(r.z, 3.0 / 4.65f64.sqrt(), 1e-12);
        close(r.p, 0.164_159_728_478_515_23, 1e-6); // scipy 1.17
    }

    #[test]
    fn mann_whitney_matches_scipy_on_larger_samples() {
        // Values and p-values from scipy 1.17.1 `mannwhitneyu(a, b, method="asymptotic")`.
        let a = [0.3, 0.8, 0.3, -1.3, 0.9, 0.4, -0.5, 0.6, 0.4, 0.3, 0.0, 0.5, -0.7, -0.2, -0.5, 0.6, 0.0, -0.3, -0.8, -0.3];
        let b = [0.8, 0.5, 2.1, 1.8, -1.9, -1.1, 0.6, 0.4, 1.0, 1.0, 2.9, -0.3, 0.4, 2.8, 1.4, 1.5, 0.3, -0.8, 1.0, 0.9];
        let r = mann_whitney_u(&a, &b).unwrap();
        assert_eq!(r.u1, 101.5);
        close(r.p, 0.007_915_659_451_650_521, 1e-6);
        let c = [0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 3.0];
        let d = [0.0, 1.0, 1.0, 4.0, 5.0, 0.0, 2.0, 6.0, 7.0];
        let r = mann_whitney_u(&c, &d).unwrap();
        assert_eq!(r.u1, 17.5);
        close(r.p, 0.071_756_149_995_514_34, 1e-6);
    }

    #[test]
    fn mann_whitney_degenerate_inputs() {
        let r = mann_whitney_u(&[0.0, 0.0], &[0.0, 0.0, 0.0]).unwrap();
        assert_eq!((r.z, r.p), (0.0, 1.0));
        assert!(mann_whitney_u(&[], &[1.0]).is_none());
        assert!(mann_whitney_u(&[f64::NAN], &[1.0]).is_none());
    }
}
