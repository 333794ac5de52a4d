//! What the explorer is given at a decision ([`Situation`]) and what it answers ([`Action`]).

use crate::frontier::Boundary;
use crate::pose::Pose2;
use crate::select::SelectError;
use crate::utility::LandmarkVoxels;
use serde::{Deserialize, Serialize};

/// Everything a decision needs besides the map.
///
/// # Examples
///
/// The same decision with and without position uncertainty: an unsure robot is sent less far
/// towards unknown ground.
///
/// ```
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{Action, ExploreParams, Explorer, Params, Situation, Valid};
///
/// let world = corridor_two_frontiers(true);
/// let planner = Valid::new(Params::default())?;
/// let voxels = LandmarkVoxels::new(&world.landmarks, planner.u2.voxel_m, planner.u2.sigma_landmark_m)?;
/// let path_end_x_m = |situation: &Situation| -> Result<f64, Box<dyn std::error::Error>> {
///     let mut explorer = Explorer::new(Valid::new(ExploreParams::default())?, planner.clone());
///     match explorer.decide(&mut world.grid.clone(), situation) {
///         Action::Goal(plan) => Ok(plan.target().x_m),
///         other => Err(format!("expected a goal, got {other:?}").into()),
///     }
/// };
/// let certain = Situation::one_off(&voxels, world.robot, None);
/// // σx² + σy² = 0.08 m²: the path stops short of the frontier by a multiple of σ.
/// let unsure = Situation { position_var_m2: 0.08, ..certain };
/// assert!(path_end_x_m(&unsure)? < path_end_x_m(&certain)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Situation<'a> {
    /// Landmark voxels of the current landmark map (u2).
    pub landmarks: &'a LandmarkVoxels,
    /// The robot's estimated pose, map frame.
    pub robot: Pose2,
    /// Exploration boundary; `None`: the whole map.
    pub boundary: Option<&'a Boundary>,
    /// Height of the ground under the robot, map frame, metres (u2 puts the camera
    /// `camera_height_m` above it).
    pub ground_z_m: f64,
    /// The map's known ground for u2's terrain-following cameras; `None`: flat at `ground_z_m`.
    pub ground: Option<crate::traversability::GroundModel<'a>>,
    /// σx² + σy² of the position estimate, m² (the set-back of paths; 0 without a covariance).
    pub position_var_m2: f64,
    /// Periodic replanning while a goal is pursued: the current goal is kept while it is still a
    /// reachable frontier candidate.
    pub replanning: bool,
    /// Whether the adapter can forget its map around the robot (a map it builds itself): only
    /// then does a trapped robot [`Action::Recover`].
    pub can_forget_map: bool,
}

impl<'a> Situation<'a> {
    /// A decision with no history and nothing known beyond the map and the landmarks: flat
    /// ground at z = 0, no position uncertainty, no goal to keep, a map the adapter cannot
    /// forget. What `fitslam select` and the studio show for a scene or a recorded instant.
    pub fn one_off(landmarks: &'a LandmarkVoxels, robot: Pose2, boundary: Option<&'a Boundary>) -> Self {
        Self { landmarks, robot, boundary, ground_z_m: 0.0, ground: None, position_var_m2: 0.0, replanning: false, can_forget_map: false }
    }
}

/// The goal being pursued.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ActiveGoal {
    /// The frontier candidate it serves (its cell centre) and the heading to face on arrival (Θ*).
    /// The blacklist, the goals reached and goal keeping compare candidates, not set-back ends.
    pub goal: Pose2,
    /// The inflation radius its path was planned with, metres: `robot.radius_m`, or one of
    /// [`super::ExploreParams::tight_inflations_m`]. A path check of it uses the same radius.
    pub inflation_m: f64,
    /// Whether its path was planned with the trail open ([`super::ExploreParams::reuse_trail`]):
    /// a path check then lets it pass beside trail cells.
    pub on_trail: bool,
}

/// A path to drive to a goal.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The goal it serves (for [`Action::Keep`], the current one, its path planned again).
    pub goal: ActiveGoal,
    /// The candidate's path from the robot, metres, ended short of unknown ground by the
    /// position's uncertainty (`set_back`); its last point is where a navigation
    /// stack that plans its own path is sent.
    pub path_m: Vec<[f64; 2]>,
    /// The candidate's path length ρ, metres.
    pub rho_m: f64,
    /// The candidate's index in [`super::Explorer::last_decision`].
    pub candidate: usize,
    /// Planned with a tight inflation ([`super::ExploreParams::tight_inflations_m`]).
    pub tight: bool,
}

impl Plan {
    /// Where to send a navigation stack: the set-back path's end, facing the goal's heading.
    pub fn target(&self) -> Pose2 {
        let g = self.goal.goal;
        match self.path_m.last() {
            Some(&[x_m, y_m]) => Pose2 { x_m, y_m, yaw_rad: g.yaw_rad },
            None => g,
        }
    }
}

/// Why the explorer has no plan now; the adapter looks around (or waits) and decides again.
#[derive(Clone, Debug, PartialEq)]
pub enum WaitReason {
    /// The selector failed even after footprint clearing (typically: the robot's cell is not
    /// free in its own map yet). The current goal, if any, is dropped.
    NoPlan(SelectError),
    /// Every retry chose again a goal reached before (each now blacklisted).
    Reselected,
    /// The map walls the robot in, and the adapter cannot forget it
    /// ([`Situation::can_forget_map`]): the map must change.
    Trapped,
}

/// Why a mission ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EndReason {
    /// No non-blacklisted reachable frontier candidate left.
    NoFrontier,
    /// No frontier candidate left, but only because the robot's map walls it in: every free
    /// cell it can reach lies within [`super::ExploreParams::trapped_radius_m`]
    /// (`enclosed_within`; e.g. a ring of registration speckle), still after
    /// [`super::ExploreParams::trap_recoveries`] recoveries.
    Trapped,
    /// The adapter's time limit (the explorer itself never answers it).
    TimeLimit,
    /// [`super::ExploreParams::max_failed_decisions`] decisions in a row found no plan (e.g. the
    /// robot's own cell stayed untraversable in its map): the robot is stuck.
    Stuck,
}

impl EndReason {
    /// Its serialised name: `no_frontier`, `trapped`, `time_limit`, `stuck`.
    pub fn as_str(self) -> &'static str {
        match self {
            EndReason::NoFrontier => "no_frontier",
            EndReason::Trapped => "trapped",
            EndReason::TimeLimit => "time_limit",
            EndReason::Stuck => "stuck",
        }
    }
}

/// The explorer's answer to one decision.
///
/// # Examples
///
/// A mapped room has nothing left to explore:
///
/// ```
/// use fitslam_core::explore::EndReason;
/// use fitslam_core::grid::{FREE, LETHAL};
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{Action, ExploreParams, Explorer, GridGeometry, OccupancyGrid, Params, PointCloud, Pose2, Situation, Valid};
///
/// // A 4 m × 4 m room, walls all round, all of it already mapped: no frontier left.
/// let g = GridGeometry::new(0.0, 0.0, 0.1, 40, 40);
/// let mut room = OccupancyGrid::filled(g, FREE);
/// for i in 0..g.len() {
///     let c = g.cell_at(i);
///     if c.col == 0 || c.row == 0 || c.col == 39 || c.row == 39 {
///         room.data[i] = LETHAL;
///     }
/// }
/// let planner = Valid::new(Params::default())?;
/// let voxels = LandmarkVoxels::new(&PointCloud::default(), planner.u2.voxel_m, planner.u2.sigma_landmark_m)?;
/// let explore = ExploreParams { trapped_radius_m: 0.0, ..ExploreParams::default() }; // no trap check
/// let mut explorer = Explorer::new(Valid::new(explore)?, planner);
/// let situation = Situation::one_off(&voxels, Pose2::new(2.0, 2.0, 0.0), None);
/// assert_eq!(explorer.decide(&mut room, &situation), Action::Done(EndReason::NoFrontier));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Drive to a new goal (replacing the current one, if any).
    Goal(Plan),
    /// Keep the current goal: still a reachable frontier candidate at periodic replanning; its
    /// path planned again.
    Keep(Plan),
    /// No plan now (see the reason): look around or wait, then decide again.
    Wait(WaitReason),
    /// Trapped by its own map: forget the map within `radius_m` of the robot and map that ground
    /// again (turn in place), then decide again. The `NoPath` blacklist entries judged on that
    /// map are already dropped.
    Recover {
        /// Radius of the disc to forget around the robot, metres.
        radius_m: f64,
    },
    /// The mission is over.
    Done(EndReason),
}

/// Counters of the explorer's work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ExploreStats {
    /// Selector runs (every retry counts).
    pub decisions: u64,
    /// Selector runs that failed even after footprint clearing.
    pub planning_errors: u64,
    /// Decisions made again with the footprint cleared.
    pub footprint_clearings: u64,
    /// Paths planned with a tight inflation: to a new goal, or to the current one when periodic
    /// replanning found it only so.
    pub tight_plans: u64,
    /// Recoveries from a trap.
    pub trap_recoveries: u64,
    /// Goals reached.
    pub goals_reached: u64,
    /// Goals failed (timed out, aborted, rejected, stopped by the bumper): blacklisted.
    pub goals_failed: u64,
    /// Wall time of every selector run so far, ms (0 without a clock).
    pub total_plan_ms: f64,
    /// Wall time of the last [`super::Explorer::decide`], every retry included, ms.
    pub last_decide_ms: f64,
}
