//! The *Mission* mode: play simulated missions ([`crate::sim_runner`]) in a built-in world with
//! several strategies side by side. Left: the world, strategies, seed, localisation, Play / Pause
//! / Step tick (0.1 s) / Step decision / Reset and the speed; centre: one map per strategy (the
//! robot's thresholded map or score as it builds it, the true and estimated trajectories, the
//! robot, the current goal, its path and the last decision's candidates); bottom: live plots of
//! unexplored % and tr(cov) over simulated time (egui_plot), one line per strategy.
//!
//! Drawing reuses the planner canvas' pieces ([`crate::canvas`]: view transform, layer images,
//! robot, goal and candidate markers). Map textures are refreshed at most every 0.5 simulated
//! seconds per lane (an image is O(cells)).

mod controls;

use crate::action::{Action, WidgetRects};
use crate::canvas::{self, View};
use crate::sim_runner::{self, MissionConfig, RunState, SimRunner};
use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, Vec2};
use egui_plot::{Legend, Line, Plot, PlotPoints};
use fitslam_core::params::Strategy;
use fitslam_core::sim::Localisation;
use fitslam_core::traversability::score_rgb;

/// Which map each lane shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MissionLayer {
    /// The robot's map thresholded by τ (free, lethal, unknown).
    Thresholded,
    /// The robot's traversability score (red → green), unknown grey.
    Score,
    /// The ground truth (thresholded), for comparison.
    Truth,
}

impl MissionLayer {
    pub const ALL: [MissionLayer; 3] = [MissionLayer::Thresholded, MissionLayer::Score, MissionLayer::Truth];

    pub fn label(self) -> &'static str {
        match self {
            MissionLayer::Thresholded => "robot's map (τ)",
            MissionLayer::Score => "robot's score",
            MissionLayer::Truth => "ground truth",
        }
    }
}

/// Colour of a strategy (lane header, trajectory, plot line).
pub fn strategy_color(s: Strategy) -> Color32 {
    match s {
        Strategy::Fit => Color32::from_rgb(255, 200, 40),
        Strategy::Greedy => Color32::from_rgb(80, 200, 255),
        Strategy::Random => Color32::from_rgb(255, 120, 200),
        Strategy::U1 => Color32::from_rgb(140, 255, 140),
        Strategy::Matched => Color32::from_rgb(190, 150, 255),
        Strategy::MatchedTop => Color32::from_rgb(255, 160, 90),
        Strategy::U2Length => Color32::from_rgb(200, 200, 200),
        Strategy::U2Truth => Color32::from_rgb(120, 230, 230),
    }
}

/// Texture cache key: layer, simulated time (ms), τ bits, runner generation.
type TexKey = (MissionLayer, u64, u64, u64);

/// State of the Mission mode.
pub struct MissionView {
    /// The settings being edited (applied on Reset).
    pub config: MissionConfig,
    pub runner: Option<SimRunner>,
    /// Why the last start failed.
    pub error: Option<String>,
    /// Speed slider value, simulated seconds per real second.
    pub speed: f64,
    /// Run as fast as the frame budget allows.
    pub max_speed: bool,
    pub budget_ms: f64,
    pub layer: MissionLayer,
    pub show_candidates: bool,
    textures: Vec<Option<(TexKey, egui::TextureHandle, f64)>>,
    /// Incremented at every (re)start, part of the texture keys.
    generation: u64,
    /// Points handed to the plots in the last frame (for tests and the page state).
    pub plot_points: usize,
}

impl Default for MissionView {
    fn default() -> Self {
        Self {
            config: MissionConfig::default(),
            runner: None,
            error: None,
            speed: 20.0,
            max_speed: false,
            budget_ms: sim_runner::DEFAULT_BUDGET_MS,
            layer: MissionLayer::Thresholded,
            show_candidates: true,
            textures: Vec::new(),
            generation: 0,
            plot_points: 0,
        }
    }
}

impl MissionView {
    /// (Re)starts the missions with the current settings and planner parameters (the world is
    /// rebuilt only if another world or τ was chosen).
    pub fn restart(&mut self, params: &fitslam_core::Params) {
        self.generation += 1;
        self.textures.clear();
        let reuse =
            self.runner.as_ref().is_some_and(|r| r.config.world == self.config.world && r.params.traversability == params.traversability);
        let result = match (reuse, self.runner.as_mut()) {
            (true, Some(r)) => match fitslam_core::params::Valid::new(params.clone()) {
                Ok(p) => {
                    r.config = self.config.clone();
                    r.params = p;
                    r.reset()
                }
                Err(e) => Err(format!("planner parameters: {e}")),
            },
            _ => SimRunner::new(self.config.clone(), params).map(|r| {
                self.runner = Some(r);
            }),
        };
        match result {
            Ok(()) => self.error = None,
            Err(e) => {
                self.runner = None;
                self.error = Some(e);
            }
        }
        self.apply_speed();
    }

    fn apply_speed(&mut self) {
        if let Some(r) = &mut self.runner {
            r.speed = if self.max_speed { f64::INFINITY } else { self.speed };
            r.budget_ms = self.budget_ms;
        }
    }

    /// Advances the running missions for one frame (called once per frame in Mission mode).
    pub fn advance(&mut self, ctx: &egui::Context) {
        self.apply_speed();
        let dt = f64::from(ctx.input(|i| i.stable_dt));
        if let Some(r) = &mut self.runner {
            r.advance(dt, sim_runner::now_ms);
            if r.state != RunState::Paused {
                ctx.request_repaint();
            }
        }
    }

    /// State for page scripts and tests (JSON). While paused, each lane also carries its
    /// `metrics.csv` text, which the browser test compares with the native CLI's for the same
    /// world, strategy and seed (same seed, same run, native and wasm).
    pub fn stats(&self) -> serde_json::Value {
        let Some(r) = &self.runner else {
            return serde_json::json!({ "world": self.config.world, "error": self.error, "lanes": [] });
        };
        let lanes: Vec<_> = r
            .lanes
            .iter()
            .map(|l| {
                let last = l.mission.rows().last();
                serde_json::json!({
                    "strategy": l.strategy.name(),
                    "strategy_id": l.strategy,
                    "time_s": l.mission.time_s(),
                    "rows": l.mission.rows().len(),
                    "unexplored_pct": last.map(|r| r.unexplored_pct),
                    "first_unexplored_pct": l.mission.rows().first().map(|r| r.unexplored_pct),
                    "cov_trace": last.map(|r| r.cov_trace),
                    "decisions": l.decisions,
                    "end": l.end.map(|e| format!("{e:?}")),
                    "metrics_csv": (r.state == RunState::Paused).then(|| fitslam_core::sim::metrics_csv(l.mission.rows())),
                })
            })
            .collect();
        serde_json::json!({
            "world": r.config.world,
            "seed": r.config.seed,
            "localisation": sim_runner::localisation_label(r.config.localisation),
            "localisation_id": r.config.localisation,
            "reproducible_slam": r.config.reproducible_slam,
            "sim_params_toml": r.config.sim_params_toml,
            "state": format!("{:?}", r.state),
            "time_s": r.time_s(),
            "speed": if r.speed.is_finite() { Some(r.speed) } else { None },
            "achieved_speed": r.achieved_speed(),
            "budget_ms": r.budget_ms,
            "last_frame_ms": r.last_frame_ms,
            "last_frame_ticks": r.last_frame_ticks,
            "ticks": r.ticks,
            "plot_points": self.plot_points,
            "error": self.error,
            "lanes": lanes,
        })
    }
}

/// Draws the Mission mode (controls, lane maps, plots) and advances the missions. `params` are
/// the Planner mode's, which the missions take at (re)start; "open in planner" is returned as
/// [`Action::OpenLaneInPlanner`].
pub fn show(ui: &mut egui::Ui, m: &mut MissionView, params: &fitslam_core::Params, rects: &mut WidgetRects, actions: &mut Vec<Action>) {
    let ctx = ui.ctx().clone();
    if m.runner.is_none() && m.error.is_none() {
        m.restart(params);
    }
    m.advance(&ctx);
    // A click may change the layout (e.g. the "press Reset" line): draw once more so that the
    // published widget rectangles settle.
    if ctx.input(|i| i.pointer.any_click()) {
        ctx.request_repaint();
    }

    egui::Panel::left("mission_controls").resizable(true).default_size(270.0).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| controls::controls(ui, m, params, rects));
    });
    egui::Panel::bottom("mission_plots").resizable(true).default_size(230.0).min_size(120.0).show(ui, |ui| {
        plots(ui, m);
    });
    egui::CentralPanel::default().show(ui, |ui| lanes(ui, m, rects, actions));
}

fn plots(ui: &mut egui::Ui, m: &mut MissionView) {
    let Some(r) = &m.runner else {
        ui.label("no mission");
        return;
    };
    let mut points = 0;
    let height = (ui.available_height() - 4.0).max(60.0);
    ui.columns(2, |cols| {
        let series = |f: fn(&fitslam_core::sim::MetricsRow) -> f64| {
            r.lanes
                .iter()
                .map(|l| {
                    let mut pts: Vec<[f64; 2]> = l.mission.rows().iter().map(|row| [row.time_s, f(row)]).collect();
                    // Plus "now" between two rows, from the last row (rows come once a second).
                    if let Some(last) = l.mission.rows().last()
                        && l.mission.time_s() > last.time_s
                    {
                        pts.push([l.mission.time_s(), f(last)]);
                    }
                    (l.strategy, pts)
                })
                .collect::<Vec<_>>()
        };
        let unexplored = series(|row| row.unexplored_pct);
        let cov = series(|row| row.cov_trace);
        points = unexplored.iter().chain(&cov).map(|(_, p)| p.len()).sum();
        Plot::new("plot_unexplored")
            .legend(Legend::default())
            .height(height)
            .x_axis_label("time [s]")
            .y_axis_label("unexplored [%]")
            .include_y(0.0)
            .include_y(100.0)
            .include_x(0.0)
            .show(&mut cols[0], |p| {
                for (s, pts) in unexplored {
                    p.line(Line::new(s.name(), PlotPoints::new(pts)).color(strategy_color(s)).width(2.0));
                }
            });
        Plot::new("plot_cov")
            .legend(Legend::default())
            .height(height)
            .x_axis_label("time [s]")
            .y_axis_label("tr(cov) [m² + rad²]")
            .include_y(0.0)
            .include_x(0.0)
            .show(&mut cols[1], |p| {
                for (s, pts) in cov {
                    p.line(Line::new(s.name(), PlotPoints::new(pts)).color(strategy_color(s)).width(2.0));
                }
            });
    });
    m.plot_points = points;
}

/// Refreshes lane `i`'s map texture if it is stale; returns its id.
fn lane_texture(ui: &egui::Ui, m: &mut MissionView, i: usize) -> Option<egui::TextureId> {
    let r = m.runner.as_mut()?;
    let lane = r.lanes.get_mut(i)?;
    let mission = &mut lane.mission;
    let tau = mission.params().traversability.tau;
    let t_ms = (mission.time_s() * 1e3).round() as u64;
    if m.textures.len() <= i {
        m.textures.resize_with(i + 1, || None);
    }
    let now = sim_runner::now_ms();
    let stale = match &m.textures[i] {
        None => true,
        Some(((layer, t, tau_bits, generation), _, refreshed_ms)) => {
            *layer != m.layer
                || *tau_bits != tau.to_bits()
                || *generation != m.generation
                // The robot's map: every 0.5 s simulated (at once when it ends or restarts),
                // at most ~6 times per real second.
                || (m.layer != MissionLayer::Truth
                    && t_ms != *t
                    && (t_ms < *t || lane.end.is_some() || (t_ms - *t >= 500 && now - refreshed_ms >= 150.0)))
        }
    };
    if stale {
        let image = match m.layer {
            MissionLayer::Thresholded => canvas::layer_image(&mission.occupancy(), |v| canvas::occupancy_pixel(*v)),
            MissionLayer::Score => canvas::layer_image(&mission.layers().score, |s| {
                let [r, g, b] = score_rgb(*s);
                Color32::from_rgb(r, g, b)
            }),
            MissionLayer::Truth => canvas::layer_image(&mission.world().gt_occupancy, |v| canvas::occupancy_pixel(*v)),
        };
        let max = ui.ctx().input(|i| i.max_texture_side);
        if image.size[0] > max || image.size[1] > max {
            return None;
        }
        let key = (m.layer, t_ms, tau.to_bits(), m.generation);
        match &mut m.textures[i] {
            Some((k, tex, refreshed_ms)) => {
                tex.set(image, egui::TextureOptions::NEAREST);
                *k = key;
                *refreshed_ms = now;
            }
            slot => {
                let tex = ui.ctx().load_texture(format!("fitslam-mission-{i}"), image, egui::TextureOptions::NEAREST);
                *slot = Some((key, tex, now));
            }
        }
    }
    m.textures[i].as_ref().map(|(_, t, _)| t.id())
}

fn lanes(ui: &mut egui::Ui, m: &mut MissionView, widget_rects: &mut WidgetRects, actions: &mut Vec<Action>) {
    let n = m.runner.as_ref().map(|r| r.lanes.len()).unwrap_or(0);
    if n == 0 {
        ui.label(match &m.error {
            Some(e) => format!("no mission: {e}"),
            None => "no strategy selected: tick at least one and press Reset".into(),
        });
        return;
    }
    let mut open = None;
    let mut rects = Vec::new();
    ui.columns(n, |cols| {
        for (i, col) in cols.iter_mut().enumerate() {
            if lane(col, m, i, &mut rects) {
                open = Some(i);
            }
        }
    });
    widget_rects.extend(rects);
    if let Some(i) = open {
        actions.push(Action::OpenLaneInPlanner(i));
    }
}

/// One lane: header and map. Returns whether "open in planner" was clicked.
fn lane(ui: &mut egui::Ui, m: &mut MissionView, i: usize, rects: &mut Vec<(&'static str, Rect)>) -> bool {
    // One name per lane: a lane per strategy at most.
    const NAMES: [&str; Strategy::ALL.len()] = [
        "mission_lane0",
        "mission_lane1",
        "mission_lane2",
        "mission_lane3",
        "mission_lane4",
        "mission_lane5",
        "mission_lane6",
        "mission_lane7",
    ];
    const OPEN: [&str; Strategy::ALL.len()] = [
        "mission_open0",
        "mission_open1",
        "mission_open2",
        "mission_open3",
        "mission_open4",
        "mission_open5",
        "mission_open6",
        "mission_open7",
    ];
    let tex = lane_texture(ui, m, i);
    let Some(r) = &m.runner else { return false };
    let Some(lane) = r.lanes.get(i) else { return false };
    let mission = &lane.mission;
    let last = mission.rows().last();
    let mut open = false;
    ui.horizontal_wrapped(|ui| {
        ui.colored_label(strategy_color(lane.strategy), egui::RichText::new(lane.strategy.name()).strong());
        ui.label(format!(
            "t {:.1} s · {:.1} % unexplored · tr(cov) {:.3} · {:.1} m · {} decisions{}{}{}",
            mission.time_s(),
            last.map(|r| r.unexplored_pct).unwrap_or(100.0),
            last.map(|r| r.cov_trace).unwrap_or(0.0),
            mission.distance_m(),
            lane.decisions,
            match lane.trap_recoveries {
                0 => String::new(),
                n => format!(" · {n} trap recover{} (map forgotten around the robot)", if n == 1 { "y" } else { "ies" }),
            },
            match lane.tight_plans {
                0 => String::new(),
                n => format!(
                    " · {n} path{} planned with a tight inflation ({} m)",
                    if n == 1 { "" } else { "s" },
                    mission.mission_params().explore.tight_inflations_m.iter().map(|r| r.to_string()).collect::<Vec<_>>().join(" or ")
                ),
            },
            match lane.end {
                Some(e) => format!(" · ended: {e:?}"),
                None => String::new(),
            }
        ));
        let b = ui.small_button("open in planner").on_hover_text(
            "Load this mission's current map, landmarks, pose and blacklist into the Planner mode, which re-ranks from them.",
        );
        if i < OPEN.len() {
            rects.push((OPEN[i], b.rect));
        }
        open = b.clicked();
    });
    let (response, painter) = ui.allocate_painter(ui.available_size(), Sense::hover());
    let rect = response.rect;
    if i < NAMES.len() {
        rects.push((NAMES[i], rect));
    }
    painter.rect_filled(rect, 0.0, Color32::from_rgb(24, 24, 28));
    let g = mission.world().field.geometry;
    let (x0, y0, x1, y1) = g.bounds_m();
    let view = View::fit(rect, (x0, y0, x1, y1));
    match tex {
        Some(tex) => {
            let r = Rect::from_two_pos(view.to_screen(x0, y1), view.to_screen(x1, y0));
            painter.image(tex, r, Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)), Color32::WHITE);
        }
        None => {
            painter.text(
                rect.center(),
                Align2::CENTER_CENTER,
                "map too large for a texture",
                FontId::proportional(14.0),
                Color32::LIGHT_RED,
            );
        }
    }
    // Exploration boundary.
    let [bx0, by0, bx1, by1] = mission.world().boundary_box_m;
    let corners = [[bx0, by0], [bx1, by0], [bx1, by1], [bx0, by1]].map(|[x, y]| view.to_screen(x, y));
    painter.add(Shape::closed_line(corners.to_vec(), Stroke::new(1.2, Color32::from_rgb(255, 220, 0))));

    // The last decision's candidates and the path being driven (the goal's candidate path, set
    // back from unknown ground by the position uncertainty).
    if m.show_candidates
        && let Some(d) = &mission.last_decision()
    {
        for (k, c) in d.candidates.iter().enumerate() {
            canvas::draw_candidate(&painter, &view, d, k, c, false, false);
        }
    }
    if mission.goal().is_some() && mission.driven_path_m().len() >= 2 {
        let pts: Vec<Pos2> = mission.driven_path_m().iter().map(|p| view.to_screen(p[0], p[1])).collect();
        painter.add(Shape::line(pts, Stroke::new(2.0, Color32::from_rgb(255, 215, 0))));
    }
    if let Some(goal) = mission.goal() {
        canvas::draw_goal(&painter, &view, goal.goal);
    }
    // Trajectories: true (white) and estimated (the strategy's colour), up to now.
    let track = |poses: &[fitslam_core::sim::StampedPose], now: fitslam_core::Pose2| {
        let mut pts: Vec<Pos2> = poses.iter().map(|p| view.to_screen(p.position_m[0], p.position_m[1])).collect();
        pts.push(view.to_screen(now.x_m, now.y_m));
        pts
    };
    painter.add(Shape::line(track(mission.trajectory_gt(), mission.true_pose()), Stroke::new(1.2, Color32::from_gray(230))));
    painter.add(Shape::line(track(mission.trajectory_est(), mission.estimate()), Stroke::new(1.8, strategy_color(lane.strategy))));
    // The robot: estimate (disc + heading), truth (ring) when they differ.
    let body_r = view.len(mission.params().robot.radius_m).max(5.0);
    let gt = view.to_screen(mission.true_pose().x_m, mission.true_pose().y_m);
    painter.circle_stroke(gt, body_r, Stroke::new(1.5, Color32::from_gray(230)));
    let p = view.to_screen(mission.estimate().x_m, mission.estimate().y_m);
    let heading = p + Vec2::new(mission.estimate().yaw_rad.cos() as f32, -(mission.estimate().yaw_rad.sin() as f32)) * (body_r + 10.0);
    canvas::draw_robot(&painter, p, body_r, heading, false);
    painter.text(
        rect.left_top() + Vec2::new(6.0, 6.0),
        Align2::LEFT_TOP,
        "white: true path · colour: estimate · gold: goal + path",
        FontId::proportional(11.0),
        Color32::from_gray(210),
    );
    open
}
