//! Rocks on a heightfield: flat-topped cylinders whose tops are added to the ground, placed by a
//! seeded Poisson-like process (one candidate per lattice cell, kept with a probability).
//! O(rocks × footprint cells).

use super::heightfield::Heightfield;
use super::noise::hash_unit;
use crate::math;
use serde::{Deserialize, Serialize};

/// One rock: a half-ellipsoid dome standing on the terrain (its top `height_m` above the ground
/// at its centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rock {
    /// Centre x, map frame, metres.
    pub x_m: f64,
    /// Centre y, map frame, metres.
    pub y_m: f64,
    /// Radius of its footprint, metres.
    pub radius_m: f64,
    /// Height of its top above the ground at its centre, metres.
    pub height_m: f64,
}

/// Rocks scattered on a lattice ([`scatter_rocks`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RockSpec {
    /// Lattice spacing, metres, > 0.
    pub spacing_m: f64,
    /// Probability of a rock per lattice cell, in [0, 1].
    pub density: f64,
    /// Radius range [min, max], metres: 0 < min ≤ max ≤ half the terrain's shorter side.
    pub radius_m: [f64; 2],
    /// Height range [min, max], metres: 0 ≤ min ≤ max, finite.
    pub height_m: [f64; 2],
    /// No rock within this distance of the start, metres. Default 1.2.
    #[serde(default = "default_keep_clear")]
    pub keep_clear_m: f64,
}

fn default_keep_clear() -> f64 {
    1.2
}

/// Scatters rocks over the heightfield as `spec` says: one candidate per `spacing_m` lattice
/// cell, kept with probability `density`, radius and height drawn in their ranges; rocks within
/// `keep_clear_m` of `clear_xy` (the robot's start) are skipped. Returns the rocks placed.
pub fn scatter_rocks(field: &mut Heightfield, seed: u64, spec: &RockSpec, clear_xy: (f64, f64)) -> Vec<Rock> {
    let RockSpec { spacing_m, density, radius_m: radius_range_m, height_m: height_range_m, keep_clear_m } = *spec;
    let (min_x, min_y, max_x, max_y) = field.geometry.bounds_m();
    let nx = ((max_x - min_x) / spacing_m).floor() as i64;
    let ny = ((max_y - min_y) / spacing_m).floor() as i64;
    let mut rocks = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            if hash_unit(i, j, seed) >= density {
                continue;
            }
            let x = min_x + (i as f64 + hash_unit(i, j, seed ^ 1)) * spacing_m;
            let y = min_y + (j as f64 + hash_unit(i, j, seed ^ 2)) * spacing_m;
            let r = radius_range_m[0] + (radius_range_m[1] - radius_range_m[0]) * hash_unit(i, j, seed ^ 3);
            let h = height_range_m[0] + (height_range_m[1] - height_range_m[0]) * hash_unit(i, j, seed ^ 4);
            if math::hypot(x - clear_xy.0, y - clear_xy.1) < keep_clear_m + r {
                continue;
            }
            rocks.push(Rock { x_m: x, y_m: y, radius_m: r, height_m: h });
        }
    }
    for rock in &rocks {
        stamp_rock(field, rock);
    }
    rocks
}

/// Raises the cells under `rock` to a half-ellipsoid dome: base height + h·sqrt(1 − (r/R)²).
fn stamp_rock(field: &mut Heightfield, rock: &Rock) {
    let g = field.geometry;
    let base = field.height_at(rock.x_m, rock.y_m).unwrap_or(0.0);
    let r_cells = (rock.radius_m / g.resolution_m).ceil() as i32 + 1;
    let Some(center) = g.cell_unchecked(rock.x_m, rock.y_m) else { return };
    for dr in -r_cells..=r_cells {
        for dc in -r_cells..=r_cells {
            let cell = crate::grid::Cell::new(center.col + dc, center.row + dr);
            let Some(i) = g.index(cell) else { continue };
            let (x, y) = g.center_of(cell);
            let r = math::hypot(x - rock.x_m, y - rock.y_m) / rock.radius_m;
            if r <= 1.0 {
                let top = base + rock.height_m * (1.0 - r * r).sqrt();
                field.heights_m[i] = field.heights_m[i].max(top);
            }
        }
    }
}
