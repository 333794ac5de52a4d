//! # fitslam-core
//!
//! FIT-SLAM (Fisher Information and Traversability estimation-based Active SLAM) for ground
//! robots: every algorithm of the method, pure and deterministic, compiling natively and to
//! `wasm32-unknown-unknown`. No files, clocks, threads, printing, GUI or DDS here: loaders take
//! bytes, ROS messages are `fitslam_msgs`'s plain structs, randomness takes a seeded RNG. The
//! equations are specified in `docs/fitslam-paper-notes.md` (referred to as "notes §N").
//!
//! | module | what |
//! |---|---|
//! | [`grid`] | one geometry, flat layers, ROS occupancy convention, inflation |
//! | [`ros`] | messages ⇄ grids, points, poses, boundaries (validated); the node's status JSON |
//! | [`bag`] | rosbag2 MCAP bags: reader (zstd, lz4), writer, the decision inputs at an instant |
//! | [`io`] | map_server YAML + PGM, PNG, PCD, PLY, CSV, LAS: bytes in, typed errors out |
//! | [`traversability`] | per-cell slope / step / roughness from 3D points (notes §2) |
//! | [`frontier`] | WFD frontiers, clusters, candidates, blacklist (notes §3) |
//! | [`path`] | A* and one Dijkstra (notes §4) |
//! | [`utility`] | u1 (entropy rays, Θ*) and u2 (bearing FIM along the path) (notes §5–6) |
//! | [`select`] | goal selectors: FIT-SLAM, greedy, random, u1-only, with the whole ranking (notes §7) |
//! | [`explore`] | the exploration policy: retries, goal keeping, blacklist, trail, set-back (notes §3) |
//! | [`slam`] | SE(3) factor graphs, batch and keyframe SLAM, marginals, g2o (notes §1) |
//! | [`sim`] | the simulator: worlds, sensors, localisation, missions, metrics, bag recording (notes §8) |
//! | [`params`] | every parameter with the paper's defaults |
//! | `math` (internal) | sin, cos, atan2… computed alike on every target (same seed, same run, native and wasm) |
//! | [`fixtures`] | shared fixture worlds (synthetic map + landmarks, corridor) for tests, benches, examples |
//!
//! The entry points are re-exported here: the parameters ([`Params`], checked once into
//! [`Valid`]), one decision ([`make_selector`] → [`GoalSelector`] → [`Decision`]), the
//! exploration policy every face runs ([`Explorer`]), whole simulated missions ([`Mission`] in a
//! [`World`]), the loaders ([`load_map`], [`load_cloud`]; more in [`io`]), the SLAM solvers
//! ([`GraphSlam`], [`Isam2`], [`LevenbergMarquardt`]) and recorded missions ([`Bag`]).

// Tests compare against the platform's maths library on purpose (see math.rs).
#![cfg_attr(test, allow(clippy::disallowed_methods))]
#![deny(missing_docs)]

pub mod bag;
pub(crate) mod cache;
pub mod cloud;
pub mod explore;
pub mod fixtures;
pub mod frontier;
pub mod grid;
pub mod io;
pub(crate) mod math;
pub mod params;
pub mod path;
pub mod pose;
pub mod ros;
pub mod select;
pub mod sim;
pub mod slam;
pub mod traversability;
pub mod utility;

// The library's entry points (each documented with an example where it is defined).
pub use bag::Bag;
pub use cloud::PointCloud;
pub use explore::{Action, ExploreParams, Explorer, Situation, TracedDecision};
pub use grid::{Cell, Grid, GridGeometry, OccupancyGrid};
pub use io::{load_cloud, load_map};
pub use params::{Params, Valid};
pub use pose::Pose2;
pub use select::{Decision, DecisionInput, GoalSelector, make_selector};
pub use sim::{Localisation, Mission, MissionParams, World, WorldSpec};
pub use slam::{GraphSlam, Isam2, LevenbergMarquardt};
