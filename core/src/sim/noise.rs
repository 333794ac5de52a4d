//! Deterministic value noise: a hash of integer lattice coordinates and a seed, smoothly
//! interpolated, summed over octaves. Pure function of its inputs (same value native and wasm),
//! O(octaves) per sample.

/// A uniform value in [0, 1) from integer coordinates and a seed (SplitMix64 finaliser).
#[inline]
pub fn hash_unit(ix: i64, iy: i64, seed: u64) -> f64 {
    let mut z = seed ^ (ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// Value noise in [0, 1) at (x, y) with unit lattice spacing (smoothstep interpolation).
fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (tx, ty) = (x - x0, y - y0);
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let (ix, iy) = (x0 as i64, y0 as i64);
    let a = hash_unit(ix, iy, seed);
    let b = hash_unit(ix + 1, iy, seed);
    let c = hash_unit(ix, iy + 1, seed);
    let d = hash_unit(ix + 1, iy + 1, seed);
    let top = a + (b - a) * sx;
    let bottom = c + (d - c) * sx;
    top + (bottom - top) * sy
}

/// Fractal (fBm) value noise in [0, 1): `octaves` layers, each twice the frequency and half the
/// amplitude of the previous, normalised. `wavelength_m` is the first octave's lattice spacing.
pub(crate) fn fractal_noise(x_m: f64, y_m: f64, wavelength_m: f64, octaves: u32, seed: u64) -> f64 {
    let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, 1.0 / wavelength_m);
    for o in 0..octaves.max(1) {
        sum += amp * value_noise(x_m * freq, y_m * freq, seed.wrapping_add(o as u64 * 0x51_7CC1));
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_deterministic_bounded_and_continuous() {
        for k in 0..1000 {
            let (x, y) = (k as f64 * 0.37 - 50.0, k as f64 * 0.11);
            let v = fractal_noise(x, y, 3.0, 4, 7);
            assert!((0.0..1.0).contains(&v));
            assert_eq!(v, fractal_noise(x, y, 3.0, 4, 7));
            let dv = (fractal_noise(x + 1e-4, y, 3.0, 4, 7) - v).abs();
            assert!(dv < 1e-2, "jump {dv} at {x},{y}");
        }
        assert_ne!(fractal_noise(1.3, 2.7, 3.0, 4, 7), fractal_noise(1.3, 2.7, 3.0, 4, 8));
    }
}
