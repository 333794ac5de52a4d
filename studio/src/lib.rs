//! # fitslam-studio
//!
//! The FIT-SLAM studio: an egui/eframe application, native and in the browser, that makes the
//! planner's decision visible and tunable. It is a thin view over `fitslam_core`: the core
//! computes every number (thresholding, voxels, frontiers, paths, u1, u2, ranking); the studio
//! loads inputs, caches stages, draws and exports.
//!
//! | module | what |
//! |---|---|
//! | [`app`] | [`StudioApp`]: panels, file loading, shortcuts, title digest |
//! | [`scene`] | map (score layer), landmarks, robot, boundary, blacklist |
//! | [`pipeline`] | scene + `Params` → `Decision` via the core, cached per stage, timed |
//! | [`canvas`] | drawing of layers and the decision, robot dragging, picking |
//! | [`panels`] | parameter sliders, candidate details, sortable table |
//! | [`loader`] / [`files`] | files → scene parts; drop, picker, in-app file browser, downloads |
//! | [`export`] | ranking CSV / JSON, parameter YAML, digest |
//! | [`assets`] | built-in scenes (embedded) |
//! | [`tour`] | the teaching tour |
//! | [`sim_runner`] | Mission mode: built-in worlds, missions side by side under a frame budget |
//! | [`mission_view`] | Mission mode: controls, lane maps, live plots (egui_plot) |

pub mod app;
pub mod assets;
pub mod canvas;
pub mod export;
pub mod files;
pub mod loader;
pub mod mission_view;
pub mod panels;
pub mod pipeline;
pub mod scene;
pub mod sim_runner;
pub mod tour;
#[cfg(target_arch = "wasm32")]
pub mod web;

pub use app::StudioApp;
