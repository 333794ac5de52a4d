//! A short built-in tour for teaching: seven steps on the default map that explain u1 and u2 by
//! setting the parameters and the view so that the effect of each term is visible.

use crate::planner::{Layer, Overlays, PlannerState, RayMode};
use fitslam_core::Params;
use fitslam_core::params::Strategy;

/// The tour's state.
#[derive(Clone, Debug, Default)]
pub struct Tour {
    pub open: bool,
    pub step: usize,
}

struct Step {
    title: &'static str,
    text: &'static str,
    apply: fn(&mut PlannerState),
}

const STEPS: [Step; 7] = [
    Step {
        title: "1 · The map",
        text: "Green cells are easy ground, red ones hard, grey ones unknown. The robot (blue) stands in the explored part. \
               Cells with a traversability score ≥ τ are free; the planner also keeps the robot's radius away from obstacles.",
        apply: |planner| {
            planner.params = Params::default();
            planner.layer = Layer::Score;
            planner.overlays = Overlays { rays: RayMode::None, paths: false, frustums: false, ..Overlays::default() };
            planner.selected = None;
        },
    },
    Step {
        title: "2 · Frontiers and candidates",
        text: "A frontier is free ground next to the unknown that the robot can reach. Each cluster of frontier cells (cyan / \
               magenta) gives one candidate goal C_i, its middle cell. FIT-SLAM scores every candidate; the numbers are the ranks.",
        apply: |planner| {
            planner.layer = Layer::Thresholded;
            planner.overlays = Overlays { rays: RayMode::None, paths: false, frustums: false, ..Overlays::default() };
        },
    },
    Step {
        title: "3 · u1: what would the camera discover?",
        text: "From each candidate, rays fan out every Δθ up to the camera range d_max. An unknown cell adds up to 1 bit, less \
               the further it is along the ray (γ). Bright rays gain most. Θ* is the heading whose camera window Φ (white cone) \
               collects the most bits: that sum is ΔE. Hover candidates to compare their fans.",
        apply: |planner| {
            planner.layer = Layer::Score;
            planner.overlays = Overlays { rays: RayMode::Focused, paths: false, frustums: false, ..Overlays::default() };
            planner.selected = planner.pipeline.ok_decision().and_then(|d| d.chosen);
        },
    },
    Step {
        title: "4 · u1: near or informative? (α)",
        text: "u1 = α·ρ_min/ρ + (1 − α)·ΔE/ΔE_max. Here α = 1: only the path length counts, so the nearest candidate ranks first \
               (like the greedy baseline). Move α towards 0 and watch far but informative frontiers overtake it. The paper uses 0.35.",
        apply: |planner| {
            planner.params.u1.alpha = 1.0;
            planner.params.u2.beta = 1.0;
            planner.overlays = Overlays { rays: RayMode::Ranked, all_cones: true, paths: false, frustums: false, ..Overlays::default() };
            planner.selected = None;
        },
    },
    Step {
        title: "5 · u2: keep the map localisable",
        text: "The N best candidates by u1 get a second look. Along the path to each, waypoints every d_max carry a camera; every \
               landmark voxel inside a camera's frustum adds Fisher information (how well its bearing pins down the pose). The \
               frustums are coloured by that information; I_p sums it over the path.",
        apply: |planner| {
            planner.params = Params::default();
            planner.overlays = Overlays { rays: RayMode::None, paths: true, frustums: true, ..Overlays::default() };
            planner.selected = None;
        },
    },
    Step {
        title: "6 · u2 = β·u1 + (1 − β)·I_p",
        text: "β balances exploration (u1) against localisation (I_p). With β = 1 the order is u1's; lower β and paths that keep \
               landmarks in view climb. The paper uses β = 0.4. Compare the table's u1 and u2 columns.",
        apply: |planner| {
            planner.params.u2.beta = 0.4;
            planner.params.selector.strategy = Strategy::Fit;
            planner.overlays = Overlays { rays: RayMode::None, paths: true, frustums: true, ..Overlays::default() };
        },
    },
    Step {
        title: "7 · Your turn",
        text: "Drag the robot (or its white handle to turn it), move τ to make rough ground lethal, switch the strategy to greedy \
               or random, and export the parameters for the robot with File > Export parameters.",
        apply: |planner| {
            planner.params = Params::default();
            planner.overlays = Overlays::default();
        },
    },
];

impl Tour {
    pub fn start(&mut self) {
        self.open = true;
        self.step = 0;
    }

    pub fn len(&self) -> usize {
        STEPS.len()
    }

    pub fn is_empty(&self) -> bool {
        false
    }

    /// Title of the current step.
    pub fn title(&self) -> &'static str {
        STEPS[self.step.min(STEPS.len() - 1)].title
    }

    /// Applies the current step to the planner (parameters, layer, overlays, selection).
    pub fn apply_step(&self, planner: &mut PlannerState) {
        let k = self.step.min(STEPS.len() - 1);
        (STEPS[k].apply)(planner);
    }

    /// Draws the step; returns the step to go to when the user pressed Back / Next.
    pub fn ui(&self, ui: &mut egui::Ui) -> Option<usize> {
        let k = self.step.min(STEPS.len() - 1);
        ui.label(egui::RichText::new(STEPS[k].title).strong().size(16.0));
        ui.add_space(4.0);
        ui.label(STEPS[k].text);
        ui.add_space(8.0);
        let mut go = None;
        ui.horizontal(|ui| {
            if ui.add_enabled(k > 0, egui::Button::new("< Back")).clicked() {
                go = Some(k - 1);
            }
            ui.label(format!("{} / {}", k + 1, STEPS.len()));
            if ui.add_enabled(k + 1 < STEPS.len(), egui::Button::new("Next >")).clicked() {
                go = Some(k + 1);
            }
        });
        go
    }
}
