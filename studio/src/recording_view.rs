//! The recording's timeline, above the Planner mode's canvas while a bag is open: the decision
//! instants as ticks on a strip spanning the bag (click to jump: to the tick under the pointer,
//! else to that time), previous / next decision, and what the robot chose at the instant beside
//! what the current parameters choose.

use crate::action::{Action, WidgetRects};
use crate::recording::Recording;
use egui::{Align2, Color32, FontId, Pos2, Sense, Stroke, Vec2};
use fitslam_core::explore::Action as Answer;

/// Colour of the robot's recorded choice (timeline and canvas).
pub const ROBOT_CHOICE: Color32 = Color32::from_rgb(255, 80, 255);

/// Ticks closer than this to the pointer are snapped to, pixels.
const SNAP_PX: f32 = 6.0;

/// The frontier goal of the explorer's answer (its candidate's cell centre), if it is a goal.
pub fn answer_goal_m(answer: Option<&Answer>) -> Option<[f64; 2]> {
    match answer? {
        Answer::Goal(plan) | Answer::Keep(plan) => Some([plan.goal.goal.x_m, plan.goal.goal.y_m]),
        _ => None,
    }
}

/// How far the explorer's goal on these parameters is from the robot's, metres (`None`: one of
/// them is missing).
pub fn choice_gap_m(rec: &Recording, answer: Option<&Answer>) -> Option<f64> {
    let robot = rec.robot_target()?;
    let [x, y] = answer_goal_m(answer)?;
    Some((x - robot[0]).hypot(y - robot[1]))
}

/// The explorer's answer in a few words.
fn describe(answer: Option<&Answer>) -> String {
    match answer {
        Some(Answer::Goal(plan) | Answer::Keep(plan)) => {
            let g = plan.goal.goal;
            let tight = if plan.tight { format!(", at the tight inflation {} m", plan.goal.inflation_m) } else { String::new() };
            format!("these parameters choose ({:.2}, {:.2}){tight}", g.x_m, g.y_m)
        }
        Some(Answer::Done(reason)) => format!("these parameters end the mission ({reason:?})"),
        Some(Answer::Wait(why)) => format!("these parameters wait ({why:?})"),
        Some(Answer::Recover { radius_m }) => format!("these parameters forget the map within {radius_m} m"),
        None => "these parameters choose no goal".to_string(),
    }
}

/// Draws the timeline; jumps, export and close are returned as actions.
pub fn show(ui: &mut egui::Ui, rec: &Recording, answer: Option<&Answer>, rects: &mut WidgetRects, actions: &mut Vec<Action>) {
    let duration = rec.duration_s();
    let index = rec.current_index();
    ui.horizontal(|ui| {
        ui.strong(crate::files::base_name(rec.name()));
        ui.label(format!(
            "t = {:.3} s of {duration:.3} s · decision {} of {}",
            rec.t_s,
            index.map_or_else(|| "-".to_string(), |k| (k + 1).to_string()),
            rec.instants().len()
        ));
        let prev = ui.add_enabled(rec.previous_instant_s().is_some(), egui::Button::new("< previous decision"));
        rects.insert("bag_prev", prev.rect);
        if prev.clicked()
            && let Some(t) = rec.previous_instant_s()
        {
            actions.push(Action::ShowInstant(t));
        }
        let next = ui.add_enabled(rec.next_instant_s().is_some(), egui::Button::new("next decision >"));
        rects.insert("bag_next", next.rect);
        if next.clicked()
            && let Some(t) = rec.next_instant_s()
        {
            actions.push(Action::ShowInstant(t));
        }
        if ui
            .button("Export scene")
            .on_hover_text("Map YAML + PGM, landmarks CSV and the `fitslam select` command line of this instant.")
            .clicked()
        {
            actions.push(Action::ExportScene);
        }
        if ui.button("Close").on_hover_text("Close the recording (the scene stays).").clicked() {
            actions.push(Action::CloseRecording);
        }
    });

    // The strip: the bag's span, decision ticks, the instant shown.
    let (response, painter) = ui.allocate_painter(Vec2::new(ui.available_width(), 22.0), Sense::click());
    let r = response.rect.shrink2(Vec2::new(8.0, 3.0));
    rects.insert("bag_timeline", r);
    let x_of = |t: f64| r.left() + r.width() * if duration > 0.0 { (t / duration) as f32 } else { 0.0 };
    painter.rect_filled(r, 3.0, Color32::from_gray(45));
    for i in rec.instants() {
        let x = x_of(i.t_s);
        painter.line_segment([Pos2::new(x, r.top()), Pos2::new(x, r.bottom())], Stroke::new(1.5, Color32::from_rgb(255, 170, 60)));
    }
    let x = x_of(rec.t_s);
    painter.line_segment([Pos2::new(x, r.top() - 2.0), Pos2::new(x, r.bottom() + 2.0)], Stroke::new(3.0, Color32::WHITE));
    if response.clicked()
        && let Some(p) = response.interact_pointer_pos()
    {
        let nearest = rec.instants().iter().map(|i| (i.t_s, (x_of(i.t_s) - p.x).abs())).min_by(|a, b| a.1.total_cmp(&b.1));
        let t = match nearest {
            Some((t, d)) if d <= SNAP_PX => t,
            _ => f64::from(((p.x - r.left()) / r.width().max(1.0)).clamp(0.0, 1.0)) * duration,
        };
        actions.push(Action::ShowInstant(t));
    }
    response.on_hover_text("Decision instants (orange); click one, or anywhere for that instant.");

    // The robot's choice against the re-ranking.
    ui.horizontal_wrapped(|ui| {
        match &rec.robot_choice {
            Some(c) => {
                let target = rec.robot_target().unwrap_or([c.goal.x_m, c.goal.y_m]);
                ui.colored_label(
                    ROBOT_CHOICE,
                    format!(
                        "robot chose ({:.2}, {:.2}) at {:.3} s{}",
                        target[0],
                        target[1],
                        c.t_s,
                        c.phase.map_or_else(String::new, |p| format!(" ({})", p.as_str()))
                    ),
                );
            }
            None => {
                ui.label("robot's choice: none recorded before this instant");
            }
        }
        ui.separator();
        if answer_goal_m(answer).is_some() {
            ui.colored_label(Color32::from_rgb(255, 215, 0), describe(answer));
        } else {
            ui.label(describe(answer));
        }
        if let Some(gap) = choice_gap_m(rec, answer) {
            ui.separator();
            ui.label(if gap < 1e-6 { "the same goal".to_string() } else { format!("{gap:.2} m apart") });
        }
    });
}

/// The robot's recorded choice on the canvas: a magenta diamond labelled "robot".
pub fn draw_robot_choice(painter: &egui::Painter, p: Pos2) {
    let d = 11.0;
    let pts = vec![p + Vec2::new(0.0, -d), p + Vec2::new(d, 0.0), p + Vec2::new(0.0, d), p + Vec2::new(-d, 0.0)];
    painter.add(egui::Shape::closed_line(pts, Stroke::new(2.5, ROBOT_CHOICE)));
    let at = p + Vec2::new(-13.0, 13.0);
    painter.text(at + Vec2::new(1.0, 1.0), Align2::RIGHT_TOP, "robot", FontId::proportional(12.0), Color32::BLACK);
    painter.text(at, Align2::RIGHT_TOP, "robot", FontId::proportional(12.0), ROBOT_CHOICE);
}
