//! The Planner mode's state: the scene, the parameters, the cached decision and how it is
//! shown (map layer, overlays, the focused candidate). The planner's views ([`crate::canvas`],
//! [`crate::panels`], [`crate::tour`]) read and edit it; the app owns it.

use crate::pipeline::{Pipeline, Revisions};
use crate::scene::Scene;
use fitslam_core::Params;
use fitslam_core::explore::ExploreParams;

/// Which map layer is drawn under the overlays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layer {
    /// Traversability score (red → green), unknown grey.
    Score,
    /// Score thresholded by τ: free, lethal, unknown.
    Thresholded,
    /// The thresholded grid inflated by the robot radius (what the planner uses).
    Inflated,
    /// Known versus unknown cells.
    Unknown,
}

impl Layer {
    pub const ALL: [Layer; 4] = [Layer::Score, Layer::Thresholded, Layer::Inflated, Layer::Unknown];

    pub fn label(self) -> &'static str {
        match self {
            Layer::Score => "score",
            Layer::Thresholded => "thresholded (τ)",
            Layer::Inflated => "inflated (planning)",
            Layer::Unknown => "unknown",
        }
    }
}

/// Which rays are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayMode {
    None,
    /// The hovered or selected candidate (else the chosen one).
    Focused,
    /// Every ranked candidate.
    Ranked,
}

/// Overlay switches.
#[derive(Clone, Debug, PartialEq)]
pub struct Overlays {
    pub landmarks: bool,
    pub boundary: bool,
    pub frontiers: bool,
    pub candidates: bool,
    pub rays: RayMode,
    /// Θ* cones for every ranked candidate (the focused one always has its cone).
    pub all_cones: bool,
    pub paths: bool,
    pub frustums: bool,
}

impl Default for Overlays {
    fn default() -> Self {
        Self {
            landmarks: true,
            boundary: true,
            frontiers: true,
            candidates: true,
            rays: RayMode::Focused,
            all_cones: false,
            paths: true,
            frustums: true,
        }
    }
}

impl Overlays {
    pub fn checkboxes(&mut self, ui: &mut egui::Ui) {
        ui.checkbox(&mut self.landmarks, "landmarks (by height)");
        ui.checkbox(&mut self.boundary, "boundary");
        ui.checkbox(&mut self.frontiers, "frontier clusters");
        ui.checkbox(&mut self.candidates, "candidates");
        ui.horizontal(|ui| {
            ui.label("rays:");
            ui.radio_value(&mut self.rays, RayMode::None, "none");
            ui.radio_value(&mut self.rays, RayMode::Focused, "focused");
            ui.radio_value(&mut self.rays, RayMode::Ranked, "ranked");
        });
        ui.checkbox(&mut self.all_cones, "Θ* cones of all ranked");
        ui.checkbox(&mut self.paths, "paths + waypoints (top N)");
        ui.checkbox(&mut self.frustums, "camera frustums (by FIM)");
    }
}

/// One decision on a map, and how it is shown.
pub struct PlannerState {
    pub scene: Scene,
    pub revs: Revisions,
    pub params: Params,
    /// The exploration policy's parameters (the retry ladder, the set-back), as the robot's.
    pub explore: ExploreParams,
    pub pipeline: Pipeline,
    pub layer: Layer,
    pub overlays: Overlays,
    /// Candidate selected in the canvas or the table.
    pub selected: Option<usize>,
    /// Candidate under the pointer in the canvas this frame.
    pub hovered: Option<usize>,
    /// The goal a recorded robot chose at this scene's instant (map frame), drawn beside the
    /// re-ranked one; set while a recording is shown.
    pub recorded_goal_m: Option<[f64; 2]>,
}

impl PlannerState {
    /// The planner on `scene` with the paper's parameters and the decision made.
    pub fn new(scene: Scene) -> Self {
        let mut planner = Self {
            scene,
            revs: Revisions::default(),
            params: Params::default(),
            explore: ExploreParams::default(),
            pipeline: Pipeline::default(),
            layer: Layer::Score,
            overlays: Overlays::default(),
            selected: None,
            hovered: None,
            recorded_goal_m: None,
        };
        planner.pipeline.update(&planner.scene, planner.revs, &planner.params, &planner.explore);
        planner
    }

    /// Marks the robot pose, boundary or blacklist as edited.
    pub fn layout_changed(&mut self) {
        self.revs.layout += 1;
    }
}
