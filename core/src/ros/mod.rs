//! The ROS 2 side of the core's types: conversions between the messages of `fitslam_msgs` and
//! the core's grids, points, poses and boundaries ([`convert`]), and the fitslam node's status
//! ([`status`]). Plain data in, plain data out: no DDS, no clocks. The robot node, the bag replay
//! and the simulator's mission recorder use these, so each conversion and the status exist once.
//!
//! | module | what |
//! |---|---|
//! | [`convert`] | OccupancyGrid ⇄ grid, PointCloud2 ⇄ points, poses, transforms, PolygonStamped → boundary; [`ConvertError`], [`MAX_MAP_CELLS`] |
//! | [`status`] | [`NodeStatus`]: the `/fitslam/status` JSON (phase, goal, counters, warnings) |

pub mod convert;
pub mod status;

pub use convert::{
    CloudStats, ConvertError, MAX_MAP_CELLS, MAX_MAP_YAW_RAD, boundary_of_polygon, cloud_of_points, isometry_of_pose,
    isometry_of_transform, msg_of_occupancy, occupancy_of_msg, points_of_cloud, pose_of_pose2, pose2_of_isometry, pose2_of_pose,
    resolution_m, transform_of_pose2, unit_quaternion, yaw_of,
};
pub use status::{NodeGoal, NodeStats, NodeStatus, Phase};
