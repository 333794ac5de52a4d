//! First-level utility u1 (paper eq. 2; notes §5, whose reading of α this follows).
//!
//! `u1(C_i) = α · (ρ_min / ρ_i) + (1 − α) · (ΔE_i / ΔE_max)`, normalised over the current
//! candidates: `N_{ρ⁻¹} = ρ_min`, `N_ΔE = 1/ΔE_max`. **α weights the path-length term** (paper,
//! α = 0.35). Guards: a path length below one cell (ρ_i = 0, the robot already on the
//! candidate) counts as one cell; when every ΔE is 0 the entropy term is 0. Both terms lie in
//! [0, 1], so u1 does too. O(n) for n candidates.

/// u1 of every candidate, written into `out` (cleared; one value per candidate, same order).
///
/// `rho_m` and `delta_e_bits` must have the same length; `one_cell_m` is the grid resolution
/// used as the floor of ρ. Non-finite or negative inputs are treated as the worst value of their
/// term (an infinite ρ gives 0 path term; a NaN ΔE gives 0 entropy term).
pub(crate) fn u1_scores(rho_m: &[f64], delta_e_bits: &[f64], alpha: f64, one_cell_m: f64, out: &mut Vec<f64>) {
    out.clear();
    debug_assert_eq!(rho_m.len(), delta_e_bits.len());
    let n = rho_m.len().min(delta_e_bits.len());
    let floor = if one_cell_m.is_finite() && one_cell_m > 0.0 { one_cell_m } else { f64::MIN_POSITIVE };
    let guard_rho = |r: f64| if r.is_nan() { f64::INFINITY } else { r.max(floor) };
    let guard_e = |e: f64| if e.is_finite() && e > 0.0 { e } else { 0.0 };
    let rho_min = rho_m[..n].iter().map(|&r| guard_rho(r)).fold(f64::INFINITY, f64::min);
    let e_max = delta_e_bits[..n].iter().map(|&e| guard_e(e)).fold(0.0, f64::max);
    for i in 0..n {
        let rho = guard_rho(rho_m[i]);
        let path_term = if rho.is_finite() { rho_min / rho } else { 0.0 };
        let entropy_term = if e_max > 0.0 { guard_e(delta_e_bits[i]) / e_max } else { 0.0 };
        out.push(alpha * path_term + (1.0 - alpha) * entropy_term);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_candidates_by_hand() {
        // ρ = 2, 4, 8 m → ρ_min/ρ = 1, 1/2, 1/4; ΔE = 10, 40, 20 → ΔE/ΔE_max = 1/4, 1, 1/2.
        // α = 0.35: u1 = 0.35·1 + 0.65·0.25 = 0.5125; 0.35·0.5 + 0.65·1 = 0.825;
        //               0.35·0.25 + 0.65·0.5 = 0.4125.
        let mut out = Vec::new();
        u1_scores(&[2.0, 4.0, 8.0], &[10.0, 40.0, 20.0], 0.35, 0.05, &mut out);
        let expected = [0.5125, 0.825, 0.4125];
        for (u, e) in out.iter().zip(expected) {
            assert!((u - e).abs() < 1e-12, "{out:?}");
        }
    }

    #[test]
    fn alpha_weights_the_path_term() {
        let mut out = Vec::new();
        // α = 1: only the path term. Nearest candidate scores 1.
        u1_scores(&[1.0, 2.0], &[0.0, 100.0], 1.0, 0.05, &mut out);
        assert_eq!(out, vec![1.0, 0.5]);
        // α = 0: only the entropy term.
        u1_scores(&[1.0, 2.0], &[0.0, 100.0], 0.0, 0.05, &mut out);
        assert_eq!(out, vec![0.0, 1.0]);
    }

    #[test]
    fn guards() {
        let mut out = Vec::new();
        // ρ = 0 counts as one cell (0.05 m): ρ_min = 0.05; the other at 0.1 m gets 1/2.
        // ΔE all zero: entropy term 0 (no division by zero).
        u1_scores(&[0.0, 0.1], &[0.0, 0.0], 0.5, 0.05, &mut out);
        assert_eq!(out, vec![0.5, 0.25]);
        u1_scores(&[], &[], 0.5, 0.05, &mut out);
        assert!(out.is_empty());
        u1_scores(&[f64::INFINITY, 1.0], &[f64::NAN, 2.0], 0.5, 0.05, &mut out);
        assert_eq!(out, vec![0.0, 1.0]);
    }
}
