//! # fitslam-robot
//!
//! The FIT-SLAM ROS 2 node for the LeoRover: a thin adapter between ROS 2 topics and actions
//! (over the pure-Rust `ros2-client`, no ROS installation needed) and `fitslam_core`. The
//! messages are `fitslam_msgs`'s (with its `ros2` feature), their conversions to the core's
//! types `fitslam_core::ros`'s, and the status it publishes `fitslam_core::ros::NodeStatus`.
//!
//! | module | what |
//! |---|---|
//! | [`tf`] | a latest-only tf2 buffer |
//! | [`config`] | node configuration + the core's `Params`, one YAML file |
//! | [`node`] | the node's state: inputs → the core's exploration policy (`fitslam_core::explore`) → goals; no DDS |
//! | [`markers`] | RViz markers of a decision |
//! | [`ros`] | the DDS side: participant, endpoints, the polling loop |
//! | `rerun_log` | rerun recording of maps, decisions and metrics (feature `rerun`) |
//!
//! The state machine runs without DDS: messages in, commands out, on the caller's clock.
//!
//! ```
//! use fitslam_core::fixtures::corridor_two_frontiers;
//! use fitslam_robot::config::NodeConfig;
//! use fitslam_core::ros::{cloud_of_points, msg_of_occupancy};
//! use fitslam_msgs::{Header, Quaternion, TFMessage, Time, Transform, TransformStamped, Vector3};
//! use fitslam_robot::node::{Command, ExplorerNode};
//!
//! let world = corridor_two_frontiers(true); // landmarks east of the robot only
//! let mut node = ExplorerNode::new(NodeConfig::default(), fitslam_core::Params::default())?;
//! let header = Header::new(Time::from_secs_f64(1.0), "map");
//! node.handle_map(&msg_of_occupancy(&world.grid, header.clone()), 0.0);
//! node.handle_landmarks(&cloud_of_points(&world.landmarks.points, header.clone()), 0.0);
//! let robot = TransformStamped {
//!     header,
//!     child_frame_id: "base_link".into(),
//!     transform: Transform {
//!         translation: Vector3 { x: world.robot.x_m, y: world.robot.y_m, z: 0.0 },
//!         rotation: Quaternion::default(),
//!     },
//! };
//! node.handle_tf(&TFMessage { transforms: vec![robot] }, false, 0.0);
//! let commands = node.tick(0.0);
//! let Command::SendGoal { goal, .. } = &commands[0] else { panic!("{commands:?}") };
//! assert!(goal.x_m > world.robot.x_m); // FIT-SLAM heads for the landmarks
//! println!("{}", serde_json::to_string(&node.status(0.0))?);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod config;
pub mod markers;
pub mod node;
pub mod qos_check;
#[cfg(feature = "rerun")]
pub mod rerun_log;
pub mod ros;
pub mod tf;
