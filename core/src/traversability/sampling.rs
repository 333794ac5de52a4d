//! Is a cloud dense enough for the disc? (not in the paper; a diagnostic for clouds of another
//! scale, such as airborne LiDAR, which leave almost every cell unknown at the rover's defaults).
//!
//! The horizontal density ρ (points per m² of x-y footprint) is measured by binning the points
//! into square bins, doubling the bin side `b` from `extent / 4096` until the occupied bins hold
//! [`POINTS_PER_BIN`] points on average (or one bin spans the cloud). The footprint is the
//! occupied bins, those on its boundary (fewer than 4 occupied 4-neighbours) counted half, as
//! the data covers about half of each: `A = (occupied − boundary / 2) b²`, ρ = n / A. Smaller
//! bins would see every point alone and overestimate ρ; larger ones would average the holes in.
//! A disc of radius r then holds about `ρ π r²` points, and the radius at which it holds `k`
//! points is `√(k / (ρ π))`. O(n log n) per bin size, O(n) memory.

use nalgebra::Point3;

/// Mean points per occupied bin at which the density is read.
pub(crate) const POINTS_PER_BIN: f64 = 4.0;

/// The horizontal sampling of a cloud, against the traversability disc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscSampling {
    /// Points per m² of the cloud's x-y footprint.
    pub density_per_m2: f64,
    /// Mean spacing of the points in x-y, `1 / √ρ`, metres.
    pub spacing_m: f64,
}

impl DiscSampling {
    /// The sampling of the finite points, or `None` with fewer than two of them or no horizontal
    /// extent.
    pub fn of(points: &[Point3<f64>]) -> Option<Self> {
        let finite: Vec<[f64; 2]> = points.iter().filter(|p| p.coords.iter().all(|v| v.is_finite())).map(|p| [p.x, p.y]).collect();
        if finite.len() < 2 {
            return None;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &finite {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let extent_m = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        if extent_m <= 0.0 {
            return None;
        }
        let n = finite.len() as f64;
        let mut keys = Vec::with_capacity(finite.len());
        let mut bin_m = extent_m / 4096.0;
        loop {
            keys.clear();
            // Bin indices below 2^13 each (the extent is at most 4096 bins of the first size).
            keys.extend(finite.iter().map(|p| {
                let [i, j] = [0, 1].map(|a| ((p[a] - lo[a]) / bin_m) as u64);
                (i << 32) | j
            }));
            keys.sort_unstable();
            keys.dedup();
            let occupied = keys.len() as f64;
            if n / occupied >= POINTS_PER_BIN || bin_m >= extent_m {
                let has = |k: u64| keys.binary_search(&k).is_ok();
                let boundary = keys
                    .iter()
                    .filter(|&&k| {
                        let (i, j) = (k >> 32, k & 0xffff_ffff);
                        !(i > 0 && j > 0 && has(k - (1 << 32)) && has(k + (1 << 32)) && has(k - 1) && has(k + 1))
                    })
                    .count() as f64;
                let density_per_m2 = n / ((occupied - boundary / 2.0) * bin_m * bin_m);
                return Some(Self { density_per_m2, spacing_m: density_per_m2.sqrt().recip() });
            }
            bin_m *= 2.0;
        }
    }

    /// Expected points in a disc of radius `radius_m`.
    pub fn points_in_disc(&self, radius_m: f64) -> f64 {
        self.density_per_m2 * std::f64::consts::PI * radius_m * radius_m
    }

    /// The radius of a disc that holds `points` points on average, metres.
    pub fn radius_holding(&self, points: f64) -> f64 {
        (points / (self.density_per_m2 * std::f64::consts::PI)).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(spacing_m: f64, side: usize) -> Vec<Point3<f64>> {
        (0..side).flat_map(|i| (0..side).map(move |j| Point3::new(i as f64 * spacing_m, j as f64 * spacing_m, 0.1 * i as f64))).collect()
    }

    #[test]
    fn a_lattice_has_its_spacing() {
        // A square lattice of spacing s has density 1/s² (edge bins aside).
        for (s, side) in [(0.5, 60), (0.02, 200), (3.0, 40)] {
            let d = DiscSampling::of(&lattice(s, side)).unwrap();
            assert!((d.spacing_m / s - 1.0).abs() < 0.15, "spacing {s}: measured {d:?}");
            // ρ π r² at r = radius_holding(k) is k.
            assert!((d.points_in_disc(d.radius_holding(20.0)) - 20.0).abs() < 1e-9);
        }
    }

    #[test]
    fn holes_do_not_thin_the_density() {
        // Two dense patches 50 m apart: the density is the patches', not the bounding box's.
        let mut points = lattice(0.05, 100);
        points.extend(lattice(0.05, 100).into_iter().map(|p| Point3::new(p.x + 50.0, p.y, p.z)));
        let d = DiscSampling::of(&points).unwrap();
        assert!((d.spacing_m / 0.05 - 1.0).abs() < 0.15, "{d:?}");
    }

    #[test]
    fn degenerate_clouds_have_no_sampling() {
        assert_eq!(DiscSampling::of(&[]), None);
        assert_eq!(DiscSampling::of(&[Point3::new(1.0, 2.0, 3.0), Point3::new(1.0, 2.0, 4.0)]), None);
        assert_eq!(DiscSampling::of(&[Point3::new(f64::NAN, 0.0, 0.0), Point3::new(0.0, 0.0, 0.0)]), None);
    }
}
