//! The node's inputs: map, tf, landmark and LiDAR clouds, pose, boundary messages, each
//! validated (frame, stamp, finite values) and converted to the core's types; a bad or late
//! message is a warning, never a crash.

use super::{CloudMapper, ExplorerNode, MapState, PoseSample};
use crate::config::PoseSource;
use crate::tf::normalise_frame;
use fitslam_core::grid::GridGeometry;
use fitslam_core::ros::{self, ConvertError};
use fitslam_core::traversability::TraversabilityMap;
use fitslam_core::utility::LandmarkVoxels;
use fitslam_core::{OccupancyGrid, PointCloud};
use fitslam_msgs as msgs;
use nalgebra::{Isometry3, Point3};

impl ExplorerNode {
    pub(super) fn reject(&mut self, key: &'static str, now_s: f64, what: &str, e: &ConvertError) {
        self.stats.messages_rejected += 1;
        self.warn(key, now_s, format!("{what} rejected: {e}"));
    }

    /// A `nav_msgs/OccupancyGrid` (used when `map_source: occupancy`).
    pub fn handle_map(&mut self, msg: &msgs::OccupancyGrid, now_s: f64) {
        let grid = match ros::occupancy_of_msg(msg) {
            Ok(g) => g,
            Err(e) => return self.reject("map", now_s, "map", &e),
        };
        let frame = normalise_frame(&msg.header.frame_id);
        if !frame.is_empty() && frame != normalise_frame(&self.cfg.map_frame) {
            self.stats.messages_rejected += 1;
            let text = format!("map rejected: frame '{frame}' is not the map frame '{}'", self.cfg.map_frame);
            return self.warn("map", now_s, text);
        }
        self.set_map(grid, msg.header.stamp.as_secs_f64(), now_s);
    }

    pub(super) fn set_map(&mut self, grid: OccupancyGrid, stamp_s: f64, now_s: f64) {
        if let Some(old) = &self.map {
            if stamp_s != 0.0 && stamp_s < old.stamp_s {
                self.stats.messages_late += 1;
                let text = format!("late map dropped (stamp {stamp_s:.3} s < {:.3} s)", old.stamp_s);
                return self.warn("map_late", now_s, text);
            }
            if old.grid.geometry != grid.geometry {
                let (a, b) = (old.grid.geometry, grid.geometry);
                let text = format!(
                    "map geometry changed: {}×{} cells at {} m from ({}, {}) → {}×{} at {} m from ({}, {})",
                    a.width,
                    a.height,
                    a.resolution_m,
                    a.origin_x_m,
                    a.origin_y_m,
                    b.width,
                    b.height,
                    b.resolution_m,
                    b.origin_x_m,
                    b.origin_y_m
                );
                self.info(now_s, text);
            }
        } else {
            let g = grid.geometry;
            self.info(now_s, format!("first map: {}×{} cells at {} m", g.width, g.height, g.resolution_m));
        }
        self.stats.maps += 1;
        self.map = Some(MapState { grid, inflated: Vec::new(), stamp_s });
    }

    /// `/tf` (`is_static` false) or `/tf_static` (true).
    pub fn handle_tf(&mut self, msg: &msgs::TFMessage, is_static: bool, now_s: f64) {
        for t in &msg.transforms {
            match self.tf.insert(t, is_static, now_s) {
                Ok(true) => {}
                Ok(false) => self.stats.messages_late += 1,
                Err(e) => {
                    let what = format!("transform {} → {}", t.header.frame_id, t.child_frame_id);
                    self.reject("tf", now_s, &what, &e);
                }
            }
        }
    }

    /// `target_from_source` from the tf buffer.
    pub(super) fn lookup(&self, target: &str, source: &str) -> Option<Isometry3<f64>> {
        self.tf.lookup(target, source).map(|l| l.transform)
    }

    /// Points of a cloud in the map frame (transformed by tf if it is in another frame).
    fn cloud_in_map(&mut self, msg: &msgs::PointCloud2, key: &'static str, what: &str, now_s: f64) -> Option<Vec<Point3<f64>>> {
        let (mut points, stats) = match ros::points_of_cloud(msg) {
            Ok(p) => p,
            Err(e) => {
                self.reject(key, now_s, what, &e);
                return None;
            }
        };
        if stats.non_finite > 0 {
            let text = format!("{what}: {} of {} points are not finite (skipped)", stats.non_finite, stats.records);
            self.warn(key, now_s, text);
        }
        let frame = normalise_frame(&msg.header.frame_id).to_owned();
        let map_frame = self.cfg.map_frame.clone();
        if !frame.is_empty() && frame != normalise_frame(&map_frame) {
            let Some(map_from_cloud) = self.lookup(&map_frame, &frame) else {
                self.stats.messages_rejected += 1;
                self.warn(key, now_s, format!("{what} dropped: no transform {map_frame} ← {frame}"));
                return None;
            };
            for p in &mut points {
                *p = map_from_cloud * *p;
            }
        }
        Some(points)
    }

    /// The landmark map (`sensor_msgs/PointCloud2` of map points): replaces the previous set.
    pub fn handle_landmarks(&mut self, msg: &msgs::PointCloud2, now_s: f64) {
        let Some(points) = self.cloud_in_map(msg, "landmarks", "landmark cloud", now_s) else { return };
        let n = points.len();
        let cloud = PointCloud::from_points(points);
        match LandmarkVoxels::new(&cloud, self.explorer.planner().u2.voxel_m, self.explorer.planner().u2.sigma_landmark_m) {
            Ok(v) => {
                if self.landmarks.is_empty() && !v.is_empty() {
                    self.info(now_s, format!("first landmark map: {n} points in {} voxels", v.len()));
                }
                self.landmarks = v;
                self.landmark_points = cloud.points.iter().map(|p| [p.x, p.y, p.z]).collect();
            }
            Err(e) => {
                self.stats.messages_rejected += 1;
                self.warn("landmarks", now_s, format!("landmark cloud rejected: {e}"));
            }
        }
    }

    /// A registered LiDAR cloud (used when `map_source: clouds`): fused into the traversability
    /// map; the occupancy grid is recomputed before the next decision.
    pub fn handle_cloud(&mut self, msg: &msgs::PointCloud2, now_s: f64) {
        let Some(points) = self.cloud_in_map(msg, "cloud", "LiDAR cloud", now_s) else { return };
        if self.cloud_mapper.is_none() {
            let c = &self.cfg.cloud_map;
            let res = self.explorer.planner().grid.resolution_m;
            let geometry =
                GridGeometry::new(c.origin_x_m, c.origin_y_m, res, (c.size_x_m / res).ceil() as usize, (c.size_y_m / res).ceil() as usize);
            match TraversabilityMap::new(geometry) {
                Ok(map) => {
                    let layers = map.compute(&self.explorer.planner().traversability);
                    self.cloud_mapper = Some(CloudMapper { map, layers, dirty: true });
                }
                Err(e) => {
                    self.stats.messages_rejected += 1;
                    return self.warn("cloud", now_s, format!("cannot build the cloud map: {e}"));
                }
            }
        }
        // With a pose topic that carries a covariance, each point's height gets the variance its
        // tilt uncertainty implies (σ_t² × horizontal range², as in the core's simulator), so the
        // map discounts the roughness that registration noise explains.
        let origin = self.topic_pose.filter(|s| self.cfg.pose_source == PoseSource::Topic && s.tilt_var_rad2 > 0.0);
        if let Some(m) = &mut self.cloud_mapper {
            let s = match origin {
                Some(o) => {
                    let (x, y, var) = (o.pose.x_m, o.pose.y_m, o.tilt_var_rad2);
                    m.map.insert_points_with_variance(points.into_iter().map(|p| (p, var * ((p.x - x).powi(2) + (p.y - y).powi(2)))))
                }
                None => m.map.insert_points(points),
            };
            m.dirty |= s.inserted > 0;
        }
    }

    /// `geometry_msgs/PoseWithCovarianceStamped` (used when `pose_source: topic`).
    pub fn handle_pose(&mut self, msg: &msgs::PoseWithCovarianceStamped, now_s: f64) {
        let iso = match ros::isometry_of_pose(&msg.pose.pose) {
            Ok(i) => i,
            Err(e) => return self.reject("pose", now_s, "pose", &e),
        };
        let frame = normalise_frame(&msg.header.frame_id).to_owned();
        let map_frame = self.cfg.map_frame.clone();
        let map_from_body = if frame.is_empty() || frame == normalise_frame(&map_frame) {
            iso
        } else {
            match self.lookup(&map_frame, &frame) {
                Some(t) => t * iso,
                None => {
                    self.stats.messages_rejected += 1;
                    return self.warn("pose", now_s, format!("pose dropped: no transform {map_frame} ← {frame}"));
                }
            }
        };
        let stamp_s = msg.header.stamp.as_secs_f64();
        if let Some(old) = self.topic_pose
            && stamp_s != 0.0
            && stamp_s < old.stamp_s
        {
            self.stats.messages_late += 1;
            return self.warn("pose_late", now_s, format!("late pose dropped (stamp {stamp_s:.3} s < {:.3} s)", old.stamp_s));
        }
        let pose = ros::pose2_of_isometry(&map_from_body);
        // ROS order (x, y, z, rot X, rot Y, rot Z), fixed axes: roll and pitch at 21 and 28.
        let c = &msg.pose.covariance;
        let tilt = 0.5 * (c[21] + c[28]);
        let tilt_var_rad2 = if tilt.is_finite() && tilt > 0.0 { tilt } else { 0.0 };
        let position = c[0] + c[7];
        let position_var_m2 = if position.is_finite() && position > 0.0 { position } else { 0.0 };
        let z_m = map_from_body.translation.z;
        self.topic_pose = Some(PoseSample { pose, z_m, stamp_s, received_s: now_s, tilt_var_rad2, position_var_m2 });
    }

    /// `std_msgs/String` on `control_topic`: `pause`, `resume` or `stop` (case and surrounding
    /// blanks ignored); anything else is a warning.
    pub fn handle_control(&mut self, msg: &msgs::StringMsg, now_s: f64) {
        match msg.data.trim().to_ascii_lowercase().as_str() {
            "pause" => {
                self.paused = true;
                self.info(now_s, "paused: the running goal is cancelled, no goal is sent until `resume`".into());
            }
            "resume" => {
                if self.paused {
                    self.paused = false;
                    self.replan_now = true;
                    self.info(now_s, "resumed".into());
                }
            }
            "stop" => self.stop_requested = true,
            other => {
                self.stats.messages_rejected += 1;
                let text = format!("control command {other:?} ignored: expected pause, resume or stop");
                self.warn("control", now_s, text);
            }
        }
    }

    /// `geometry_msgs/PolygonStamped`: the exploration boundary; an empty polygon clears it.
    pub fn handle_boundary(&mut self, msg: &msgs::PolygonStamped, now_s: f64) {
        if msg.polygon.points.is_empty() {
            self.boundary = None;
            self.info(now_s, "boundary cleared".into());
            return;
        }
        let mut b = match ros::boundary_of_polygon(msg) {
            Ok(b) => b,
            Err(e) => return self.reject("boundary", now_s, "boundary", &e),
        };
        let frame = normalise_frame(&msg.header.frame_id).to_owned();
        let map_frame = self.cfg.map_frame.clone();
        if !frame.is_empty() && frame != normalise_frame(&map_frame) {
            let Some(t) = self.lookup(&map_frame, &frame) else {
                self.stats.messages_rejected += 1;
                return self.warn("boundary", now_s, format!("boundary dropped: no transform {map_frame} ← {frame}"));
            };
            for v in &mut b.vertices_m {
                let p = t * Point3::new(v[0], v[1], 0.0);
                *v = [p.x, p.y];
            }
        }
        self.info(now_s, format!("boundary: {} vertices, {:.1} m²", b.vertices_m.len(), b.area_m2()));
        self.boundary = Some(b);
        self.replan_now = true;
    }
}
