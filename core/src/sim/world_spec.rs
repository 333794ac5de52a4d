//! A world's description ([`WorldSpec`], a TOML file) and its validation: every key is checked
//! with the reason it is wrong before anything is built ([`super::World::build`] builds it).

#![allow(clippy::collapsible_if, clippy::nonminimal_bool)] // explicit range checks read better

use super::heightfield::HeightfieldError;
use super::landmarks::LandmarkDensity;
pub use super::obstacles::RockSpec;
pub use super::terrain_spec::TerrainSpec;
use crate::grid::GridGeometry;
use crate::io::MapError;
use crate::params::{InvalidParam, Num};
use crate::traversability::TraversabilityError;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a world could not be built.
#[derive(Debug, Error)]
pub enum WorldError {
    /// The world file is not valid TOML for a [`WorldSpec`] (syntax, unknown key, wrong type).
    #[error("{name}: invalid TOML: {message}")]
    Toml {
        /// The name given to [`WorldSpec::from_toml`].
        name: String,
        /// The parser's message, with the line.
        message: String,
    },
    /// A value out of range, or a world the machine cannot hold (named by the file when parsed
    /// from one).
    #[error("{0}")]
    Invalid(InvalidParam),
    /// [`Self::Invalid`] in a parsed world file.
    #[error("{name}: {error}")]
    InvalidFile {
        /// The name given to [`WorldSpec::from_toml`].
        name: String,
        /// The key and why it is wrong.
        error: InvalidParam,
    },
    /// A file the spec names (DEM, map_server YAML or image) could not be loaded.
    #[error("{name}: {message}")]
    Load {
        /// The file's name, as the spec gives it.
        name: String,
        /// The loader's error.
        message: String,
    },
    /// The DEM image is unreadable or its scaling invalid.
    #[error(transparent)]
    Heightfield(#[from] HeightfieldError),
    /// The map_server terrain's YAML or image is invalid.
    #[error(transparent)]
    Map(#[from] MapError),
    /// The ground-truth traversability map could not be built.
    #[error(transparent)]
    Traversability(#[from] TraversabilityError),
}

/// Most rock or landmark sites a world may scatter (spacing against the terrain's area), so that
/// a tiny spacing is an error rather than an allocation the machine cannot make.
pub(crate) const MAX_SCATTER_SITES: f64 = (1u64 << 22) as f64;

/// A world file: everything the simulator needs to build the ground truth.
///
/// # Examples
///
/// ```
/// use fitslam_core::sim::WorldError;
/// use fitslam_core::WorldSpec;
///
/// let text = "name = \"ridge\"\nstart = [1.0, 1.0, 0.0]\n\
///             [terrain]\nkind = \"procedural\"\nseed = 3\nsize_m = 8.0\nridge_height_m = 0.3\n";
/// let spec = WorldSpec::from_toml(text, "ridge.toml")?;
/// assert_eq!(spec.cell_m, 0.05); // the default
/// // Member 2 of the family: same kind of terrain, other seeds.
/// assert_ne!(spec.with_world_seed(2).terrain, spec.terrain);
///
/// // Out-of-range values are refused before anything is built, named by their key.
/// match WorldSpec::from_toml(&text.replace("size_m = 8.0", "size_m = 800.0"), "ridge.toml") {
///     Err(WorldError::InvalidFile { error, .. }) => assert_eq!(error.key, "terrain.size_m"),
///     other => panic!("expected an invalid terrain.size_m, got {other:?}"),
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldSpec {
    /// A short name (plots, summary). Default "".
    #[serde(default)]
    pub name: String,
    /// Seed of rocks and landmarks (the procedural terrain has its own). Default 1.
    #[serde(default = "one")]
    pub seed: u64,
    /// Heightfield cell, metres. Default 0.05 (map_server terrains use the map's resolution).
    #[serde(default = "default_cell")]
    pub cell_m: f64,
    /// Where the ground comes from (required).
    pub terrain: TerrainSpec,
    /// Rocks scattered by the seed; none if absent.
    #[serde(default)]
    pub rocks: Option<RockSpec>,
    /// Boxes (and straight walls) standing on the terrain.
    #[serde(default)]
    pub boxes: Vec<BoxSpec>,
    /// Ramps: wedges rising from 0 at one end to `height_m` at the other.
    #[serde(default)]
    pub ramps: Vec<RampSpec>,
    /// Visual landmark density. Default [`LandmarkDensity::default`].
    #[serde(default)]
    pub landmarks: LandmarkSpec,
    /// Start pose [x_m, y_m, yaw_rad].
    pub start: [f64; 3],
    /// Exploration boundary [min_x_m, min_y_m, max_x_m, max_y_m], min < max, holding the start;
    /// default: the world inset by 0.5 m.
    #[serde(default)]
    pub boundary: Option<[f64; 4]>,
    /// Mission time limit, seconds, finite and > 0. Default 5000.
    #[serde(default = "default_time_limit")]
    pub time_limit_s: f64,
    /// The family's members [first, last] (inclusive, at most [`MAX_WORLD_SEEDS`]) that
    /// `compare` runs when it is not given `--world-seeds` ([`Self::with_world_seed`]); default:
    /// none, the file's world as written.
    #[serde(default)]
    pub world_seeds: Option<[u64; 2]>,
    /// What else a family's members draw per world seed (DEM crop, rotation and relief).
    #[serde(default)]
    pub family: FamilySpec,
}

/// Most members of a family one comparison runs (each holds a built world in memory).
pub const MAX_WORLD_SEEDS: u64 = 1000;

fn one() -> u64 {
    1
}
fn default_cell() -> f64 {
    0.05
}
fn default_time_limit() -> f64 {
    5000.0
}

/// What each member of a family draws from its world seed besides the seeds of the terrain,
/// rocks and landmarks ([`WorldSpec::with_world_seed`]); every key is optional (none: the
/// file's value in every member).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FamilySpec {
    /// DEM: the crop's position (`crop_centre`) drawn uniformly where the (rotated) crop lies
    /// inside the DEM.
    pub dem_crop_anywhere: bool,
    /// DEM: the crop's rotation drawn uniformly in [low, high] degrees.
    pub dem_rotation_deg: Option<[f64; 2]>,
    /// DEM: the relief scale drawn uniformly in [low, high], each ≥ 0.
    pub dem_relief_scale: Option<[f64; 2]>,
    /// Every member starts at the file's `start` instead of one drawn on its ground (a world
    /// built around its start, such as the positive control's two routes). Default false.
    pub keep_start: bool,
}

/// An axis-aligned box (or wall) on the terrain: its top is `height_m` above the ground at its
/// centre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Lower-left corner [x, y], metres (finite, < `max_m` on each axis).
    pub min_m: [f64; 2],
    /// Upper-right corner [x, y], metres. The box must hold at least one cell centre of the
    /// terrain.
    pub max_m: [f64; 2],
    /// Height of the top above the ground at the box's centre, metres, > 0: a box only raises
    /// the terrain (each cell to at least that top), so it cannot dig a pit.
    pub height_m: f64,
}

/// An axis-aligned wedge: rises from 0 at `from` side to `height_m` along `axis` ("x" or "-x",
/// "y", "-y").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RampSpec {
    /// Lower-left corner [x, y], metres (finite, < `max_m` on each axis).
    pub min_m: [f64; 2],
    /// Upper-right corner [x, y], metres. The ramp must hold at least one cell centre of the
    /// terrain.
    pub max_m: [f64; 2],
    /// Height of the high end above the ground at `min_m`, metres, > 0 (a ramp only raises the
    /// terrain).
    pub height_m: f64,
    /// The direction the ramp rises along: "x", "-x", "y" or "-y".
    pub rises_along: String,
}

/// Serde mirror of [`LandmarkDensity`]; every key defaults to [`LandmarkDensity::default`]'s value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LandmarkSpec {
    /// Lattice spacing of candidate positions, metres, > 0. Default 0.1.
    pub spacing_m: f64,
    /// Probability of a landmark at a candidate in the richest texture, [0, 1]. Default 0.5.
    pub max_probability: f64,
    /// Exponent sharpening the texture field (higher: starker rich/poor contrast). Default 4.
    pub contrast: f64,
    /// Wavelength of the texture field, metres, > 0. Default 6.
    pub texture_wavelength_m: f64,
    /// Landmarks per square metre of rock side, ≥ 0. Default 25.
    pub rock_density_per_m2: f64,
    /// Landmarks stand up to this high above the ground, metres, ≥ 0. Default 0.4.
    pub max_height_m: f64,
    /// Bare regions [min_x, min_y, max_x, max_y], metres: no landmark at all inside (ground,
    /// rocks and walls alike). Default none.
    pub bare_m: Vec<[f64; 4]>,
}

impl Default for LandmarkSpec {
    fn default() -> Self {
        let d = LandmarkDensity::default();
        Self {
            spacing_m: d.spacing_m,
            max_probability: d.max_probability,
            contrast: d.contrast,
            texture_wavelength_m: d.texture_wavelength_m,
            rock_density_per_m2: d.rock_density_per_m2,
            max_height_m: d.max_height_m,
            bare_m: Vec::new(),
        }
    }
}

impl LandmarkSpec {
    /// The density these keys describe.
    pub fn density(&self) -> LandmarkDensity {
        LandmarkDensity {
            spacing_m: self.spacing_m,
            max_probability: self.max_probability,
            contrast: self.contrast,
            texture_wavelength_m: self.texture_wavelength_m,
            rock_density_per_m2: self.rock_density_per_m2,
            max_height_m: self.max_height_m,
        }
    }
}

/// SplitMix64's finaliser of `a` and `b`: a member seed of a family, well spread for any two
/// inputs (consecutive world seeds give unrelated terrains).
fn mix_seed(a: u64, b: u64) -> u64 {
    let mut z = a ^ b.wrapping_add(0x9E37_79B9_7F4A_7C15).wrapping_mul(0xD6E8_FEB8_6659_FD93);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl WorldSpec {
    /// Member `world_seed` of the family this file describes: the same terrain kind and
    /// parameters, the seeds of the procedural terrain, the rocks, the landmarks and their
    /// texture drawn from the file's seeds and `world_seed`, and so is a floor plan. A DEM keeps
    /// its image; its crop, rotation and relief are drawn as `[family]` says
    /// ([`FamilySpec`]). A map_server plan keeps its ground. The start stays the file's:
    /// [`super::World::draw_start`] draws one per world seed on the built world.
    pub fn with_world_seed(&self, world_seed: u64) -> Self {
        let mut spec = self.clone();
        spec.seed = mix_seed(self.seed, world_seed);
        let (f, member_seed) = (&self.family, spec.seed);
        match &mut spec.terrain {
            TerrainSpec::Procedural { seed, .. } | TerrainSpec::FloorPlan { seed, .. } => *seed = mix_seed(*seed, world_seed),
            TerrainSpec::Dem { relief_scale, crop_centre, rotation_deg, .. } => {
                // One stream per drawn key, so adding a key to [family] leaves the others' draws.
                let draw = |k: i64| super::noise::hash_unit(k, 0, mix_seed(member_seed, 0xFA17));
                let lerp = |[lo, hi]: [f64; 2], u: f64| lo + (hi - lo) * u;
                if let Some(range) = f.dem_relief_scale {
                    *relief_scale = lerp(range, draw(0));
                }
                if let Some(range) = f.dem_rotation_deg {
                    *rotation_deg = lerp(range, draw(1));
                }
                if f.dem_crop_anywhere {
                    *crop_centre = [draw(2), draw(3)];
                }
            }
            TerrainSpec::MapServer { .. } => {}
        }
        spec
    }

    /// Parses a world file; `name` is quoted in errors.
    pub fn from_toml(text: &str, name: &str) -> Result<Self, WorldError> {
        let text = crate::io::without_bom_str(text);
        let spec: WorldSpec =
            toml::from_str(text).map_err(|e| WorldError::Toml { name: name.into(), message: crate::params::toml_error_line(text, &e) })?;
        spec.validate().map_err(|e| match e {
            WorldError::Invalid(error) => WorldError::InvalidFile { name: name.into(), error },
            other => other,
        })?;
        Ok(spec)
    }

    /// Rock and landmark sites on a terrain of this geometry: at most [`MAX_SCATTER_SITES`] each.
    pub(super) fn check_scatter_sites(&self, geometry: &GridGeometry) -> Result<(), WorldError> {
        let (min_x, min_y, max_x, max_y) = geometry.bounds_m();
        let sites = |spacing_m: f64| ((max_x - min_x) / spacing_m).floor() * ((max_y - min_y) / spacing_m).floor();
        let spacings = self.rocks.iter().map(|r| ("rocks", r.spacing_m)).chain([("landmarks", self.landmarks.spacing_m)]);
        for (what, spacing_m) in spacings {
            let n = sites(spacing_m);
            if n.is_nan() || n > MAX_SCATTER_SITES {
                let reason = format!("({}) gives {n:.3e} sites on this terrain, over the limit of {MAX_SCATTER_SITES}", Num(spacing_m));
                return Err(WorldError::Invalid(InvalidParam::new(format!("{what}.spacing_m"), reason)));
            }
        }
        Ok(())
    }

    /// Rocks no wider than the terrain: a rock's radius is at most half the terrain's shorter
    /// side. A larger one is surely a mistake (metres for centimetres), and it would not even
    /// show: every lattice site lies within `keep_clear_m` + radius of the start, so all are
    /// skipped without a word.
    pub(super) fn check_rock_radius(&self, geometry: &GridGeometry) -> Result<(), WorldError> {
        let Some(r) = &self.rocks else { return Ok(()) };
        let (min_x, min_y, max_x, max_y) = geometry.bounds_m();
        let (w, h) = (max_x - min_x, max_y - min_y);
        if r.radius_m[1] > 0.5 * w.min(h) {
            let reason = format!(
                "the largest radius {} m is wider than the terrain ({w} m × {h} m): at most half its shorter side, {} m",
                r.radius_m[1],
                0.5 * w.min(h)
            );
            return Err(WorldError::Invalid(InvalidParam::new("rocks.radius_m", reason)));
        }
        Ok(())
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), WorldError> {
        let bad = |key: &str, reason: String| Err(WorldError::Invalid(InvalidParam::new(key, reason)));
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !pos(self.cell_m) || self.cell_m > 1.0 {
            return bad("cell_m", format!("must be in (0, 1] (got {})", Num(self.cell_m)));
        }
        crate::params::check_positive("time_limit_s", self.time_limit_s).map_err(WorldError::Invalid)?;
        if let Some([first, last]) = self.world_seeds {
            if first > last || last - first >= MAX_WORLD_SEEDS {
                return bad(
                    "world_seeds",
                    format!("must be [first, last] with first ≤ last and at most {MAX_WORLD_SEEDS} members (got [{first}, {last}])"),
                );
            }
        }
        let f = &self.family;
        if let Some([lo, hi]) = f.dem_relief_scale {
            if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
                return bad("family.dem_relief_scale", format!("must be [low, high] with 0 ≤ low ≤ high (got [{}, {}])", Num(lo), Num(hi)));
            }
        }
        if let Some([lo, hi]) = f.dem_rotation_deg {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return bad("family.dem_rotation_deg", format!("must be [low, high], finite, low ≤ high (got [{}, {}])", Num(lo), Num(hi)));
            }
        }
        if !self.start.iter().all(|v| v.is_finite()) {
            return bad("start", format!("must be finite (got {:?})", self.start));
        }
        self.terrain.validate(self.cell_m).map_err(WorldError::Invalid)?;
        if let Some(r) = &self.rocks {
            if !pos(r.spacing_m)
                || !(0.0..=1.0).contains(&r.density)
                || !(r.radius_m[0] > 0.0 && r.radius_m[0] <= r.radius_m[1] && r.radius_m[1].is_finite())
                || !(r.height_m[0] >= 0.0 && r.height_m[0] <= r.height_m[1] && r.height_m[1].is_finite())
            {
                return bad(
                    "rocks",
                    format!(
                        "need spacing_m > 0, density in [0, 1], finite 0 < min ≤ max for radius_m and 0 ≤ min ≤ max for height_m \
                         (got spacing_m {}, density {}, radius_m {:?}, height_m {:?})",
                        r.spacing_m, r.density, r.radius_m, r.height_m
                    ),
                );
            }
            crate::params::check_non_negative("rocks.keep_clear_m", r.keep_clear_m).map_err(WorldError::Invalid)?;
        }
        for (i, b) in self.boxes.iter().enumerate() {
            check_box(&format!("boxes[{i}]"), b.min_m, b.max_m, b.height_m)?;
        }
        for (i, r) in self.ramps.iter().enumerate() {
            check_box(&format!("ramps[{i}]"), r.min_m, r.max_m, r.height_m)?;
            if !["x", "-x", "y", "-y"].contains(&r.rises_along.as_str()) {
                return bad(&format!("ramps[{i}].rises_along"), format!("must be x, -x, y or -y (got {:?})", r.rises_along));
            }
        }
        for (key, v) in [("spacing_m", self.landmarks.spacing_m), ("texture_wavelength_m", self.landmarks.texture_wavelength_m)] {
            if !pos(v) {
                return bad(&format!("landmarks.{key}"), format!("must be a finite number > 0 (got {})", Num(v)));
            }
        }
        let l = &self.landmarks;
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !(nonneg(l.rock_density_per_m2) && nonneg(l.max_height_m) && (0.0..=1.0).contains(&l.max_probability) && l.contrast.is_finite())
        {
            return bad(
                "landmarks",
                format!(
                    "need rock_density_per_m2 and max_height_m ≥ 0, max_probability in [0, 1], contrast finite (got {}, {}, {}, {})",
                    Num(l.rock_density_per_m2),
                    Num(l.max_height_m),
                    Num(l.max_probability),
                    Num(l.contrast)
                ),
            );
        }
        for (i, b) in self.landmarks.bare_m.iter().enumerate() {
            if !(b.iter().all(|v| v.is_finite()) && b[0] < b[2] && b[1] < b[3]) {
                return bad(&format!("landmarks.bare_m[{i}]"), format!("must be [min_x, min_y, max_x, max_y] with min < max (got {b:?})"));
            }
        }
        if let Some(b) = self.boundary {
            if !(b.iter().all(|v| v.is_finite()) && b[0] < b[2] && b[1] < b[3]) {
                return bad("boundary", format!("must be [min_x, min_y, max_x, max_y] with min < max (got {b:?})"));
            }
            // No cell is explorable from a start outside the boundary (the start cell is the
            // seed of the explorable region): say so here rather than "not traversable" later.
            let [x, y, _] = self.start;
            if !(b[0] <= x && x <= b[2] && b[1] <= y && y <= b[3]) {
                return bad("start", format!("({x}, {y}) is outside the boundary {b:?}"));
            }
        }
        Ok(())
    }
}

/// `Ok` when a box or ramp named `key` has finite corners with min < max on each axis and a
/// finite height > 0 (both only raise the terrain, to at most `height_m` above the ground at a
/// reference point: a height ≤ 0 would raise nothing, and a pit cannot be dug with one).
fn check_box(key: &str, min_m: [f64; 2], max_m: [f64; 2], height_m: f64) -> Result<(), WorldError> {
    let bad = |reason: String| Err(WorldError::Invalid(InvalidParam::new(key, reason)));
    if !min_m.iter().chain(&max_m).all(|v| v.is_finite()) {
        return bad(format!("min_m and max_m must be finite (got min_m {min_m:?}, max_m {max_m:?})"));
    }
    if !(min_m[0] < max_m[0] && min_m[1] < max_m[1]) {
        return bad(format!("min_m must be < max_m on each axis (got min_m {min_m:?}, max_m {max_m:?})"));
    }
    crate::params::check_positive(&format!("{key}.height_m"), height_m).map_err(WorldError::Invalid)
}
