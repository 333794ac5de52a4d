//! Visual landmarks on the terrain with spatially varying density: texture-rich and texture-poor
//! regions (a low-frequency noise field), denser on rocks (strong corners). Without this
//! variation, path information could not matter (notes §6). Deterministic in `seed`.
//! O(area / spacing²).

use super::heightfield::Heightfield;
use super::noise::{fractal_noise, hash_unit};
use super::obstacles::Rock;
use crate::math;
use nalgebra::Point3;

/// How landmarks are scattered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LandmarkDensity {
    /// Lattice spacing of candidate positions, metres.
    pub spacing_m: f64,
    /// Probability of a landmark at a candidate in the richest texture (texture field = 1).
    pub max_probability: f64,
    /// Exponent sharpening the texture field (higher: starker rich/poor contrast).
    pub contrast: f64,
    /// Wavelength of the texture field, metres.
    pub texture_wavelength_m: f64,
    /// Landmarks per square metre of rock side.
    pub rock_density_per_m2: f64,
    /// Landmarks stand up to this high above the ground (bushes, stones), metres.
    pub max_height_m: f64,
}

impl Default for LandmarkDensity {
    fn default() -> Self {
        Self {
            spacing_m: 0.1,
            max_probability: 0.5,
            contrast: 4.0,
            texture_wavelength_m: 6.0,
            rock_density_per_m2: 25.0,
            max_height_m: 0.4,
        }
    }
}

/// The texture richness in [0, 1] at (x, y): where landmarks are dense.
pub(crate) fn texture_richness(x_m: f64, y_m: f64, density: &LandmarkDensity, seed: u64) -> f64 {
    let n = fractal_noise(x_m, y_m, density.texture_wavelength_m, 3, seed ^ 0x7E47);
    // fBm concentrates near 0.5: stretch to [0, 1] before sharpening.
    math::powf(((n - 0.25) / 0.5).clamp(0.0, 1.0), density.contrast)
}

/// Scatters landmarks over the terrain and on rock sides.
pub fn scatter_landmarks(field: &Heightfield, rocks: &[Rock], density: &LandmarkDensity, seed: u64) -> Vec<Point3<f64>> {
    let mut out = Vec::new();
    let (min_x, min_y, max_x, max_y) = field.geometry.bounds_m();
    let nx = ((max_x - min_x) / density.spacing_m).floor() as i64;
    let ny = ((max_y - min_y) / density.spacing_m).floor() as i64;
    for j in 0..ny {
        for i in 0..nx {
            let x = min_x + (i as f64 + hash_unit(i, j, seed ^ 11)) * density.spacing_m;
            let y = min_y + (j as f64 + hash_unit(i, j, seed ^ 12)) * density.spacing_m;
            let p = density.max_probability * texture_richness(x, y, density, seed);
            if hash_unit(i, j, seed ^ 13) >= p {
                continue;
            }
            if let Some(z) = field.height_at(x, y) {
                out.push(Point3::new(x, y, z + density.max_height_m * hash_unit(i, j, seed ^ 14)));
            }
        }
    }
    for (k, rock) in rocks.iter().enumerate() {
        let side_m2 = std::f64::consts::TAU * rock.radius_m * rock.height_m;
        let n = (side_m2 * density.rock_density_per_m2).round() as i64;
        let base = field.height_at(rock.x_m, rock.y_m).unwrap_or(0.0) - rock.height_m;
        for m in 0..n {
            let a = std::f64::consts::TAU * hash_unit(k as i64, m, seed ^ 21);
            let h = rock.height_m * hash_unit(k as i64, m, seed ^ 22);
            out.push(Point3::new(rock.x_m + rock.radius_m * math::cos(a), rock.y_m + rock.radius_m * math::sin(a), base + h));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;

    #[test]
    fn density_follows_texture() {
        let field = Heightfield::from_fn(GridGeometry::new(0.0, 0.0, 0.1, 200, 200), |_, _| 0.0);
        let d = LandmarkDensity::default();
        let pts = scatter_landmarks(&field, &[], &d, 3);
        assert!(!pts.is_empty());
        // Mean richness at landmarks is well above the mean richness of the area.
        let mean_at = pts.iter().map(|p| texture_richness(p.x, p.y, &d, 3)).sum::<f64>() / pts.len() as f64;
        let mut area = 0.0;
        for k in 0..400 {
            area += texture_richness((k % 20) as f64, (k / 20) as f64, &d, 3);
        }
        assert!(mean_at > 1.5 * area / 400.0, "{mean_at} vs {}", area / 400.0);
        assert_eq!(pts, scatter_landmarks(&field, &[], &d, 3));
    }
}
