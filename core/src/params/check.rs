//! Checking parameters: [`Validate`] checks every field of a parameter struct, and [`Valid`]
//! is the proof that it did, so the code that takes a `Valid<T>` (the selectors, the explorer,
//! the simulator) never checks again. [`InvalidParam`] names the first bad key.

use serde::Serialize;
use std::ops::Deref;
use thiserror::Error;

use super::Params;

/// A parameter struct whose every field can be checked against its documented range.
pub trait Validate {
    /// Checks every field; the error names the first bad one by its key path relative to this
    /// struct (`u1.alpha`; a parent adds its own prefix with [`InvalidParam::under`]).
    fn validate(&self) -> Result<(), InvalidParam>;
}

/// A `T` that passed [`Validate::validate`]: made only by [`Valid::new`] (or, inside the crate,
/// from a part of a valid whole), read through `Deref`. Serialises as `T`.
///
/// # Examples
///
/// Parameters are checked once, where they enter; whatever takes a `Valid<Params>` relies on it.
/// To change a checked value, take it out and check it again:
///
/// ```
/// use fitslam_core::{Params, Valid};
///
/// let checked = Valid::new(Params::default())?;
/// assert_eq!(checked.robot.radius_m, Params::default().robot.radius_m); // read through Deref
///
/// let mut edited = checked.into_inner();
/// edited.robot.radius_m = -0.1;
/// let error = Valid::new(edited).unwrap_err();
/// assert_eq!(error.key, "robot.radius_m");
/// println!("{error}"); // the key and why its value is wrong
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Valid<T>(T);

impl<T: Validate> Valid<T> {
    /// Checks `value`; the error names the first bad key.
    pub fn new(value: T) -> Result<Self, InvalidParam> {
        value.validate()?;
        Ok(Self(value))
    }
}

impl<T> Valid<T> {
    /// A value whose validity follows from a valid whole it was taken from (crate-internal: the
    /// parts of a valid struct are valid).
    pub(crate) fn part_of_valid(value: T) -> Self {
        Self(value)
    }

    /// The checked value, to edit (check it again with [`Valid::new`]).
    pub fn into_inner(self) -> T {
        self.0
    }
}

impl<T> Deref for Valid<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<T: Default> Default for Valid<T> {
    /// The defaults, which are valid by construction (each crate's tests check it).
    fn default() -> Self {
        Self(T::default())
    }
}

impl Valid<Params> {
    /// These parameters with lethal cells inflated by `radius_m` instead of `robot.radius_m`
    /// (the explorer's tight retries). A smaller radius keeps every range valid, so `radius_m`
    /// is clamped to [0, `robot.radius_m`].
    pub(crate) fn with_robot_radius_m(&self, radius_m: f64) -> Self {
        Self(self.0.with_robot_radius_m(radius_m.clamp(0.0, self.0.robot.radius_m)))
    }

    /// These parameters with another selector (its fields have no range to check).
    pub fn with_selector(&self, selector: super::SelectorParams) -> Self {
        let mut p = self.0.clone();
        p.selector = selector;
        Self(p)
    }
}

/// A parameter value outside its documented range: the key (its path in the file, e.g.
/// `u1.alpha` or `explore.tight_inflations_m[1]`) and why. Shown as one sentence: "`key` must
/// be …" or "`key` (value) is …" where the reason goes on from the key, else "`key`: reason".
#[derive(Clone, Debug, PartialEq, Error)]
#[error("{key}{}{reason}", if reason.starts_with("must ") || reason.starts_with('(') { " " } else { ": " })]
pub struct InvalidParam {
    /// The parameter's path in the file (e.g. `u1.alpha`).
    pub key: String,
    /// Why the value is wrong.
    pub reason: String,
}

impl InvalidParam {
    /// The error for `key` with `reason`.
    pub fn new(key: impl Into<String>, reason: impl Into<String>) -> Self {
        Self { key: key.into(), reason: reason.into() }
    }

    /// The same error with `prefix` before its key (a struct's error seen from its parent).
    pub fn under(mut self, prefix: &str) -> Self {
        self.key.insert_str(0, prefix);
        self
    }
}

impl Validate for Params {
    /// Checks ranges; the error names the first bad field.
    fn validate(&self) -> Result<(), InvalidParam> {
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
        pos("u2.tracked_spacing_m", self.u2.tracked_spacing_m)?;
        if self.u2.tracked_min_voxels == 0 {
            return bad("u2.tracked_min_voxels", "must be ≥ 1".into());
        }
        Ok(())
    }
}

/// Most rays a decision casts per candidate (Δθ ≥ 2π / this): far beyond any useful fan, and
/// a bound on a fan's memory.
pub(crate) const MAX_RAYS: usize = 4096;

/// Largest radius, in grid cells, of the robot's inflation and of the traversability disc:
/// 50 m at 0.05 m, and a bound on the kernels' work per cell.
pub(crate) const MAX_RADIUS_CELLS: f64 = 1000.0;

/// `Ok` when the radius `radius_m` is at most [`MAX_RADIUS_CELLS`] cells of `resolution_m`.
pub(crate) fn check_radius_cells(name: &str, radius_m: f64, resolution_m: f64) -> Result<(), InvalidParam> {
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
pub(crate) fn check_waypoint_spacing(spacing_m: f64, resolution_m: f64) -> Result<(), InvalidParam> {
    if spacing_m >= resolution_m {
        Ok(())
    } else {
        let reason = format!("({} m) must be at least a grid cell ({} m)", Num(spacing_m), Num(resolution_m));
        Err(InvalidParam::new("u2.waypoint_spacing_m", reason))
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
pub(crate) fn check_non_negative(name: &str, v: f64) -> Result<(), InvalidParam> {
    if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(InvalidParam::new(name, format!("must be a finite number ≥ 0 (got {})", Num(v)))) }
}
