//! A recorded mission (rosbag2 MCAP, from the robot or `fitslam explore --bag`) in the Planner
//! mode: its decision instants on a timeline, the scene the robot had at any instant, the goal
//! it chose then beside the one the current parameters choose, and the instant exported as a
//! scene that `fitslam select` reads.
//!
//! `fitslam_core::bag` reads the bag; the scene at an instant is the same as
//! `fitslam select --bag B --at T` uses: the latest map, landmarks and pose at T, the whole map
//! as boundary, no blacklist. The map is taken by class (free, lethal, unknown, as the node and
//! the CLI read an occupancy grid), so τ does not move its cells.

use crate::scene::{Landmarks, MapLayers, Scene};
use fitslam_core::Pose2;
use fitslam_core::bag::{Bag, BagTopics, DecisionInstant, RobotChoice, Snapshot};
use fitslam_core::grid::{CellClass, FREE, LETHAL, OccupancyGrid, UNKNOWN};
use fitslam_core::io;

/// An open recording and the instant shown.
#[derive(Debug)]
pub struct Recording {
    bag: Bag,
    topics: BagTopics,
    instants: Vec<DecisionInstant>,
    /// The instant shown, seconds from the bag's start.
    pub t_s: f64,
    /// What the robot had chosen by then (its latest status with a goal).
    pub robot_choice: Option<RobotChoice>,
}

impl Recording {
    /// Reads a bag with the node's default topic names and finds its decision instants.
    pub fn open(bytes: &[u8], name: &str) -> Result<Self, String> {
        let bag = Bag::parse(bytes, name).map_err(|e| e.to_string())?;
        let topics = BagTopics::default();
        let instants = bag.decision_instants(&topics).map_err(|e| e.to_string())?;
        Ok(Self { bag, topics, instants, t_s: 0.0, robot_choice: None })
    }

    pub fn name(&self) -> &str {
        self.bag.name()
    }

    pub fn duration_s(&self) -> f64 {
        self.bag.duration_s()
    }

    /// The decision instants, in time order.
    pub fn instants(&self) -> &[DecisionInstant] {
        &self.instants
    }

    /// The instant to open first: the first decision, else the bag's end.
    pub fn first_instant_s(&self) -> f64 {
        self.instants.first().map_or(self.duration_s(), |i| i.t_s)
    }

    /// Index of the decision instant at or before the shown one.
    pub fn current_index(&self) -> Option<usize> {
        self.instants.iter().rposition(|i| i.t_s <= self.t_s + 1e-9)
    }

    /// The first decision instant after the shown one.
    pub fn next_instant_s(&self) -> Option<f64> {
        self.instants.iter().map(|i| i.t_s).find(|&t| t > self.t_s + 1e-9)
    }

    /// The last decision instant before the shown one.
    pub fn previous_instant_s(&self) -> Option<f64> {
        self.instants.iter().rev().map(|i| i.t_s).find(|&t| t < self.t_s - 1e-9)
    }

    /// The scene at `t_s` (which becomes the shown instant): the robot's map, landmarks and pose
    /// then, the whole map as boundary, an empty blacklist.
    pub fn scene_at(&mut self, t_s: f64, blacklist_radius_m: f64) -> Result<Scene, String> {
        let s = self.bag.snapshot(&self.topics, t_s).map_err(|e| e.to_string())?;
        let scene = scene_of(&s, self.bag.name(), blacklist_radius_m);
        self.t_s = t_s;
        self.robot_choice = s.robot_choice;
        Ok(scene)
    }

    /// The robot's goal to compare with a re-ranking: the frontier candidate its status names,
    /// else the goal it sent.
    pub fn robot_target(&self) -> Option<[f64; 2]> {
        self.robot_choice.as_ref().map(|c| c.frontier_m.unwrap_or([c.goal.x_m, c.goal.y_m]))
    }
}

/// The occupancy grid by class: 0 free, 100 lethal, −1 unknown ([`CellClass::of`]).
fn by_class(grid: &OccupancyGrid) -> OccupancyGrid {
    let data = grid
        .data
        .iter()
        .map(|&v| match CellClass::of(v) {
            CellClass::Free => FREE,
            CellClass::Lethal => LETHAL,
            CellClass::Unknown => UNKNOWN,
        })
        .collect();
    OccupancyGrid { geometry: grid.geometry, data }
}

fn scene_of(s: &Snapshot, bag_name: &str, blacklist_radius_m: f64) -> Scene {
    let name = format!("{} at t = {:.3} s", crate::files::base_name(bag_name), s.t_s);
    let map = MapLayers::from_occupancy(&by_class(&s.map), name.clone());
    let landmarks = Landmarks { cloud: s.landmarks.clone(), source: format!("{name} landmarks") };
    let mut scene = Scene::new(map, landmarks, Some(s.robot), blacklist_radius_m);
    // The pose as recorded, even off the free cells: the decision starts from it as the CLI's does.
    scene.robot = s.robot;
    scene
}

/// A scene as files `fitslam select` reads: `{stem}_map.yaml` + `{stem}_map.pgm` (the grid the
/// planner used, map_saver's trinary format), `{stem}_landmarks.csv`, and `{stem}_select.txt`
/// holding the command line with the robot's pose. Numbers are written exactly, so the command
/// makes the same decision on the same parameters.
pub fn scene_files(grid: &OccupancyGrid, landmarks: &Landmarks, robot: Pose2, stem: &str) -> Vec<(String, Vec<u8>)> {
    let (map_yaml, map_pgm, landmarks_csv) = (format!("{stem}_map.yaml"), format!("{stem}_map.pgm"), format!("{stem}_landmarks.csv"));
    let (yaml, pgm) = io::save_map(grid, &map_pgm);
    let command =
        format!("fitslam select --map {map_yaml} --landmarks {landmarks_csv} --pose {:?},{:?},{:?}\n", robot.x_m, robot.y_m, robot.yaw_rad);
    vec![
        (map_yaml, yaml.into_bytes()),
        (map_pgm, pgm),
        (landmarks_csv, io::write_csv(&landmarks.cloud).into_bytes()),
        (format!("{stem}_select.txt"), command.into_bytes()),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_core::grid::GridGeometry;

    #[test]
    fn grid_by_class_keeps_the_classes_cli_and_node_read() {
        let g = GridGeometry::new(0.0, 0.0, 1.0, 6, 1);
        let occ = OccupancyGrid { geometry: g, data: vec![0, 30, 49, 50, 100, -1] };
        assert_eq!(by_class(&occ).data, vec![FREE, FREE, FREE, LETHAL, LETHAL, UNKNOWN]);
    }
}
