//! The studio application: panels around the canvas, the loading of files, and the glue
//! between the views and the state they show. Same code natively, in the browser and in the
//! headless UI tests ([`StudioApp::show`] draws everything into a `Ui`).
//!
//! Each view is handed the part of the state it reads and edits ([`PlannerState`],
//! [`MissionView`], the canvas' and the table's own state) and returns what reaches further
//! as [`Action`]s, which [`StudioApp`] applies once the view is drawn. This file is the only
//! one that knows the whole state and wires the views together.

mod publish;
mod windows;

use crate::action::{Action, WidgetRects};
use crate::assets;
use crate::canvas::CanvasState;
use crate::export;
use crate::files::{self, FileBrowser, Inbox, IncomingFile, Intent};
use crate::loader::{self, Loaded};
use crate::mission_view::MissionView;
use crate::panels::{self, TableState};
use crate::planner::{Layer, PlannerState};
use crate::recording::{self, Recording};
use crate::scene::{Landmarks, Scene};
use crate::tour::Tour;
use fitslam_core::Params;
use fitslam_core::params::Validate;
use std::collections::BTreeMap;

/// What the studio shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// One decision on a map: see and tune how the planner picks its next goal.
    Planner,
    /// Simulated missions played side by side ([`crate::mission_view`]).
    Mission,
}

/// A message for the user (loading errors, exports, decision failures).
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    pub error: bool,
    pub text: String,
}

/// The whole studio state.
pub struct StudioApp {
    /// The Planner mode's state: scene, parameters, decision, layer, overlays, selection.
    pub planner: PlannerState,
    pub canvas: CanvasState,
    pub table: TableState,
    pub messages: Vec<Message>,
    pub tour: Tour,
    pub mode: Mode,
    /// The Mission mode's state (its missions are started when the mode is first shown).
    pub mission: MissionView,
    /// The recorded mission shown in the Planner mode, if one is open.
    pub recording: Option<Recording>,
    inbox: Inbox,
    browser: FileBrowser,
    /// Map YAMLs waiting for their image, and the last bare image (for a YAML that comes later).
    pairing: loader::Pairing,
    /// A cloud dropped without intent, waiting for the user's choice.
    ask_cloud: Option<IncomingFile>,
    /// Screen rectangles of named widgets this frame (published on the web for tests).
    pub widget_rects: WidgetRects,
    last_title: String,
    last_published: String,
    show_about: bool,
}

impl StudioApp {
    /// The studio showing the built-in asset `asset` (or the first one) with a decision made.
    pub fn new(ctx: &egui::Context, asset: Option<&str>) -> Self {
        let params = Params::default();
        let builtin = asset.and_then(assets::builtin).unwrap_or(&assets::builtins()[0]);
        let mut messages = Vec::new();
        if let Some(name) = asset.filter(|n| assets::builtin(n).is_none()) {
            messages.push(Message { error: true, text: format!("no built-in asset named '{name}'; showing '{}'", builtin.name) });
        }
        let scene = match builtin.build(params.frontier.blacklist_radius_m) {
            Ok(s) => s,
            Err(e) => {
                messages.push(Message { error: true, text: format!("built-in asset '{}': {e}", builtin.name) });
                empty_scene()
            }
        };
        let _ = ctx;
        Self {
            planner: PlannerState::new(scene),
            canvas: CanvasState::default(),
            table: TableState::default(),
            messages,
            tour: Tour::default(),
            mode: Mode::Planner,
            mission: MissionView::default(),
            recording: None,
            inbox: Inbox::default(),
            browser: FileBrowser::default(),
            pairing: loader::Pairing::default(),
            ask_cloud: None,
            widget_rects: BTreeMap::new(),
            last_title: String::new(),
            last_published: String::new(),
            show_about: false,
        }
    }

    /// Replaces the scene by a built-in asset.
    pub fn load_builtin(&mut self, name: &str) {
        match assets::builtin(name).map(|b| b.build(self.planner.params.frontier.blacklist_radius_m)) {
            Some(Ok(scene)) => {
                self.close_recording();
                self.planner.scene = scene;
                self.planner.revs.map += 1;
                self.planner.revs.landmarks += 1;
                self.planner.revs.layout += 1;
                self.after_scene_change();
                self.info(format!("loaded built-in '{name}'"));
            }
            Some(Err(e)) => self.error(format!("built-in asset '{name}': {e}")),
            None => self.error(format!("no built-in asset named '{name}'")),
        }
    }

    fn after_scene_change(&mut self) {
        self.planner.selected = None;
        self.planner.hovered = None;
        self.canvas.fit_requested = true;
    }

    pub fn info(&mut self, text: impl Into<String>) {
        self.push_message(Message { error: false, text: text.into() });
    }

    pub fn error(&mut self, text: impl Into<String>) {
        self.push_message(Message { error: true, text: text.into() });
    }

    fn push_message(&mut self, m: Message) {
        self.messages.push(m);
        if self.messages.len() > 6 {
            self.messages.remove(0);
        }
    }

    /// Loads files as if dropped (tests and the web use this too).
    pub fn load_files(&mut self, files: Vec<IncomingFile>) {
        if files.is_empty() {
            return;
        }
        let results = loader::load_batch(files, &mut self.pairing, &self.planner.params);
        for r in results {
            match r {
                Ok(Loaded::Map(map)) => {
                    self.close_recording();
                    let (name, cells, known) = (map.source.clone(), map.geometry().len(), map.known_cells());
                    let robot = self.planner.scene.robot;
                    let landmarks = std::mem::take(&mut self.planner.scene.landmarks);
                    let mut scene = Scene::new(map, landmarks, None, self.planner.params.frontier.blacklist_radius_m);
                    // Keep the robot where it was if that is on the new map.
                    if scene.map.score.at_world(robot.x_m, robot.y_m).is_some_and(|s| *s >= 0.5) {
                        scene.robot = robot;
                    }
                    self.planner.scene = scene;
                    self.planner.revs.map += 1;
                    self.planner.revs.layout += 1;
                    self.after_scene_change();
                    self.messages.retain(|m| !m.text.contains("now drop or open its image"));
                    self.info(format!("map {name}: {cells} cells, {known} known"));
                }
                Ok(Loaded::Landmarks(lm)) => {
                    let n = lm.cloud.len();
                    let name = lm.source.clone();
                    self.planner.scene.landmarks = lm;
                    self.planner.revs.landmarks += 1;
                    self.planner.selected = None;
                    self.info(format!("landmarks {name}: {n} points"));
                }
                Ok(Loaded::Params(p)) => {
                    self.planner.params = *p;
                    self.info("parameters loaded");
                }
                Ok(Loaded::Recording(r)) => self.open_recording(*r),
                Ok(Loaded::WaitingForImage { yaml_name, image }) => {
                    self.info(format!("{yaml_name}: now drop or open its image {image}"));
                }
                Ok(Loaded::AskCloudUse(f)) => self.ask_cloud = Some(f),
                Err(e) => self.error(e),
            }
        }
    }

    /// Opens a recording at its first decision instant (else its end).
    pub fn open_recording(&mut self, rec: Recording) {
        let (name, n, duration) = (rec.name().to_string(), rec.instants().len(), rec.duration_s());
        let t = rec.first_instant_s();
        self.recording = Some(rec);
        if self.show_instant(t) {
            self.canvas.fit_requested = true;
            self.info(format!("recording {name}: {duration:.1} s, {n} decision instants"));
        } else {
            self.recording = None;
        }
    }

    /// Shows the open recording at `t_s`: the robot's scene then, its choice beside the
    /// re-ranking. The view is kept (the map grows in the same frame). Returns whether it could.
    pub fn show_instant(&mut self, t_s: f64) -> bool {
        let radius = self.planner.params.frontier.blacklist_radius_m;
        let Some(rec) = self.recording.as_mut() else { return false };
        match rec.scene_at(t_s, radius) {
            Ok(scene) => {
                self.planner.recorded_goal_m = rec.robot_target();
                self.planner.scene = scene;
                self.planner.revs.map += 1;
                self.planner.revs.landmarks += 1;
                self.planner.revs.layout += 1;
                self.planner.selected = None;
                self.planner.hovered = None;
                true
            }
            Err(e) => {
                self.error(e);
                false
            }
        }
    }

    /// Closes the recording; the scene shown stays.
    pub fn close_recording(&mut self) {
        self.recording = None;
        self.planner.recorded_goal_m = None;
    }

    /// Writes the scene as files `fitslam select` reads (the grid at τ, the landmarks, the
    /// command line with the pose); named after the recording's instant when one is shown.
    pub fn export_scene(&mut self) {
        let Some(grid) = self.planner.pipeline.occupancy() else {
            self.error("no scene to export yet");
            return;
        };
        let stem = match &self.recording {
            Some(r) => {
                let base = files::base_name(r.name());
                format!("{}_t{:.3}s", base.strip_suffix(".mcap").unwrap_or(base), r.t_s)
            }
            None => "fitslam_scene".to_string(),
        };
        let files = recording::scene_files(grid, &self.planner.scene.landmarks, self.planner.scene.robot, &stem);
        let mut written = Vec::new();
        for (name, bytes) in &files {
            match files::save(name, "application/octet-stream", bytes) {
                Ok(p) => written.push(p),
                Err(e) => {
                    self.error(format!("export scene: {e}"));
                    return;
                }
            }
        }
        self.info(format!("scene written: {}", written.join(", ")));
    }

    /// Draws the whole studio into `ui` and updates the decision; the body of `eframe::App::ui`.
    pub fn show(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        self.widget_rects.clear();
        self.inbox.take_dropped(&ctx);
        let incoming = self.inbox.drain();
        self.load_files(incoming);
        self.shortcuts(&ctx);

        egui::Panel::top("menu").show(ui, |ui| {
            egui::MenuBar::new().ui(ui, |ui| self.menu_bar(ui));
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar(ui));
        if self.mode == Mode::Mission {
            let mut actions = Vec::new();
            crate::mission_view::show(ui, &mut self.mission, &self.planner.params, &mut self.widget_rects, &mut actions);
            self.apply(actions);
        } else {
            self.planner_panels(ui);
        }

        self.browser.show(&ctx, &self.inbox);
        self.cloud_question(&ctx);
        self.tour_window(&ctx);
        self.about_window(&ctx);
        self.publish(&ctx);
    }

    /// The Planner mode: parameters, details, candidate table and the canvas; then the decision
    /// is brought up to date.
    fn planner_panels(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        let mut actions = Vec::new();
        if let Some(rec) = &self.recording {
            egui::Panel::top("recording")
                .show(ui, |ui| crate::recording_view::show(ui, rec, self.planner.pipeline.action(), &mut self.widget_rects, &mut actions));
        }
        let p = &mut self.planner;
        egui::Panel::left("params").resizable(true).default_size(270.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| panels::params_panel(ui, &mut p.params, &mut self.widget_rects, &mut actions));
        });
        egui::Panel::right("details").resizable(true).default_size(270.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| panels::details_panel(ui, p));
        });
        egui::Panel::bottom("table")
            .resizable(true)
            .default_size(200.0)
            .min_size(120.0)
            .show(ui, |ui| panels::candidate_table(ui, &p.pipeline, &mut p.selected, &mut self.table, &mut actions));
        egui::CentralPanel::default().show(ui, |ui| crate::canvas::show(ui, p, &mut self.canvas, &mut self.widget_rects));
        self.apply(actions);

        // The parameters or the scene may have changed above: bring the decision up to date.
        // (The canvas drew last frame's decision for at most one frame.) A terrain map is
        // re-scored first if a hazard parameter moved.
        let valid = self.planner.params.validate().is_ok();
        if valid && self.planner.scene.map.refresh_terrain(&self.planner.params.traversability) {
            self.planner.revs.map += 1;
        }
        if valid && self.planner.pipeline.update(&self.planner.scene, self.planner.revs, &self.planner.params, &self.planner.explore) {
            ctx.request_repaint();
            // While the robot is dragged across obstacles the canvas shows the error live; only
            // a failure that stays is worth a message.
            if let (Some(Err(e)), false) = (self.planner.pipeline.decision(), self.canvas.dragging()) {
                let e = e.clone();
                if self.messages.last().is_none_or(|m| m.text != e) {
                    self.error(e);
                }
            }
        }
        if let Some(sel) = self.planner.selected
            && self.planner.pipeline.ok_decision().is_none_or(|d| sel >= d.candidates.len())
        {
            self.planner.selected = None;
        }
    }

    /// Loads mission lane `i`'s current state (the robot's map as the score layer, its landmark
    /// map, estimated pose, blacklist, the world's boundary, the lane's strategy) into the
    /// Planner mode and switches to it; the planner re-ranks from that state.
    pub fn open_lane_in_planner(&mut self, i: usize) {
        let Some(lane) = self.mission.runner.as_mut().and_then(|r| r.lanes.get_mut(i)) else { return };
        let m = &mut lane.mission;
        let name = format!("{} / {} at t = {:.1} s", m.world().spec.name, lane.strategy.name(), m.time_s());
        let map = crate::scene::MapLayers::from_score(m.layers().score.clone(), name.clone(), crate::scene::MapKind::Traversability);
        let landmarks = Landmarks { cloud: m.landmark_map(), source: format!("{name} landmark map") };
        let mut scene = Scene::new(map, landmarks, Some(m.estimate()), self.planner.params.frontier.blacklist_radius_m);
        scene.robot = m.estimate();
        scene.boundary = m.world().boundary.clone();
        scene.blacklist = m.explorer().blacklist().clone();
        let (strategy, seed) = (lane.strategy, m.seed());
        self.close_recording();
        self.planner.scene = scene;
        self.planner.params.selector.strategy = strategy;
        self.planner.params.selector.seed = seed;
        self.planner.revs.map += 1;
        self.planner.revs.landmarks += 1;
        self.planner.revs.layout += 1;
        self.after_scene_change();
        self.mode = Mode::Planner;
        if let Some(r) = &mut self.mission.runner {
            r.pause();
        }
        self.info(format!("opened {name} in the planner"));
    }

    fn shortcuts(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        let open = KeyboardShortcut::new(Modifiers::COMMAND, Key::O);
        let params = KeyboardShortcut::new(Modifiers::COMMAND, Key::E);
        let json = KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::J);
        let csv = KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::C);
        if ctx.input_mut(|i| i.consume_shortcut(&open)) {
            files::open_picker(Intent::Any, &self.inbox, ctx, &mut self.browser);
        }
        if ctx.input_mut(|i| i.consume_shortcut(&params)) {
            self.export_params();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&json)) {
            self.export_ranking(true);
        }
        if ctx.input_mut(|i| i.consume_shortcut(&csv)) {
            self.export_ranking(false);
        }
    }

    /// Carries out what the views asked for this frame.
    fn apply(&mut self, actions: Vec<Action>) {
        for a in actions {
            match a {
                Action::ExportParams => self.export_params(),
                Action::ExportRanking { json } => self.export_ranking(json),
                Action::OpenLaneInPlanner(i) => self.open_lane_in_planner(i),
                Action::ShowInstant(t) => {
                    self.show_instant(t);
                }
                Action::CloseRecording => self.close_recording(),
                Action::ExportScene => self.export_scene(),
            }
        }
    }

    /// Writes the parameters as the robot node's YAML file.
    pub fn export_params(&mut self) {
        match files::save("fitslam_params.yaml", "application/yaml", self.planner.params.to_yaml().as_bytes()) {
            Ok(p) => self.info(format!("parameters written to {p}")),
            Err(e) => self.error(format!("export parameters: {e}")),
        }
    }

    /// Writes the ranking as JSON or CSV.
    pub fn export_ranking(&mut self, json: bool) {
        let Some(d) = self.planner.pipeline.ok_decision() else {
            self.error("no ranking to export (the decision failed)");
            return;
        };
        let (name, mime, text) = if json {
            (
                "fitslam_ranking.json",
                "application/json",
                export::ranking_json(d, &self.planner.params, &self.planner.scene.map.source, &self.planner.scene.landmarks.source),
            )
        } else {
            ("fitslam_ranking.csv", "text/csv", export::ranking_csv(d))
        };
        match files::save(name, mime, text.as_bytes()) {
            Ok(p) => self.info(format!("ranking written to {p}")),
            Err(e) => self.error(format!("export ranking: {e}")),
        }
    }

    /// The title digest last published.
    pub fn title(&self) -> &str {
        &self.last_title
    }

    /// The landmarks in use.
    pub fn landmarks(&self) -> &Landmarks {
        &self.planner.scene.landmarks
    }
}

/// A one-cell unknown map, used only if a built-in asset fails to build.
fn empty_scene() -> Scene {
    use fitslam_core::grid::{Grid, GridGeometry};
    let map = crate::scene::MapLayers::from_score(
        Grid::filled(GridGeometry::new(0.0, 0.0, 0.05, 1, 1), f32::NAN),
        "empty",
        crate::scene::MapKind::Synthetic,
    );
    Scene::new(map, Landmarks::default(), None, 0.5)
}

impl eframe::App for StudioApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.show(ui);
    }
}
