//! The map canvas: map layers as a texture, then landmarks, boundary, frontier clusters,
//! candidates with rank numbers, Θ* cones, ray fans coloured by entropy gain, paths to the top N
//! with waypoints and camera frustums coloured by information, the chosen goal and the robot.
//! Interaction: drag the robot to move it, drag its heading handle to rotate it, drag the
//! background to pan, scroll to zoom, hover or click a candidate.
//!
//! Everything drawn comes from the scene or the core's `Decision`; nothing is computed here but
//! screen coordinates and colours.

use crate::action::WidgetRects;
use crate::export;
use crate::planner::{Layer, PlannerState, RayMode};
use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, Vec2};
use fitslam_core::grid::{CellClass, Grid, OccupancyGrid};
use fitslam_core::select::{CandidateReport, Decision, DropReason};
use fitslam_core::traversability::{UNKNOWN_RGB, score_rgb};

#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum Drag {
    #[default]
    None,
    Pan,
    MoveRobot,
    RotateRobot,
}

type TexKey = (Layer, u64, u64, u64, u64);

/// View transform and interaction state.
#[derive(Default)]
pub struct CanvasState {
    /// World point at the centre of the canvas, metres.
    pub center_m: [f64; 2],
    /// Zoom, screen points per metre (0 = not yet fitted).
    pub px_per_m: f64,
    /// Fit the map to the canvas on the next frame.
    pub fit_requested: bool,
    drag: Drag,
    texture: Option<(TexKey, egui::TextureHandle)>,
    /// The canvas rectangle last frame.
    pub rect: Option<Rect>,
    /// Whether the user panned or zoomed since the last fit.
    user_view: bool,
}

impl CanvasState {
    /// Whether the robot is being moved or rotated.
    pub fn dragging(&self) -> bool {
        matches!(self.drag, Drag::MoveRobot | Drag::RotateRobot)
    }
}

/// World ↔ screen for one frame (y up in the world, down on screen).
#[derive(Clone, Copy, Debug)]
pub struct View {
    rect: Rect,
    center_m: [f64; 2],
    px_per_m: f64,
}

impl View {
    /// The view of `rect` centred on `center_m` at `px_per_m` screen points per metre.
    pub fn new(rect: Rect, center_m: [f64; 2], px_per_m: f64) -> Self {
        Self { rect, center_m, px_per_m }
    }

    /// The view of `rect` that shows the box `(x0, y0, x1, y1)` (metres) whole, centred, with a
    /// small margin.
    pub fn fit(rect: Rect, (x0, y0, x1, y1): (f64, f64, f64, f64)) -> Self {
        let w = (x1 - x0).max(1e-6);
        let h = (y1 - y0).max(1e-6);
        let px_per_m = (f64::from(rect.width()) / w).min(f64::from(rect.height()) / h) * 0.96;
        Self { rect, center_m: [0.5 * (x0 + x1), 0.5 * (y0 + y1)], px_per_m }
    }

    pub fn to_screen(&self, x_m: f64, y_m: f64) -> Pos2 {
        let c = self.rect.center();
        Pos2::new(c.x + ((x_m - self.center_m[0]) * self.px_per_m) as f32, c.y - ((y_m - self.center_m[1]) * self.px_per_m) as f32)
    }

    pub fn to_world(&self, p: Pos2) -> [f64; 2] {
        let c = self.rect.center();
        [self.center_m[0] + f64::from(p.x - c.x) / self.px_per_m, self.center_m[1] - f64::from(p.y - c.y) / self.px_per_m]
    }

    pub fn len(&self, m: f64) -> f32 {
        (m * self.px_per_m) as f32
    }
}

/// Colour ramp (viridis-like) for t in [0, 1].
pub fn ramp(t: f64) -> Color32 {
    const STOPS: [[f32; 3]; 6] =
        [[68., 1., 84.], [65., 68., 135.], [42., 120., 142.], [34., 168., 132.], [122., 209., 81.], [253., 231., 37.]];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) as f32 } else { 0.0 };
    let x = t * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c: Vec<u8> = (0..3).map(|k| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])) as u8).collect();
    Color32::from_rgb(c[0], c[1], c[2])
}

/// Colour of the `rank`-th path (1-based).
fn rank_color(rank: usize) -> Color32 {
    const P: [Color32; 8] = [
        Color32::from_rgb(255, 200, 40),
        Color32::from_rgb(80, 200, 255),
        Color32::from_rgb(255, 120, 200),
        Color32::from_rgb(140, 255, 140),
        Color32::from_rgb(255, 150, 80),
        Color32::from_rgb(180, 150, 255),
        Color32::from_rgb(120, 230, 220),
        Color32::from_rgb(230, 230, 230),
    ];
    P[(rank.max(1) - 1) % P.len()]
}

pub(crate) fn occupancy_pixel(v: i8) -> Color32 {
    match CellClass::of(v) {
        CellClass::Free => Color32::from_rgb(235, 235, 228),
        CellClass::Lethal => Color32::from_rgb(30, 30, 34),
        CellClass::Unknown => Color32::from_rgb(UNKNOWN_RGB[0], UNKNOWN_RGB[1], UNKNOWN_RGB[2]),
    }
}

/// Image of a layer, top row first (grid row 0 is the bottom).
pub(crate) fn layer_image<T>(grid: &Grid<T>, pixel: impl Fn(&T) -> Color32) -> egui::ColorImage {
    let g = grid.geometry;
    let mut pixels = Vec::with_capacity(g.len());
    for row in (0..g.height).rev() {
        pixels.extend(grid.data[row * g.width..(row + 1) * g.width].iter().map(&pixel));
    }
    egui::ColorImage::new([g.width, g.height], pixels)
}

fn map_texture(ui: &egui::Ui, planner: &mut PlannerState, canvas: &mut CanvasState) -> Option<egui::TextureId> {
    let layer = planner.layer;
    let radius = planner.params.robot.radius_m;
    let (m, t) = planner.pipeline.occupancy_key()?;
    let key: TexKey = match layer {
        Layer::Score | Layer::Unknown => (layer, planner.revs.map, 0, 0, 0),
        Layer::Thresholded => (layer, m, t, 0, 0),
        Layer::Inflated => (layer, m, t, radius.to_bits(), 0),
    };
    if canvas.texture.as_ref().is_none_or(|(k, _)| *k != key) {
        let image = match layer {
            Layer::Score => layer_image(&planner.scene.map.score, |s| {
                let [r, g, b] = score_rgb(*s);
                Color32::from_rgb(r, g, b)
            }),
            Layer::Unknown => layer_image(&planner.scene.map.score, |s| {
                if s.is_nan() { Color32::from_rgb(150, 60, 170) } else { Color32::from_rgb(60, 60, 60) }
            }),
            Layer::Thresholded => layer_image(planner.pipeline.occupancy()?, |v| occupancy_pixel(*v)),
            Layer::Inflated => {
                let (g, _) = planner.pipeline.inflated(radius)?;
                layer_image::<i8>(g as &OccupancyGrid, |v| occupancy_pixel(*v))
            }
        };
        let max = ui.ctx().input(|i| i.max_texture_side);
        if image.size[0] > max || image.size[1] > max {
            return None;
        }
        let tex = ui.ctx().load_texture("fitslam-map", image, egui::TextureOptions::NEAREST);
        canvas.texture = Some((key, tex));
    }
    canvas.texture.as_ref().map(|(_, t)| t.id())
}

/// Pixel distance within which a candidate is under the pointer.
const PICK_PX: f32 = 10.0;

/// The candidate whose marker is nearest `p` within [`PICK_PX`].
fn pick_candidate(view: &View, d: &Decision, p: Pos2) -> Option<usize> {
    d.candidates
        .iter()
        .enumerate()
        .map(|(i, c)| (i, view.to_screen(c.x_m, c.y_m).distance(p)))
        .filter(|(_, dist)| *dist <= PICK_PX)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// Draws the canvas and handles its interaction: the robot is moved and turned in `planner`'s
/// scene, the hovered and selected candidates are set there; `canvas` keeps the view.
pub fn show(ui: &mut egui::Ui, planner: &mut PlannerState, canvas: &mut CanvasState, widget_rects: &mut WidgetRects) {
    let (response, painter) = ui.allocate_painter(ui.available_size(), Sense::click_and_drag());
    let rect = response.rect;
    widget_rects.insert("canvas", rect);
    painter.rect_filled(rect, 0.0, Color32::from_rgb(24, 24, 28));
    let g = planner.scene.map.geometry();
    let (x0, y0, x1, y1) = g.bounds_m();
    // Refit when asked, on the first frame, and when the canvas is resized (panels or messages
    // changed) as long as the user has not panned or zoomed since the last fit.
    let resized = canvas.rect.is_some_and(|r| r.size() != rect.size());
    if canvas.fit_requested || canvas.px_per_m <= 0.0 || canvas.rect.is_none() || (resized && !canvas.user_view) {
        canvas.user_view = false;
        let fitted = View::fit(rect, (x0, y0, x1, y1));
        canvas.px_per_m = fitted.px_per_m;
        canvas.center_m = fitted.center_m;
        canvas.fit_requested = false;
    }
    canvas.rect = Some(rect);

    // Zoom about the pointer.
    if let (true, Some(p)) = (response.hovered(), response.hover_pos()) {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0 {
            let before = View { rect, center_m: canvas.center_m, px_per_m: canvas.px_per_m }.to_world(p);
            canvas.px_per_m = (canvas.px_per_m * f64::from((scroll * 0.002).exp())).clamp(1.0, 5000.0);
            let after = View { rect, center_m: canvas.center_m, px_per_m: canvas.px_per_m }.to_world(p);
            canvas.center_m[0] += before[0] - after[0];
            canvas.center_m[1] += before[1] - after[1];
            canvas.user_view = true;
        }
    }
    let view = View { rect, center_m: canvas.center_m, px_per_m: canvas.px_per_m };

    // Robot handles (screen).
    let robot = planner.scene.robot;
    let robot_px = view.to_screen(robot.x_m, robot.y_m);
    let body_r = view.len(planner.params.robot.radius_m).max(7.0);
    let handle_len = body_r + 22.0;
    let handle_px = robot_px + Vec2::new(robot.yaw_rad.cos() as f32, -(robot.yaw_rad.sin() as f32)) * handle_len;
    widget_rects.insert("robot", Rect::from_center_size(robot_px, Vec2::splat(2.0 * body_r)));
    widget_rects.insert("robot_handle", Rect::from_center_size(handle_px, Vec2::splat(12.0)));

    // Interaction.
    if response.drag_started() {
        // Hit-test where the button went down, not where the drag was recognised.
        if let Some(p) = ui.input(|i| i.pointer.press_origin()).or(response.interact_pointer_pos()) {
            canvas.drag = if p.distance(handle_px) <= 9.0 {
                Drag::RotateRobot
            } else if p.distance(robot_px) <= body_r + 3.0 {
                Drag::MoveRobot
            } else {
                Drag::Pan
            };
        }
    }
    if response.dragged() {
        let delta = response.drag_delta();
        match canvas.drag {
            Drag::Pan => {
                canvas.center_m[0] -= f64::from(delta.x) / canvas.px_per_m;
                canvas.center_m[1] += f64::from(delta.y) / canvas.px_per_m;
                canvas.user_view = true;
            }
            Drag::MoveRobot => {
                if let Some(p) = response.interact_pointer_pos() {
                    let [x, y] = view.to_world(p);
                    if planner.scene.map.score.at_world(x, y).is_some() {
                        planner.scene.robot.x_m = x;
                        planner.scene.robot.y_m = y;
                        planner.layout_changed();
                    }
                }
            }
            Drag::RotateRobot => {
                if let Some(p) = response.interact_pointer_pos() {
                    let d = p - robot_px;
                    if d.length() > 2.0 {
                        planner.scene.robot.yaw_rad = fitslam_core::pose::wrap_tau(f64::from(-d.y).atan2(f64::from(d.x)));
                        planner.layout_changed();
                    }
                }
            }
            Drag::None => {}
        }
    }
    if response.drag_stopped() {
        if canvas.drag == Drag::MoveRobot {
            // Dropped on an obstacle or in the unknown: put the robot on the nearest cell the
            // planner can start from (free on the inflated grid).
            let radius = planner.params.robot.radius_m;
            let robot = planner.scene.robot;
            let snapped = planner
                .pipeline
                .inflated(radius)
                .and_then(|(grid, _)| crate::scene::nearest_pose(grid, robot, |v| CellClass::of(*v) == CellClass::Free));
            if let Some(p) = snapped.filter(|p| *p != robot) {
                planner.scene.robot = p;
                planner.layout_changed();
            }
        }
        canvas.drag = Drag::None;
    }

    // Map.
    if let Some(tex) = map_texture(ui, planner, canvas) {
        let r = Rect::from_two_pos(view.to_screen(x0, y1), view.to_screen(x1, y0));
        painter.image(tex, r, Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)), Color32::WHITE);
    } else {
        painter.text(rect.center(), Align2::CENTER_CENTER, "map too large for a texture", FontId::proportional(16.0), Color32::LIGHT_RED);
    }

    if planner.overlays.boundary {
        let pts: Vec<Pos2> = planner.scene.boundary.vertices_m.iter().map(|v| view.to_screen(v[0], v[1])).collect();
        if pts.len() >= 2 {
            painter.add(Shape::closed_line(pts, Stroke::new(1.5, Color32::from_rgb(255, 220, 0))));
        }
    }
    if planner.overlays.landmarks {
        draw_landmarks(&painter, &view, planner);
    }

    planner.hovered = None;
    // Picking first (it writes the state), then drawing with shared borrows only.
    let (mut hovered, mut selected) = (None, planner.selected);
    if let Some(d) = planner.pipeline.ok_decision() {
        if response.hovered()
            && canvas.drag == Drag::None
            && let Some(p) = response.hover_pos()
        {
            hovered = pick_candidate(&view, d, p);
        }
        if response.clicked()
            && let Some(p) = response.interact_pointer_pos()
        {
            selected = pick_candidate(&view, d, p);
        }
    }
    planner.hovered = hovered;
    planner.selected = selected;
    let mut rank_rects = Vec::new();
    if let Some(d) = planner.pipeline.ok_decision() {
        draw_decision(&painter, &view, planner, d);
        // Candidate positions for page scripts and tests (first 10 by rank).
        const NAMES: [&str; 10] = ["rank1", "rank2", "rank3", "rank4", "rank5", "rank6", "rank7", "rank8", "rank9", "rank10"];
        for (k, i) in d.ranking().into_iter().take(10).enumerate() {
            let c = &d.candidates[i];
            rank_rects.push((NAMES[k], Rect::from_center_size(view.to_screen(c.x_m, c.y_m), Vec2::splat(2.0 * PICK_PX))));
        }
    }
    widget_rects.extend(rank_rects);
    if let Some([x, y]) = planner.recorded_goal_m {
        let p = view.to_screen(x, y);
        crate::recording_view::draw_robot_choice(&painter, p);
        widget_rects.insert("robot_choice", egui::Rect::from_center_size(p, Vec2::splat(22.0)));
    }

    draw_robot(&painter, robot_px, body_r, handle_px, canvas.drag == Drag::RotateRobot);

    if let (Some(d), Some(i)) = (planner.pipeline.ok_decision(), planner.hovered)
        && let Some(c) = d.candidates.get(i)
    {
        response.clone().on_hover_ui_at_pointer(|ui| crate::summary::candidate_summary(ui, d, i, c));
    }
    if planner.hovered.is_some() {
        ui.ctx().set_cursor_icon(egui::CursorIcon::PointingHand);
    } else if matches!(canvas.drag, Drag::MoveRobot | Drag::RotateRobot) {
        ui.ctx().set_cursor_icon(egui::CursorIcon::Grabbing);
    }
    legend(&painter, rect, planner);
}

fn draw_landmarks(painter: &egui::Painter, view: &View, planner: &PlannerState) {
    let Some((z0, z1)) = planner.scene.landmark_z_range() else { return };
    let span = (z1 - z0).max(1e-9);
    let clip = view.rect.expand(4.0);
    for p in &planner.scene.landmarks.cloud.points {
        let s = view.to_screen(p.x, p.y);
        if clip.contains(s) {
            painter.circle_filled(s, 2.2, ramp((p.z - z0) / span));
        }
    }
}

/// A circular sector as a polygon (angles in world radians, counter-clockwise).
fn sector(view: &View, x: f64, y: f64, heading: f64, fov: f64, radius_m: f64) -> Vec<Pos2> {
    let n = ((fov.to_degrees() / 6.0).ceil() as usize).clamp(2, 60);
    let mut pts = Vec::with_capacity(n + 2);
    pts.push(view.to_screen(x, y));
    for k in 0..=n {
        let a = heading - 0.5 * fov + fov * k as f64 / n as f64;
        pts.push(view.to_screen(x + radius_m * a.cos(), y + radius_m * a.sin()));
    }
    pts
}

fn draw_decision(painter: &egui::Painter, view: &View, planner: &PlannerState, d: &Decision) {
    let res = planner.scene.map.geometry().resolution_m;
    let cell_px = view.len(res).max(2.0);
    let hfov = planner.params.camera.hfov_rad;
    let dmax = planner.params.camera.max_depth_m;
    let focus = planner.hovered.or(planner.selected).or(d.chosen);

    if planner.overlays.frontiers {
        for (i, c) in d.candidates.iter().enumerate() {
            let color = if c.dropped == Some(DropReason::NoPath) || matches!(c.dropped, Some(DropReason::Blacklisted(_))) {
                Color32::from_rgba_unmultiplied(200, 60, 60, 200)
            } else if i % 2 == 0 {
                Color32::from_rgba_unmultiplied(0, 200, 255, 200)
            } else {
                Color32::from_rgba_unmultiplied(255, 90, 230, 200)
            };
            let g = planner.scene.map.geometry();
            for cell in &c.cluster_cells {
                let (x, y) = g.center_of(*cell);
                painter.rect_filled(Rect::from_center_size(view.to_screen(x, y), Vec2::splat(cell_px)), 0.0, color);
            }
        }
    }

    // Paths, waypoints and frustums of the ranked candidates.
    if planner.overlays.paths || planner.overlays.frustums {
        let max_info = d.candidates.iter().flat_map(|c| c.waypoints.iter().map(|w| w.info)).fold(0.0f64, f64::max);
        let order = d.ranking();
        for &i in order.iter().rev() {
            let c = &d.candidates[i];
            if c.waypoints.is_empty() && d.chosen != Some(i) {
                continue;
            }
            let rank = c.rank.unwrap_or(99);
            let focused = focus == Some(i);
            let width = if d.chosen == Some(i) || focused { 3.0 } else { 1.6 };
            if planner.overlays.paths && c.path_m.len() >= 2 {
                let pts: Vec<Pos2> = c.path_m.iter().map(|p| view.to_screen(p[0], p[1])).collect();
                painter.add(Shape::line(pts, Stroke::new(width, rank_color(rank))));
            }
            for w in &c.waypoints {
                let t = if max_info > 0.0 { w.info / max_info } else { 0.0 };
                if planner.overlays.frustums {
                    let len = (0.35 * dmax).min(1.5);
                    let mut poly = sector(view, w.x_m, w.y_m, w.yaw_rad, hfov.min(std::f64::consts::PI * 1.9), len);
                    let c = ramp(t);
                    let fill = Color32::from_rgba_unmultiplied(c.r(), c.g(), c.b(), 90);
                    poly.push(poly[0]);
                    painter.add(Shape::convex_polygon(poly.clone(), fill, Stroke::NONE));
                    painter.add(Shape::line(poly, Stroke::new(1.0, c)));
                }
                if planner.overlays.paths {
                    painter.circle(view.to_screen(w.x_m, w.y_m), 3.5, ramp(t), Stroke::new(1.0, Color32::BLACK));
                }
            }
        }
    }

    // Rays and Θ* cones.
    let ray_max = d.candidates.iter().flat_map(|c| c.ray_gains_bits.iter().copied()).fold(0.0f64, f64::max);
    for (i, c) in d.candidates.iter().enumerate() {
        let ranked = c.rank.is_some();
        let show_rays = match planner.overlays.rays {
            RayMode::None => false,
            RayMode::Focused => focus == Some(i),
            RayMode::Ranked => ranked || focus == Some(i),
        };
        if show_rays {
            draw_rays(painter, view, d, c, dmax, ray_max);
        }
        if (focus == Some(i) || (planner.overlays.all_cones && ranked))
            && let Some(th) = c.theta_star_rad
        {
            let poly = sector(view, c.x_m, c.y_m, th, hfov.min(std::f64::consts::TAU), dmax);
            let fill = Color32::from_rgba_unmultiplied(255, 255, 255, 28);
            // A sector over 180° is not convex: draw it as a fan of triangles.
            let apex = poly[0];
            for k in 1..poly.len() - 1 {
                painter.add(Shape::convex_polygon(vec![apex, poly[k], poly[k + 1]], fill, Stroke::NONE));
            }
            let mut outline = poly;
            outline.push(apex);
            painter.add(Shape::line(outline, Stroke::new(1.2, Color32::from_rgb(255, 255, 255))));
        }
    }

    if planner.overlays.candidates {
        for (i, c) in d.candidates.iter().enumerate() {
            draw_candidate(painter, view, d, i, c, focus == Some(i), planner.selected == Some(i));
        }
    }

    // The chosen goal pose.
    if let Some(goal) = d.goal {
        draw_goal(painter, view, goal);
    }
}

/// A goal pose: a gold ring with an arrow along its heading.
pub(crate) fn draw_goal(painter: &egui::Painter, view: &View, goal: fitslam_core::Pose2) {
    let p = view.to_screen(goal.x_m, goal.y_m);
    painter.circle_stroke(p, 13.0, Stroke::new(2.5, Color32::from_rgb(255, 215, 0)));
    let tip = p + Vec2::new(goal.yaw_rad.cos() as f32, -(goal.yaw_rad.sin() as f32)) * 26.0;
    painter.arrow(p, tip - p, Stroke::new(2.5, Color32::from_rgb(255, 215, 0)));
}

fn draw_rays(painter: &egui::Painter, view: &View, d: &Decision, c: &CandidateReport, dmax: f64, ray_max: f64) {
    let o = view.to_screen(c.x_m, c.y_m);
    for (a, g) in d.ray_angles_rad.iter().zip(&c.ray_gains_bits) {
        let t = if ray_max > 0.0 { g / ray_max } else { 0.0 };
        let end = view.to_screen(c.x_m + dmax * a.cos(), c.y_m + dmax * a.sin());
        let color = ramp(t);
        let alpha = (60.0 + 195.0 * t) as u8;
        painter.line_segment(
            [o, end],
            Stroke::new(1.0 + 1.5 * t as f32, Color32::from_rgba_unmultiplied(color.r(), color.g(), color.b(), alpha)),
        );
    }
}

pub(crate) fn draw_candidate(
    painter: &egui::Painter,
    view: &View,
    d: &Decision,
    i: usize,
    c: &CandidateReport,
    focused: bool,
    selected: bool,
) {
    let p = view.to_screen(c.x_m, c.y_m);
    let (fill, label) = match (c.rank, c.dropped) {
        (Some(r), _) => (if d.chosen == Some(i) { Color32::from_rgb(255, 215, 0) } else { rank_color(r) }, Some(r.to_string())),
        (None, Some(DropReason::NotInTopN)) => (Color32::from_rgb(120, 140, 170), None),
        (None, Some(DropReason::NoPath)) => (Color32::from_rgb(220, 60, 60), None),
        (None, Some(DropReason::Blacklisted(_))) => (Color32::from_rgb(130, 30, 30), None),
        (None, None) => (Color32::from_rgb(160, 160, 160), None),
    };
    let r = if c.rank.is_some() { 7.0 } else { 4.5 };
    painter.circle(p, r, fill, Stroke::new(if focused { 2.5 } else { 1.0 }, Color32::BLACK));
    if selected {
        painter.circle_stroke(p, r + 4.0, Stroke::new(2.0, Color32::WHITE));
    }
    if let Some(text) = label {
        let pos = p + Vec2::new(9.0, -9.0);
        painter.text(pos + Vec2::new(1.0, 1.0), Align2::LEFT_BOTTOM, &text, FontId::proportional(14.0), Color32::BLACK);
        painter.text(pos, Align2::LEFT_BOTTOM, &text, FontId::proportional(14.0), Color32::WHITE);
    }
}

/// The robot: a disc with a heading handle (gold while it is being rotated).
pub(crate) fn draw_robot(painter: &egui::Painter, p: Pos2, body_r: f32, handle: Pos2, rotating: bool) {
    let body = Color32::from_rgba_unmultiplied(40, 140, 255, 170);
    painter.circle(p, body_r, body, Stroke::new(2.0, Color32::WHITE));
    painter.line_segment([p, handle], Stroke::new(2.5, Color32::WHITE));
    let hc = if rotating { Color32::from_rgb(255, 215, 0) } else { Color32::from_rgb(255, 255, 255) };
    painter.circle(handle, 6.0, hc, Stroke::new(1.5, Color32::from_rgb(40, 140, 255)));
}

fn legend(painter: &egui::Painter, rect: Rect, planner: &PlannerState) {
    let mut y = rect.top() + 8.0;
    let x = rect.left() + 8.0;
    let line = |text: String, y: &mut f32| {
        painter.text(Pos2::new(x, *y), Align2::LEFT_TOP, text, FontId::proportional(12.0), Color32::from_gray(220));
        *y += 15.0;
    };
    line(format!("layer: {} · strategy: {:?}", planner.layer.label(), planner.params.selector.strategy), &mut y);
    match planner.pipeline.decision() {
        Some(Ok(d)) => line(
            match d.chosen_candidate() {
                Some(c) => format!(
                    "{}  ·  goal ({:.2}, {:.2}) m, Θ* {:.0}°",
                    export::digest(d, 3),
                    c.x_m,
                    c.y_m,
                    c.theta_star_rad.unwrap_or(0.0).to_degrees()
                ),
                None => format!("no goal: {} candidates, none reachable and not blacklisted", d.candidates.len()),
            },
            &mut y,
        ),
        Some(Err(e)) => {
            painter.text(
                Pos2::new(x, y),
                Align2::LEFT_TOP,
                format!("no decision: {e}"),
                FontId::proportional(13.0),
                Color32::from_rgb(255, 120, 110),
            );
        }
        None => {}
    }
    // Gain colour bar.
    let bar = Rect::from_min_size(Pos2::new(rect.right() - 170.0, rect.top() + 10.0), Vec2::new(120.0, 8.0));
    for k in 0..60 {
        let t = k as f64 / 59.0;
        let r = Rect::from_min_size(
            Pos2::new(bar.left() + bar.width() * k as f32 / 60.0, bar.top()),
            Vec2::new(bar.width() / 60.0 + 0.5, bar.height()),
        );
        painter.rect_filled(r, 0.0, ramp(t));
    }
    painter.text(Pos2::new(bar.left(), bar.bottom() + 2.0), Align2::LEFT_TOP, "low", FontId::proportional(11.0), Color32::from_gray(200));
    painter.text(
        Pos2::new(bar.right(), bar.bottom() + 2.0),
        Align2::RIGHT_TOP,
        "high",
        FontId::proportional(11.0),
        Color32::from_gray(200),
    );
    painter.text(
        Pos2::new(bar.center().x, bar.bottom() + 14.0),
        Align2::CENTER_TOP,
        "ray gain · FIM · landmark z",
        FontId::proportional(11.0),
        Color32::from_gray(200),
    );
}
