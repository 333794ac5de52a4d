//! # fitslam-robot
//!
//! The FIT-SLAM ROS 2 node for the LeoRover: a thin adapter between ROS 2 topics and actions
//! (over the pure-Rust `ros2-client`, no ROS installation needed) and `fitslam_core`.

pub mod msgs;
