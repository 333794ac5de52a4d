//! Where a world's ground comes from ([`TerrainSpec`], the world file's `[terrain]` table) and
//! the checks of its keys, made before anything is built.

#![allow(clippy::collapsible_if, clippy::nonminimal_bool)] // explicit range checks read better

use crate::params::{InvalidParam, Num};
use crate::traversability::MAX_CELLS;
use serde::{Deserialize, Serialize};

/// Where the terrain comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TerrainSpec {
    /// Seeded value-noise hills and ridges on a tilted plane, `size_m` square.
    Procedural {
        /// Seed of the noise.
        seed: u64,
        /// Edge of the square terrain, metres, in (0, 500].
        size_m: f64,
        /// Peak-to-trough height of the hills, metres.
        #[serde(default)]
        hill_height_m: f64,
        /// Wavelength of the hills, metres, > 0. Default 8.
        #[serde(default = "default_hill_wavelength")]
        hill_wavelength_m: f64,
        /// Height of the ridges (sharp crests of ridged noise), metres.
        #[serde(default)]
        ridge_height_m: f64,
        /// Wavelength of the ridges, metres, > 0. Default 6.
        #[serde(default = "default_ridge_wavelength")]
        ridge_wavelength_m: f64,
        /// Global tilt along +x, degrees, in (-90, 90): the ground rises by tan(tilt) per metre of x.
        #[serde(default)]
        tilt_x_deg: f64,
        /// Global tilt along +y, degrees, in (-90, 90).
        #[serde(default)]
        tilt_y_deg: f64,
    },
    /// A grey DEM image, PNG or PGM (pixel value = metres; grey saved as RGB(A) is accepted),
    /// central crop scaled to `size_m`.
    Dem {
        /// The image's name, as passed to [`super::World::build`]'s loader.
        file: String,
        /// Ground size of one DEM pixel along x (columns), metres.
        pixel_x_m: f64,
        /// Ground size of one DEM pixel along y (rows), metres.
        pixel_y_m: f64,
        /// Edge of the square world the crop is mapped onto, metres, in (0, 500].
        size_m: f64,
        /// Fraction of the DEM's shorter side the central crop spans, (0, 1]. Default 0.1.
        #[serde(default = "default_crop")]
        crop_fraction: f64,
        /// Vertical scale relative to the horizontal one. Default 1.
        #[serde(default = "one_f")]
        relief_scale: f64,
        /// Where the crop lies in the DEM, [across, down], each in [0, 1] over the positions
        /// where the (rotated) crop stays inside the DEM: 0 against the left edge (top row), 1
        /// against the right edge (bottom row). Default [0.5, 0.5], the central crop.
        #[serde(default = "default_crop_centre")]
        crop_centre: [f64; 2],
        /// Rotation of the crop about its centre, degrees counter-clockwise: the world's +x runs
        /// along this bearing on the DEM (0: east). Default 0.
        #[serde(default)]
        rotation_deg: f64,
    },
    /// A map_server map (YAML naming a PGM/PNG): occupied and unknown pixels become walls.
    MapServer {
        /// The YAML's name, as passed to [`super::World::build`]'s loader (its image is named
        /// relative to it).
        file: String,
        /// Height of the walls, metres, > 0 (free pixels are at 0). Default 1.
        #[serde(default = "default_wall_height")]
        wall_height_m: f64,
    },
    /// A seeded floor plan of rooms and doors (binary space partition, `super::floor_plan`).
    FloorPlan {
        /// Seed of the plan.
        seed: u64,
        /// Outer size [x, y] of the plan, outer walls included, metres, each in (0, 500].
        size_m: [f64; 2],
        /// Shortest side a split may leave a room, metres, > 0. Default 2.5.
        #[serde(default = "default_min_room")]
        min_room_m: f64,
        /// A room with a longer side is split again when a split fits, metres, ≥ 2 ×
        /// `min_room_m`. Default 5.
        #[serde(default = "default_max_room")]
        max_room_m: f64,
        /// Clear width of a door, metres, > 0. Default 1.2.
        #[serde(default = "default_door_width")]
        door_width_m: f64,
        /// Thickness of every wall, metres, > 0. Default 0.15.
        #[serde(default = "default_wall_thickness")]
        wall_thickness_m: f64,
        /// Height of the walls, metres, > 0. Default 1.
        #[serde(default = "default_wall_height")]
        wall_height_m: f64,
        /// Probability that a wall long enough for two doors gets a second one (a loop), [0, 1].
        /// Default 0.3.
        #[serde(default = "default_extra_door")]
        extra_door_probability: f64,
    },
}

fn default_crop_centre() -> [f64; 2] {
    [0.5, 0.5]
}
fn default_min_room() -> f64 {
    2.5
}
fn default_max_room() -> f64 {
    5.0
}
fn default_door_width() -> f64 {
    1.2
}
fn default_wall_thickness() -> f64 {
    0.15
}
fn default_extra_door() -> f64 {
    0.3
}

fn default_hill_wavelength() -> f64 {
    8.0
}
fn default_ridge_wavelength() -> f64 {
    6.0
}
fn default_crop() -> f64 {
    0.1
}
fn one_f() -> f64 {
    1.0
}
fn default_wall_height() -> f64 {
    1.0
}

impl TerrainSpec {
    /// Checks the ranges of the terrain's keys for heightfield cells of `cell_m`.
    pub(super) fn validate(&self, cell_m: f64) -> Result<(), InvalidParam> {
        let bad = |key: &str, reason: String| Err(InvalidParam::new(key, reason));
        let pos = |v: f64| v.is_finite() && v > 0.0;
        // The heightfield's cells, checked before they are allocated (the ground-truth map has as
        // many, and its limit is the traversability map's).
        let cells = |size_m: f64| {
            let side = (size_m / cell_m).round().max(2.0);
            if side * side > MAX_CELLS as f64 {
                return bad(
                    "terrain.size_m",
                    format!("({size_m}) at cell_m {} is {side} × {side} cells, over the limit of {MAX_CELLS} (coarser cell_m?)", cell_m),
                );
            }
            Ok(())
        };
        match self {
            TerrainSpec::Procedural {
                size_m,
                hill_height_m,
                hill_wavelength_m,
                ridge_height_m,
                ridge_wavelength_m,
                tilt_x_deg,
                tilt_y_deg,
                ..
            } => {
                if !pos(*size_m) || *size_m > 500.0 {
                    return bad("terrain.size_m", format!("must be in (0, 500] (got {})", Num(*size_m)));
                }
                for (key, v) in [("hill_wavelength_m", *hill_wavelength_m), ("ridge_wavelength_m", *ridge_wavelength_m)] {
                    if !pos(v) {
                        return bad(&format!("terrain.{key}"), format!("must be a finite number > 0 (got {})", Num(v)));
                    }
                }
                for (key, v) in [("hill_height_m", *hill_height_m), ("ridge_height_m", *ridge_height_m)] {
                    if !v.is_finite() {
                        return bad(&format!("terrain.{key}"), format!("must be finite (got {})", Num(v)));
                    }
                }
                for (key, v) in [("tilt_x_deg", *tilt_x_deg), ("tilt_y_deg", *tilt_y_deg)] {
                    if v.is_nan() || v.abs() >= 90.0 {
                        return bad(&format!("terrain.{key}"), format!("must be in (-90, 90) degrees (got {})", Num(v)));
                    }
                }
                cells(*size_m)?;
            }
            TerrainSpec::Dem { size_m, relief_scale, crop_centre, rotation_deg, .. } => {
                if !pos(*size_m) || *size_m > 500.0 {
                    return bad("terrain.size_m", format!("must be in (0, 500] (got {})", Num(*size_m)));
                }
                if !(relief_scale.is_finite() && *relief_scale >= 0.0) {
                    return bad("terrain.relief_scale", format!("must be a finite number ≥ 0 (got {})", Num(*relief_scale)));
                }
                if !crop_centre.iter().all(|v| (0.0..=1.0).contains(v)) {
                    return bad("terrain.crop_centre", format!("must be [across, down], each in [0, 1] (got {crop_centre:?})"));
                }
                if !rotation_deg.is_finite() {
                    return bad("terrain.rotation_deg", format!("must be finite (got {})", Num(*rotation_deg)));
                }
                cells(*size_m)?;
            }
            TerrainSpec::FloorPlan {
                size_m,
                min_room_m,
                max_room_m,
                door_width_m,
                wall_thickness_m,
                wall_height_m,
                extra_door_probability,
                ..
            } => {
                if !size_m.iter().all(|&v| pos(v) && v <= 500.0) {
                    return bad("terrain.size_m", format!("must be [x, y], each in (0, 500] (got {size_m:?})"));
                }
                for (key, v) in [
                    ("min_room_m", *min_room_m),
                    ("door_width_m", *door_width_m),
                    ("wall_thickness_m", *wall_thickness_m),
                    ("wall_height_m", *wall_height_m),
                ] {
                    if !pos(v) {
                        return bad(&format!("terrain.{key}"), format!("must be a finite number > 0 (got {})", Num(v)));
                    }
                }
                if !(max_room_m.is_finite() && *max_room_m >= 2.0 * min_room_m) {
                    return bad(
                        "terrain.max_room_m",
                        format!("must be ≥ 2 × min_room_m = {} (got {})", Num(2.0 * min_room_m), Num(*max_room_m)),
                    );
                }
                if !(0.0..=1.0).contains(extra_door_probability) {
                    return bad("terrain.extra_door_probability", format!("must be in [0, 1] (got {})", Num(*extra_door_probability)));
                }
                let inner = size_m[0].min(size_m[1]) - 2.0 * wall_thickness_m;
                if inner < *min_room_m {
                    return bad(
                        "terrain.size_m",
                        format!("leaves {} m inside the outer walls, less than min_room_m {}", Num(inner), Num(*min_room_m)),
                    );
                }
                cells(size_m[0].max(size_m[1]))?;
            }
            TerrainSpec::MapServer { wall_height_m, .. } => {
                if !pos(*wall_height_m) {
                    return bad("terrain.wall_height_m", format!("must be a finite number > 0 (got {})", Num(*wall_height_m)));
                }
            }
        }
        Ok(())
    }
}
