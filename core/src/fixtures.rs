//! Shared fixture worlds for tests, benchmarks and examples (like GTSAM's `simulated2D.h`).
//!
//! Every world is deterministic: built from a seed with a ChaCha8 generator. Grids follow the ROS
//! convention (0 free, 100 lethal, −1 unknown) and are *thresholded, not inflated*, as a
//! [`crate::select::DecisionInput`] expects.
//!
//! - [`synthetic_world`]: a square map, partially explored around its centre with a ragged
//!   frontier, obstacles (discs and boxes) some of which hide unknown pockets, and landmarks
//!   mostly on obstacle surfaces. [`SyntheticWorldSpec::benchmark`] is the planner benchmark
//!   (100 m × 100 m at 0.05 m, 50,000 landmarks).
//! - [`corridor_two_frontiers`]: a straight corridor open to the unknown at both ends, the robot
//!   slightly nearer the west end, landmarks on the walls of the east half only: greedy goes
//!   west, FIT-SLAM east.

use crate::cloud::PointCloud;
use crate::grid::{Cell, FREE, Grid, GridGeometry, LETHAL, OccupancyGrid, UNKNOWN};
use crate::math;
use crate::pose::Pose2;
use nalgebra::Point3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::TAU;

/// A map, a landmark set and the robot's pose.
#[derive(Clone, Debug)]
pub struct SyntheticWorld {
    /// Thresholded (not inflated) occupancy grid.
    pub grid: OccupancyGrid,
    /// Landmarks (world frame, metres), without covariances.
    pub landmarks: PointCloud,
    /// Robot pose.
    pub robot: Pose2,
}

/// Parameters of [`synthetic_world`].
#[derive(Clone, Debug, PartialEq)]
pub struct SyntheticWorldSpec {
    /// Edge of the square map, metres (origin at (0, 0)).
    pub size_m: f64,
    /// Cell size, metres.
    pub resolution_m: f64,
    /// Mean radius of the explored region around the map centre, metres.
    pub explored_radius_m: f64,
    /// Number of obstacles inside the explored region.
    pub obstacles: usize,
    /// Number of landmarks.
    pub landmarks: usize,
    /// Seed of the generator.
    pub seed: u64,
}

impl SyntheticWorldSpec {
    /// The planner benchmark: 100 m × 100 m at 0.05 m (2000 × 2000 cells), explored out to about
    /// 30 m from the centre, 400 obstacles, 50,000 landmarks.
    pub fn benchmark() -> Self {
        Self { size_m: 100.0, resolution_m: 0.05, explored_radius_m: 30.0, obstacles: 400, landmarks: 50_000, seed: 7 }
    }

    /// A small world for tests: 20 m × 20 m at 0.1 m.
    pub fn small(seed: u64) -> Self {
        Self { size_m: 20.0, resolution_m: 0.1, explored_radius_m: 6.0, obstacles: 12, landmarks: 2_000, seed }
    }
}

/// Builds the world described by `spec` (see the module doc). O(cells + obstacles · area +
/// landmarks).
pub fn synthetic_world(spec: &SyntheticWorldSpec) -> SyntheticWorld {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let n = (spec.size_m / spec.resolution_m).round().max(1.0) as usize;
    let geometry = GridGeometry::new(0.0, 0.0, spec.resolution_m, n, n);
    let mut grid = Grid::filled(geometry, UNKNOWN);
    let centre = [0.5 * spec.size_m, 0.5 * spec.size_m];
    let r0 = spec.explored_radius_m;

    // Ragged boundary: a few harmonics plus a random jitter per 0.5° bin.
    const BINS: usize = 720;
    let phases: [f64; 4] = std::array::from_fn(|_| rng.random_range(0.0..TAU));
    let jitter: Vec<f64> = (0..BINS).map(|_| rng.random_range(-0.04..0.04) * r0).collect();
    let radius_at = |phi: f64| {
        let bin = ((phi.rem_euclid(TAU) / TAU) * BINS as f64) as usize % BINS;
        r0 * (1.0
            + 0.22 * math::sin(3.0 * phi + phases[0])
            + 0.1 * math::sin(7.0 * phi + phases[1])
            + 0.05 * math::sin(17.0 * phi + phases[2])
            + 0.03 * math::sin(41.0 * phi + phases[3]))
            + jitter[bin]
    };
    for r in 0..n {
        for c in 0..n {
            let (x, y) = geometry.center_of(Cell::new(c as i32, r as i32));
            let (dx, dy) = (x - centre[0], y - centre[1]);
            if (dx * dx + dy * dy).sqrt() < radius_at(math::atan2(dy, dx)) {
                grid.data[r * n + c] = FREE;
            }
        }
    }

    // Obstacles inside the explored region, 2 m clear of the robot; some hide an unknown pocket.
    let mut surfaces: Vec<(f64, f64, f64, f64, bool)> = Vec::new(); // (cx, cy, half_w, half_h, disc)
    let mut tries = 0;
    while surfaces.len() < spec.obstacles && tries < spec.obstacles * 50 {
        tries += 1;
        let phi = rng.random_range(0.0..TAU);
        let rho = rng.random_range(0.0..1.0f64).sqrt() * radius_at(phi) * 0.95;
        let (cx, cy) = (centre[0] + rho * math::cos(phi), centre[1] + rho * math::sin(phi));
        let disc = rng.random_range(0.0..1.0) < 0.5;
        let (hw, hh): (f64, f64) = if disc {
            let r: f64 = rng.random_range(0.2..0.8);
            (r, r)
        } else {
            (rng.random_range(0.1..1.5), rng.random_range(0.1..1.5))
        };
        if math::hypot(cx - centre[0], cy - centre[1]) < 2.0 + hw.max(hh) * 1.5 {
            continue;
        }
        let pocket = rng.random_range(0.0..1.0) < 0.3;
        let (pdx, pdy) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let mut stamp = |x0: f64, y0: f64, x1: f64, y1: f64, value: i8, shape: &dyn Fn(f64, f64) -> bool| {
            let (Some(a), Some(b)) =
                (geometry.cell_of(x0.max(0.0), y0.max(0.0)), geometry.cell_of(x1.min(spec.size_m - 1e-9), y1.min(spec.size_m - 1e-9)))
            else {
                return;
            };
            for r in a.row..=b.row {
                for c in a.col..=b.col {
                    let (x, y) = geometry.center_of(Cell::new(c, r));
                    if shape(x, y) {
                        grid.data[r as usize * n + c as usize] = value;
                    }
                }
            }
        };
        if pocket {
            // An unobserved pocket beside the obstacle (its "shadow").
            let (px, py) = (cx + pdx * (hw + 0.6), cy + pdy * (hh + 0.6));
            stamp(px - 0.6, py - 0.6, px + 0.6, py + 0.6, UNKNOWN, &|x, y| math::hypot(x - px, y - py) < 0.6);
        }
        if disc {
            stamp(cx - hw, cy - hw, cx + hw, cy + hw, LETHAL, &|x, y| math::hypot(x - cx, y - cy) <= hw);
        } else {
            stamp(cx - hw, cy - hh, cx + hw, cy + hh, LETHAL, &|_, _| true);
        }
        surfaces.push((cx, cy, hw, hh, disc));
    }

    // Landmarks: 70 % on obstacle surfaces, 30 % scattered over the explored region.
    let mut points = Vec::with_capacity(spec.landmarks);
    for k in 0..spec.landmarks {
        if k % 10 < 7 && !surfaces.is_empty() {
            let (cx, cy, hw, hh, disc) = surfaces[rng.random_range(0..surfaces.len())];
            let (x, y) = if disc {
                let a = rng.random_range(0.0..TAU);
                (cx + hw * math::cos(a), cy + hw * math::sin(a))
            } else {
                let t = rng.random_range(0.0..4.0f64);
                let u = t.fract() * 2.0 - 1.0;
                match t as u32 {
                    0 => (cx + u * hw, cy - hh),
                    1 => (cx + hw, cy + u * hh),
                    2 => (cx - u * hw, cy + hh),
                    _ => (cx - hw, cy - u * hh),
                }
            };
            points.push(Point3::new(x, y, rng.random_range(0.0..2.0)));
        } else {
            let phi = rng.random_range(0.0..TAU);
            let rho = rng.random_range(0.0..1.0f64).sqrt() * radius_at(phi);
            points.push(Point3::new(centre[0] + rho * math::cos(phi), centre[1] + rho * math::sin(phi), rng.random_range(0.0..1.5)));
        }
    }
    SyntheticWorld { grid, landmarks: PointCloud::from_points(points), robot: Pose2::new(centre[0], centre[1], 0.0) }
}

/// A 24 m × 4 m map at 0.1 m: a corridor 2 m wide (free rows 10..=29, lethal walls on rows 9
/// and 30) from x = 4.0 m to x = 19.6 m (columns 40..=195), unknown everywhere else. The robot
/// stands at column 115, row 20 — 7.5 m from the west end and 8.0 m from the east end. When
/// `landmarks_east` is set, landmarks line both walls every 0.2 m at z = 0.5 m between the
/// robot and the east end; none lie to the west.
pub fn corridor_two_frontiers(landmarks_east: bool) -> SyntheticWorld {
    let geometry = GridGeometry::new(0.0, 0.0, 0.1, 240, 40);
    let mut grid = Grid::filled(geometry, UNKNOWN);
    for c in 40..=195 {
        for r in 9..=30 {
            grid.data[r * 240 + c] = if r == 9 || r == 30 { LETHAL } else { FREE };
        }
    }
    let mut points = Vec::new();
    if landmarks_east {
        let mut x = 11.6;
        while x < 19.6 {
            points.push(Point3::new(x, 0.95, 0.5));
            points.push(Point3::new(x, 3.05, 0.5));
            x += 0.2;
        }
    }
    let (x, y) = geometry.center_of(Cell::new(115, 20));
    SyntheticWorld { grid, landmarks: PointCloud::from_points(points), robot: Pose2::new(x, y, 0.0) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_world_is_deterministic_and_partially_explored() {
        let a = synthetic_world(&SyntheticWorldSpec::small(3));
        let b = synthetic_world(&SyntheticWorldSpec::small(3));
        assert_eq!(a.grid, b.grid);
        assert_eq!(a.landmarks, b.landmarks);
        let count = |v: i8| a.grid.data.iter().filter(|&&x| x == v).count();
        let (free, lethal, unknown) = (count(FREE), count(LETHAL), count(UNKNOWN));
        assert!(free > 0 && lethal > 0 && unknown > 0);
        assert_eq!(free + lethal + unknown, a.grid.data.len());
        assert_eq!(a.landmarks.len(), 2_000);
        // The robot's cell is free.
        assert_eq!(*a.grid.at_world(a.robot.x_m, a.robot.y_m).unwrap(), FREE);
        let c = synthetic_world(&SyntheticWorldSpec::small(4));
        assert_ne!(a.grid, c.grid);
    }

    #[test]
    fn corridor_layout() {
        let w = corridor_two_frontiers(true);
        assert_eq!(*w.grid.at_world(w.robot.x_m, w.robot.y_m).unwrap(), FREE);
        assert!((w.robot.x_m - 11.55).abs() < 1e-9);
        assert!(w.landmarks.points.iter().all(|p| p.x > w.robot.x_m));
        assert!(corridor_two_frontiers(false).landmarks.is_empty());
    }
}
