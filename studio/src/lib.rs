//! # fitslam-studio
//!
//! The FIT-SLAM studio: an egui/eframe application, native and in the browser, that makes the
//! planner's decision visible and tunable. It is a thin view over `fitslam_core`: the core
//! computes every number (thresholding, voxels, frontiers, paths, u1, u2, ranking); the studio
//! loads inputs, caches stages, draws and exports.
//!
//! | module | what |
//! |---|---|
//! | [`app`] | [`StudioApp`]: wires the views to the state; file loading, shortcuts, title digest |
//! | [`action`] | what the views hand back to the app: actions, named widget rectangles |
//! | [`planner`] | the Planner mode's state: scene, parameters, decision, layer, overlays, selection |
//! | [`scene`] | map (score layer), landmarks, robot, boundary, blacklist |
//! | [`pipeline`] | scene + `Params` → `Decision` via the core, cached per stage, timed |
//! | [`canvas`] | drawing of layers and the decision, robot dragging, picking |
//! | [`panels`] | parameter sliders, candidate details, sortable table |
//! | [`summary`] | one candidate's numbers (canvas tooltip, details panel) |
//! | [`loader`] / [`files`] | files → scene parts; drop, picker, in-app file browser, downloads |
//! | [`recording`] / [`recording_view`] | a recorded mission (rosbag2 MCAP): decision instants, the scene at an instant, the robot's choice beside the re-ranking, export; its timeline |
//! | [`export`] | ranking CSV / JSON, parameter YAML, digest |
//! | [`assets`] | built-in scenes (embedded) |
//! | [`tour`] | the teaching tour |
//! | [`sim_runner`] | Mission mode: built-in worlds, missions side by side under a frame budget |
//! | [`mission_view`] | Mission mode: controls, lane maps, live plots (egui_plot) |
//! | `web` / `browser` | (web build) entry points; file picker, downloads, state for page scripts |

pub mod action;
pub mod app;
pub mod assets;
#[cfg(target_arch = "wasm32")]
pub mod browser;
pub mod canvas;
pub mod export;
pub mod files;
pub mod loader;
pub mod mission_view;
pub mod panels;
pub mod pipeline;
pub mod planner;
pub mod recording;
pub mod recording_view;
pub mod scene;
pub mod sim_runner;
pub mod summary;
pub mod tour;
#[cfg(target_arch = "wasm32")]
pub mod web;

pub use app::StudioApp;
