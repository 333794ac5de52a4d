//! Side panels: the parameter sliders, the focused candidate's details and the sortable
//! candidate table. They edit the parameters, the selection and the table's order, read the
//! core's `Decision`, and hand exports back to the app as [`Action`]s.

use crate::action::{Action, WidgetRects};
use crate::export::drop_text;
use crate::pipeline::Pipeline;
use crate::planner::PlannerState;
use crate::summary::{candidate_summary, fmt};
use fitslam_core::Params;
use fitslam_core::params::Validate;
use fitslam_core::params::{InfoNormalisation, Strategy};
use fitslam_core::select::{CandidateReport, Decision};

/// A slider over an `f64` field shown in another unit (degrees for radians); returns the
/// response so its rectangle can be published.
fn scaled_slider(
    ui: &mut egui::Ui,
    value: &mut f64,
    scale: f64,
    range: std::ops::RangeInclusive<f64>,
    text: &str,
    decimals: usize,
) -> egui::Response {
    let mut shown = *value * scale;
    let r = ui.add(egui::Slider::new(&mut shown, range).text(text).fixed_decimals(decimals));
    if r.changed() {
        *value = shown / scale;
    }
    r
}

/// The parameter panel: every tunable the issue lists, live.
pub fn params_panel(ui: &mut egui::Ui, p: &mut Params, widget_rects: &mut WidgetRects, actions: &mut Vec<Action>) {
    ui.heading("Parameters");
    ui.label("Changes re-rank at once.");
    ui.add_space(4.0);
    let deg = 180.0 / std::f64::consts::PI;
    let mut rects: Vec<(&'static str, egui::Rect)> = Vec::new();

    ui.label(egui::RichText::new("Strategy").strong());
    let strat = egui::ComboBox::from_label("strategy").selected_text(strategy_name(p.selector.strategy)).show_ui(ui, |ui| {
        for s in Strategy::ALL {
            ui.selectable_value(&mut p.selector.strategy, s, strategy_name(s));
        }
    });
    rects.push(("strategy", strat.response.rect));
    if matches!(p.selector.strategy, Strategy::Random | Strategy::Matched | Strategy::MatchedTop) {
        ui.horizontal(|ui| {
            let l = ui.label("seed");
            ui.add(egui::DragValue::new(&mut p.selector.seed)).labelled_by(l.id);
        });
    }

    ui.add_space(6.0);
    ui.label(egui::RichText::new("u1: path length vs entropy").strong());
    let r = ui
        .add(egui::Slider::new(&mut p.u1.alpha, 0.0..=1.0).text("α").fixed_decimals(2))
        .on_hover_text("α weights the path-length term ρ_min/ρ; 1 − α weights the entropy term ΔE/ΔE_max (paper 0.35).");
    rects.push(("alpha", r.rect));
    let r = scaled_slider(ui, &mut p.u1.delta_theta_rad, deg, 1.0..=45.0, "Δθ [°]", 1).on_hover_text("Angle between rays (paper 8.5°).");
    rects.push(("delta_theta", r.rect));
    let r = ui
        .add(egui::Slider::new(&mut p.u1.gamma, 0.9..=1.0).text("γ").fixed_decimals(3))
        .on_hover_text("Visibility decay per cell along a ray: an unknown cell N cells out gains 1 − H((1 + γ^N)/2) bits.");
    rects.push(("gamma", r.rect));
    let r = scaled_slider(ui, &mut p.camera.hfov_rad, deg, 10.0..=360.0, "Φ [°]", 0)
        .on_hover_text("Camera horizontal field of view: the Θ* window (D435: 87°).");
    rects.push(("hfov", r.rect));
    let r = ui
        .add(egui::Slider::new(&mut p.camera.max_depth_m, 0.5..=10.0).text("d_max [m]").fixed_decimals(2))
        .on_hover_text("Camera max depth: ray length in u1 and waypoint spacing in u2.");
    rects.push(("max_depth", r.rect));
    if p.camera.min_depth_m >= p.camera.max_depth_m {
        p.camera.min_depth_m = 0.5 * p.camera.max_depth_m;
    }

    ui.add_space(6.0);
    ui.label(egui::RichText::new("u2: landmark information").strong());
    let r = ui
        .add(egui::Slider::new(&mut p.u2.beta, 0.0..=1.0).text("β").fixed_decimals(2))
        .on_hover_text("β weights u1 in u2; 1 − β weights the path's landmark information I_p (paper 0.4).");
    rects.push(("beta", r.rect));
    let r = ui
        .add(egui::Slider::new(&mut p.u2.top_n, 1..=20).text("N"))
        .on_hover_text("How many of the best candidates by u1 are re-ranked by u2 (paper 7).");
    rects.push(("top_n", r.rect));
    let r = ui
        .add(egui::Slider::new(&mut p.u2.voxel_m, 0.05..=1.0).text("voxel [m]").fixed_decimals(2))
        .on_hover_text("Landmark voxel edge: each occupied voxel counts once (paper 0.25 m).");
    rects.push(("voxel", r.rect));
    ui.horizontal(|ui| {
        ui.label("I_p normalisation");
        ui.radio_value(&mut p.u2.normalisation, InfoNormalisation::Max, "max");
        ui.radio_value(&mut p.u2.normalisation, InfoNormalisation::Mean, "mean");
    });

    ui.add_space(6.0);
    ui.label(egui::RichText::new("Map").strong());
    let r = ui
        .add(egui::Slider::new(&mut p.traversability.tau, 0.0..=1.0).text("τ").fixed_decimals(2))
        .on_hover_text("Risk acceptance: cells with score ≥ τ are free, below are lethal.");
    rects.push(("tau", r.rect));
    let r = ui
        .add(egui::Slider::new(&mut p.robot.radius_m, 0.0..=1.0).text("inflation [m]").fixed_decimals(2))
        .on_hover_text("Robot radius lethal cells are inflated by for planning (LeoRover: 0.25 m).");
    rects.push(("inflation", r.rect));
    ui.checkbox(&mut p.planner.allow_unknown, "plan through unknown");
    egui::CollapsingHeader::new("Terrain hazard").default_open(false).show(ui, |ui| {
        ui.label("Re-scores a map made from a terrain cloud, and the mission worlds.");
        let t = &mut p.traversability;
        let r = scaled_slider(ui, &mut t.max_slope_rad, deg, 5.0..=90.0, "max slope [°]", 1)
            .on_hover_text("Slope at which the hazard reaches 1 (default 35°).");
        rects.push(("max_slope", r.rect));
        let r = ui
            .add(egui::Slider::new(&mut t.max_step_m, 0.01..=0.5).text("max step [m]").fixed_decimals(3))
            .on_hover_text("Height difference in the disc at which the hazard reaches 1 (default 0.15 m).");
        rects.push(("max_step", r.rect));
        let r = ui
            .add(egui::Slider::new(&mut t.max_roughness_m, 0.005..=0.2).text("max roughness [m]").fixed_decimals(3))
            .on_hover_text("RMS distance to the fitted plane at which the hazard reaches 1 (default 0.05 m).");
        rects.push(("max_roughness", r.rect));
        let r = ui
            .add(egui::Slider::new(&mut t.disc_radius_m, 0.05..=0.5).text("disc radius [m]").fixed_decimals(2))
            .on_hover_text("Radius of the disc of points fused per cell (default 0.15 m).");
        rects.push(("disc_radius", r.rect));
        let r = ui
            .add(egui::Slider::new(&mut t.min_points, 1..=50).text("min points"))
            .on_hover_text("Fewer points in the disc: the cell is unknown (default 5).");
        rects.push(("min_points", r.rect));
        let r = ui
            .add(egui::Slider::new(&mut t.noise_discount_sigmas, 0.0..=4.0).text("noise discount [σ]").fixed_decimals(1))
            .on_hover_text("Standard deviations of registration noise discounted from roughness and step (default 2).");
        rects.push(("noise_discount", r.rect));
        ui.checkbox(&mut t.step_relative_to_plane, "step from the fitted plane");
    });

    ui.add_space(8.0);
    ui.horizontal(|ui| {
        if ui.button("Paper defaults").clicked() {
            *p = Params::default();
        }
        if ui.button("Export YAML").on_hover_text("The robot node's parameter file (fitslam_core::Params)").clicked() {
            actions.push(Action::ExportParams);
        }
    });
    if let Err(e) = p.validate() {
        ui.colored_label(egui::Color32::from_rgb(255, 120, 110), e.to_string());
    }
    widget_rects.extend(rects);
}

pub fn strategy_name(s: Strategy) -> &'static str {
    match s {
        Strategy::Fit => "FIT-SLAM (u1, then u2)",
        Strategy::Greedy => "greedy (nearest)",
        Strategy::Random => "random",
        Strategy::U1 => "u1 only",
        Strategy::Matched => "random at FIT-SLAM's distance",
        Strategy::MatchedTop => "random among u1's N best at FIT-SLAM's distance",
        Strategy::U2Length => "u2 with path length for information",
        Strategy::U2Truth => "u2 with the share of views tracked on the true landmarks",
    }
}

/// Right panel: the focused candidate in full, with its waypoints.
pub fn details_panel(ui: &mut egui::Ui, planner: &PlannerState) {
    ui.heading("Candidate");
    let Some(result) = planner.pipeline.decision() else { return };
    let d = match result {
        Ok(d) => d,
        Err(e) => {
            ui.colored_label(egui::Color32::from_rgb(255, 120, 110), format!("No decision: {e}"));
            return;
        }
    };
    let focus = planner.hovered.or(planner.selected).or(d.chosen);
    let Some(i) = focus.filter(|&i| i < d.candidates.len()) else {
        ui.label(format!("{} candidates; none ranked. Move the robot or lower τ.", d.candidates.len()));
        return;
    };
    let c = &d.candidates[i];
    candidate_summary(ui, d, i, c);
    if !c.waypoints.is_empty() {
        ui.add_space(6.0);
        ui.label(egui::RichText::new("Waypoints (u2)").strong());
        egui::Grid::new("waypoints").striped(true).num_columns(4).show(ui, |ui| {
            ui.label("s [m]");
            ui.label("yaw [°]");
            ui.label("voxels");
            ui.label("I_w");
            ui.end_row();
            for w in &c.waypoints {
                ui.label(format!("{:.2}{}", w.arc_length_m, if w.is_goal { " (goal)" } else { "" }));
                ui.label(format!("{:.0}", w.yaw_rad.to_degrees()));
                ui.label(w.voxels_seen.to_string());
                ui.label(format!("{:.1}", w.info));
                ui.end_row();
            }
        });
    }
    ui.add_space(6.0);
    ui.label(format!(
        "Robot ({:.2}, {:.2}) m, yaw {:.0}°{}",
        d.robot.x_m,
        d.robot.y_m,
        d.robot.yaw_rad.to_degrees(),
        if d.start_snapped { " — start snapped to a free cell" } else { "" }
    ));
    ui.label(format!("{} candidates, {} ranked", d.candidates.len(), d.ranking().len()));
}

/// Sortable columns of the candidate table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Column {
    Index,
    Rank,
    Rho,
    DeltaE,
    ThetaStar,
    U1,
    Ip,
    U2,
}

impl Column {
    const ALL: [Column; 8] =
        [Column::Index, Column::Rank, Column::Rho, Column::DeltaE, Column::ThetaStar, Column::U1, Column::Ip, Column::U2];

    fn title(self) -> &'static str {
        match self {
            Column::Index => "#",
            Column::Rank => "rank",
            Column::Rho => "ρ [m]",
            Column::DeltaE => "ΔE [bits]",
            Column::ThetaStar => "Θ* [°]",
            Column::U1 => "u1",
            Column::Ip => "I_p",
            Column::U2 => "u2",
        }
    }

    fn key(self, i: usize, c: &CandidateReport) -> Option<f64> {
        match self {
            Column::Index => Some(i as f64),
            Column::Rank => c.rank.map(|r| r as f64),
            Column::Rho => c.rho_m,
            Column::DeltaE => c.delta_e_bits,
            Column::ThetaStar => c.theta_star_rad,
            Column::U1 => c.u1,
            Column::Ip => c.path_info,
            Column::U2 => c.u2,
        }
    }
}

/// Sort state of the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TableState {
    pub column: Column,
    pub descending: bool,
}

impl Default for TableState {
    fn default() -> Self {
        Self { column: Column::Rank, descending: false }
    }
}

/// Row order for `state`: missing values last, ties by index.
pub fn sorted_rows(d: &Decision, state: TableState) -> Vec<usize> {
    let mut rows: Vec<usize> = (0..d.candidates.len()).collect();
    rows.sort_by(|&a, &b| {
        let ka = state.column.key(a, &d.candidates[a]);
        let kb = state.column.key(b, &d.candidates[b]);
        match (ka, kb) {
            (Some(x), Some(y)) => {
                let o = x.total_cmp(&y);
                if state.descending { o.reverse() } else { o }
            }
            (Some(_), None) => std::cmp::Ordering::Less,
            (None, Some(_)) => std::cmp::Ordering::Greater,
            (None, None) => std::cmp::Ordering::Equal,
        }
        .then(a.cmp(&b))
    });
    rows
}

/// The candidate table: click a header to sort (again to reverse), a row to select.
pub fn candidate_table(
    ui: &mut egui::Ui,
    pipeline: &Pipeline,
    selected: &mut Option<usize>,
    table: &mut TableState,
    actions: &mut Vec<Action>,
) {
    let Some(Ok(d)) = pipeline.decision() else {
        ui.label("No ranking.");
        return;
    };
    let header = format!(
        "({} · strategy {} · score: {})",
        d.candidates.len(),
        strategy_name(d.strategy),
        match d.strategy {
            Strategy::Fit | Strategy::Matched | Strategy::MatchedTop | Strategy::U2Length | Strategy::U2Truth => "u2",
            Strategy::Greedy => "ρ",
            Strategy::U1 | Strategy::Random => "u1",
        }
    );
    ui.horizontal(|ui| {
        ui.label(egui::RichText::new("Candidates").strong());
        ui.label(header);
        if ui.small_button("CSV").on_hover_text("Export the ranking as CSV").clicked() {
            actions.push(Action::ExportRanking { json: false });
        }
        if ui.small_button("JSON").on_hover_text("Export the ranking as JSON").clicked() {
            actions.push(Action::ExportRanking { json: true });
        }
    });
    let rows = sorted_rows(d, *table);
    let mut new_sort = None;
    let mut new_sel = None;
    egui::ScrollArea::both().auto_shrink([false, false]).show(ui, |ui| {
        egui::Grid::new("candidates").striped(true).min_col_width(48.0).show(ui, |ui| {
            for col in Column::ALL {
                let arrow = if table.column == col { if table.descending { " v" } else { " ^" } } else { "" };
                if ui.button(format!("{}{arrow}", col.title())).clicked() {
                    new_sort = Some(col);
                }
            }
            ui.label("dropped");
            ui.end_row();
            for &i in &rows {
                let c = &d.candidates[i];
                let is_selected = *selected == Some(i);
                let chosen = if d.chosen == Some(i) { " (chosen)" } else { "" };
                if ui.selectable_label(is_selected, format!("#{i}")).clicked() {
                    new_sel = Some(if is_selected { None } else { Some(i) });
                }
                ui.label(c.rank.map(|r| format!("{r}{chosen}")).unwrap_or_else(|| "—".into()));
                ui.label(fmt(c.rho_m, 2));
                ui.label(fmt(c.delta_e_bits, 2));
                ui.label(fmt(c.theta_star_rad.map(f64::to_degrees), 0));
                ui.label(fmt(c.u1, 3));
                ui.label(fmt(c.path_info, 3));
                ui.label(fmt(c.u2, 3));
                ui.label(drop_text(c.dropped));
                ui.end_row();
            }
        });
    });
    if let Some(col) = new_sort {
        if table.column == col {
            table.descending = !table.descending;
        } else {
            *table = TableState { column: col, descending: matches!(col, Column::U1 | Column::U2 | Column::Ip | Column::DeltaE) };
        }
    }
    if let Some(sel) = new_sel {
        *selected = sel;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_core::{Cell, Pose2};

    #[test]
    fn rows_sort_by_column_with_missing_values_last() {
        let mut cs: Vec<CandidateReport> = (0..4).map(|i| CandidateReport::new(Cell::new(i, 0), f64::from(i), 0.0, vec![])).collect();
        cs[0].rho_m = Some(2.0);
        cs[1].rho_m = None;
        cs[2].rho_m = Some(1.0);
        cs[3].rho_m = Some(2.0);
        let d = Decision {
            strategy: Strategy::Fit,
            chosen: None,
            goal: None,
            robot: Pose2::new(0.0, 0.0, 0.0),
            robot_cell: Cell::new(0, 0),
            requested_robot_cell: Cell::new(0, 0),
            start_snapped: false,
            ray_angles_rad: vec![],
            candidates: cs,
        };
        assert_eq!(sorted_rows(&d, TableState { column: Column::Rho, descending: false }), vec![2, 0, 3, 1]);
        assert_eq!(sorted_rows(&d, TableState { column: Column::Rho, descending: true }), vec![0, 3, 2, 1]);
        assert_eq!(sorted_rows(&d, TableState { column: Column::Index, descending: true }), vec![3, 2, 1, 0]);
    }
}
