//! Headless UI tests of the Mission mode (egui_kittest): widgets found by label and clicked like
//! a user; assertions on the missions the studio runs (simulated time, metrics rows, the points
//! handed to the plots, decisions). The small `tiny_test` world keeps them fast.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use fitslam_core::params::Strategy;
use fitslam_studio::StudioApp;
use fitslam_studio::app::Mode;
use fitslam_studio::sim_runner::{RunState, SimRunner};

fn harness() -> Harness<'static, StudioApp> {
    let ctx = egui::Context::default();
    let mut app = StudioApp::new(&ctx, None);
    app.mission.config.world = "tiny_test".into();
    Harness::builder().with_size(egui::vec2(1400.0, 900.0)).build_ui_state(|ui, app: &mut StudioApp| app.show(ui), app)
}

fn runner<'h>(h: &'h Harness<'_, StudioApp>) -> &'h SimRunner {
    h.state().mission.runner.as_ref().expect("missions started")
}

/// A strategy's checkbox in the controls (the plots' legends have checkboxes with the same
/// labels, to the right).
fn strategy_checkbox<'h>(h: &'h Harness<'_, StudioApp>, label: &'h str) -> egui_kittest::Node<'h> {
    h.query_all_by_role_and_label(egui::accesskit::Role::CheckBox, label)
        .min_by(|a, b| a.rect().left().total_cmp(&b.rect().left()))
        .expect("a checkbox")
}

/// Opens the Mission mode by its label in the menu bar.
fn open_mission(h: &mut Harness<'_, StudioApp>) {
    h.get_by_label("Mission").click();
    h.run_ok();
    assert_eq!(h.state().mode, Mode::Mission);
    assert_eq!(runner(h).config.world, "tiny_test");
}

#[test]
fn play_advances_time_and_fills_the_plots() {
    let mut h = harness();
    open_mission(&mut h);
    let r = runner(&h);
    let strategies: Vec<Strategy> = r.lanes.iter().map(|l| l.strategy).collect();
    assert_eq!(strategies, vec![Strategy::Fit, Strategy::Greedy, Strategy::Random], "default: three lanes");
    assert_eq!(r.time_s(), 0.0);
    // Only the row at t = 0 so far: one point per lane and plot.
    assert_eq!(h.state().mission.plot_points, 2 * 3);

    h.get_by_label("Step tick").click();
    h.run_ok();
    assert!(runner(&h).lanes.iter().all(|l| (l.mission.time_s() - 0.1).abs() < 1e-9), "one tick is 0.1 s");

    h.get_by_label("Play").click();
    for _ in 0..8 {
        h.step();
    }
    let r = runner(&h);
    assert_eq!(r.state, RunState::Playing);
    let t = r.time_s();
    assert!(t > 0.1, "simulated time advanced while playing: {t}");
    for l in &r.lanes {
        assert!((l.mission.time_s() - t).abs() < 0.15, "lanes in lockstep: {} vs {t}", l.mission.time_s());
    }
    // Rows come once per simulated second; the plots show every row of every lane (+ "now").
    let rows: usize = r.lanes.iter().map(|l| l.mission.rows().len()).sum();
    assert!(rows > 3, "rows recorded: {rows}");
    h.step();
    let points = h.state().mission.plot_points;
    let rows: usize = runner(&h).lanes.iter().map(|l| l.mission.rows().len()).sum();
    assert!(points >= 2 * rows, "plots got {points} points for {rows} rows");
    // The lanes' maps are drawn and published.
    assert!(h.state().widget_rects.contains_key("mission_lane2"));

    h.get_by_label("Pause").click();
    h.run_ok();
    let paused_at = runner(&h).time_s();
    for _ in 0..3 {
        h.step();
    }
    assert_eq!(runner(&h).state, RunState::Paused);
    assert_eq!(runner(&h).time_s(), paused_at, "paused: time stands still");
}

#[test]
fn step_decision_runs_each_lane_to_its_next_decision() {
    let mut h = harness();
    open_mission(&mut h);
    let before: Vec<u64> = runner(&h).lanes.iter().map(|l| l.decisions).collect();
    h.get_by_label("Step decision").click();
    for _ in 0..200 {
        h.step();
        if runner(&h).state == RunState::Paused {
            break;
        }
    }
    let r = runner(&h);
    assert_eq!(r.state, RunState::Paused);
    for (l, b) in r.lanes.iter().zip(before) {
        assert_eq!(l.decisions, b + 1, "{:?}", l.strategy);
        assert!(l.mission.last_decision().is_some());
    }
}

#[test]
fn strategy_checkboxes_apply_on_reset_and_a_lane_opens_in_the_planner() {
    let mut h = harness();
    open_mission(&mut h);
    strategy_checkbox(&h, "random").click();
    h.run_ok();
    strategy_checkbox(&h, "greedy").click();
    h.run_ok();
    assert_eq!(runner(&h).lanes.len(), 3, "not applied before Reset");
    h.get_by_label("Reset").click();
    h.run_ok();
    assert_eq!(runner(&h).lanes.iter().map(|l| l.strategy).collect::<Vec<_>>(), vec![Strategy::Fit]);

    // Run to the first goal, then load that state into the planner.
    h.get_by_label("Step decision").click();
    for _ in 0..200 {
        h.step();
        if runner(&h).state == RunState::Paused {
            break;
        }
    }
    let est = runner(&h).lanes[0].mission.estimate();
    h.get_by_label("open in planner").click();
    h.run_ok();
    let app = h.state();
    assert_eq!(app.mode, Mode::Planner);
    assert!(app.planner.scene.map.source.starts_with("tiny_test / fit at t = "), "{}", app.planner.scene.map.source);
    assert_eq!(app.planner.scene.robot, est);
    assert_eq!(app.planner.params.selector.strategy, Strategy::Fit);
    let d = app.planner.pipeline.ok_decision().expect("the planner decides on the mission's map");
    assert!(!d.candidates.is_empty());
}

/// The simulator parameters typed into the Mission mode's text (as `--sim-params` reads them)
/// reach the missions at Reset; a wrong value is shown, naming its key, and runs nothing.
#[test]
fn simulator_parameters_typed_in_apply_at_reset_and_a_wrong_one_is_shown() {
    let mut h = harness();
    open_mission(&mut h);
    h.get_by_label("simulator parameters").click();
    h.run_ok();
    let text_box = |h: &mut Harness<'_, StudioApp>, text: &str| {
        h.get_by_role(egui::accesskit::Role::MultilineTextInput).focus();
        h.run_ok();
        h.get_by_role(egui::accesskit::Role::MultilineTextInput).type_text(text);
        h.run_ok();
        h.get_by_label("Reset").click();
        h.run_ok();
    };
    text_box(&mut h, "[explore]\ntight_inflations_m = [0.2, 0.1]");
    let p = runner(&h).config.mission_params().expect("valid text");
    assert_eq!(p.explore.tight_inflations_m, vec![0.2, 0.1]);
    assert_eq!(runner(&h).lanes[0].mission.mission_params().explore.tight_inflations_m, vec![0.2, 0.1]);
    assert!(h.state().mission.error.is_none());
    // Appended to the same table: a second key whose value is out of range.
    text_box(&mut h, "\ntrapped_radius_m = -1.0");
    assert!(h.state().mission.runner.is_none());
    let e = h.state().mission.error.clone().expect("an error");
    assert!(e.contains("simulator parameters") && e.contains("trapped_radius_m"), "{e}");
    assert!(h.query_all_by_label_contains("trapped_radius_m must be").count() >= 1, "the error is on screen");
}
