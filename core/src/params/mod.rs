//! Every tunable of the planner in one typed struct, with the paper's defaults.
//!
//! Read from TOML or YAML; unknown keys are rejected so that a typo never silently falls back to
//! a default. The studio exports exactly this struct and the robot node reads exactly this struct.
//! Angles are radians, lengths metres (suffixes say so).

mod check;
mod file;
#[cfg(test)]
mod tests;

pub use check::{InvalidParam, Num, Valid, Validate, check_positive};

pub(crate) use check::{check_non_negative, check_radius_cells, check_waypoint_spacing};
pub use file::ParamsError;
pub(crate) use file::from_toml_over_default;
pub(crate) use file::toml_error_line;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// All planner parameters. `Params::default()` holds the paper's values (notes §8).
///
/// # Examples
///
/// A file sets only the keys it changes; the rest keep the paper's values. A value out of range
/// is refused with its key:
///
/// ```
/// use fitslam_core::params::{ParamsError, Strategy};
/// use fitslam_core::Params;
///
/// let params = Params::from_toml("[u1]\nalpha = 0.5\n[selector]\nstrategy = \"greedy\"\n", "planner.toml")?;
/// assert_eq!(params.u1.alpha, 0.5);
/// assert_eq!(params.selector.strategy, Strategy::Greedy);
/// assert_eq!(params.u2.top_n, Params::default().u2.top_n); // not in the file: the default
///
/// match Params::from_toml("[u1]\nalpha = 1.5\n", "planner.toml") {
///     Err(ParamsError::Invalid { error, .. }) => assert_eq!(error.key, "u1.alpha"),
///     other => panic!("expected an invalid u1.alpha, got {other:?}"),
/// }
/// // A misspelt key is an error too, never a silent default.
/// assert!(matches!(Params::from_toml("[u1]\nalfa = 0.5\n", "planner.toml"), Err(ParamsError::Toml { .. })));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Map geometry (`[grid]`).
    pub grid: GridParams,
    /// The robot's size and speed (`[robot]`).
    pub robot: RobotParams,
    /// The depth camera (`[camera]`).
    pub camera: CameraParams,
    /// Traversability estimation (`[traversability]`).
    pub traversability: TraversabilityParams,
    /// Frontier detection and candidates (`[frontier]`).
    pub frontier: FrontierParams,
    /// Path planning (`[planner]`).
    pub planner: PlannerParams,
    /// The information utility u1 (`[u1]`).
    pub u1: U1Params,
    /// The localisation utility u2 (`[u2]`).
    pub u2: U2Params,
    /// The goal selector: strategy, weights, seed (`[selector]`).
    pub selector: SelectorParams,
}

/// Map geometry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GridParams {
    /// Traversability cell size, metres (about a wheel). Default 0.05 (paper).
    pub resolution_m: f64,
}

impl Default for GridParams {
    fn default() -> Self {
        Self { resolution_m: 0.05 }
    }
}

/// The robot (LeoRover: 0.447 × 0.433 m footprint, ~0.4 m/s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotParams {
    /// Radius lethal cells are inflated by for planning, metres. Default 0.25 (LeoRover
    /// half-width 0.22 m plus a 3 cm margin). At most 1000 cells of the grid.
    pub radius_m: f64,
    /// Height of the camera's optical centre above the ground, metres. Default 0.2.
    pub camera_height_m: f64,
}

impl Default for RobotParams {
    fn default() -> Self {
        Self { radius_m: 0.25, camera_height_m: 0.2 }
    }
}

/// The depth camera (Intel RealSense D435).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraParams {
    /// Horizontal field of view Φ, radians. Default 87° (D435 depth).
    pub hfov_rad: f64,
    /// Vertical field of view Φ_v, radians. Default 58° (D435 depth).
    pub vfov_rad: f64,
    /// Minimum depth, metres. Default 0.3 (D435 minimum at full resolution ≈ 0.28 m).
    pub min_depth_m: f64,
    /// Maximum useful depth d_max, metres: ray length in u1, waypoint spacing in u2. Default 3.0.
    pub max_depth_m: f64,
}

impl Default for CameraParams {
    fn default() -> Self {
        Self { hfov_rad: 87f64.to_radians(), vfov_rad: 58f64.to_radians(), min_depth_m: 0.3, max_depth_m: 3.0 }
    }
}

/// Traversability estimation from 3D points (notes §2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TraversabilityParams {
    /// Radius of the disc whose points are fused per cell, metres. Default 0.15.
    pub disc_radius_m: f64,
    /// Slope at which hazard reaches 1, radians. Default 35°: 30° put a 15° ramp exactly at
    /// τ = 0.5 (a coin flip in floating point); 35° makes slopes up to 17.5° free at τ = 0.5.
    pub max_slope_rad: f64,
    /// Height difference within the disc at which hazard reaches 1, metres. Default 0.15: with
    /// the step measured from the fitted plane (below), steps ≥ 7.5 cm (a 10 cm kerb) are lethal
    /// at τ = 0.5 and a 15° ramp (≈ 2 cm residual at 5 cm cells) is not.
    pub max_step_m: f64,
    /// Measure the step relative to the disc's fitted plane (true) or as the raw max z − min z of
    /// notes §2 (false). Default true: the raw step counts a ramp's rise across the disc (8 cm
    /// for 15° over 0.3 m) as a step, so no `max_step_m` accepts the ramp and rejects a kerb.
    pub step_relative_to_plane: bool,
    /// Smallest horizontal spread of the disc's points — the standard deviation along their
    /// narrowest horizontal direction — as a fraction of `disc_radius_m`; below it the plane's
    /// tilt is undetermined and the cell is unknown (not in the paper). Default 0.2: a full disc
    /// of points has 0.5, a half disc 0.26, a one-cell strip at the edge of the data 0.1 (on
    /// laspy's plane.ply such strips gave 20–90° slopes from 1 cm z quantisation). At most 1/√2
    /// (points on the disc's rim), or no cell could be known.
    pub min_spread_ratio: f64,
    /// Roughness (RMS distance to the plane) at which hazard reaches 1, metres. Default 0.05.
    pub max_roughness_m: f64,
    /// Fewer points than this in the disc: the cell is unknown. Default 5.
    pub min_points: u32,
    /// Registration noise discount (not in the paper): before the hazard, roughness² loses
    /// k²·σ̄² and the step loses k·√2·σ̄, σ̄² being the mean vertical noise variance of the
    /// disc's points (given with [`crate::traversability::TraversabilityMap::insert_points_with_variance`];
    /// 0 for points inserted without one, so it changes nothing for them). Two scans registered
    /// with slightly different tilts disagree by about the range times the tilt error — 3 cm at
    /// 10 m for 3 mrad — which alone would make far cells look rough; the discount counts only
    /// what noise does not explain, and close, precise points take over as the robot nears.
    /// k, standard deviations. Default 2.
    pub noise_discount_sigmas: f64,
    /// Risk acceptance τ: score ≥ τ is free, below is lethal. Default 0.5.
    pub tau: f64,
}

impl Default for TraversabilityParams {
    fn default() -> Self {
        Self {
            disc_radius_m: 0.15,
            max_slope_rad: 35f64.to_radians(),
            max_step_m: 0.15,
            step_relative_to_plane: true,
            min_spread_ratio: 0.2,
            max_roughness_m: 0.05,
            min_points: 5,
            noise_discount_sigmas: 2.0,
            tau: 0.5,
        }
    }
}

/// Frontier detection and clustering (notes §3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrontierParams {
    /// Clusters smaller than this are dropped, cells. Default 5 (0.25 m at 0.05 m).
    pub min_cluster_cells: usize,
    /// Linked chains are split into clusters of at most this many cells. Default 40 (2 m).
    pub max_cluster_cells: usize,
    /// Two goals closer than this are the same goal for the blacklist, metres. Default 0.5.
    pub blacklist_radius_m: f64,
}

impl Default for FrontierParams {
    fn default() -> Self {
        Self { min_cluster_cells: 5, max_cluster_cells: 40, blacklist_radius_m: 0.5 }
    }
}

/// Path planning (notes §4).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerParams {
    /// Whether unknown cells may be crossed. Default false (paper).
    pub allow_unknown: bool,
}

/// First-level utility u1 (notes §5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct U1Params {
    /// α: weight of the path-length term; 1 − α weights the entropy term. Default 0.35 (paper).
    pub alpha: f64,
    /// Δθ: angle between rays, radians, in [2π / 4096, 2π]. Default 8.5° (paper).
    pub delta_theta_rad: f64,
    /// γ: per-cell visibility degradation along a ray, in (0, 1]. Default 0.99 at 0.05 m.
    pub gamma: f64,
}

impl Default for U1Params {
    fn default() -> Self {
        Self { alpha: 0.35, delta_theta_rad: 8.5f64.to_radians(), gamma: 0.99 }
    }
}

/// How I_p is normalised over the N candidates (notes §6, eq. 12).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InfoNormalisation {
    /// Divide by the largest path information among the candidates (paper).
    Max,
    /// Divide by the mean path information among the candidates.
    Mean,
}

/// Second-level utility u2 (notes §6).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct U2Params {
    /// β: weight of u1 in u2; 1 − β weights the path information. Default 0.4 (paper).
    pub beta: f64,
    /// N: how many of the best candidates by u1 are re-ranked. Default 7 (paper).
    pub top_n: usize,
    /// Landmark voxel edge, metres. Default 0.25 (paper).
    pub voxel_m: f64,
    /// Waypoint spacing along a path, metres, at least one grid cell; `None` uses the camera's
    /// max depth (paper).
    pub waypoint_spacing_m: Option<f64>,
    /// Bearing noise σ_b, radians. Default 0.01.
    pub sigma_bearing_rad: f64,
    /// Landmark position noise σ_l used when a landmark has no covariance, metres. Default 0.05.
    pub sigma_landmark_m: f64,
    /// Normalisation of I_p. Default `max` (paper).
    pub normalisation: InfoNormalisation,
    /// Stand each waypoint's camera on the map's known ground, tilted with it (notes §6); false:
    /// flat ground at the robot's height, level (the paper). Default true.
    pub follow_terrain: bool,
    /// Known ground hides the voxels behind it (not in the paper). Default false.
    pub occlusion: bool,
    /// The control `u2_truth`: its views are taken every this far along the path (at least one
    /// cell of the decision's map), metres, > 0. Default 0.5 (the simulated SLAM's keyframe
    /// spacing, where the front end tracks or not).
    pub tracked_spacing_m: f64,
    /// The control `u2_truth`: a view holding at least this many landmark voxels counts as
    /// tracked, ≥ 1. Default 10 (the front end's `relocalise_min`: 10 matched landmarks).
    pub tracked_min_voxels: usize,
}

impl Default for U2Params {
    fn default() -> Self {
        Self {
            beta: 0.4,
            top_n: 7,
            voxel_m: 0.25,
            waypoint_spacing_m: None,
            sigma_bearing_rad: 0.01,
            sigma_landmark_m: 0.05,
            normalisation: InfoNormalisation::Max,
            follow_terrain: true,
            occlusion: false,
            tracked_spacing_m: 0.5,
            tracked_min_voxels: 10,
        }
    }
}

/// Which goal selector runs (notes §7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Strategy {
    /// FIT-SLAM: u1 then u2.
    Fit,
    /// Nearest reachable candidate by path length.
    Greedy,
    /// Uniform among reachable candidates (seeded).
    Random,
    /// Ablation: u1 only (β = 1).
    U1,
    /// Control: uniform (seeded) among the candidates whose path length is within ±20 % of the
    /// goal FIT-SLAM would choose ([`crate::select::matched`]).
    Matched,
    /// Control: as `matched`, but among u1's N best only, the candidates u2 chooses from: FIT-SLAM's
    /// candidates and path lengths without its information ([`crate::select::matched`]).
    #[cfg_attr(feature = "clap", value(name = "matched_top"))]
    MatchedTop,
    /// Control: u2 with I_p replaced by the path length, normalised the same way
    /// ([`crate::select::fit`]): what u2 does if I_p only rewarded going far.
    #[cfg_attr(feature = "clap", value(name = "u2_length"))]
    U2Length,
    /// Positive control, simulator only: u2 with I_p replaced by the share of the path whose
    /// camera views hold enough of the world's *true* landmarks ([`crate::select::fit`]): a
    /// choice that knows where the visual front end will starve, mapped or not.
    #[cfg_attr(feature = "clap", value(name = "u2_truth"))]
    U2Truth,
}

impl Strategy {
    /// Every variant, in declaration order.
    pub const ALL: [Strategy; 8] = [
        Strategy::Fit,
        Strategy::Greedy,
        Strategy::Random,
        Strategy::U1,
        Strategy::Matched,
        Strategy::MatchedTop,
        Strategy::U2Length,
        Strategy::U2Truth,
    ];

    /// The name used in files, on the command line and in the studio (`fit`, `greedy`, …).
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Fit => "fit",
            Strategy::Greedy => "greedy",
            Strategy::Random => "random",
            Strategy::U1 => "u1",
            Strategy::Matched => "matched",
            Strategy::MatchedTop => "matched_top",
            Strategy::U2Length => "u2_length",
            Strategy::U2Truth => "u2_truth",
        }
    }

    /// Whether the policy reads the world's true landmarks instead of the SLAM's map (the
    /// simulator's positive control `u2_truth`; an adapter with no world refuses it).
    pub fn reads_true_landmarks(self) -> bool {
        self == Strategy::U2Truth
    }
}

impl std::fmt::Display for Strategy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Strategy {
    type Err = UnknownName;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL.into_iter().find(|v| v.name() == s).ok_or_else(|| UnknownName::new("strategy", s, &Self::ALL))
    }
}

/// A name that is none of a choice's variants.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
#[error("unknown {what} `{given}`: expected one of {expected}")]
pub struct UnknownName {
    /// What was being named (e.g. `"strategy"`).
    pub what: &'static str,
    /// The name given.
    pub given: String,
    /// The variants' names, comma-separated.
    pub expected: String,
}

impl UnknownName {
    /// The error for `given`, listing `variants` as the names expected.
    pub fn new<T: std::fmt::Display>(what: &'static str, given: &str, variants: &[T]) -> Self {
        let expected = variants.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ");
        Self { what, given: given.into(), expected }
    }
}

/// The heading a strategy sets its goal with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GoalHeading {
    /// The path's heading where it ends: the robot stops as it arrives (the paper's baselines
    /// have no Θ*, which is u1's).
    #[default]
    Arrival,
    /// u1's best view Θ*, the paper's for `fit` and `u1`.
    ThetaStar,
}

/// Selector choice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SelectorParams {
    /// Strategy. Default `fit`.
    pub strategy: Strategy,
    /// Seed for the random selector.
    pub seed: u64,
    /// The baselines' goal heading (`greedy`, `random`, `matched`, `matched_top`). Default
    /// `arrival`.
    pub baseline_heading: GoalHeading,
    /// The goal heading of the strategies that have Θ* (`fit`, `u1`, `u2_length`). Default
    /// `theta_star` (the paper's); `arrival` is the ablation of Θ*'s turn on arrival (u1 still
    /// scores each candidate's entropy gain at Θ*).
    pub fit_heading: GoalHeading,
}

impl Default for SelectorParams {
    fn default() -> Self {
        Self { strategy: Strategy::Fit, seed: 0, baseline_heading: GoalHeading::Arrival, fit_heading: GoalHeading::ThetaStar }
    }
}

impl Params {
    /// These parameters with lethal cells inflated by `radius_m` instead of `robot.radius_m`
    /// (the tight retries of the simulator and the robot node).
    pub fn with_robot_radius_m(&self, radius_m: f64) -> Params {
        let mut p = self.clone();
        p.robot.radius_m = radius_m;
        p
    }

    /// Waypoint spacing d_max actually used by u2.
    pub fn waypoint_spacing_m(&self) -> f64 {
        self.u2.waypoint_spacing_m.unwrap_or(self.camera.max_depth_m)
    }

    /// TOML text of these parameters.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// YAML text of these parameters (the robot node's parameter file).
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).unwrap_or_default()
    }
}
