//! The simulator (notes §8): ground-truth worlds (procedural, real DEM or map_server terrain,
//! rocks, boxes, ramps, landmarks; [`world`]), the robot ([`robot`]), its sensors ([`lidar`],
//! [`camera`], [`odometry`]) and whole missions ([`mission`]), plus the asset-building helpers
//! (visible ground points, deterministic noise).

pub mod camera;
mod corridor;
mod heightfield;
mod landmarks;
pub mod lidar;
pub mod mission;
mod noise;
mod obstacles;
pub mod odometry;
pub mod robot;
mod scan;
pub mod slam_frontend;
pub mod world;

pub use heightfield::{DemScaling, Heightfield, HeightfieldError};
pub use landmarks::{LandmarkDensity, scatter_landmarks, texture_richness};
pub use mission::{
    EndReason, Localisation, MetricsRow, Mission, MissionError, MissionParams, StepOutcome, Summary, check_tight_inflations,
};
pub use noise::{fractal_noise, hash_unit};
pub use obstacles::{Rock, scatter_rocks};
pub use scan::{line_of_sight, visible_ground_points};
pub use world::{World, WorldError, WorldSpec};
#[cfg(test)]
mod tests;
