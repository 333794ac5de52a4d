//! What the studio shows: a map (traversability score layer), a landmark set, the robot, the
//! exploration boundary and the blacklist. Everything computed from it goes through
//! `fitslam_core`; this module only holds the inputs and caches each stage's output so that a
//! slider re-runs only the stages it affects (see [`crate::pipeline`]).

use fitslam_core::frontier::{Blacklist, Boundary};
use fitslam_core::grid::{CellClass, Grid, GridGeometry, OccupancyGrid};
use fitslam_core::params::TraversabilityParams;
use fitslam_core::traversability::TraversabilityMap;
use fitslam_core::{PointCloud, Pose2};
use std::sync::Arc;

/// A map as the studio holds it: one traversability score per cell in [0, 1] (1 traversable,
/// 0 lethal), NaN where unknown. Thresholding by τ gives the binary grid (notes §2).
#[derive(Clone, Debug)]
pub struct MapLayers {
    /// The score layer (NaN = unknown).
    pub score: Grid<f32>,
    /// Where it came from (file name or built-in asset name).
    pub source: String,
    /// How it was made, shown in the status line.
    pub kind: MapKind,
    /// For a map computed from a terrain cloud: the fused points, so the score can be
    /// recomputed when the hazard parameters change.
    pub terrain: Option<Terrain>,
}

/// The point map behind a cloud-made score layer and the parameters the score was computed with.
#[derive(Clone, Debug)]
pub struct Terrain {
    pub map: Arc<TraversabilityMap>,
    pub params: TraversabilityParams,
}

/// How a map was obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapKind {
    /// A ROS occupancy grid (map_server YAML + PGM/PNG): score = 1 − occupancy/100.
    Occupancy,
    /// Computed from a 3D point cloud by the traversability estimator.
    Traversability,
    /// Made by the studio itself.
    Synthetic,
}

impl MapLayers {
    /// A score layer with no terrain points behind it.
    pub fn from_score(score: Grid<f32>, source: impl Into<String>, kind: MapKind) -> Self {
        Self { score, source: source.into(), kind, terrain: None }
    }

    /// From a ROS occupancy grid: free 0 → score 1, lethal 100 → 0, p% → 1 − p/100, unknown
    /// (−1) → NaN. A trinary map then thresholds to itself for any τ in (0, 1].
    pub fn from_occupancy(grid: &OccupancyGrid, source: impl Into<String>) -> Self {
        let data = grid
            .data
            .iter()
            .map(|&v| match CellClass::of(v) {
                CellClass::Unknown => f32::NAN,
                _ => 1.0 - f32::from(v.clamp(0, 100)) / 100.0,
            })
            .collect();
        Self::from_score(Grid { geometry: grid.geometry, data }, source, MapKind::Occupancy)
    }

    /// From a terrain point map, scored with `params` (notes §2); keeps the map for
    /// [`Self::refresh_terrain`].
    pub fn from_terrain(map: TraversabilityMap, params: &TraversabilityParams, source: impl Into<String>) -> Self {
        let score = map.compute(params).score;
        let terrain = Some(Terrain { map: Arc::new(map), params: params.clone() });
        Self { score, source: source.into(), kind: MapKind::Traversability, terrain }
    }

    /// Recomputes the score of a terrain map when a hazard parameter differs from the ones it was
    /// computed with (τ only thresholds, later); returns whether it did. Other maps: no-op.
    pub fn refresh_terrain(&mut self, params: &TraversabilityParams) -> bool {
        let Some(t) = &mut self.terrain else { return false };
        let same_hazard = TraversabilityParams { tau: t.params.tau, ..params.clone() } == t.params;
        if same_hazard {
            return false;
        }
        self.score = t.map.compute(params).score;
        t.params = params.clone();
        true
    }

    pub fn geometry(&self) -> GridGeometry {
        self.score.geometry
    }

    /// Number of known cells.
    pub fn known_cells(&self) -> usize {
        self.score.data.iter().filter(|s| !s.is_nan()).count()
    }
}

/// The landmark set used by u2 (notes §6).
#[derive(Clone, Debug, Default)]
pub struct Landmarks {
    pub cloud: PointCloud,
    pub source: String,
}

/// All inputs of one decision besides the parameters.
#[derive(Clone, Debug)]
pub struct Scene {
    pub map: MapLayers,
    pub landmarks: Landmarks,
    pub robot: Pose2,
    pub boundary: Boundary,
    pub blacklist: Blacklist,
}

impl Scene {
    /// A scene with the robot on the free cell nearest the map's centre (or the given pose if
    /// it is free), the whole map as boundary and an empty blacklist.
    pub fn new(map: MapLayers, landmarks: Landmarks, robot: Option<Pose2>, blacklist_radius_m: f64) -> Self {
        let (x0, y0, x1, y1) = map.geometry().bounds_m();
        let boundary = Boundary::from_bounds(x0, y0, x1, y1);
        let mut scene = Self { map, landmarks, robot: Pose2::new(0.0, 0.0, 0.0), boundary, blacklist: Blacklist::new(blacklist_radius_m) };
        let start = robot.unwrap_or(Pose2::new(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0));
        scene.robot = scene.nearest_free_pose(start, 0.5).unwrap_or(start);
        scene
    }

    /// The free cell (score ≥ `min_score`) nearest to `pose`; keeps the yaw. `None` if the map
    /// has no such cell.
    pub fn nearest_free_pose(&self, pose: Pose2, min_score: f32) -> Option<Pose2> {
        nearest_pose(&self.map.score, pose, |s| *s >= min_score)
    }

    /// Landmark height range (min z, max z), for colouring; `None` without landmarks.
    pub fn landmark_z_range(&self) -> Option<(f64, f64)> {
        let mut it = self.landmarks.cloud.points.iter();
        let first = it.next()?;
        Some(it.fold((first.z, first.z), |(lo, hi), p| (lo.min(p.z), hi.max(p.z))))
    }
}

/// The cell of `grid` nearest to `pose` (searched in growing square rings, nearest centre within
/// a ring) whose value satisfies `ok`, as a pose keeping the yaw; `pose` itself if its own cell
/// does. `None` if no cell does or the pose is not finite. O(cells) at worst.
pub fn nearest_pose<T>(grid: &Grid<T>, pose: Pose2, ok: impl Fn(&T) -> bool) -> Option<Pose2> {
    let g = grid.geometry;
    let c = g.cell_unchecked(pose.x_m, pose.y_m)?;
    let max_r = g.width.max(g.height) as i32 + c.col.abs().max(c.row.abs());
    for r in 0..=max_r {
        let mut best: Option<(i64, i32, i32)> = None;
        for dr in -r..=r {
            for dc in -r..=r {
                if dr.abs() != r && dc.abs() != r {
                    continue;
                }
                let (col, row) = (c.col + dc, c.row + dr);
                if grid.get(fitslam_core::Cell::new(col, row)).is_some_and(&ok) {
                    let d2 = i64::from(dc) * i64::from(dc) + i64::from(dr) * i64::from(dr);
                    if best.is_none_or(|(b, _, _)| d2 < b) {
                        best = Some((d2, col, row));
                    }
                }
            }
        }
        if let Some((_, col, row)) = best {
            if r == 0 {
                return Some(pose);
            }
            let (x, y) = g.center_of(fitslam_core::Cell::new(col, row));
            return Some(Pose2::new(x, y, pose.yaw_rad));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_core::grid::{FREE, LETHAL, UNKNOWN};

    #[test]
    fn occupancy_becomes_score() {
        let g = GridGeometry::new(0.0, 0.0, 1.0, 4, 1);
        let occ = OccupancyGrid { geometry: g, data: vec![FREE, LETHAL, 30, UNKNOWN] };
        let m = MapLayers::from_occupancy(&occ, "m");
        assert_eq!(m.score.data[0], 1.0);
        assert_eq!(m.score.data[1], 0.0);
        assert!((m.score.data[2] - 0.7).abs() < 1e-6);
        assert!(m.score.data[3].is_nan());
        assert_eq!(m.known_cells(), 3);
        // τ = 0.5 thresholds it back to the trinary classes (30 % occupied is free).
        let back = fitslam_core::traversability::to_occupancy(&m.score, 0.5);
        assert_eq!(back.data, vec![FREE, LETHAL, FREE, UNKNOWN]);
    }

    #[test]
    fn nearest_pose_searches_rings_and_keeps_yaw() {
        // 5 × 5 grid of 1 m cells, only cell (4, 1) is ok: from (0.5, 0.5) the answer is its
        // centre (4.5, 1.5).
        let g = GridGeometry::new(0.0, 0.0, 1.0, 5, 5);
        let mut grid = Grid::filled(g, false);
        grid.data[5 + 4] = true;
        let p = nearest_pose(&grid, Pose2::new(0.5, 0.5, 1.0), |v| *v).unwrap();
        assert_eq!(p, Pose2::new(4.5, 1.5, 1.0));
        // Already ok: unchanged (not moved to the centre).
        let q = Pose2::new(4.2, 1.9, -2.0);
        assert_eq!(nearest_pose(&grid, q, |v| *v), Some(q));
        // Nothing ok, or a non-finite pose: None.
        assert_eq!(nearest_pose(&Grid::filled(g, false), q, |v| *v), None);
        assert_eq!(nearest_pose(&grid, Pose2::new(f64::NAN, 0.0, 0.0), |v| *v), None);
        // From outside the grid it still finds the cell.
        assert_eq!(nearest_pose(&grid, Pose2::new(9.5, 1.5, 0.0), |v| *v), Some(Pose2::new(4.5, 1.5, 0.0)));
    }
}
