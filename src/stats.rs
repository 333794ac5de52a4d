//! Small statistics for `fitslam compare`: percentiles and, for paired runs (same world and
//! seed, two strategies), the Wilcoxon signed-rank test, a percentile-bootstrap confidence
//! interval of the mean paired difference and Holm's correction over several tests.
//!
//! Percentiles use linear interpolation between order statistics (Hyndman & Fan type 7, numpy's
//! default): for sorted x₀ ≤ … ≤ x_{n−1}, h = (n − 1)·q, Q(q) = x_⌊h⌋ + (h − ⌊h⌋)(x_⌊h⌋+1 − x_⌊h⌋).
//!
//! Wilcoxon signed-rank (two-sided, zeros dropped, normal approximation with tie and continuity
//! corrections, as scipy's `wilcoxon(d, zero_method="wilcox", correction=True,
//! method="approx")`): rank |dᵢ| over the n non-zero differences (ties get their mean rank),
//! W⁺ = sum of the positive ones' ranks, μ = n(n+1)/4, σ² = n(n+1)(2n+1)/24 − Σ(t³−t)/48,
//! z = (|W⁺ − μ| − ½)/σ, p = erfc(z/√2).
//!
//! Holm's step-down correction (Holm 1979): with the m p-values sorted, p₍₁₎ ≤ … ≤ p₍ₘ₎, the
//! adjusted p₍ᵢ₎ is maxⱼ≤ᵢ min(1, (m − j + 1)·p₍ⱼ₎); rejecting where it is below α keeps the
//! family-wise error rate at α.
//!
//! World-level summaries (`report::worlds`): the geometric mean, the sample standard deviation
//! and the smallest ratio a signed-rank test detects with 80 % power ([`detectable_ratio`]).
//!
//! Percentile bootstrap (Efron & Tibshirani 1993, §13.3): B resamples of the n differences drawn
//! with replacement; the interval is the (1−level)/2 and (1+level)/2 percentiles of their means.

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

/// The result of a Wilcoxon signed-rank test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wilcoxon {
    /// Sum of the ranks of the positive differences.
    pub w_plus: f64,
    /// Non-zero differences.
    pub n: usize,
    /// z score (with continuity correction, ≥ 0).
    pub z: f64,
    /// Two-sided p-value.
    pub p: f64,
}

/// Two-sided Wilcoxon signed-rank test of the paired differences `d` (see the module doc).
/// `None` if `d` holds NaN. No non-zero difference, or every rank tied at σ = 0: p = 1.
pub fn wilcoxon_signed_rank(d: &[f64]) -> Option<Wilcoxon> {
    if d.iter().any(|v| v.is_nan()) {
        return None;
    }
    let mut nz: Vec<f64> = d.iter().copied().filter(|&v| v != 0.0).collect();
    nz.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    let n = nz.len();
    let (mut w_plus, mut tie_sum) = (0.0, 0.0);
    let mut i = 0;
    while i < n {
        let mut j = i + 1;
        while j < n && nz[j].abs() == nz[i].abs() {
            j += 1;
        }
        let rank = (i + 1 + j) as f64 / 2.0;
        let t = (j - i) as f64;
        tie_sum += t * t * t - t;
        w_plus += rank * nz[i..j].iter().filter(|&&v| v > 0.0).count() as f64;
        i = j;
    }
    let nf = n as f64;
    let mu = nf * (nf + 1.0) / 4.0;
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - tie_sum / 48.0;
    if n == 0 || var <= 0.0 {
        return Some(Wilcoxon { w_plus, n, z: 0.0, p: 1.0 });
    }
    let z = ((w_plus - mu).abs() - 0.5).max(0.0) / var.sqrt();
    Some(Wilcoxon { w_plus, n, z, p: erfc(z / std::f64::consts::SQRT_2).min(1.0) })
}

/// Holm's step-down adjusted p-values, in the order given (see the module doc).
pub fn holm(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let mut out = vec![0.0; m];
    let mut running: f64 = 0.0;
    for (rank, &i) in order.iter().enumerate() {
        running = running.max(((m - rank) as f64 * p[i]).min(1.0));
        out[i] = running;
    }
    out
}

/// Percentile-bootstrap interval at `level` (e.g. 0.95) of the mean of `d`, from `resamples`
/// resamples drawn with `rng` (see the module doc). `None` when `d` is empty or holds NaN.
pub fn bootstrap_mean_ci(d: &[f64], level: f64, resamples: usize, rng: &mut impl rand::Rng) -> Option<(f64, f64)> {
    use rand::RngExt;
    if d.is_empty() || d.iter().any(|v| v.is_nan()) || resamples == 0 {
        return None;
    }
    let n = d.len();
    let means: Vec<f64> = (0..resamples).map(|_| (0..n).map(|_| d[rng.random_range(0..n)]).sum::<f64>() / n as f64).collect();
    let tail = (1.0 - level.clamp(0.0, 1.0)) / 2.0;
    Some((percentile(&means, tail)?, percentile(&means, 1.0 - tail)?))
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

/// z quantiles of the power line: two-sided 5 % and 80 % power.
const Z_975: f64 = 1.959_963_984_540_054;
const Z_80: f64 = 0.841_621_233_572_914_3;
/// Pitman's asymptotic relative efficiency of the signed-rank test to the t-test under normal
/// data (3/π): the signed-rank test needs n / 0.955 pairs for the t-test's power.
const SIGNED_RANK_ARE: f64 = 3.0 / std::f64::consts::PI;

/// The geometric mean of the finite values (0 if one of them is 0; NaN if none is finite or one
/// is negative).
pub fn geometric_mean(values: &[f64]) -> f64 {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() || finite.iter().any(|&v| v < 0.0) {
        return f64::NAN;
    }
    if finite.contains(&0.0) {
        return 0.0;
    }
    (finite.iter().map(|v| v.ln()).sum::<f64>() / finite.len() as f64).exp()
}

/// The smallest ratio R > 1 such that a true world-level ratio of R or 1/R is detected with 80 %
/// power by a two-sided 5 % test over `worlds` worlds whose log ratios spread with standard
/// deviation `sd`: ln R = (z₀.₉₇₅ + z₀.₈) sd / √(0.955 n) (the t-test's normal approximation,
/// with the signed-rank test's efficiency). NaN below 2 worlds.
pub fn detectable_ratio(sd: f64, worlds: usize) -> f64 {
    if worlds < 2 {
        return f64::NAN;
    }
    ((Z_975 + Z_80) * sd / (SIGNED_RANK_ARE * worlds as f64).sqrt()).exp()
}

/// Sample standard deviation (n − 1); NaN below two values.
pub fn sample_sd(v: &[f64]) -> f64 {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0)).sqrt()
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
    fn wilcoxon_hand_example() {
        // d = 1 −2 3 4 0: the zero is dropped, n = 4, ranks of |d| 1 2 3 4, W⁺ = 1 + 3 + 4 = 8,
        // μ = 5, σ² = 4·5·9/24 = 7.5, z = (3 − 0.5)/√7.5 = 0.912871, p = erfc(z/√2) = 0.361310.
        let r = wilcoxon_signed_rank(&[1.0, -2.0, 3.0, 4.0, 0.0]).unwrap();
        assert_eq!((r.w_plus, r.n), (8.0, 4));
        close(r.z, 2.5 / 7.5f64.sqrt(), 1e-12);
        close(r.p, 0.361_310_428_526_178_9, 1e-6);
        // Ties: d = 1 1 −1 2: |d| ranks 2 2 2 4 (t = 3: Σ = 24), W⁺ = 2 + 2 + 4 = 8, μ = 5,
        // σ² = 4·5·9/24 − 24/48 = 7, z = 2.5/√7.
        let r = wilcoxon_signed_rank(&[1.0, 1.0, -1.0, 2.0]).unwrap();
        assert_eq!(r.w_plus, 8.0);
        close(r.z, 2.5 / 7f64.sqrt(), 1e-12);
        // Sign flip: same p.
        let s = wilcoxon_signed_rank(&[-1.0, -1.0, 1.0, -2.0]).unwrap();
        close(s.p, r.p, 1e-15);
        assert_eq!(wilcoxon_signed_rank(&[0.0, 0.0]).unwrap().p, 1.0);
        assert!(wilcoxon_signed_rank(&[f64::NAN]).is_none());
    }

    #[test]
    fn wilcoxon_matches_scipy() {
        // scipy 1.17.1 wilcoxon(d, zero_method="wilcox", correction=True, method="approx").
        let d = [0.5, -1.2, 2.3, 0.7, 1.9, -0.4, 3.1, 0.9, 1.1, -0.2, 2.2, 0.6, 1.4, 0.0, 0.8, -0.9, 1.7, 2.6, 0.3, 1.0];
        let r = wilcoxon_signed_rank(&d).unwrap();
        close(r.p, 0.004_843_863_368_480_81, 1e-6);
    }

    #[test]
    fn holm_by_hand() {
        // Sorted 0.01 0.02 0.03 0.5 (m = 4): 0.04, max(0.04, 0.06) = 0.06, max(0.06, 0.06) = 0.06,
        // max(0.06, 0.5) = 0.5; back in the given order.
        let adj = holm(&[0.03, 0.5, 0.01, 0.02]);
        for (a, b) in adj.iter().zip([0.06, 0.5, 0.04, 0.06]) {
            close(*a, b, 1e-15);
        }
        assert_eq!(holm(&[0.6, 0.7]), vec![1.0, 1.0]);
        assert!(holm(&[]).is_empty());
    }

    #[test]
    fn bootstrap_interval_covers_the_mean_and_is_reproducible() {
        use rand::SeedableRng;
        let d: Vec<f64> = (0..40).map(|i| (i % 7) as f64 - 2.0).collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let ci = |seed| bootstrap_mean_ci(&d, 0.95, 2000, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed)).unwrap();
        let (lo, hi) = ci(1);
        assert!(lo < mean && mean < hi, "{lo} {mean} {hi}");
        // Normal theory: ±1.96·s/√n with s = 2.0 (the values −2…4 in turn) gives about ±0.62.
        assert!((hi - lo) > 0.8 && (hi - lo) < 1.7, "{lo} {hi}");
        assert_eq!(ci(1), (lo, hi));
        // A constant sample: a point interval.
        let (a, b) = bootstrap_mean_ci(&[2.0; 5], 0.95, 100, &mut rand_chacha::ChaCha8Rng::seed_from_u64(3)).unwrap();
        assert_eq!((a, b), (2.0, 2.0));
        assert!(bootstrap_mean_ci(&[], 0.95, 100, &mut rand_chacha::ChaCha8Rng::seed_from_u64(3)).is_none());
    }

    #[test]
    fn geometric_means_by_hand() {
        // √(1e-3 · 4e-3) = 2e-3; NaN (a run never at 90 %) is left out; a 0 makes it 0.
        assert!((geometric_mean(&[1e-3, 4e-3]) - 2e-3).abs() < 1e-15);
        assert!((geometric_mean(&[1e-3, f64::NAN, 4e-3]) - 2e-3).abs() < 1e-15);
        assert_eq!(geometric_mean(&[0.0, 5.0]), 0.0);
        assert!(geometric_mean(&[f64::NAN]).is_nan());
        assert!(geometric_mean(&[-1.0, 1.0]).is_nan());
        // 2, 4, 8 → ∛64 = 4.
        assert!((geometric_mean(&[2.0, 4.0, 8.0]) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn sample_sd_by_hand() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, squared deviations 32, / 7 → √4.571429 = 2.138090.
        close(sample_sd(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]), 2.138_090, 1e-6);
        assert!(sample_sd(&[1.0]).is_nan());
    }

    #[test]
    fn detectable_ratio_by_hand() {
        // sd 0.5 over 10 worlds: (1.959964 + 0.841621) · 0.5 / √(10 · 3/π) = 1.400793 / 3.090194
        // = 0.453303 → e^0.453303 = 1.573500.
        assert!((detectable_ratio(0.5, 10) - 1.573_500).abs() < 1e-5, "{}", detectable_ratio(0.5, 10));
        assert!(detectable_ratio(0.5, 1).is_nan());
        // More worlds, smaller detectable effects.
        assert!(detectable_ratio(0.5, 40) < detectable_ratio(0.5, 10));
    }
}
