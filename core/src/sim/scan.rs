//! Ground points a range sensor at a given position sees on a heightfield: the terrain sampled on
//! a regular lattice within range, kept where the straight line from the sensor clears the terrain
//! (line-of-sight marched at half-cell steps), with seeded range noise on z. A deterministic
//! stand-in for a registered LiDAR sweep, used to build assets and maps.
//! O(points in range × range / step).

use super::heightfield::Heightfield;
use super::noise::hash_unit;
use crate::math;
use nalgebra::Point3;

/// Points on the terrain visible from `sensor_m` within `max_range_m` (horizontal), sampled every
/// `spacing_m`, with uniform ±`noise_m` on z. Appends to `out`.
pub fn visible_ground_points(
    field: &Heightfield,
    sensor_m: Point3<f64>,
    max_range_m: f64,
    spacing_m: f64,
    noise_m: f64,
    seed: u64,
    out: &mut Vec<Point3<f64>>,
) {
    let step = field.geometry.resolution_m * 0.5;
    let n = (max_range_m / spacing_m).ceil() as i64;
    let (ix0, iy0) = ((sensor_m.x / spacing_m).round() as i64, (sensor_m.y / spacing_m).round() as i64);
    for iy in iy0 - n..=iy0 + n {
        for ix in ix0 - n..=ix0 + n {
            let (x, y) = (ix as f64 * spacing_m, iy as f64 * spacing_m);
            let dist = math::hypot(x - sensor_m.x, y - sensor_m.y);
            if dist > max_range_m {
                continue;
            }
            let Some(z) = field.height_at(x, y) else { continue };
            if !line_of_sight(field, sensor_m, Point3::new(x, y, z + 0.02), step) {
                continue;
            }
            let dz = (2.0 * hash_unit(ix, iy, seed) - 1.0) * noise_m;
            out.push(Point3::new(x, y, z + dz));
        }
    }
}

/// Whether the segment from `a` to `b` stays above the terrain (checked every `step_m`).
pub fn line_of_sight(field: &Heightfield, a: Point3<f64>, b: Point3<f64>, step_m: f64) -> bool {
    let d = b - a;
    let len = math::hypot(d.x, d.y);
    let steps = (len / step_m).ceil() as usize;
    for k in 1..steps {
        let t = k as f64 / steps as f64;
        let p = a + d * t;
        match field.height_at(p.x, p.y) {
            Some(z) if z > p.z => return false,
            _ => {}
        }
    }
    true
}
