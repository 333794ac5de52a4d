//! The transcendental functions the core uses, computed by the pure-Rust `libm` crate on every
//! target, so that the same seed gives the same run natively and in wasm, on any CPU.
//!
//! `f64::sin` and its kind call the platform's maths library: glibc natively (which picks an FMA
//! or a plain variant by the CPU it runs on), a port of musl's in wasm. They agree to an ulp or
//! so, not to the bit, and one ulp in a LiDAR range or a noise sample moves a point across a cell
//! boundary sooner or later: a whole ground-truth mission on the paper world ran identically in
//! both only up to t ≈ 470 s before this module. Basic arithmetic and `sqrt` are IEEE-exact
//! everywhere and stay as they are; nalgebra's own calls go through the same `libm` (its
//! `libm-force` feature, set in the workspace). clippy's `disallowed-methods` (core/clippy.toml)
//! keeps the std versions out of the core.

/// sin x (x in radians).
#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}

/// cos x (x in radians).
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}

/// (sin x, cos x).
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// tan x (x in radians).
#[inline]
pub fn tan(x: f64) -> f64 {
    libm::tan(x)
}

/// acos x, radians in [0, π].
#[inline]
pub(crate) fn acos(x: f64) -> f64 {
    libm::acos(x)
}

/// atan x, radians in (−π/2, π/2).
#[inline]
pub(crate) fn atan(x: f64) -> f64 {
    libm::atan(x)
}

/// The angle of the point (x, y), radians in [−π, π] (argument order as `f64::atan2`: y first).
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

/// Natural logarithm.
#[inline]
pub(crate) fn ln(x: f64) -> f64 {
    libm::log(x)
}

/// ln(1 + x), accurate for small x.
#[inline]
pub(crate) fn ln_1p(x: f64) -> f64 {
    libm::log1p(x)
}

/// Base-2 logarithm.
#[inline]
pub(crate) fn log2(x: f64) -> f64 {
    libm::log2(x)
}

/// √(x² + y²) without undue overflow or underflow.
#[inline]
pub fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}

/// xʸ.
#[inline]
pub(crate) fn powf(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

/// A standard normal sample (Box–Muller, one of the pair), through this module's `ln` and `cos`
/// so that a seed gives the same bits on every target.
pub fn standard_normal<R: rand::Rng + ?Sized>(rng: &mut R) -> f64 {
    use rand::RngExt;
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * ln(u1)).sqrt() * cos(std::f64::consts::TAU * u2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    #[test]
    fn exact_values() {
        assert_eq!(sin(0.0), 0.0);
        assert_eq!(cos(0.0), 1.0);
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert_eq!(atan2(1.0, 1.0), FRAC_PI_4);
        assert_eq!(atan2(0.0, -1.0), PI);
        assert_eq!(atan2(1.0, 0.0), FRAC_PI_2);
        assert_eq!(acos(-1.0), PI);
        assert_eq!(ln(1.0), 0.0);
        assert_eq!(log2(8.0), 3.0);
        assert_eq!(hypot(3.0, 4.0), 5.0);
        assert_eq!(powf(2.0, 10.0), 1024.0);
        assert_eq!(tan(0.0), 0.0);
        assert_eq!(atan(0.0), 0.0);
    }

    #[test]
    fn within_a_few_ulps_of_the_platform_library() {
        // Not equal to the bit (that is the point), but the same functions.
        let close = |a: f64, b: f64| (a - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(b.abs()).max(1e-300);
        let mut x = -10.0;
        while x < 10.0 {
            assert!(close(sin(x), x.sin()) && close(cos(x), x.cos()), "{x}");
            assert!(close(sin_cos(x).0, x.sin()) && close(sin_cos(x).1, x.cos()), "{x}");
            assert!(close(atan2(x, 1.3), x.atan2(1.3)) && close(hypot(x, 0.7), x.hypot(0.7)), "{x}");
            assert!(close(atan(x), x.atan()), "{x}");
            if x > 0.0 {
                assert!(close(ln(x), x.ln()) && close(log2(x), x.log2()) && close(powf(x, 0.3), x.powf(0.3)), "{x}");
            }
            if x.abs() < 1.0 {
                assert!(close(acos(x), x.acos()) && close(tan(x), x.tan()), "{x}");
            }
            x += 0.0137;
        }
    }
}
