//! What the studio tells the outside each frame: the window (or document) title digest, and in
//! the browser the ranking, the state and the widget positions for page scripts and the browser
//! test.

use super::*;

impl StudioApp {
    /// Window title / document title digest, and (web) the ranking for page scripts.
    pub(super) fn publish(&mut self, ctx: &egui::Context) {
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
}
