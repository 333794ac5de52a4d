//! Goal selectors (notes §5–7): FIT-SLAM, greedy, random, u1-only and length-matched random,
//! behind one trait, all on the same pipeline ([`candidates`]) and all returning the whole
//! ranking ([`Decision`]).
//!
//! | file | what |
//! |---|---|
//! | [`candidates`] | inflate, robot cell (snap), frontiers, one Dijkstra, blacklist, rays, u1, u2 |
//! | [`report`] | [`Decision`], [`CandidateReport`], [`DropReason`] (serde) |
//! | [`fit`] | FIT-SLAM: u2 over the N best by u1 (and the controls `u2_length`: u2 with the path length in place of I_p; `u2_truth`: with the share of tracked views) |
//! | [`greedy`] | smallest ρ |
//! | [`random`] | uniform among reachable candidates, seeded ChaCha8 |
//! | `u1_only` | ablation: u1 alone |
//! | [`matched`] | controls: random among the candidates (all, or u1's N best) at FIT-SLAM's path length |
//!
//! ```
//! use fitslam_core::fixtures::corridor_two_frontiers;
//! use fitslam_core::frontier::Blacklist;
//! use fitslam_core::select::{make_selector, DecisionInput};
//! use fitslam_core::utility::LandmarkVoxels;
//! use fitslam_core::{Params, Valid};
//!
//! let world = corridor_two_frontiers(true); // landmarks only east of the robot
//! let params = Valid::new(Params::default())?; // strategy: fit; checked once
//! let voxels = LandmarkVoxels::new(&world.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m)?;
//! let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
//! let input = DecisionInput::new(&world.grid, &voxels, world.robot, &blacklist);
//! let decision = make_selector(&params.selector).select(&input, &params)?;
//! let goal = decision.goal.expect("a frontier is left");
//! assert!(goal.x_m > world.robot.x_m); // FIT-SLAM goes east, where the landmarks are
//! println!("{}", serde_json::to_string(&decision)?); // the whole ranking
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod candidates;
pub mod fit;
pub mod greedy;
pub mod matched;
pub mod random;
pub mod report;
pub(crate) mod u1_only;

pub use fit::FitSlam;
pub use greedy::Greedy;
pub(crate) use matched::{LengthMatched, MatchPool};
pub(crate) use random::RandomSelector;
pub use report::{CandidateReport, Decision, DropReason};
pub(crate) use u1_only::U1Only;

use crate::frontier::{Blacklist, Boundary, FrontierError};
use crate::grid::{Cell, OccupancyGrid};
use crate::params::{Params, SelectorParams, Strategy, Valid};
use crate::path::PathError;
use crate::pose::Pose2;
use crate::utility::{LandmarkVoxels, UtilityError};
use candidates::PathScore;
use thiserror::Error;

/// Everything one decision needs.
///
/// # Examples
///
/// A boundary keeps the decision inside it:
///
/// ```
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::frontier::{Blacklist, Boundary};
/// use fitslam_core::params::{SelectorParams, Strategy};
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{make_selector, DecisionInput, Params, Valid};
///
/// let world = corridor_two_frontiers(false);
/// let params = Valid::new(Params::default())?;
/// let voxels = LandmarkVoxels::new(&world.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m)?;
/// let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
/// let mut greedy = make_selector(&SelectorParams { strategy: Strategy::Greedy, ..params.selector.clone() });
///
/// let input = DecisionInput::new(&world.grid, &voxels, world.robot, &blacklist);
/// let west = greedy.select(&input, &params)?.goal.ok_or("a goal")?;
/// assert!(west.x_m < world.robot.x_m); // the nearer end
/// // Exploration bounded to x ≥ 5 m: the west end lies outside, the east end is what is left.
/// let east_only = Boundary::from_bounds(5.0, 0.0, 24.0, 4.0);
/// let bounded = greedy.select(&input.with_boundary(&east_only), &params)?.goal.ok_or("a goal")?;
/// assert!(bounded.x_m > world.robot.x_m);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct DecisionInput<'a> {
    /// Thresholded traversability grid (0 free, 100 lethal, −1 unknown), NOT yet inflated.
    pub grid: &'a OccupancyGrid,
    /// Landmark voxels (built once per landmark set with [`LandmarkVoxels::new`]).
    pub landmarks: &'a LandmarkVoxels,
    /// The robot's pose in the map frame.
    pub robot: Pose2,
    /// Exploration boundary; `None` means the whole map.
    pub boundary: Option<&'a Boundary>,
    /// Blacklisted goals.
    pub blacklist: &'a Blacklist,
    /// Height of the ground under the robot in the map frame, metres: u2's cameras sit
    /// `camera_height_m` above it where `ground` does not know better. Default 0.
    pub ground_z_m: f64,
    /// The map's known ground (height and slope per cell) for u2's terrain-following cameras
    /// ([`crate::params::U2Params::follow_terrain`]). Default `None`: flat.
    pub ground: Option<crate::traversability::GroundModel<'a>>,
    /// Cells (flat indices into `grid`) the robot's centre has driven on: each one free in `grid`
    /// stays free after inflation (`free_traversed`), so the robot can go back the
    /// way it came. Default empty.
    pub traversed: &'a [usize],
}

impl<'a> DecisionInput<'a> {
    /// An input with no boundary and the ground at z = 0.
    pub fn new(grid: &'a OccupancyGrid, landmarks: &'a LandmarkVoxels, robot: Pose2, blacklist: &'a Blacklist) -> Self {
        Self { grid, landmarks, robot, boundary: None, blacklist, ground_z_m: 0.0, ground: None, traversed: &[] }
    }

    /// The same input with an exploration boundary.
    pub fn with_boundary(mut self, boundary: &'a Boundary) -> Self {
        self.boundary = Some(boundary);
        self
    }
}

/// Why no decision could be made (an empty frontier is not an error: `Decision::chosen` is
/// `None`).
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SelectError {
    /// A parameter does not suit this map (e.g. the robot radius or the waypoint spacing against
    /// the map's resolution).
    #[error("invalid parameters: {0}")]
    InvalidParams(#[from] crate::params::InvalidParam),
    /// The grid's data and geometry disagree.
    #[error("grid has {data_len} values but its geometry has {cells} cells")]
    GridSizeMismatch {
        /// Values in the grid's data.
        data_len: usize,
        /// Cells its geometry has.
        cells: usize,
    },
    /// [`DecisionInput::traversed`] holds an index outside the grid.
    #[error("traversed cell {index} is outside the grid's {cells} cells")]
    TraversedOutsideGrid {
        /// The flat index.
        index: usize,
        /// Cells in the grid.
        cells: usize,
    },
    /// The robot's pose has a NaN or infinite component.
    #[error("robot pose is not finite")]
    RobotPoseNotFinite,
    /// The robot's position lies outside the grid.
    #[error("robot at ({x_m}, {y_m}) m is outside the map")]
    RobotOutsideMap {
        /// The robot's x in the map frame, metres.
        x_m: f64,
        /// The robot's y in the map frame, metres.
        y_m: f64,
    },
    /// The robot's cell is not free after inflation, and no free cell lies within the robot
    /// radius plus one cell of it.
    #[error("robot cell ({}, {}) is blocked and no free cell lies within {search_radius_m} m", .cell.col, .cell.row)]
    RobotBlocked {
        /// The robot's cell.
        cell: Cell,
        /// How far a free cell was searched for, metres.
        search_radius_m: f64,
    },
    /// Frontier detection failed.
    #[error("frontier detection: {0}")]
    Frontier(#[from] FrontierError),
    /// Path planning failed.
    #[error("path planning: {0}")]
    Path(#[from] PathError),
    /// A utility (u1 or u2) could not be computed.
    #[error("utility: {0}")]
    Utility(#[from] UtilityError),
}

/// A goal selector: one decision from the current map, landmarks and robot pose.
///
/// # Examples
///
/// Selectors are chosen by [`make_selector`]; the random ones draw from their own seeded RNG, so
/// the same seed gives the same goals:
///
/// ```
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::frontier::Blacklist;
/// use fitslam_core::params::{SelectorParams, Strategy};
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{make_selector, DecisionInput, GoalSelector, Params, Valid};
///
/// let world = corridor_two_frontiers(false);
/// let params = Valid::new(Params::default())?;
/// let voxels = LandmarkVoxels::new(&world.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m)?;
/// let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
/// let input = DecisionInput::new(&world.grid, &voxels, world.robot, &blacklist);
///
/// let random = SelectorParams { strategy: Strategy::Random, seed: 42, ..params.selector.clone() };
/// let goals = |selector: &mut dyn GoalSelector| -> Result<Vec<Option<usize>>, Box<dyn std::error::Error>> {
///     (0..3).map(|_| Ok(selector.select(&input, &params)?.chosen)).collect()
/// };
/// let first = goals(make_selector(&random).as_mut())?;
/// assert_eq!(first, goals(make_selector(&random).as_mut())?);
/// assert!(first.iter().all(Option::is_some));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub trait GoalSelector {
    /// Ranks the frontier candidates and picks one.
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError>;

    /// The strategy this selector implements.
    fn strategy(&self) -> Strategy;
}

/// The selector named by `params.strategy` (the random one seeded with `params.seed`).
///
/// # Examples
///
/// In a corridor with a frontier at each end, 7.5 m to the west and 8.0 m to the east, and
/// landmarks only to the east, the greedy selector takes the nearer end and FIT-SLAM the one
/// where the landmarks keep the robot localised:
///
/// ```
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::frontier::Blacklist;
/// use fitslam_core::params::{SelectorParams, Strategy};
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{make_selector, DecisionInput, Params, Valid};
///
/// let world = corridor_two_frontiers(true);
/// let params = Valid::new(Params::default())?;
/// let voxels = LandmarkVoxels::new(&world.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m)?;
/// let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
/// let input = DecisionInput::new(&world.grid, &voxels, world.robot, &blacklist);
///
/// let goal_x_m = |strategy: Strategy| -> Result<f64, Box<dyn std::error::Error>> {
///     let mut selector = make_selector(&SelectorParams { strategy, ..params.selector.clone() });
///     assert_eq!(selector.strategy(), strategy);
///     let decision = selector.select(&input, &params)?;
///     assert_eq!(decision.strategy, strategy);
///     Ok(decision.goal.ok_or("a frontier is left")?.x_m)
/// };
/// assert!(goal_x_m(Strategy::Greedy)? < world.robot.x_m); // west: shorter path
/// assert!(goal_x_m(Strategy::Fit)? > world.robot.x_m); // east: landmarks on the way
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn make_selector(params: &SelectorParams) -> Box<dyn GoalSelector> {
    match params.strategy {
        Strategy::Fit => Box::new(FitSlam::default()),
        Strategy::Greedy => Box::new(Greedy::default()),
        Strategy::Random => Box::new(RandomSelector::new(params.seed)),
        Strategy::U1 => Box::new(U1Only::default()),
        Strategy::Matched => Box::new(LengthMatched::new(params.seed, MatchPool::Reachable)),
        Strategy::MatchedTop => Box::new(LengthMatched::new(params.seed, MatchPool::TopN)),
        Strategy::U2Length => Box::new(FitSlam::with_path_score(PathScore::Length)),
        Strategy::U2Truth => Box::new(FitSlam::with_path_score(PathScore::TrackedShare)),
    }
}

#[cfg(test)]
mod tests;
