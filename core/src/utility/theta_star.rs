//! Best viewing direction Θ* of a candidate (paper eq. 7; notes §5): a circular sliding window.
//!
//! `Θ*_s = argmax_{Θ_s ∈ Θ} Σ_{θ ∈ Θ, |θ − Θ_s|_∘ ≤ Φ/2} ΔE^θ` and `ΔE_i` is that maximum, where
//! `|a − b|_∘ = min(|a − b| mod 2π, 2π − |a − b| mod 2π)` is the angular distance, so the window
//! wraps around 2π (a gain block straddling 0 is one window). Ties go to the smallest ray index.
//!
//! The rays within Φ/2 of a sorted fan's ray form a contiguous circular arc of indices;
//! `FovWindows` stores that arc (start, length) per ray once, and `FovWindows::best` sums each
//! window: O(R · W) per candidate for R rays and W rays per window, no allocation. A 1e-12 rad
//! tolerance on Φ/2 keeps rays exactly on the window's edge inside despite rounding.

use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

const EDGE_TOLERANCE_RAD: f64 = 1e-12;

/// The best window of a fan.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThetaStar {
    /// Index of the window's central ray.
    pub index: usize,
    /// Θ*, radians in [0, 2π).
    pub theta_rad: f64,
    /// ΔE_i: the window's summed gain, bits.
    pub delta_e_bits: f64,
}

/// Angular distance between two angles, in [0, π].
#[inline]
pub(crate) fn angular_distance_rad(a_rad: f64, b_rad: f64) -> f64 {
    let d = (a_rad - b_rad).rem_euclid(TAU);
    d.min(TAU - d)
}

/// For each ray of a fan, the circular arc of rays within Φ/2 of it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FovWindows {
    start: Vec<u32>,
    len: Vec<u32>,
}

impl FovWindows {
    /// Windows of half-width `hfov_rad / 2` over rays at `angles_rad` (sorted ascending, in
    /// [0, 2π)).
    pub fn new(angles_rad: &[f64], hfov_rad: f64) -> Self {
        let n = angles_rad.len();
        let half = 0.5 * hfov_rad + EDGE_TOLERANCE_RAD;
        let inside = |s: usize, j: usize| angular_distance_rad(angles_rad[s], angles_rad[j]) <= half;
        let mut start = Vec::with_capacity(n);
        let mut len = Vec::with_capacity(n);
        for s in 0..n {
            if (0..n).all(|j| inside(s, j)) {
                // The whole fan: the same summation order for every ray, so all sums tie exactly.
                start.push(0);
                len.push(n as u32);
                continue;
            }
            let mut back = 0;
            while back + 1 < n && inside(s, (s + n - back - 1) % n) {
                back += 1;
            }
            let mut fwd = 0;
            while fwd + 1 < n && inside(s, (s + fwd + 1) % n) {
                fwd += 1;
            }
            start.push(((s + n - back) % n) as u32);
            len.push((back + fwd + 1) as u32);
        }
        Self { start, len }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.start.len()
    }

    pub fn is_empty(&self) -> bool {
        self.start.is_empty()
    }

    #[cfg(test)]
    /// Ray indices in the window of ray `s`, in circular order.
    pub fn window(&self, s: usize) -> impl Iterator<Item = usize> + '_ {
        let n = self.len();
        let (a, l) = (self.start[s] as usize, self.len[s] as usize);
        (0..l).map(move |k| (a + k) % n)
    }

    /// Summed gain of ray `s`'s window.
    #[inline]
    pub(crate) fn window_sum(&self, s: usize, gains_bits: &[f64]) -> f64 {
        let n = self.len();
        let (a, l) = (self.start[s] as usize, self.len[s] as usize);
        if a + l <= n {
            gains_bits[a..a + l].iter().sum()
        } else {
            gains_bits[a..].iter().sum::<f64>() + gains_bits[..a + l - n].iter().sum::<f64>()
        }
    }

    /// Θ* and ΔE over `gains_bits` (one per ray, same order as the angles). `None` for an empty
    /// fan or a length mismatch.
    pub fn best(&self, angles_rad: &[f64], gains_bits: &[f64]) -> Option<ThetaStar> {
        if self.is_empty() || gains_bits.len() != self.len() || angles_rad.len() != self.len() {
            return None;
        }
        let mut best = ThetaStar { index: 0, theta_rad: angles_rad[0], delta_e_bits: self.window_sum(0, gains_bits) };
        for (s, &theta_rad) in angles_rad.iter().enumerate().skip(1) {
            let sum = self.window_sum(s, gains_bits);
            if sum > best.delta_e_bits {
                best = ThetaStar { index: s, theta_rad, delta_e_bits: sum };
            }
        }
        Some(best)
    }
}

/// One-shot Θ* (builds the windows; prefer `FovWindows` when casting many candidates).
pub fn theta_star(angles_rad: &[f64], gains_bits: &[f64], hfov_rad: f64) -> Option<ThetaStar> {
    FovWindows::new(angles_rad, hfov_rad).best(angles_rad, gains_bits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn fan(delta: f64) -> Vec<f64> {
        let n = crate::utility::rays::ray_count(delta);
        (0..n).map(|k| k as f64 * delta).collect()
    }

    #[test]
    fn hand_example() {
        // 8 rays every 45°, Φ = 90°: the window of ray s is {s−1, s, s+1}.
        let a = fan(TAU / 8.0);
        let g = [0.0, 1.0, 0.0, 0.0, 2.0, 2.0, 0.0, 0.0];
        let t = theta_star(&a, &g, TAU / 4.0).unwrap();
        // windows: s=4: 0+2+2 = 4, s=5: 2+2+0 = 4 → tie, smallest index 4.
        assert_eq!(t.index, 4);
        assert_eq!(t.delta_e_bits, 4.0);
        assert!((t.theta_rad - std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn wrap_around_block_straddling_zero() {
        // 43 rays at 8.5°, Φ = 87° (±43.5°: 5 rays each side). Gains on the last 3 rays and the
        // first 3: the best window is centred at ray 0 or its neighbours — it must wrap.
        let a = fan(8.5f64.to_radians());
        let mut g = vec![0.0; a.len()];
        for k in [40, 41, 42, 0, 1, 2] {
            g[k] = 1.0;
        }
        g[0] = 3.0;
        let t = theta_star(&a, &g, 87f64.to_radians()).unwrap();
        assert_eq!(t.delta_e_bits, 8.0);
        // The windows of rays 40, 41, 42, 0, 1, 2 each hold the whole block (e.g. ray 40 at 340°
        // reaches ray 2 at 17°: 37° ≤ 43.5°, thanks to the 3° gap at 2π); the smallest index is 0.
        assert_eq!(t.index, 0);
        // The window of ray 0 includes rays 38..42 (the last gap is 3°, not 8.5°).
        let w = FovWindows::new(&a, 87f64.to_radians());
        let win0: Vec<_> = w.window(0).collect();
        assert_eq!(win0, vec![38, 39, 40, 41, 42, 0, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn full_circle_fov_ties_to_ray_zero() {
        let a = fan(TAU / 10.0);
        let g: Vec<f64> = (0..10).map(|k| 0.1 * k as f64).collect();
        let t = theta_star(&a, &g, TAU).unwrap();
        assert_eq!(t.index, 0);
        assert!((t.delta_e_bits - 4.5).abs() < 1e-12);
    }

    #[test]
    fn mismatched_inputs_give_none() {
        let a = fan(1.0);
        assert!(theta_star(&a, &[1.0], 1.0).is_none());
        assert!(theta_star(&[], &[], 1.0).is_none());
    }

    fn brute_force(angles: &[f64], gains: &[f64], hfov: f64) -> Vec<f64> {
        (0..angles.len())
            .map(|s| {
                (0..angles.len())
                    .filter(|&j| angular_distance_rad(angles[s], angles[j]) <= 0.5 * hfov + EDGE_TOLERANCE_RAD)
                    .map(|j| gains[j])
                    .sum()
            })
            .collect()
    }

    proptest! {
        #[test]
        fn theta_star_maximises_its_circular_window(
            delta_deg in 2.0f64..120.0,
            hfov_deg in 1.0f64..360.0,
            eighths in proptest::collection::vec(0u32..40, 180),
        ) {
            let a = fan(delta_deg.to_radians());
            // Gains in multiples of 1/8: sums are exact in any order, so ties are real ties.
            let g: Vec<f64> = eighths.iter().take(a.len()).map(|&k| k as f64 / 8.0).collect();
            let t = theta_star(&a, &g, hfov_deg.to_radians()).unwrap();
            let sums = brute_force(&a, &g, hfov_deg.to_radians());
            let max = sums.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            prop_assert_eq!(t.delta_e_bits, max);
            let first = sums.iter().position(|&s| s == max).unwrap();
            prop_assert_eq!(t.index, first);
            prop_assert_eq!(t.theta_rad, a[first]);
        }

        #[test]
        fn windows_are_symmetric_arcs(delta_deg in 2.0f64..120.0, hfov_deg in 1.0f64..360.0) {
            let a = fan(delta_deg.to_radians());
            let hfov = hfov_deg.to_radians();
            let w = FovWindows::new(&a, hfov);
            for s in 0..a.len() {
                let mut members: Vec<usize> = w.window(s).collect();
                members.sort_unstable();
                let expected: Vec<usize> = (0..a.len())
                    .filter(|&j| angular_distance_rad(a[s], a[j]) <= 0.5 * hfov + EDGE_TOLERANCE_RAD)
                    .collect();
                prop_assert_eq!(members, expected);
            }
        }
    }
}
