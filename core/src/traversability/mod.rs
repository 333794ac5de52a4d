//! Traversability from registered 3D points (notes §2, paper §II-B).
//!
//! Points (LiDAR scans registered with the SLAM keyframe poses) are binned into a grid whose
//! cells keep moments (`CellMoments`); over a disc around each cell the moments are fused and
//! a plane is fitted, giving slope, step and roughness; their worst ratio to the robot's limits is
//! the hazard, and score = 1 − hazard. Thresholding the score by the risk acceptance τ gives the
//! ROS occupancy grid (0 free, 100 lethal, −1 unknown) that [`crate::grid::inflate_lethal`]
//! inflates by the robot radius for planning.
//!
//! ```
//! use fitslam_core::{traversability::TraversabilityMap, GridGeometry, Params};
//! use nalgebra::Point3;
//!
//! let params = Params::default();
//! let mut map = TraversabilityMap::new(GridGeometry::new(0.0, 0.0, 0.05, 40, 40)).unwrap();
//! // A flat 2 m × 2 m floor sampled every 2 cm.
//! map.insert_points((0..100).flat_map(|i| (0..100).map(move |j| Point3::new(i as f64 * 0.02, j as f64 * 0.02, 0.0))));
//! let layers = map.compute(&params.traversability);
//! let occupancy = layers.to_occupancy(params.traversability.tau);
//! assert!(occupancy.data.iter().all(|&v| v == 0)); // all free
//! let planning = fitslam_core::grid::inflate_lethal(&occupancy, params.robot.radius_m);
//! # let _ = planning;
//! ```
//!
//! | file | what |
//! |---|---|
//! | `moments.rs` | per-cell moments, Welford insertion, exact parallel-axis fusion |
//! | `plane.rs` | plane fit from moments: normal, slope, roughness, degenerate cases |
//! | `map.rs` | the moments layer: insertion (with an optional height variance), sizing to a cloud, clearing, stale cells |
//! | `disc_sums.rs` | per-cell sums of the points in its disc, kept up to date at insertion |
//! | `estimate.rs` | disc sums → slope / step / roughness / hazard / score; lazy refresh; thresholding |
//! | `render.rs` | score layer → RGB image |
//! | `sampling.rs` | a cloud's horizontal density against the disc (is it too sparse for the parameters?) |

mod disc_sums;
mod estimate;
mod map;
mod moments;
mod plane;
mod render;
mod sampling;
#[cfg(test)]
pub(crate) mod tests;

pub(crate) use crate::grid::MAX_CELLS;
pub use estimate::GroundModel;
pub use estimate::{TraversabilityLayers, to_occupancy};
pub use map::InsertStats;
pub use map::TraversabilityMap;
pub use render::{UNKNOWN_RGB, score_rgb, score_to_rgb};
pub use sampling::DiscSampling;

use thiserror::Error;

/// Why a traversability map could not be built.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum TraversabilityError {
    /// The cloud has no point with finite coordinates.
    #[error("the point cloud has no point with finite coordinates")]
    EmptyCloud,
    /// Resolution not finite and > 0, or origin not finite.
    #[error("grid geometry needs a finite resolution > 0 and a finite origin")]
    BadGeometry,
    /// The grid would have more cells than 2²³ (8 388 608).
    #[error("a {width} × {height} grid exceeds the limit of {limit} cells (coarser resolution or smaller extent?)")]
    TooManyCells {
        /// Columns the grid would have.
        width: usize,
        /// Rows the grid would have.
        height: usize,
        /// The cell limit, 2²³ (8 388 608).
        limit: usize,
    },
}
