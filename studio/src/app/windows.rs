//! The studio's chrome around the views: the menu bar, the status bar, and the windows (the
//! question what a dropped cloud is, the tour, about).

use super::*;

impl StudioApp {
    pub(super) fn menu_bar(&mut self, ui: &mut egui::Ui) {
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

    pub(super) fn status_bar(&mut self, ui: &mut egui::Ui) {
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

    pub(super) fn cloud_question(&mut self, ctx: &egui::Context) {
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

    pub(super) fn tour_window(&mut self, ctx: &egui::Context) {
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

    pub(super) fn about_window(&mut self, ctx: &egui::Context) {
        let mut open = self.show_about;
        egui::Window::new("About the FIT-SLAM studio").open(&mut open).show(ctx, |ui| {
            ui.label("FIT-SLAM ranks frontier goals by u1 (path length and expected entropy gain over the camera's best heading Θ*) and re-ranks the best N by u2 (landmark Fisher information along the path).");
            ui.label("Drag the robot to move it, drag its heading handle to rotate it, scroll to zoom, drag the background to pan. Hover or click a candidate for its numbers.");
            ui.label("Drop map_server YAML + PGM/PNG, PNG, or PCD/PLY/CSV/LAS files on the window to load them; drop a rosbag2 MCAP recording to replay the robot's decisions.");
        });
        self.show_about = open;
    }
}
