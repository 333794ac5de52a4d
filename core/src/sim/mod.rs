//! The simulator (notes §8): ground-truth worlds (procedural, real DEM or map_server terrain,
//! rocks, boxes, ramps, landmarks; [`world`]), the robot ([`robot`]) and its sensors
//! ([`lidar`], [`camera`] and its visual front end [`vision`], [`odometry`]) in one world simulator (`world_sim`), localisation
//! ([`localisation`]: ground truth, odometry, keyframe SLAM), metrics ([`metrics`]; coverage
//! milestones and figures at matched coverage: [`coverage`]) and whole missions ([`mission`])
//! driven by the core's exploration policy ([`crate::explore`]), recorded as the robot node's
//! rosbag2 topics ([`recorder`]), plus the asset-building helpers (visible ground points,
//! deterministic noise).

pub mod camera;
mod corridor;
pub mod coverage;
pub mod floor_plan;
mod heightfield;
mod landmarks;
pub mod lidar;
pub mod localisation;
pub mod metrics;
pub mod mission;
mod noise;
mod obstacles;
pub mod odometry;
pub mod params;
pub mod recorder;
pub mod robot;
mod scan;
mod terrain_spec;
pub mod vision;
pub mod world;
pub(crate) mod world_sim;
mod world_spec;

pub use crate::explore::EndReason;
pub use heightfield::HeightfieldError;
pub use heightfield::{DemScaling, Heightfield};
pub use landmarks::{LandmarkDensity, scatter_landmarks};
pub use localisation::Localisation;
pub use localisation::PoseCovariance;
pub use localisation::{TrackingLoss, tracking_losses_csv};
pub use metrics::{MetricsCsvError, MetricsRow, StampedPose, Summary, metrics_csv, read_metrics_csv, timing_csv, tum};
pub use mission::MissionError;
pub use mission::{Mission, StepOutcome};
pub use noise::hash_unit;
pub use obstacles::Rock;
pub use obstacles::scatter_rocks;
pub use params::MissionParams;
pub use recorder::MissionRecorder;
pub use scan::{line_of_sight, visible_ground_points};
pub use world::{MAX_WORLD_SEEDS, World, WorldSpec};
pub use world::{StartError, WorldError};
pub use world_sim::Motion;
pub use world_sim::WorldSim;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod vision_tests;
