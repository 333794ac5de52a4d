//! Ground-truth world for simulation and asset building: terrain heightfields (procedural or from
//! a real DEM), rocks, visible ground points, and deterministic noise. (The mission simulator
//! builds on this.)

pub mod camera;
mod heightfield;
mod landmarks;
pub mod lidar;
mod noise;
mod obstacles;
pub mod odometry;
pub mod robot;
mod scan;
pub mod world;

pub use heightfield::{DemScaling, Heightfield, HeightfieldError};
pub use landmarks::{scatter_landmarks, texture_richness, LandmarkDensity};
pub use noise::{fractal_noise, hash_unit};
pub use obstacles::{scatter_rocks, Rock};
pub use scan::{line_of_sight, visible_ground_points};
pub use world::{World, WorldError, WorldSpec};
