//! The core's world simulator ([`fitslam_core::sim::WorldSim`]) as the robot for the node's
//! tests: a 3D heightfield world with obstacles and visual landmarks, the true motion with the
//! bumper, the LiDAR, depth-camera and footprint points that build the thresholded
//! traversability map the node receives (as the SLAM stack would publish it), and the camera's
//! landmark observations that build the landmark map. The robot follows A* paths on the world's
//! ground-truth traversability, turning on the spot at each corner. Localisation is ground
//! truth: these tests exercise the node, not the SLAM.

#![allow(dead_code)]

use super::sim::{SimRobot, plan_on_truth};
use fitslam_core::grid::{UNKNOWN, inflate_lethal};
use fitslam_core::pose::wrap_pi;
use fitslam_core::sim::robot::Twist;
use fitslam_core::sim::{MissionParams, World, WorldSim, WorldSpec};
use fitslam_core::traversability::{TraversabilityLayers, TraversabilityMap};
use fitslam_core::{OccupancyGrid, Params, Pose2};
use nalgebra::Point3;
use std::collections::BTreeMap;

/// Distance between scans, metres (the simulator's default scan spacing).
const SCAN_EVERY_M: f64 = 0.25;

pub struct CoreSim {
    sim: WorldSim,
    params: Params,
    tmap: TraversabilityMap,
    layers: TraversabilityLayers,
    map: OccupancyGrid,
    /// Landmark id → mapped position (its first observation).
    mapped: BTreeMap<u64, Point3<f64>>,
    truth_inflated: OccupancyGrid,
    path: Vec<[f64; 2]>,
    goal_yaw: f64,
    pub speed_mps: f64,
    travelled_since_scan_m: f64,
}

impl CoreSim {
    /// Builds the world of `world_toml` (which must not reference other files) and senses once
    /// at the start, after a full turn in place (the LiDAR is blind close to the robot).
    pub fn new(world_toml: &str, name: &str, params: Params, seed: u64) -> Result<Self, String> {
        let spec = WorldSpec::from_toml(world_toml, name).map_err(|e| e.to_string())?;
        let world = World::build(&spec, &params.traversability, params.traversability.tau, |f| Err(format!("{f}: no files here")))
            .map_err(|e| e.to_string())?;
        let tmap = TraversabilityMap::new(world.field.geometry).map_err(|e| e.to_string())?;
        let layers = tmap.compute(&params.traversability);
        let map = layers.to_occupancy(params.traversability.tau);
        let truth_inflated = inflate_lethal(&world.gt_occupancy, params.robot.radius_m);
        let mut sim = Self {
            sim: WorldSim::new(world, &MissionParams::default(), &params, seed),
            params,
            tmap,
            layers,
            map,
            mapped: BTreeMap::new(),
            truth_inflated,
            path: Vec::new(),
            goal_yaw: 0.0,
            speed_mps: 1.0,
            travelled_since_scan_m: 0.0,
        };
        for _ in 0..8 {
            sim.sense();
            sim.turn_by(std::f64::consts::FRAC_PI_4);
        }
        Ok(sim)
    }

    pub fn world(&self) -> &World {
        self.sim.world()
    }

    /// Turns on the spot by `dyaw_rad` in one step.
    fn turn_by(&mut self, dyaw_rad: f64) {
        self.sim.drive(Twist { v_mps: 0.0, omega_radps: dyaw_rad }, 1.0);
    }

    /// One scan into the traversability map, one camera frame into the landmark map.
    fn sense(&mut self) {
        self.sim.scan();
        self.tmap.insert_points(self.sim.scan_points().iter().copied());
        self.tmap.update(&self.params.traversability, &mut self.layers);
        self.map = self.layers.to_occupancy(self.params.traversability.tau);
        let (body, world_from_body) = self.sim.body_pose();
        for o in self.sim.observe_landmarks() {
            self.mapped.entry(o.landmark_id).or_insert(body + world_from_body * o.point_in_robot);
        }
    }
}

impl SimRobot for CoreSim {
    fn map(&self) -> &OccupancyGrid {
        &self.map
    }

    fn landmarks(&self) -> Vec<Point3<f64>> {
        self.mapped.values().copied().collect()
    }

    fn pose(&self) -> Pose2 {
        self.sim.pose()
    }

    fn go_to(&mut self, goal: Pose2) -> Result<(), String> {
        self.path = plan_on_truth(&self.truth_inflated, self.sim.pose(), goal)?;
        self.goal_yaw = goal.yaw_rad;
        Ok(())
    }

    fn stop(&mut self) {
        self.path.clear();
    }

    /// Drives `speed_mps · dt_s` along the path: per waypoint a turn towards it, then straight.
    /// The bumper stops the robot (and its path) before untraversable ground.
    fn advance(&mut self, dt_s: f64) -> bool {
        if self.path.is_empty() {
            return false;
        }
        let mut budget_m = self.speed_mps * dt_s;
        while budget_m > 0.0 && !self.path.is_empty() {
            let p = self.sim.pose();
            let [tx, ty] = self.path[0];
            let d = (tx - p.x_m).hypot(ty - p.y_m);
            if d > 1e-9 {
                self.turn_by(wrap_pi((ty - p.y_m).atan2(tx - p.x_m) - p.yaw_rad));
            }
            let step_m = d.min(budget_m);
            if self.sim.drive(Twist { v_mps: step_m, omega_radps: 0.0 }, 1.0).bumped {
                self.path.clear();
                return false;
            }
            budget_m -= step_m;
            self.travelled_since_scan_m += step_m;
            if step_m >= d {
                self.path.remove(0);
            }
        }
        if self.travelled_since_scan_m >= SCAN_EVERY_M {
            self.travelled_since_scan_m = 0.0;
            self.sense();
        }
        if self.path.is_empty() {
            self.turn_by(wrap_pi(self.goal_yaw - self.sim.pose().yaw_rad));
            self.sense();
            return true;
        }
        false
    }

    fn truth_lethal(&self, x_m: f64, y_m: f64) -> bool {
        self.sim.world().gt_lethal_at(x_m, y_m)
    }

    /// The map comes from LiDAR scans through the traversability estimate: a cell seen from
    /// afar can read free while the terrain there is too steep.
    fn map_is_truth(&self) -> bool {
        false
    }

    fn explored_fraction(&self) -> f64 {
        let w = self.sim.world();
        let known = w.explorable.iter().zip(&self.map.data).filter(|(e, v)| **e && **v != UNKNOWN).count();
        known as f64 / w.explorable_count.max(1) as f64
    }
}
