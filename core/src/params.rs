//! Every tunable of the planner in one typed struct, with the paper's defaults.
//!
//! Read from TOML or YAML; unknown keys are rejected so that a typo never silently falls back to
//! a default. The studio exports exactly this struct and the robot node reads exactly this struct.
//! Angles are radians, lengths metres (suffixes say so).

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// All planner parameters. `Params::default()` holds the paper's values (notes §8).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    pub grid: GridParams,
    pub robot: RobotParams,
    pub camera: CameraParams,
    pub traversability: TraversabilityParams,
    pub frontier: FrontierParams,
    pub planner: PlannerParams,
    pub u1: U1Params,
    pub u2: U2Params,
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
    /// half-width 0.22 m plus a 3 cm margin). At most [`MAX_RADIUS_CELLS`] cells of the grid.
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
    /// Δθ: angle between rays, radians, in [2π / [`MAX_RAYS`], 2π]. Default 8.5° (paper).
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
}

impl Strategy {
    /// Every variant, in declaration order.
    pub const ALL: [Strategy; 5] = [Strategy::Fit, Strategy::Greedy, Strategy::Random, Strategy::U1, Strategy::Matched];

    /// The name used in files, on the command line and in the studio (`fit`, `greedy`, …).
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Fit => "fit",
            Strategy::Greedy => "greedy",
            Strategy::Random => "random",
            Strategy::U1 => "u1",
            Strategy::Matched => "matched",
        }
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
    pub what: &'static str,
    pub given: String,
    /// The variants' names, comma-separated.
    pub expected: String,
}

impl UnknownName {
    pub fn new<T: std::fmt::Display>(what: &'static str, given: &str, variants: &[T]) -> Self {
        let expected = variants.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ");
        Self { what, given: given.into(), expected }
    }
}

/// The heading a baseline (`greedy`, `random`, `matched`) sets its goal with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BaselineHeading {
    /// The path's heading where it ends: the robot stops as it arrives (the paper's baselines
    /// have no Θ*, which is u1's).
    #[default]
    Arrival,
    /// u1's best view Θ*, as `fit` and `u1`.
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
    /// The baselines' goal heading. Default `arrival`.
    pub baseline_heading: BaselineHeading,
}

impl Default for SelectorParams {
    fn default() -> Self {
        Self { strategy: Strategy::Fit, seed: 0, baseline_heading: BaselineHeading::Arrival }
    }
}

/// A parameter file that could not be read.
#[derive(Debug, Error)]
pub enum ParamsError {
    #[error("{source_name}: invalid TOML: {message}")]
    Toml { source_name: String, message: String },
    #[error("{source_name}: invalid YAML: {message}")]
    Yaml { source_name: String, message: String },
    #[error("{source_name}: {error}")]
    Invalid { source_name: String, error: InvalidParam },
    #[error("{source_name}: not UTF-8 text")]
    NotUtf8 { source_name: String },
    #[error("{source_name}: `{key}` has moved: write it as `{moved_to}`")]
    Moved { source_name: String, key: String, moved_to: String },
}

/// A parameter value outside its documented range: the key (its path in the file, e.g.
/// `u1.alpha` or `explore.tight_inflations_m[1]`) and why. Shown as one sentence: "`key` must
/// be …" or "`key` (value) is …" where the reason goes on from the key, else "`key`: reason".
#[derive(Clone, Debug, PartialEq, Error)]
#[error("{key}{}{reason}", if reason.starts_with("must ") || reason.starts_with('(') { " " } else { ": " })]
pub struct InvalidParam {
    pub key: String,
    pub reason: String,
}

impl InvalidParam {
    pub fn new(key: impl Into<String>, reason: impl Into<String>) -> Self {
        Self { key: key.into(), reason: reason.into() }
    }

    /// The same error with `prefix` before its key (a struct's error seen from its parent).
    pub fn under(mut self, prefix: &str) -> Self {
        self.key.insert_str(0, prefix);
        self
    }
}

/// A TOML error `e` of `text` in one line, "line N: message" (the crate's own Display draws a
/// multi-line caret).
pub(crate) fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let line = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    let message = e.message().trim().replace('\n', " ");
    match line {
        Some(l) => format!("line {l}: {message}"),
        None => message,
    }
}

impl ParamsError {
    /// The TOML error `e` of `text`, from `source_name`.
    pub(crate) fn toml(text: &str, source_name: &str, e: &toml::de::Error) -> Self {
        ParamsError::Toml { source_name: source_name.into(), message: toml_error_line(text, e) }
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

    /// Parses TOML text; `source_name` (usually the file name) is quoted in errors.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Self, ParamsError> {
        let text = crate::io::without_bom_str(text);
        let p: Params = from_toml_over_default(text).map_err(|e| ParamsError::toml(text, source_name, &e))?;
        p.validate().map_err(|error| ParamsError::Invalid { source_name: source_name.into(), error })?;
        Ok(p)
    }

    /// Parses YAML text; `source_name` is quoted in errors.
    pub fn from_yaml(text: &str, source_name: &str) -> Result<Self, ParamsError> {
        let text = crate::io::without_bom_str(text);
        let p: Params = serde_yaml::from_str(text)
            .map_err(|e| ParamsError::Yaml { source_name: source_name.into(), message: e.to_string().replace('\n', " ") })?;
        p.validate().map_err(|error| ParamsError::Invalid { source_name: source_name.into(), error })?;
        Ok(p)
    }

    /// Parses TOML or YAML by the file name's extension (`.toml`, `.yaml`/`.yml`).
    pub fn from_bytes(bytes: &[u8], source_name: &str) -> Result<Self, ParamsError> {
        let text = std::str::from_utf8(bytes).map_err(|_| ParamsError::NotUtf8 { source_name: source_name.into() })?;
        let lower = source_name.to_ascii_lowercase();
        if lower.ends_with(".yaml") || lower.ends_with(".yml") {
            Self::from_yaml(text, source_name)
        } else {
            Self::from_toml(text, source_name)
        }
    }

    /// TOML text of these parameters.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// YAML text of these parameters (the robot node's parameter file).
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).unwrap_or_default()
    }

    /// Checks ranges; the error names the first bad field.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        use std::f64::consts::{FRAC_1_SQRT_2, PI, TAU};
        let pos = check_positive;
        let nonneg = check_non_negative;
        let bad = |key: &str, reason: String| Err(InvalidParam::new(key, reason));
        fn unit(name: &str, v: f64) -> Result<(), InvalidParam> {
            if (0.0..=1.0).contains(&v) { Ok(()) } else { Err(InvalidParam::new(name, format!("must be in [0, 1] (got {})", Num(v)))) }
        }
        pos("grid.resolution_m", self.grid.resolution_m)?;
        nonneg("robot.radius_m", self.robot.radius_m)?;
        check_radius_cells("robot.radius_m", self.robot.radius_m, self.grid.resolution_m)?;
        if !self.robot.camera_height_m.is_finite() {
            return bad("robot.camera_height_m", format!("must be finite (got {})", Num(self.robot.camera_height_m)));
        }
        pos("camera.hfov_rad", self.camera.hfov_rad)?;
        pos("camera.vfov_rad", self.camera.vfov_rad)?;
        if self.camera.hfov_rad > TAU {
            return bad("camera.hfov_rad", format!("must be ≤ 2π (got {})", Num(self.camera.hfov_rad)));
        }
        if self.camera.vfov_rad >= PI {
            return bad("camera.vfov_rad", format!("must be < π (got {})", Num(self.camera.vfov_rad)));
        }
        pos("camera.max_depth_m", self.camera.max_depth_m)?;
        if !(self.camera.min_depth_m >= 0.0 && self.camera.min_depth_m < self.camera.max_depth_m) {
            return bad("camera.min_depth_m", format!("must be in [0, camera.max_depth_m) (got {})", Num(self.camera.min_depth_m)));
        }
        pos("traversability.disc_radius_m", self.traversability.disc_radius_m)?;
        check_radius_cells("traversability.disc_radius_m", self.traversability.disc_radius_m, self.grid.resolution_m)?;
        pos("traversability.max_slope_rad", self.traversability.max_slope_rad)?;
        pos("traversability.max_step_m", self.traversability.max_step_m)?;
        pos("traversability.max_roughness_m", self.traversability.max_roughness_m)?;
        unit("traversability.tau", self.traversability.tau)?;
        nonneg("traversability.noise_discount_sigmas", self.traversability.noise_discount_sigmas)?;
        nonneg("traversability.min_spread_ratio", self.traversability.min_spread_ratio)?;
        // Points anywhere in a disc of radius r spread at most r/√2 along any direction (all on
        // its rim): a larger ratio would leave every cell unknown.
        if self.traversability.min_spread_ratio > FRAC_1_SQRT_2 {
            let reason = format!(
                "must be ≤ 1/√2 ≈ 0.707 (got {}): no points in a disc spread wider, so every cell would be unknown",
                Num(self.traversability.min_spread_ratio)
            );
            return bad("traversability.min_spread_ratio", reason);
        }
        if self.frontier.max_cluster_cells == 0 {
            return bad("frontier.max_cluster_cells", "must be ≥ 1".into());
        }
        if self.frontier.min_cluster_cells > self.frontier.max_cluster_cells {
            let f = &self.frontier;
            return bad(
                "frontier.min_cluster_cells",
                format!("must be ≤ frontier.max_cluster_cells ({}; got {})", f.max_cluster_cells, f.min_cluster_cells),
            );
        }
        nonneg("frontier.blacklist_radius_m", self.frontier.blacklist_radius_m)?;
        unit("u1.alpha", self.u1.alpha)?;
        pos("u1.delta_theta_rad", self.u1.delta_theta_rad)?;
        if self.u1.delta_theta_rad > TAU {
            return bad("u1.delta_theta_rad", format!("must be ≤ 2π (got {})", Num(self.u1.delta_theta_rad)));
        }
        if TAU / self.u1.delta_theta_rad > MAX_RAYS as f64 {
            let reason = format!("must be ≥ 2π / {MAX_RAYS} (at most {MAX_RAYS} rays; got {})", Num(self.u1.delta_theta_rad));
            return bad("u1.delta_theta_rad", reason);
        }
        if !(self.u1.gamma > 0.0 && self.u1.gamma <= 1.0) {
            return bad("u1.gamma", format!("must be in (0, 1] (got {})", Num(self.u1.gamma)));
        }
        unit("u2.beta", self.u2.beta)?;
        if self.u2.top_n == 0 {
            return bad("u2.top_n", "must be ≥ 1".into());
        }
        pos("u2.voxel_m", self.u2.voxel_m)?;
        if let Some(s) = self.u2.waypoint_spacing_m {
            pos("u2.waypoint_spacing_m", s)?;
        }
        check_waypoint_spacing(self.waypoint_spacing_m(), self.grid.resolution_m)?;
        pos("u2.sigma_bearing_rad", self.u2.sigma_bearing_rad)?;
        nonneg("u2.sigma_landmark_m", self.u2.sigma_landmark_m)?;
        Ok(())
    }

    /// Waypoint spacing d_max actually used by u2.
    pub fn waypoint_spacing_m(&self) -> f64 {
        self.u2.waypoint_spacing_m.unwrap_or(self.camera.max_depth_m)
    }
}

/// Most rays a decision casts per candidate (Δθ ≥ 2π / this): far beyond any useful fan, and
/// a bound on a fan's memory.
pub const MAX_RAYS: usize = 4096;

/// Largest radius, in grid cells, of the robot's inflation and of the traversability disc:
/// 50 m at 0.05 m, and a bound on the kernels' work per cell.
pub const MAX_RADIUS_CELLS: f64 = 1000.0;

/// `Ok` when the radius `radius_m` is at most [`MAX_RADIUS_CELLS`] cells of `resolution_m`.
pub fn check_radius_cells(name: &str, radius_m: f64, resolution_m: f64) -> Result<(), InvalidParam> {
    let cells = radius_m / resolution_m;
    if cells <= MAX_RADIUS_CELLS {
        Ok(())
    } else {
        let reason = format!("({} m) is {cells:.0} cells of {} m, over the limit of {MAX_RADIUS_CELLS}", Num(radius_m), Num(resolution_m));
        Err(InvalidParam::new(name, reason))
    }
}

/// `Ok` when u2's waypoints are at least a cell of `resolution_m` apart (closer ones add nothing
/// but work: a path of L metres has L / spacing of them).
pub fn check_waypoint_spacing(spacing_m: f64, resolution_m: f64) -> Result<(), InvalidParam> {
    if spacing_m >= resolution_m {
        Ok(())
    } else {
        let reason = format!("({} m) must be at least a grid cell ({} m)", Num(spacing_m), Num(resolution_m));
        Err(InvalidParam::new("u2.waypoint_spacing_m", reason))
    }
}

/// Deserialises TOML `text` over `T::default()`: every key the text leaves out keeps the
/// default's value, at every depth. serde's `default` alone fills the missing keys of a nested
/// table from the nested type's own `Default`, which is not what its parent chose where the two
/// differ (the SLAM front end's optimiser stops earlier than [`crate::slam::OptimizerParams`]'s
/// own default): a file restating one nested default would then change the others. A file the
/// merge refuses (a wrong type, an unknown key) is parsed once more straight into `T`, whose
/// error carries the position in `text`.
pub fn from_toml_over_default<T: Default + Serialize + DeserializeOwned>(text: &str) -> Result<T, toml::de::Error> {
    let text = crate::io::without_bom_str(text);
    let given: toml::Table = toml::from_str(text)?;
    let mut merged = toml::Table::try_from(T::default()).map_err(<toml::de::Error as serde::de::Error>::custom)?;
    merge_into(&mut merged, given);
    toml::Value::Table(merged).try_into().map_err(|e| toml::from_str::<T>(text).err().unwrap_or(e))
}

/// Overwrites `base` with `over`, descending into tables present in both.
fn merge_into(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge_into(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// A value as error messages print it: as Rust prints an `f64` (shortest round-trip form), but
/// in scientific notation below 10⁻⁴ or from 10⁹ up in magnitude, where that form runs to
/// hundreds of digits (1e300 prints 301).
#[derive(Clone, Copy, Debug)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a.is_finite() && a != 0.0 && !(1e-4..1e9).contains(&a) { write!(f, "{:e}", self.0) } else { write!(f, "{}", self.0) }
    }
}

/// `Ok` when `v` is finite and > 0, else a message naming the field `name` (for `validate`s).
pub fn check_positive(name: &str, v: f64) -> Result<(), InvalidParam> {
    if v.is_finite() && v > 0.0 { Ok(()) } else { Err(InvalidParam::new(name, format!("must be a finite number > 0 (got {})", Num(v)))) }
}

/// `Ok` when `v` is finite and ≥ 0, else a message naming the field `name` (for `validate`s).
pub fn check_non_negative(name: &str, v: f64) -> Result<(), InvalidParam> {
    if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(InvalidParam::new(name, format!("must be a finite number ≥ 0 (got {})", Num(v)))) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Messages print a value as Rust does, but huge and tiny ones in scientific notation.
    #[test]
    fn messages_print_numbers_short() {
        let shown = |v: f64| Num(v).to_string();
        assert_eq!(shown(0.25), "0.25");
        assert_eq!(shown(-3.0), "-3");
        assert_eq!(shown(0.0), "0");
        assert_eq!(shown(123456789.0), "123456789");
        assert_eq!(shown(1e9), "1e9");
        assert_eq!(shown(-1e300), "-1e300");
        assert_eq!(shown(1.5e-5), "1.5e-5");
        assert_eq!(shown(1e-4), "0.0001");
        assert_eq!((shown(f64::NAN), shown(f64::INFINITY)), ("NaN".to_string(), "inf".to_string()));
        assert_eq!(check_non_negative("x", -1e300).unwrap_err().to_string(), "x must be a finite number ≥ 0 (got -1e300)");
    }

    #[test]
    fn defaults_are_the_papers() {
        let p = Params::default();
        assert_eq!(p.u1.alpha, 0.35);
        assert_eq!(p.u2.beta, 0.4);
        assert!((p.u1.delta_theta_rad.to_degrees() - 8.5).abs() < 1e-12);
        assert_eq!(p.u2.top_n, 7);
        assert_eq!(p.grid.resolution_m, 0.05);
        assert_eq!(p.u2.voxel_m, 0.25);
        assert!((p.camera.hfov_rad.to_degrees() - 87.0).abs() < 1e-12);
        assert!(p.validate().is_ok());
    }

    /// Values whose work or memory has no useful bound are rejected (they hung or aborted a
    /// decision: 1e-9 rad between rays asked for 6e9 rays).
    #[test]
    fn values_beyond_the_work_bounds_are_rejected() {
        let check = |edit: fn(&mut Params), needle: &str| {
            let mut p = Params::default();
            edit(&mut p);
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        };
        check(|p| p.u1.delta_theta_rad = 1e-9, "at most 4096 rays");
        check(|p| p.robot.radius_m = 50.01, "robot.radius_m (50.01 m) is 1000 cells");
        check(|p| p.traversability.disc_radius_m = 1e6, "traversability.disc_radius_m");
        check(|p| p.u2.waypoint_spacing_m = Some(0.04), "at least a grid cell (0.05 m)");
        // The bounds themselves are allowed.
        let mut p = Params::default();
        p.u1.delta_theta_rad = std::f64::consts::TAU / MAX_RAYS as f64;
        p.robot.radius_m = 49.99;
        p.u2.waypoint_spacing_m = Some(0.05);
        assert_eq!(p.validate(), Ok(()));
    }

    #[test]
    fn toml_and_yaml_round_trip() {
        let mut p = Params::default();
        p.u1.alpha = 0.5;
        p.selector.strategy = Strategy::Greedy;
        p.u2.waypoint_spacing_m = Some(2.0);
        assert_eq!(Params::from_toml(&p.to_toml(), "t.toml").unwrap(), p);
        assert_eq!(Params::from_yaml(&p.to_yaml(), "t.yaml").unwrap(), p);
    }

    #[test]
    fn partial_files_keep_defaults_and_unknown_keys_are_rejected() {
        let p = Params::from_toml("[u1]\nalpha = 0.2\n", "p.toml").unwrap();
        assert_eq!(p.u1.alpha, 0.2);
        assert_eq!(p.u2.beta, 0.4);
        let e = Params::from_toml("[u1]\nalpah = 0.2\n", "p.toml").unwrap_err().to_string();
        assert!(e.contains("p.toml") && e.contains("alpah"), "{e}");
        let e = Params::from_yaml("u2:\n  bta: 0.1\n", "p.yaml").unwrap_err().to_string();
        assert!(e.contains("p.yaml") && e.contains("bta"), "{e}");
        let e = Params::from_toml("[u1]\nalpha = 2.0\n", "p.toml").unwrap_err().to_string();
        assert!(e.contains("u1.alpha"), "{e}");
    }
}
