//! # fitslam-robot
//!
//! The FIT-SLAM ROS 2 node for the LeoRover: a thin adapter between ROS 2 topics and actions
//! (over the pure-Rust `ros2-client`, no ROS installation needed) and `fitslam_core`.
//!
//! | module | what |
//! |---|---|
//! | [`msgs`] | the ROS 2 message types used, as serde structs (CDR field order) |
//! | [`convert`] | messages ⇄ core types, validated (typed errors, never panics) |
//! | [`tf`] | a latest-only tf2 buffer |
//! | [`config`] | node configuration + the core's `Params`, one YAML file |
//! | [`node`] | the state machine: inputs → `fitslam_core::select` → goals; no DDS |
//! | [`markers`] | RViz markers of a decision |
//! | [`ros`] | the DDS side: participant, endpoints, the polling loop |
//! | `rerun_log` | rerun recording of maps, decisions and metrics (feature `rerun`) |

pub mod config;
pub mod convert;
pub mod markers;
pub mod msgs;
pub mod node;
#[cfg(feature = "rerun")]
pub mod rerun_log;
pub mod ros;
pub mod tf;
