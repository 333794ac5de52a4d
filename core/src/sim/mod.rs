//! Ground-truth world for simulation and asset building: terrain heightfields (procedural or from
//! a real DEM), rocks, visible ground points, and deterministic noise. (The mission simulator
//! builds on this.)

mod heightfield;
mod landmarks;
mod noise;
mod obstacles;
mod scan;

pub use heightfield::{DemScaling, Heightfield, HeightfieldError};
pub use landmarks::{scatter_landmarks, texture_richness, LandmarkDensity};
pub use noise::{fractal_noise, hash_unit};
pub use obstacles::{scatter_rocks, Rock};
pub use scan::{line_of_sight, visible_ground_points};
