//! The core's simulator as the robot for the node's tests: a `fitslam_core::sim::World` (3D
//! heightfield terrain with obstacles and visual landmarks), ground-truth motion along A* paths on
//! the world's ground-truth traversability, the VLP-16-like LiDAR ray-cast against the terrain
//! and the depth camera's ground rays, whose points build the thresholded traversability map the node receives (as the SLAM stack
//! would publish it), and the D435-like camera whose observations build the landmark map.
//! Localisation is ground truth: these tests exercise the node, not the SLAM.

#![allow(dead_code)]

use super::sim::{SimRobot, drive_along, plan_on_truth};
use fitslam_core::grid::{UNKNOWN, inflate_lethal};
use fitslam_core::sim::camera::{CameraNoise, CameraObservation, LandmarkIndex, depth_ground_hits, observe_landmarks};
use fitslam_core::sim::lidar::{LidarParams, RayCaster, scan};
use fitslam_core::sim::robot::{DriveParams, body_on_terrain, footprint_points};
use fitslam_core::sim::{World, WorldSpec};
use fitslam_core::traversability::{TraversabilityLayers, TraversabilityMap};
use fitslam_core::{OccupancyGrid, Params, Pose2};
use nalgebra::{Point3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;

pub struct CoreSim {
    pub world: World,
    params: Params,
    lidar: LidarParams,
    body_half_m: f64,
    caster: RayCaster,
    tmap: TraversabilityMap,
    layers: TraversabilityLayers,
    map: OccupancyGrid,
    index: LandmarkIndex,
    /// Landmark id → mapped position (its first observation).
    mapped: BTreeMap<u64, Point3<f64>>,
    truth_inflated: OccupancyGrid,
    pose: Pose2,
    path: Vec<[f64; 2]>,
    goal_yaw: f64,
    pub speed_mps: f64,
    travelled_since_scan_m: f64,
    rng: ChaCha8Rng,
    points: Vec<Point3<f64>>,
    observations: Vec<CameraObservation>,
}

impl CoreSim {
    /// Builds the world of `world_toml` (which must not reference other files) and senses once
    /// at the start, after a full turn in place (the LiDAR is blind close to the robot).
    pub fn new(world_toml: &str, name: &str, params: Params, seed: u64) -> Result<Self, String> {
        let spec = WorldSpec::from_toml(world_toml, name).map_err(|e| e.to_string())?;
        let world = World::build(&spec, &params.traversability, params.traversability.tau, |f| Err(format!("{f}: no files here")))
            .map_err(|e| e.to_string())?;
        let g = world.field.geometry;
        let tmap = TraversabilityMap::new(g).map_err(|e| e.to_string())?;
        let layers = tmap.compute(&params.traversability);
        let map = layers.to_occupancy(params.traversability.tau);
        let truth_inflated = inflate_lethal(&world.gt_occupancy, params.robot.radius_m);
        let mut sim = Self {
            caster: RayCaster::new(&world.field),
            index: LandmarkIndex::new(&world.landmarks, g.bounds_m(), 1.0),
            pose: world.start,
            world,
            params,
            lidar: LidarParams::default(),
            body_half_m: DriveParams::default().body_half_m,
            tmap,
            layers,
            map,
            mapped: BTreeMap::new(),
            truth_inflated,
            path: Vec::new(),
            goal_yaw: 0.0,
            speed_mps: 1.0,
            travelled_since_scan_m: 0.0,
            rng: ChaCha8Rng::seed_from_u64(seed),
            points: Vec::new(),
            observations: Vec::new(),
        };
        let yaw0 = sim.pose.yaw_rad;
        for k in 0..8 {
            sim.pose.yaw_rad = yaw0 + f64::from(k) * std::f64::consts::FRAC_PI_4;
            sim.sense();
        }
        sim.pose.yaw_rad = yaw0;
        Ok(sim)
    }

    /// One LiDAR sweep into the traversability map, one camera frame into the landmark map.
    fn sense(&mut self) {
        let (body, world_from_body) = body_on_terrain(&self.world.field, self.pose, self.body_half_m);
        let sensor = body + world_from_body * Vector3::new(0.0, 0.0, self.lidar.mount_height_m);
        self.points.clear();
        scan(&self.world.field, &self.caster, sensor, &world_from_body, &self.lidar, &mut self.rng, &mut self.points);
        // The depth camera's ground points (24 × 12 rays), and the ground under the wheels every
        // 5 cm (the LiDAR is blind within ~1 m; a real stack marks the footprint as traversed).
        let camera = body + world_from_body * Vector3::new(0.0, 0.0, self.params.robot.camera_height_m);
        let points = &mut self.points;
        depth_ground_hits(&self.world.field, &self.caster, camera, &world_from_body, &self.params.camera, [24, 12], |dir, d| {
            points.push(camera + dir * d)
        });
        footprint_points(&self.world.field, body, &world_from_body, self.body_half_m, 0.05, &mut self.points);
        self.tmap.insert_points(self.points.drain(..));
        self.tmap.update(&self.params.traversability, &mut self.layers);
        self.map = self.layers.to_occupancy(self.params.traversability.tau);
        observe_landmarks(
            &self.world.field,
            &self.world.landmarks,
            &self.index,
            camera,
            body,
            &world_from_body,
            &self.params.camera,
            &CameraNoise::default(),
            &mut self.rng,
            &mut self.observations,
        );
        for o in &self.observations {
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
        self.travelled_since_scan_m += drive_along(&mut self.pose, &mut self.path, self.speed_mps * dt_s);
        if self.travelled_since_scan_m >= 0.25 {
            self.travelled_since_scan_m = 0.0;
            self.sense();
        }
        if self.path.is_empty() {
            self.pose.yaw_rad = self.goal_yaw;
            self.sense();
            return true;
        }
        false
    }

    fn truth_lethal(&self, x_m: f64, y_m: f64) -> bool {
        self.world.gt_lethal_at(x_m, y_m)
    }

    fn explored_fraction(&self) -> f64 {
        let known = self.world.explorable.iter().zip(&self.map.data).filter(|(e, v)| **e && **v != UNKNOWN).count();
        known as f64 / self.world.explorable_count.max(1) as f64
    }
}
