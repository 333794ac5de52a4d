//! The Mission mode's controls: world, strategies, seed, localisation, simulator parameters,
//! play / pause / step and speed.

use super::*;

/// Strategy checkboxes per row.
const STRATEGY_COLUMNS: usize = 4;

pub(super) fn controls(ui: &mut egui::Ui, m: &mut MissionView, params: &fitslam_core::Params, widget_rects: &mut WidgetRects) {
    let mut rects: Vec<(&'static str, Rect)> = Vec::new();
    ui.heading("Simulated mission");
    ui.label("One mission per strategy, same world and seed, side by side.");
    ui.add_space(4.0);

    let world = egui::ComboBox::from_label("world").selected_text(m.config.world.clone()).show_ui(ui, |ui| {
        for w in sim_runner::worlds() {
            ui.selectable_value(&mut m.config.world, w.name.to_string(), w.name).on_hover_text(w.description);
        }
    });
    rects.push(("mission_world", world.response.rect));
    ui.label("strategies:");
    // A fixed grid, not a wrapped row: the controls below keep their place whatever the panel's width.
    egui::Grid::new("mission_strategies").num_columns(STRATEGY_COLUMNS).show(ui, |ui| {
        const NAMES: [&str; Strategy::ALL.len()] = [
            "strategy_fit",
            "strategy_greedy",
            "strategy_random",
            "strategy_u1",
            "strategy_matched",
            "strategy_matched_top",
            "strategy_u2_length",
            "strategy_u2_truth",
        ];
        for (k, s) in Strategy::ALL.into_iter().enumerate() {
            let mut on = m.config.strategies.contains(&s);
            let r = ui.checkbox(&mut on, s.name());
            rects.push((NAMES[k], r.rect));
            if r.changed() {
                if on {
                    m.config.strategies.push(s);
                    m.config.strategies.sort_by_key(|x| Strategy::ALL.iter().position(|y| y == x));
                } else {
                    m.config.strategies.retain(|x| *x != s);
                }
            }
            if k % STRATEGY_COLUMNS == STRATEGY_COLUMNS - 1 {
                ui.end_row();
            }
        }
    });
    ui.horizontal(|ui| {
        let l = ui.label("seed");
        ui.add(egui::DragValue::new(&mut m.config.seed)).labelled_by(l.id);
    });
    let combo =
        egui::ComboBox::from_label("localisation").selected_text(sim_runner::localisation_label(m.config.localisation)).show_ui(ui, |ui| {
            const NAMES: [&str; 4] = ["localisation_ground_truth", "localisation_odometry", "localisation_slam", "localisation_pose_graph"];
            for (k, l) in Localisation::ALL.into_iter().enumerate() {
                let r = ui.selectable_value(&mut m.config.localisation, l, sim_runner::localisation_label(l));
                rects.push((NAMES[k], r.rect));
            }
        });
    rects.push(("mission_localisation", combo.response.rect));
    let slam = m.config.localisation == Localisation::Slam;
    let r = ui.add_enabled(slam, egui::Checkbox::new(&mut m.config.reproducible_slam, "same bits on every CPU")).on_hover_text(
        "For the batch SLAM solver (solver = \"batch\" under [slam.graph]): the reproducible (simplicial) factorisation, so \
         that the run is the same in the browser, natively and in `fitslam explore` with factorisation = \"reproducible\". \
         The default incremental solver (iSAM2) gives the same run everywhere without it.",
    );
    rects.push(("mission_reproducible", r.rect));
    let header = egui::CollapsingHeader::new("simulator parameters").default_open(false).show(ui, |ui| {
        ui.weak("TOML, as `fitslam explore --sim-params` reads it: keys left out keep their defaults (README, Parameters).");
        let hint = "tight_inflations_m = [0.20, 0.10]\n[lidar]\nmax_range_m = 8.0";
        let r = ui.add(egui::TextEdit::multiline(&mut m.config.sim_params_toml).code_editor().desired_rows(4).hint_text(hint));
        rects.push(("mission_sim_params", r.rect));
    });
    rects.push(("mission_sim_params_header", header.header_response.rect));
    let pending = m.runner.as_ref().is_none_or(|r| r.config != m.config);
    // Always one line, so that the buttons below do not move when a setting changes.
    if pending {
        ui.colored_label(Color32::from_rgb(255, 200, 120), "settings changed: press Reset to apply");
    } else {
        ui.weak("settings in use");
    }
    ui.label("Planner parameters: the Planner mode's, taken at Reset.")
        .on_hover_text("Tune α, β, τ … in the Planner mode, then Reset here to run missions with them.");

    ui.add_space(6.0);
    let state = m.runner.as_ref().map(|r| r.state);
    let finished = m.runner.as_ref().is_some_and(|r| r.finished());
    ui.horizontal_wrapped(|ui| {
        let playing = state == Some(RunState::Playing);
        let r = ui.add_enabled(!finished && !playing, egui::Button::new("Play"));
        rects.push(("mission_play", r.rect));
        if r.clicked()
            && let Some(run) = &mut m.runner
        {
            run.play();
        }
        let r = ui.add_enabled(state.is_some_and(|s| s != RunState::Paused), egui::Button::new("Pause"));
        rects.push(("mission_pause", r.rect));
        if r.clicked()
            && let Some(run) = &mut m.runner
        {
            run.pause();
        }
        let r =
            ui.add_enabled(!finished, egui::Button::new("Step tick")).on_hover_text("One control tick (0.1 s simulated) of every mission.");
        rects.push(("mission_step_tick", r.rect));
        if r.clicked()
            && let Some(run) = &mut m.runner
        {
            run.step_tick();
        }
        let r = ui
            .add_enabled(!finished, egui::Button::new("Step decision"))
            .on_hover_text("Run every mission until it has chosen its next goal, then pause.");
        rects.push(("mission_step_decision", r.rect));
        if r.clicked()
            && let Some(run) = &mut m.runner
        {
            run.step_decision();
        }
        let r = ui.button("Reset").on_hover_text("Restart from t = 0 with the settings above.");
        rects.push(("mission_reset", r.rect));
        if r.clicked() {
            m.restart(params);
        }
    });
    ui.add_space(4.0);
    ui.add_enabled_ui(!m.max_speed, |ui| {
        let r = ui.add(egui::Slider::new(&mut m.speed, 1.0..=500.0).logarithmic(true).text("speed [sim s / s]").fixed_decimals(0));
        rects.push(("mission_speed", r.rect));
    });
    let r = ui.checkbox(&mut m.max_speed, "as fast as possible");
    rects.push(("mission_max_speed", r.rect));
    ui.add(egui::Slider::new(&mut m.budget_ms, 2.0..=30.0).text("budget [ms / frame]").fixed_decimals(0))
        .on_hover_text("Simulation time allowed per frame; the rest draws. Larger is faster but less responsive.");
    if let Some(r) = &m.runner {
        let achieved = r.achieved_speed().map(|s| format!("{s:.1}×")).unwrap_or_else(|| "–".into());
        ui.label(format!(
            "t = {:.1} s · achieved {achieved} · {} ticks in {:.1} ms last frame",
            r.time_s(),
            r.last_frame_ticks,
            r.last_frame_ms
        ));
    }

    ui.add_space(6.0);
    ui.label(egui::RichText::new("View").strong());
    for l in MissionLayer::ALL {
        ui.radio_value(&mut m.layer, l, l.label());
    }
    ui.checkbox(&mut m.show_candidates, "last decision's candidates");
    if let Some(e) = &m.error {
        ui.colored_label(Color32::from_rgb(255, 120, 110), e);
    }
    widget_rects.extend(rects);
}
