//! Binary entropy and the expected information gain of an unknown cell seen along a ray
//! (paper eqs. 5–6; see notes §5, which fixes the reading used here).
//!
//! - `H(p) = −p log₂ p − (1 − p) log₂(1 − p)` bits, with `0 · log 0 = 0` (so `H(0) = H(1) = 0`,
//!   `H(½) = 1`: the prior entropy of an unknown cell is one bit).
//! - `g(N) = 1 − H((1 + γ^N) / 2)`: the visibility `γ^N` decays with the number `N` of cells the
//!   ray crossed before the cell, and a fully visible cell (`γ^N = 1`) ends certain, so it yields
//!   its whole bit; `g` falls towards 0 as `N` grows. γ is per cell (default 0.99 at 0.05 m).
//!
//! O(1) per evaluation; `GainTable` precomputes `g(0..n)` once so ray casting never calls
//! `log₂` per cell.

use crate::math;

/// Binary entropy `H(p)` in bits. Returns 0 outside the open interval (0, 1) and for NaN.
#[inline]
pub(crate) fn binary_entropy_bits(p: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) {
        return 0.0;
    }
    -p * math::log2(p) - (1.0 - p) * math::log2(1.0 - p)
}

/// Expected gain `g(N) = 1 − H((1 + γ^N)/2)` in bits of an unknown cell with `cells_before`
/// cells between it and the ray's origin cell (paper eqs. 5–6, notes §5).
#[inline]
pub(crate) fn visibility_gain_bits(gamma: f64, cells_before: u32) -> f64 {
    let visibility = math::powf(gamma, f64::from(cells_before));
    1.0 - binary_entropy_bits(0.5 * (1.0 + visibility))
}

/// `g(N)` for `N = 0, 1, …, len − 1`, precomputed.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct GainTable {
    gamma: f64,
    gains_bits: Vec<f64>,
}

impl GainTable {
    /// Table of `len` gains for visibility degradation `gamma` per cell.
    pub fn new(gamma: f64, len: usize) -> Self {
        let gains_bits = (0..len).map(|n| visibility_gain_bits(gamma, n as u32)).collect();
        Self { gamma, gains_bits }
    }

    #[cfg(test)]
    /// γ the table was built for.
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// `g(N)` for every tabulated `N`.
    #[inline]
    pub fn as_slice(&self) -> &[f64] {
        &self.gains_bits
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entropy_hand_values() {
        assert_eq!(binary_entropy_bits(0.5), 1.0);
        assert_eq!(binary_entropy_bits(0.0), 0.0);
        assert_eq!(binary_entropy_bits(1.0), 0.0);
        assert_eq!(binary_entropy_bits(f64::NAN), 0.0);
        // H(1/4) = ¼·2 + ¾·log₂(4/3) = 2 − ¾·log₂3
        let expected = 2.0 - 0.75 * 3f64.log2();
        assert!((binary_entropy_bits(0.25) - expected).abs() < 1e-15);
        assert!((binary_entropy_bits(0.75) - expected).abs() < 1e-15);
    }

    #[test]
    fn gain_hand_values() {
        // N = 0: γ⁰ = 1, p = (1+1)/2 = 1, H = 0, g = 1 whatever γ.
        assert_eq!(visibility_gain_bits(0.99, 0), 1.0);
        assert_eq!(visibility_gain_bits(0.3, 0), 1.0);
        // γ = 1: the cell stays fully visible, every cell gives its whole bit.
        assert_eq!(visibility_gain_bits(1.0, 500), 1.0);
        // γ = 0.5, N = 1: p = 3/4, g = 1 − H(3/4) = 1 − (2 − ¾·log₂3) = ¾·log₂3 − 1 ≈ 0.188722.
        let expected = 0.75 * 3f64.log2() - 1.0;
        assert!((visibility_gain_bits(0.5, 1) - expected).abs() < 1e-15);
        // γ = 0.99, N = 60: γ^60 = exp(60 ln 0.99) = 0.5471566…, p = 0.7735783…,
        // H(p) = 0.7717211…, g = 0.2282788… (worked by hand with a calculator).
        assert!((visibility_gain_bits(0.99, 60) - 0.228_278_858_9).abs() < 1e-9);
    }

    #[test]
    fn gain_decreases_with_distance() {
        let t = GainTable::new(0.99, 200);
        assert_eq!(t.as_slice().len(), 200);
        assert!(t.as_slice().windows(2).all(|w| w[1] < w[0]));
        assert!(t.as_slice().iter().all(|&g| (0.0..=1.0).contains(&g)));
        assert_eq!(t.gamma(), 0.99);
    }
}
