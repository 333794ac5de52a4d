//! The simulated world (notes §8): a ground-truth heightfield with its obstacles (rocks, boxes,
//! walls, ramps all raise the heightfield), visual landmarks, a start pose, an exploration
//! boundary and a time limit, described by a TOML [`WorldSpec`] and built into a [`World`].
//!
//! Terrain sources: a seeded procedural generator (hills, ridges, tilt, ramps), a real DEM image
//! scaled to rover size, or a 2D map_server map whose occupied (and unknown) pixels are extruded
//! into walls. Core does no file IO: [`World::build`] takes a loader closure that returns a
//! named file's bytes (the CLI resolves names relative to the world file). A map_server YAML's
//! `image:` is asked for relative to the YAML's directory ([`relative_to`]), as map_server reads it.
//!
//! Ground truth for the metrics: the traversability of the true heightfield, computed by the same
//! estimator as the robot's map ([`crate::traversability`]) on dense noise-free points (four per
//! cell), so "untraversable" means the same thresholds for both; and the *explorable* cells: GT
//! free cells inside the boundary, 8-connected through GT free cells to the start.
//! Building is O(cells × disc cells).

#![allow(clippy::collapsible_if, clippy::nonminimal_bool)] // explicit range checks read better

use super::floor_plan::{FloorPlan, FloorPlanParams};
use super::heightfield::{DemScaling, Heightfield};
use super::landmarks::scatter_landmarks;
use super::noise::fractal_noise;
use super::obstacles::{Rock, scatter_rocks};
use crate::frontier::Boundary;
use crate::grid::{Cell, FREE, GridGeometry, LETHAL, OccupancyGrid};
use crate::math;
use crate::params::{InvalidParam, Num, TraversabilityParams};
use crate::pose::Pose2;
use crate::traversability::TraversabilityMap;
use nalgebra::Point3;
use thiserror::Error;

pub use super::world_spec::{MAX_WORLD_SEEDS, RockSpec, WorldSpec};

pub use super::world_spec::{BoxSpec, FamilySpec, LandmarkSpec, RampSpec, TerrainSpec, WorldError};

pub(crate) use super::world_spec::MAX_SCATTER_SITES;

/// Why a robot cannot start where a world puts it ([`World::check_start`]).
#[derive(Clone, Debug, Error, PartialEq)]
pub enum StartError {
    /// The start lies outside the exploration boundary.
    #[error("start ({x_m:.2}, {y_m:.2}) is outside the exploration boundary {boundary_m:?}{}", if *.default_boundary { " (by default the terrain inset by 0.5 m)" } else { "" })]
    OutsideBoundary {
        /// The start's x in the map frame, metres.
        x_m: f64,
        /// The start's y in the map frame, metres.
        y_m: f64,
        /// The boundary [min_x, min_y, max_x, max_y], metres.
        boundary_m: [f64; 4],
        /// Whether the boundary is the default one (the spec gives none).
        default_boundary: bool,
    },
    /// The start's cell is ground-truth untraversable (no explorable cell).
    #[error("start ({x_m:.2}, {y_m:.2}) is not on ground-truth traversable terrain")]
    NotTraversable {
        /// The start's x in the map frame, metres.
        x_m: f64,
        /// The start's y in the map frame, metres.
        y_m: f64,
    },
    /// Ground-truth untraversable ground lies within the robot's radius of the start.
    #[error(
        "start ({x_m:.2}, {y_m:.2}): untraversable ground {distance_m:.2} m away, within the robot radius {robot_radius_m} m; move the start"
    )]
    TooClose {
        /// The start's x in the map frame, metres.
        x_m: f64,
        /// The start's y in the map frame, metres.
        y_m: f64,
        /// Distance to the nearest untraversable cell centre, metres.
        distance_m: f64,
        /// The robot's radius, metres.
        robot_radius_m: f64,
    },
}

/// A built world: ground truth for the simulator and the metrics.
///
/// # Examples
///
/// ```
/// use fitslam_core::{Params, World, WorldSpec};
///
/// let text = "start = [0.5, 0.5, 0.0]\n[terrain]\nkind = \"procedural\"\nseed = 1\nsize_m = 4.0\n\
///             [[boxes]]\nmin_m = [2.0, 1.0]\nmax_m = [2.4, 3.0]\nheight_m = 0.5\n";
/// let spec = WorldSpec::from_toml(text, "wall.toml")?;
/// let params = Params::default();
/// let tr = &params.traversability;
/// let world = World::build(&spec, tr, tr.tau, |name| Err(format!("no file {name}")))?;
///
/// assert!(world.explorable_count > 0);
/// assert!(world.gt_lethal_at(2.2, 2.0)); // the wall
/// assert!(!world.gt_lethal_at(1.0, 2.0));
/// // The default boundary is the terrain inset by 0.5 m: a start at (0.5, 0.5) is on its edge,
/// // but a robot of 0.25 m radius stands clear of hazards there.
/// world.check_start(0.25)?;
/// // A start drawn for another member of the family stands clear too.
/// let [x, y, _] = world.draw_start(9, 0.25).ok_or("some ground is clear")?;
/// assert!(!world.gt_lethal_at(x, y));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct World {
    /// The spec it was built from.
    pub spec: WorldSpec,
    /// Ground heights including every obstacle.
    pub field: Heightfield,
    /// The rocks scattered on it (none without `rocks` in the spec).
    pub rocks: Vec<Rock>,
    /// Landmark positions (their index is their id).
    pub landmarks: Vec<Point3<f64>>,
    /// The spec's start pose, map frame.
    pub start: Pose2,
    /// The exploration boundary as a polygon, map frame.
    pub boundary: Boundary,
    /// Boundary as [min_x, min_y, max_x, max_y].
    pub boundary_box_m: [f64; 4],
    /// GT traversability thresholded (not inflated), on `field.geometry`.
    pub gt_occupancy: OccupancyGrid,
    /// GT free, inside the boundary, connected to the start.
    pub explorable: Vec<bool>,
    /// How many cells of `explorable` are true.
    pub explorable_count: usize,
}

/// Clearance beyond the robot radius around a drawn start ([`World::draw_start`]), metres: room
/// to turn in place before the first decision.
pub(crate) const START_CLEARANCE_M: f64 = 0.25;

impl World {
    /// Builds a world; `load(name)` returns the bytes of a file the spec names (its error is
    /// quoted in [`WorldError::Load`]).
    pub fn build<E: std::fmt::Display>(
        spec: &WorldSpec,
        traversability: &TraversabilityParams,
        tau: f64,
        mut load: impl FnMut(&str) -> Result<Vec<u8>, E>,
    ) -> Result<Self, WorldError> {
        spec.validate()?;
        let mut fetch = |name: &str| load(name).map_err(|e| WorldError::Load { name: name.into(), message: e.to_string() });
        let mut field = match &spec.terrain {
            TerrainSpec::Procedural {
                seed,
                size_m,
                hill_height_m,
                hill_wavelength_m,
                ridge_height_m,
                ridge_wavelength_m,
                tilt_x_deg,
                tilt_y_deg,
            } => {
                let n = (size_m / spec.cell_m).round().max(2.0) as usize;
                let g = GridGeometry::new(0.0, 0.0, size_m / n as f64, n, n);
                let (tx, ty) = (math::tan(tilt_x_deg.to_radians()), math::tan(tilt_y_deg.to_radians()));
                Heightfield::from_fn(g, |x, y| {
                    let hills = hill_height_m * fractal_noise(x, y, *hill_wavelength_m, 3, *seed);
                    let ridged = 1.0 - (2.0 * fractal_noise(x, y, *ridge_wavelength_m, 2, seed ^ 0xA5A5) - 1.0).abs();
                    let ridges = ridge_height_m * ridged.powi(4);
                    hills + ridges + tx * x + ty * y
                })
            }
            TerrainSpec::Dem { file, pixel_x_m, pixel_y_m, size_m, crop_fraction, relief_scale, crop_centre, rotation_deg } => {
                let bytes = fetch(file)?;
                let scaling = DemScaling {
                    pixel_x_m: *pixel_x_m,
                    pixel_y_m: *pixel_y_m,
                    world_size_m: *size_m,
                    cell_m: spec.cell_m,
                    crop_fraction: *crop_fraction,
                    crop_centre: *crop_centre,
                    rotation_rad: rotation_deg.to_radians(),
                };
                let mut f = Heightfield::from_dem_png(&bytes, file, scaling)?;
                f.heights_m.iter_mut().for_each(|z| *z *= relief_scale);
                f
            }
            TerrainSpec::MapServer { file, wall_height_m } => {
                let yaml_bytes = fetch(file)?;
                let yaml = crate::io::MapYaml::parse(&yaml_bytes, file)?;
                let image_name = relative_to(file, &yaml.image);
                let image = fetch(&image_name)?;
                let grid = crate::io::load_map(&yaml_bytes, file, &image, &image_name)?;
                let g = grid.geometry;
                // A thick wall's top is flat, hence traversable: refuse a start on one by name.
                if let Some(i) = g.cell_of(spec.start[0], spec.start[1]).and_then(|c| g.index(c))
                    && grid.data[i] != FREE
                {
                    let reason =
                        format!("({}, {}) is inside a wall: an occupied or unknown pixel of {image_name}", spec.start[0], spec.start[1]);
                    return Err(WorldError::Invalid(InvalidParam::new("start", reason)));
                }
                Heightfield { geometry: g, heights_m: grid.data.iter().map(|&v| if v == FREE { 0.0 } else { *wall_height_m }).collect() }
            }
            TerrainSpec::FloorPlan {
                seed,
                size_m,
                min_room_m,
                max_room_m,
                door_width_m,
                wall_thickness_m,
                wall_height_m,
                extra_door_probability,
            } => {
                let p = FloorPlanParams {
                    size_m: *size_m,
                    min_room_m: *min_room_m,
                    max_room_m: *max_room_m,
                    door_width_m: *door_width_m,
                    wall_thickness_m: *wall_thickness_m,
                    extra_door_probability: *extra_door_probability,
                };
                FloorPlan::generate(&p, *seed).heightfield(*size_m, spec.cell_m, *wall_height_m)
            }
        };
        let start_xy = (spec.start[0], spec.start[1]);
        if field.geometry.cell_of(start_xy.0, start_xy.1).is_none() {
            let reason = format!("({}, {}) is outside the terrain", start_xy.0, start_xy.1);
            return Err(WorldError::Invalid(InvalidParam::new("start", reason)));
        }
        spec.check_scatter_sites(&field.geometry)?;
        spec.check_rock_radius(&field.geometry)?;
        for (i, b) in spec.boxes.iter().enumerate() {
            let cells = stamp_box(&mut field, b);
            check_covers_cells(&format!("boxes[{i}]"), &field.geometry, b.min_m, b.max_m, cells)?;
        }
        for (i, r) in spec.ramps.iter().enumerate() {
            let cells = stamp_ramp(&mut field, r);
            check_covers_cells(&format!("ramps[{i}]"), &field.geometry, r.min_m, r.max_m, cells)?;
        }
        let rocks = match &spec.rocks {
            Some(r) => scatter_rocks(&mut field, spec.seed, r, start_xy),
            None => Vec::new(),
        };
        let rock_side_landmarks: f64 =
            rocks.iter().map(|r| (std::f64::consts::TAU * r.radius_m * r.height_m * spec.landmarks.rock_density_per_m2).round()).sum();
        if rock_side_landmarks > MAX_SCATTER_SITES {
            let reason = format!(
                "({}) puts {rock_side_landmarks:.3e} landmarks on the rocks, over the limit of {MAX_SCATTER_SITES}",
                Num(spec.landmarks.rock_density_per_m2)
            );
            return Err(WorldError::Invalid(InvalidParam::new("landmarks.rock_density_per_m2", reason)));
        }
        // Map frame: z = 0 on the ground under the start.
        let z0 = field.height_at(start_xy.0, start_xy.1).unwrap_or(0.0);
        field.heights_m.iter_mut().for_each(|z| *z -= z0);
        let mut landmarks = scatter_landmarks(&field, &rocks, &spec.landmarks.density(), spec.seed);
        let bare = |p: &Point3<f64>| spec.landmarks.bare_m.iter().any(|b| b[0] <= p.x && p.x <= b[2] && b[1] <= p.y && p.y <= b[3]);
        landmarks.retain(|p| !bare(p));

        let (min_x, min_y, max_x, max_y) = field.geometry.bounds_m();
        let boundary_box_m = spec.boundary.unwrap_or([min_x + 0.5, min_y + 0.5, max_x - 0.5, max_y - 0.5]);
        let boundary = Boundary::from_bounds(boundary_box_m[0], boundary_box_m[1], boundary_box_m[2], boundary_box_m[3]);
        let gt_occupancy = ground_truth_occupancy(&field, traversability, tau)?;
        let start = Pose2 { x_m: spec.start[0], y_m: spec.start[1], yaw_rad: spec.start[2] };
        let explorable = explorable_cells(&gt_occupancy, &boundary, start);
        let explorable_count = explorable.iter().filter(|&&e| e).count();
        Ok(Self {
            spec: spec.clone(),
            field,
            rocks,
            landmarks,
            start,
            boundary,
            boundary_box_m,
            gt_occupancy,
            explorable,
            explorable_count,
        })
    }

    /// A start for world seed `world_seed`: the centre of a cell drawn uniformly among those
    /// where a robot of `robot_radius_m` plus 0.25 m stands on ground-truth
    /// traversable ground inside the boundary, in the largest 8-connected region of such cells
    /// (so that the mission does not start in a pocket), with a uniform yaw in [−π, π). `None`
    /// when no cell qualifies. A pure function of the world and the seed; O(cells · disc).
    pub fn draw_start(&self, world_seed: u64, robot_radius_m: f64) -> Option<[f64; 3]> {
        let clear = crate::grid::inflate_lethal(&self.gt_occupancy, robot_radius_m + START_CLEARANCE_M);
        let g = clear.geometry;
        let ok = |i: usize| {
            let (x, y) = g.center_of(g.cell_at(i));
            clear.data[i] == FREE && self.boundary.contains(x, y)
        };
        // The largest 8-connected region of qualifying cells (the first found on a tie).
        let mut region = vec![u32::MAX; g.len()];
        let (mut best, mut best_size, mut label) = (u32::MAX, 0usize, 0u32);
        for i0 in 0..g.len() {
            if region[i0] != u32::MAX || !ok(i0) {
                continue;
            }
            let (mut stack, mut size) = (vec![i0], 0usize);
            region[i0] = label;
            while let Some(i) = stack.pop() {
                size += 1;
                let c = g.cell_at(i);
                for (dc, dr) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                    if let Some(j) = g.index(Cell::new(c.col + dc, c.row + dr))
                        && region[j] == u32::MAX
                        && ok(j)
                    {
                        region[j] = label;
                        stack.push(j);
                    }
                }
            }
            if size > best_size {
                (best, best_size) = (label, size);
            }
            label += 1;
        }
        if best_size == 0 {
            return None;
        }
        let pick = (super::hash_unit(0, 0, world_seed) * best_size as f64) as usize;
        let i = region.iter().enumerate().filter(|&(_, &r)| r == best).map(|(i, _)| i).nth(pick.min(best_size - 1))?;
        let (x, y) = g.center_of(g.cell_at(i));
        let yaw = (2.0 * super::hash_unit(1, 0, world_seed) - 1.0) * std::f64::consts::PI;
        Some([x, y, yaw])
    }

    /// Distance from (x, y) to the nearest centre of a ground-truth untraversable cell within
    /// `radius_m`, metres, if any (cells of the map only).
    pub(crate) fn nearest_gt_lethal_m(&self, x_m: f64, y_m: f64, radius_m: f64) -> Option<f64> {
        let occ = &self.gt_occupancy;
        crate::grid::cells_in_disc(&occ.geometry, x_m, y_m, radius_m).filter(|&(i, _)| occ.data[i] != FREE).map(|(_, d)| d).reduce(f64::min)
    }

    /// Whether a robot of `robot_radius_m` can start here: its whole footprint on ground-truth
    /// traversable ground. Otherwise its planner has no free cell to leave from, and a mission
    /// would end at once (the loaders of the tool and the studio refuse such worlds).
    pub fn check_start(&self, robot_radius_m: f64) -> Result<(), StartError> {
        let (x_m, y_m) = (self.start.x_m, self.start.y_m);
        if self.explorable_count == 0 {
            let b = self.boundary_box_m;
            if !(b[0] <= x_m && x_m <= b[2] && b[1] <= y_m && y_m <= b[3]) {
                return Err(StartError::OutsideBoundary { x_m, y_m, boundary_m: b, default_boundary: self.spec.boundary.is_none() });
            }
            return Err(StartError::NotTraversable { x_m, y_m });
        }
        match self.nearest_gt_lethal_m(x_m, y_m, robot_radius_m) {
            Some(distance_m) => Err(StartError::TooClose { x_m, y_m, distance_m, robot_radius_m }),
            None => Ok(()),
        }
    }

    /// Whether a robot whose centre is at (x, y) touches ground-truth untraversable terrain: its
    /// centre's cell is untraversable (outside the map counts) or a cell within `reach_m` of the
    /// centre is. A cell is untraversable when its disc (radius `disc_radius_m`) holds a hazard,
    /// so with `reach_m` = robot radius − disc radius the discs of the cells within reach cover
    /// the robot's footprint: a wall its body overhangs is caught, not only one under its centre.
    pub(crate) fn gt_touches_lethal(&self, x_m: f64, y_m: f64, reach_m: f64) -> bool {
        self.gt_lethal_at(x_m, y_m) || (reach_m > 0.0 && self.nearest_gt_lethal_m(x_m, y_m, reach_m).is_some())
    }

    /// Whether the ground-truth cell under (x, y) is untraversable (outside the map counts as
    /// untraversable).
    pub fn gt_lethal_at(&self, x_m: f64, y_m: f64) -> bool {
        let g = &self.gt_occupancy.geometry;
        match g.cell_of(x_m, y_m).and_then(|c| g.index(c)) {
            Some(i) => self.gt_occupancy.data[i] != FREE,
            None => true,
        }
    }
}

/// `name` (a file named in a file at `base`, e.g. a map_server YAML's `image:`) relative to
/// `base`'s directory, as map_server resolves it; an absolute `name`, or a `base` without a
/// directory, gives `name` unchanged.
pub fn relative_to(base: &str, name: &str) -> String {
    let path = std::path::Path::new(name);
    match std::path::Path::new(base).parent() {
        Some(dir) if !path.is_absolute() && !path.has_root() && !dir.as_os_str().is_empty() => {
            dir.join(path).to_string_lossy().into_owned()
        }
        _ => name.to_owned(),
    }
}

/// `Ok` when the box or ramp `key` raised `cells` cells (those whose centre it holds): one
/// outside the terrain, or thinner than a cell between two centres, has no effect at all.
fn check_covers_cells(key: &str, geometry: &GridGeometry, min_m: [f64; 2], max_m: [f64; 2], cells: usize) -> Result<(), WorldError> {
    if cells > 0 {
        return Ok(());
    }
    let (x0, y0, x1, y1) = geometry.bounds_m();
    let reason = format!(
        "(min_m {min_m:?}, max_m {max_m:?}) holds no cell centre of the terrain [{x0}, {y0}, {x1}, {y1}] at {} m: \
         it lies outside the terrain or is thinner than a cell, and would have no effect",
        geometry.resolution_m
    );
    Err(WorldError::Invalid(InvalidParam::new(key, reason)))
}

/// GT traversability: the estimator on four noise-free points per cell.
pub(crate) fn ground_truth_occupancy(field: &Heightfield, params: &TraversabilityParams, tau: f64) -> Result<OccupancyGrid, WorldError> {
    let g = field.geometry;
    let mut map = TraversabilityMap::new(g)?;
    let q = g.resolution_m * 0.25;
    let points = (0..g.len()).flat_map(|i| {
        let (x, y) = g.center_of(g.cell_at(i));
        [(-q, -q), (q, -q), (-q, q), (q, q)].into_iter().map(move |(dx, dy)| (x + dx, y + dy))
    });
    map.insert_points(points.filter_map(|(x, y)| field.height_at(x, y).map(|z| Point3::new(x, y, z))));
    let layers = map.compute(params);
    let mut occ = layers.to_occupancy(tau);
    // Cells the estimator leaves unknown (none in practice) are not traversable ground truth.
    occ.data.iter_mut().for_each(|v| {
        if *v != FREE {
            *v = LETHAL
        }
    });
    Ok(occ)
}

/// GT free cells inside `boundary` 8-connected through GT free cells (inside the boundary) to the
/// start's cell. O(cells).
pub(crate) fn explorable_cells(gt: &OccupancyGrid, boundary: &Boundary, start: Pose2) -> Vec<bool> {
    let g = gt.geometry;
    let mut seen = vec![false; g.len()];
    let inside = |c: Cell| {
        let (x, y) = g.center_of(c);
        boundary.contains(x, y)
    };
    let Some(s) = g.cell_of(start.x_m, start.y_m) else { return seen };
    let Some(si) = g.index(s) else { return seen };
    if gt.data[si] != FREE {
        return seen;
    }
    let mut stack = vec![s];
    seen[si] = true;
    while let Some(c) = stack.pop() {
        for dr in -1..=1 {
            for dc in -1..=1 {
                let n = Cell::new(c.col + dc, c.row + dr);
                if let Some(j) = g.index(n) {
                    if !seen[j] && gt.data[j] == FREE && inside(n) {
                        seen[j] = true;
                        stack.push(n);
                    }
                }
            }
        }
    }
    // The start cell counts only if inside the boundary.
    if !inside(s) {
        seen[si] = false;
    }
    seen
}

/// Calls `f` on every cell whose centre lies in the box; returns how many did.
fn for_cells_in_box(field: &mut Heightfield, min: [f64; 2], max: [f64; 2], mut f: impl FnMut(f64, f64, &mut f64)) -> usize {
    let g = field.geometry;
    let mut cells = 0;
    for i in 0..g.len() {
        let (x, y) = g.center_of(g.cell_at(i));
        if x >= min[0] && x <= max[0] && y >= min[1] && y <= max[1] {
            f(x, y, &mut field.heights_m[i]);
            cells += 1;
        }
    }
    cells
}

/// Raises the cells under the box; returns how many it covers.
fn stamp_box(field: &mut Heightfield, b: &BoxSpec) -> usize {
    let base = field.height_at((b.min_m[0] + b.max_m[0]) / 2.0, (b.min_m[1] + b.max_m[1]) / 2.0).unwrap_or(0.0);
    for_cells_in_box(field, b.min_m, b.max_m, |_, _, z| *z = z.max(base + b.height_m))
}

/// Raises the cells under the ramp; returns how many it covers.
fn stamp_ramp(field: &mut Heightfield, r: &RampSpec) -> usize {
    let base = field.height_at(r.min_m[0], r.min_m[1]).unwrap_or(0.0);
    let (lx, ly) = (r.max_m[0] - r.min_m[0], r.max_m[1] - r.min_m[1]);
    let axis = r.rises_along.clone();
    for_cells_in_box(field, r.min_m, r.max_m, |x, y, z| {
        let t = match axis.as_str() {
            "x" => (x - r.min_m[0]) / lx,
            "-x" => (r.max_m[0] - x) / lx,
            "y" => (y - r.min_m[1]) / ly,
            _ => (r.max_m[1] - y) / ly,
        };
        *z = z.max(base + r.height_m * t.clamp(0.0, 1.0));
    })
}
