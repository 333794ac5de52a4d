//! The studio application: panels around the canvas, the loading of files, and the glue
//! between the views and the state they show. Same code natively, in the browser and in the
//! headless UI tests ([`StudioApp::show`] draws everything into a `Ui`).
//!
//! Each view is handed the part of the state it reads and edits ([`PlannerState`],
//! [`MissionView`], the canvas' and the table's own state) and returns what reaches further
//! as [`Action`]s, which [`StudioApp`] applies once the view is drawn. This file is the only
//! one that knows the whole state and wires the views together.

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

    fn menu_bar(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        let r = ui.selectable_label(self.mode == Mode::Planner, "Planner").on_hover_text("One decision: see and tune it.");
        self.widget_rects.insert("mode_planner", r.rect);
        if r.clicked() {
            self.mode = Mode::Planner;
        }
        let r =
            ui.selectable_label(self.mode == Mode::Mission, "Mission").on_hover_text("Play simulated missions, strategies side by side.");
        self.widget_rects.insert("mode_mission", r.rect);
        if r.clicked() {
            self.mode = Mode::Mission;
        }
        ui.separator();
        ui.menu_button("File", |ui| {
            if ui.button("Open… (Ctrl+O)").clicked() {
                files::open_picker(Intent::Any, &self.inbox, &ctx, &mut self.browser);
            }
            if ui.button("Open map (YAML + PGM/PNG, PNG)…").clicked() {
                files::open_picker(Intent::Map, &self.inbox, &ctx, &mut self.browser);
            }
            if ui.button("Open landmarks (PCD, PLY, CSV, LAS)…").clicked() {
                files::open_picker(Intent::Landmarks, &self.inbox, &ctx, &mut self.browser);
            }
            if ui.button("Open terrain cloud (-> traversability map)…").clicked() {
                files::open_picker(Intent::TerrainCloud, &self.inbox, &ctx, &mut self.browser);
            }
            if ui.button("Open parameters (YAML, TOML)…").clicked() {
                files::open_picker(Intent::Params, &self.inbox, &ctx, &mut self.browser);
            }
            if ui.button("Open recording (rosbag2 MCAP)…").clicked() {
                files::open_picker(Intent::Recording, &self.inbox, &ctx, &mut self.browser);
            }
            ui.separator();
            if ui.button("Export parameters (robot YAML, Ctrl+E)").clicked() {
                self.export_params();
            }
            if ui.button("Export ranking JSON (Ctrl+Shift+J)").clicked() {
                self.export_ranking(true);
            }
            if ui.button("Export ranking CSV (Ctrl+Shift+C)").clicked() {
                self.export_ranking(false);
            }
            if ui.button("Export scene (map, landmarks, pose for `fitslam select`)").clicked() {
                self.export_scene();
            }
        });
        ui.menu_button("Built-in", |ui| {
            for b in assets::builtins() {
                if ui.button(b.name).on_hover_text(b.description).clicked() {
                    self.load_builtin(b.name);
                }
            }
        });
        ui.menu_button("View", |ui| {
            ui.label("Map layer");
            for l in Layer::ALL {
                ui.radio_value(&mut self.planner.layer, l, l.label());
            }
            ui.separator();
            self.planner.overlays.checkboxes(ui);
            ui.separator();
            if ui.button("Fit map to view").clicked() {
                self.canvas.fit_requested = true;
            }
        });
        if ui.button("Tour").clicked() {
            self.tour.start();
            self.tour.apply_step(&mut self.planner);
        }
        if ui.button("About").clicked() {
            self.show_about = true;
        }
    }

    fn status_bar(&mut self, ui: &mut egui::Ui) {
        let g = self.planner.scene.map.geometry();
        ui.horizontal_wrapped(|ui| {
            ui.label(format!(
                "map: {} ({}×{} @ {:.2} m) · landmarks: {} ({} pts, {} voxels)",
                self.planner.scene.map.source,
                g.width,
                g.height,
                g.resolution_m,
                self.planner.scene.landmarks.source,
                self.planner.scene.landmarks.cloud.len(),
                self.planner.pipeline.voxels().map(|v| v.len()).unwrap_or(0),
            ));
            ui.separator();
            let t = self.planner.pipeline.timings;
            ui.label(format!("decision {:.1} ms (last update {:.1} ms)", t.decision_ms, t.last_update_ms))
                .on_hover_text("Wall-clock time of the last selector run and of everything re-run by the last change.");
        });
        let mut dismiss = None;
        for (k, m) in self.messages.iter().enumerate().rev().take(2) {
            ui.horizontal(|ui| {
                if ui.small_button("x").on_hover_text("Dismiss").clicked() {
                    dismiss = Some(k);
                }
                let color = if m.error { egui::Color32::from_rgb(255, 120, 110) } else { ui.visuals().text_color() };
                ui.colored_label(color, &m.text);
            });
        }
        if let Some(k) = dismiss {
            self.messages.remove(k);
        }
    }

    fn cloud_question(&mut self, ctx: &egui::Context) {
        let Some(f) = &self.ask_cloud else { return };
        let name = f.name.clone();
        let mut choice = None;
        let mut rects = Vec::new();
        egui::Window::new("Point cloud").collapsible(false).resizable(false).show(ctx, |ui| {
            ui.label(format!("What is {}?", files::base_name(&name)));
            ui.horizontal(|ui| {
                let r = ui.button("Landmarks (for u2)");
                rects.push(("cloud_landmarks", r.rect));
                if r.clicked() {
                    choice = Some(Intent::Landmarks);
                }
                let r = ui.button("Terrain (compute traversability map)");
                rects.push(("cloud_terrain", r.rect));
                if r.clicked() {
                    choice = Some(Intent::TerrainCloud);
                }
                if ui.button("Cancel").clicked() {
                    choice = Some(Intent::Any);
                }
            });
        });
        self.widget_rects.extend(rects);
        if let Some(intent) = choice
            && let Some(mut f) = self.ask_cloud.take()
            && intent != Intent::Any
        {
            f.intent = intent;
            self.load_files(vec![f]);
        }
    }

    fn tour_window(&mut self, ctx: &egui::Context) {
        if !self.tour.open {
            return;
        }
        let mut action = None;
        let mut open = true;
        egui::Window::new("Tour: how FIT-SLAM picks a goal")
            .open(&mut open)
            .default_pos([320.0, 80.0])
            .default_width(380.0)
            .show(ctx, |ui| action = self.tour.ui(ui));
        if !open {
            self.tour.open = false;
        }
        if let Some(step) = action {
            self.tour.step = step;
            self.tour.apply_step(&mut self.planner);
        }
    }

    fn about_window(&mut self, ctx: &egui::Context) {
        let mut open = self.show_about;
        egui::Window::new("About the FIT-SLAM studio").open(&mut open).show(ctx, |ui| {
            ui.label("FIT-SLAM ranks frontier goals by u1 (path length and expected entropy gain over the camera's best heading Θ*) and re-ranks the best N by u2 (landmark Fisher information along the path).");
            ui.label("Drag the robot to move it, drag its heading handle to rotate it, scroll to zoom, drag the background to pan. Hover or click a candidate for its numbers.");
            ui.label("Drop map_server YAML + PGM/PNG, PNG, or PCD/PLY/CSV/LAS files on the window to load them; drop a rosbag2 MCAP recording to replay the robot's decisions.");
        });
        self.show_about = open;
    }

    /// Window title / document title digest, and (web) the ranking for page scripts.
    fn publish(&mut self, ctx: &egui::Context) {
        let title = match self.planner.pipeline.decision() {
            Some(Ok(d)) => export::digest(d, 3),
            Some(Err(_)) => "fitslam: error".to_string(),
            None => "fitslam".to_string(),
        };
        if title != self.last_title {
            self.last_title = title.clone();
            #[cfg(not(target_arch = "wasm32"))]
            ctx.send_viewport_cmd(egui::ViewportCommand::Title(format!("FIT-SLAM studio — {title}")));
        }
        let ranking = self.planner.pipeline.ok_decision().map(export::ranking_brief_json).unwrap_or_else(|| "null".into());
        let g = self.planner.scene.map.geometry();
        let stats = serde_json::json!({
            "decision_ms": self.planner.pipeline.timings.decision_ms,
            "last_update_ms": self.planner.pipeline.timings.last_update_ms,
            "decisions_computed": self.planner.pipeline.decisions_computed,
            "decision_revision": self.planner.pipeline.decision_revision,
            "map": self.planner.scene.map.source,
            "map_cells": [g.width, g.height],
            "landmarks": self.planner.scene.landmarks.source,
            "landmark_points": self.planner.scene.landmarks.cloud.len(),
            "error": self.planner.pipeline.decision().and_then(|d| d.as_ref().err()).cloned(),
            "messages": self.messages.iter().map(|m| &m.text).collect::<Vec<_>>(),
            "robot": [self.planner.scene.robot.x_m, self.planner.scene.robot.y_m, self.planner.scene.robot.yaw_rad],
            "params": {
                "alpha": self.planner.params.u1.alpha,
                "beta": self.planner.params.u2.beta,
                "tau": self.planner.params.traversability.tau,
                "top_n": self.planner.params.u2.top_n,
                "strategy": self.planner.params.selector.strategy,
            },
            "slider_width": ctx.global_style().spacing.slider_width,
            "cloud_question": self.ask_cloud.as_ref().map(|f| f.name.clone()),
            "mode": if self.mode == Mode::Mission { "mission" } else { "planner" },
            "recording": self.recording.as_ref().map(|r| serde_json::json!({
                "name": r.name(),
                "duration_s": r.duration_s(),
                "instants_s": r.instants().iter().map(|i| i.t_s).collect::<Vec<_>>(),
                "index": r.current_index(),
                "t_s": r.t_s,
                "robot_goal": r.robot_target(),
                "chosen_m": crate::recording_view::answer_goal_m(self.planner.pipeline.action()),
                "goal_gap_m": crate::recording_view::choice_gap_m(r, self.planner.pipeline.action()),
            })),
            "mission": if self.mode == Mode::Mission || self.mission.runner.is_some() {
                self.mission.stats()
            } else {
                serde_json::Value::Null
            },
        })
        .to_string();
        let widgets: BTreeMap<&str, [f32; 4]> =
            self.widget_rects.iter().map(|(k, r)| (*k, [r.min.x, r.min.y, r.width(), r.height()])).collect();
        let widgets = serde_json::to_string(&widgets).unwrap_or_default();
        let all = format!("{title}\n{ranking}\n{stats}\n{widgets}");
        if all != self.last_published {
            #[cfg(target_arch = "wasm32")]
            crate::browser::publish(&title, &ranking, &stats, &widgets);
            self.last_published = all;
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
