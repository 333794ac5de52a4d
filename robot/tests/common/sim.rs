//! A small simulated robot for the node's tests: a ground-truth grid world whose map is revealed
//! around the robot by a perfect 2D range sensor (line of sight, `range_m`) as it drives along
//! A* paths on the ground truth at `speed_mps`. Landmarks sit on obstacle boundaries and enter the
//! landmark map once their cell has been seen.
//!
//! The node only sees what a real robot would publish: the map, the landmark cloud and the
//! pose; the sim is behind [`SimRobot`] so the core's mission simulator can replace it.

#![allow(dead_code)]

use fitslam_core::grid::{CellClass, FREE, Grid, LETHAL, UNKNOWN, inflate_lethal};
use fitslam_core::path::astar;
use fitslam_core::{Cell, GridGeometry, OccupancyGrid, Pose2};
use nalgebra::Point3;

/// What a simulated robot offers the test harness.
pub trait SimRobot {
    /// The explored map (0 free, 100 lethal, −1 unknown).
    fn map(&self) -> &OccupancyGrid;
    /// Landmarks seen so far (map frame).
    fn landmarks(&self) -> Vec<Point3<f64>>;
    /// The true pose.
    fn pose(&self) -> Pose2;
    /// Starts driving to `goal`; `Err` if no path exists on the ground truth.
    fn go_to(&mut self, goal: Pose2) -> Result<(), String>;
    /// Stops driving.
    fn stop(&mut self);
    /// Advances by `dt_s`; returns true when the current goal has just been reached.
    fn advance(&mut self, dt_s: f64) -> bool;
    /// Whether the ground truth at (x, y) is lethal.
    fn truth_lethal(&self, x_m: f64, y_m: f64) -> bool;
    /// Whether `map` is the ground truth itself (seen cells copied), rather than an estimate
    /// built from sensors that can misclassify a cell.
    fn map_is_truth(&self) -> bool;
    /// Share of the reachable free ground-truth cells that are known free.
    fn explored_fraction(&self) -> f64;
}

/// A path from `from` to `goal` on the inflated ground truth (A*), in metres, ending exactly at
/// the goal; `Err` says why there is none.
pub fn plan_on_truth(truth_inflated: &OccupancyGrid, from: Pose2, goal: Pose2) -> Result<Vec<[f64; 2]>, String> {
    let g = truth_inflated.geometry;
    let start = g.cell_of(from.x_m, from.y_m).ok_or("robot outside the map")?;
    let end = g.cell_of(goal.x_m, goal.y_m).ok_or("goal outside the map")?;
    let path = astar(truth_inflated, start, end, false).map_err(|e| format!("no path on the ground truth: {e}"))?;
    let mut points = path.points_m(&g);
    points.push([goal.x_m, goal.y_m]);
    Ok(points)
}

/// Moves `pose` up to `distance_m` along `path`, dropping the waypoints it reaches and facing
/// the direction of travel; returns the distance travelled.
pub fn drive_along(pose: &mut Pose2, path: &mut Vec<[f64; 2]>, distance_m: f64) -> f64 {
    let mut budget = distance_m;
    while budget > 0.0 && !path.is_empty() {
        let [tx, ty] = path[0];
        let (dx, dy) = (tx - pose.x_m, ty - pose.y_m);
        let d = dx.hypot(dy);
        if d <= budget {
            (pose.x_m, pose.y_m) = (tx, ty);
            budget -= d;
            path.remove(0);
        } else {
            pose.x_m += dx / d * budget;
            pose.y_m += dy / d * budget;
            pose.yaw_rad = dy.atan2(dx);
            budget = 0.0;
        }
    }
    distance_m - budget
}

/// The grid world.
pub struct GridSim {
    truth: OccupancyGrid,
    truth_inflated: OccupancyGrid,
    known: OccupancyGrid,
    landmarks_truth: Vec<(Cell, Point3<f64>)>,
    reachable: Vec<bool>,
    pose: Pose2,
    path: Vec<[f64; 2]>,
    goal_yaw: f64,
    pub range_m: f64,
    pub speed_mps: f64,
    since_scan_s: f64,
}

/// A 14 m × 10 m room at 0.1 m split by a wall with a 1.6 m door, with three boxes; the robot
/// starts at (1.5, 1.5).
pub fn two_rooms() -> OccupancyGrid {
    let g = GridGeometry::new(0.0, 0.0, 0.1, 140, 100);
    let mut grid = Grid::filled(g, FREE);
    let mut set = |c0: usize, c1: usize, r0: usize, r1: usize| {
        for r in r0..=r1 {
            for c in c0..=c1 {
                grid.data[r * 140 + c] = LETHAL;
            }
        }
    };
    set(0, 139, 0, 0);
    set(0, 139, 99, 99);
    set(0, 0, 0, 99);
    set(139, 139, 0, 99);
    set(70, 71, 0, 39);
    set(70, 71, 56, 99);
    set(30, 40, 60, 70);
    set(100, 110, 20, 35);
    set(110, 125, 70, 80);
    grid
}

impl GridSim {
    pub fn new(truth: OccupancyGrid, start: Pose2, robot_radius_m: f64) -> Self {
        let g = truth.geometry;
        let truth_inflated = inflate_lethal(&truth, robot_radius_m);
        // Free cells connected to the start (4-neighbours, on the raw ground truth).
        let mut reachable = vec![false; g.len()];
        if let Some(s) = g.cell_of(start.x_m, start.y_m).and_then(|c| g.index(c)) {
            let mut stack = vec![s];
            reachable[s] = true;
            while let Some(i) = stack.pop() {
                let c = g.cell_at(i);
                for (dc, dr) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                    if let Some(j) = g.index(Cell::new(c.col + dc, c.row + dr))
                        && !reachable[j]
                        && CellClass::of(truth.data[j]) == CellClass::Free
                    {
                        reachable[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        // Landmarks on every third obstacle-boundary cell, 0.5 m up.
        let mut landmarks_truth = Vec::new();
        let mut k = 0;
        for i in 0..g.len() {
            let c = g.cell_at(i);
            if truth.data[i] != LETHAL {
                continue;
            }
            let boundary = [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .iter()
                .any(|(dc, dr)| truth.get(Cell::new(c.col + dc, c.row + dr)).is_some_and(|&v| v == FREE));
            if boundary {
                k += 1;
                if k % 3 == 0 {
                    let (x, y) = g.center_of(c);
                    landmarks_truth.push((c, Point3::new(x, y, 0.5)));
                }
            }
        }
        let mut sim = Self {
            known: Grid::filled(g, UNKNOWN),
            truth,
            truth_inflated,
            landmarks_truth,
            reachable,
            pose: start,
            path: Vec::new(),
            goal_yaw: 0.0,
            range_m: 4.0,
            speed_mps: 3.0,
            since_scan_s: 0.0,
        };
        sim.scan();
        sim
    }

    /// Reveals the cells in line of sight within `range_m` (one ray per degree).
    fn scan(&mut self) {
        let g = self.truth.geometry;
        let step = 0.5 * g.resolution_m;
        for k in 0..360 {
            let a = (k as f64).to_radians();
            let (dx, dy) = (a.cos(), a.sin());
            let mut d = 0.0;
            while d <= self.range_m {
                let Some(i) = g.cell_of(self.pose.x_m + d * dx, self.pose.y_m + d * dy).and_then(|c| g.index(c)) else { break };
                self.known.data[i] = self.truth.data[i];
                if CellClass::of(self.truth.data[i]) == CellClass::Lethal {
                    break;
                }
                d += step;
            }
        }
    }
}

impl SimRobot for GridSim {
    fn map(&self) -> &OccupancyGrid {
        &self.known
    }

    fn landmarks(&self) -> Vec<Point3<f64>> {
        let g = self.known.geometry;
        self.landmarks_truth.iter().filter(|(c, _)| g.index(*c).is_some_and(|i| self.known.data[i] != UNKNOWN)).map(|(_, p)| *p).collect()
    }

    fn pose(&self) -> Pose2 {
        self.pose
    }

    fn go_to(&mut self, goal: Pose2) -> Result<(), String> {
        self.path = plan_on_truth(&self.truth_inflated, self.pose, goal)?;
        self.goal_yaw = goal.yaw_rad;
        Ok(())
    }

    fn stop(&mut self) {
        self.path.clear();
    }

    fn advance(&mut self, dt_s: f64) -> bool {
        if self.path.is_empty() {
            return false;
        }
        drive_along(&mut self.pose, &mut self.path, self.speed_mps * dt_s);
        self.since_scan_s += dt_s;
        if self.since_scan_s >= 0.1 || self.path.is_empty() {
            self.since_scan_s = 0.0;
            self.scan();
        }
        if self.path.is_empty() {
            self.pose.yaw_rad = self.goal_yaw;
            self.scan();
            return true;
        }
        false
    }

    fn truth_lethal(&self, x_m: f64, y_m: f64) -> bool {
        self.truth.at_world(x_m, y_m).is_none_or(|&v| CellClass::of(v) == CellClass::Lethal)
    }

    fn map_is_truth(&self) -> bool {
        true
    }

    fn explored_fraction(&self) -> f64 {
        let n = self.reachable.iter().filter(|&&r| r).count();
        let known = (0..self.reachable.len()).filter(|&i| self.reachable[i] && self.known.data[i] == FREE).count();
        known as f64 / n.max(1) as f64
    }
}
