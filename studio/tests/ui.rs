//! Headless UI tests (egui_kittest): the studio's widgets found by label and driven like a
//! user; assertions on the core's `Decision` the studio holds. Expected values come from the
//! definitions (e.g. α = 1 ranks by path length alone, so the nearest candidate must win), not
//! from recorded output.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use fitslam_core::Params;
use fitslam_core::params::Strategy;
use fitslam_core::select::Decision;
use fitslam_studio::StudioApp;
use fitslam_studio::files::{IncomingFile, Intent};

fn harness_with(asset: Option<&str>) -> Harness<'static, StudioApp> {
    let ctx = egui::Context::default();
    let app = StudioApp::new(&ctx, asset);
    Harness::builder().with_size(egui::vec2(1400.0, 900.0)).build_ui_state(|ui, app: &mut StudioApp| app.show(ui), app)
}

fn slider<'h>(h: &'h Harness<'_, StudioApp>, label: &'h str) -> egui_kittest::Node<'h> {
    h.get_by_role_and_label(egui::accesskit::Role::Slider, label)
}

fn decision(h: &Harness<'_, StudioApp>) -> Decision {
    h.state().planner.pipeline.ok_decision().cloned().expect("a decision")
}

/// Index of the scored candidate with the smallest ρ (ties by index).
fn nearest(d: &Decision) -> usize {
    (0..d.candidates.len())
        .filter(|&i| d.candidates[i].u1.is_some())
        .min_by(|&a, &b| d.candidates[a].rho_m.unwrap().total_cmp(&d.candidates[b].rho_m.unwrap()).then(a.cmp(&b)))
        .expect("a scored candidate")
}

#[test]
fn starts_with_a_decision_on_the_default_asset() {
    let h = harness_with(None);
    let app = h.state();
    assert_eq!(app.planner.scene.map.source, "jacksboro");
    let d = decision(&h);
    assert_eq!(d.strategy, Strategy::Fit);
    let chosen = d.chosen.expect("a goal is chosen");
    assert_eq!(d.candidates[chosen].rank, Some(1));
    assert!(d.ranking().len() >= 2, "several candidates ranked: {}", d.ranking().len());
    assert!(app.title().starts_with(&format!("fitslam: chosen={chosen} top=[({chosen},")), "{}", app.title());
    // The UI shows the parameters and the table.
    slider(&h, "α");
    slider(&h, "β");
    h.get_by_label("Candidates");
}

#[test]
fn every_builtin_asset_builds_and_decides() {
    for b in fitslam_studio::assets::builtins() {
        let mut scene = b.build(0.5).unwrap_or_else(|e| panic!("{}: {e}", b.name));
        assert!(scene.map.known_cells() > 0, "{}", b.name);
        assert!(!scene.landmarks.cloud.is_empty(), "{}", b.name);
        let mut p = fitslam_studio::pipeline::Pipeline::default();
        p.update(&scene, Default::default(), &Params::default(), &Default::default());
        let d = p.ok_decision().unwrap_or_else(|| panic!("{}: {:?}", b.name, p.decision()));
        assert!(d.chosen.is_some(), "{}: no goal", b.name);
        scene.robot.x_m += 0.0;
    }
}

#[test]
fn alpha_slider_reranks_towards_the_nearest_candidate() {
    let mut h = harness_with(None);
    let before = decision(&h);
    let computed = h.state().planner.pipeline.decisions_computed;
    // Switch u2 off so the u1 order is the final one, then α = 1: path length alone.
    slider(&h, "β").set_value_accesskit(1.0);
    h.run_ok();
    slider(&h, "α").set_value_accesskit(1.0);
    h.run_ok();
    assert_eq!(h.state().planner.params.u1.alpha, 1.0);
    assert_eq!(h.state().planner.params.u2.beta, 1.0);
    let after = decision(&h);
    assert!(h.state().planner.pipeline.decisions_computed >= computed + 2, "each slider change re-ranks");
    assert_eq!(after.chosen, Some(nearest(&after)), "α = 1 must choose the nearest candidate");
    assert_ne!(before.ranking(), after.ranking(), "the ranking changed");
    assert!(h.state().title().starts_with(&format!("fitslam: chosen={}", nearest(&after))));
    // α = 0: entropy alone — the chosen one has the largest ΔE among the scored.
    slider(&h, "α").set_value_accesskit(0.0);
    h.run_ok();
    let d = decision(&h);
    let best_de = d.candidates.iter().filter_map(|c| c.u1.and(c.delta_e_bits)).fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(d.candidates[d.chosen.unwrap()].delta_e_bits, Some(best_de));
}

#[test]
fn strategy_combo_switches_to_greedy() {
    let mut h = harness_with(None);
    h.get_by_label("strategy").click();
    h.run_ok();
    h.get_by_label("greedy (nearest)").click();
    h.run_ok();
    assert_eq!(h.state().planner.params.selector.strategy, Strategy::Greedy);
    let d = decision(&h);
    assert_eq!(d.strategy, Strategy::Greedy);
    assert_eq!(d.chosen, Some(nearest(&d)));
}

#[test]
fn tau_slider_changes_the_thresholded_map_and_the_decision() {
    let mut h = harness_with(Some("courtyard"));
    let lethal = |h: &Harness<'_, StudioApp>| h.state().planner.pipeline.occupancy().unwrap().data.iter().filter(|&&v| v == 100).count();
    let before_lethal = lethal(&h);
    let before = decision(&h);
    // The courtyard's rough patches score 0.3–0.7: τ = 0.75 makes them all lethal.
    slider(&h, "τ").set_value_accesskit(0.75);
    h.run_ok();
    assert_eq!(h.state().planner.params.traversability.tau, 0.75);
    assert!(lethal(&h) > before_lethal, "{} !> {before_lethal}", lethal(&h));
    let after = h.state().planner.pipeline.decision().cloned().unwrap();
    assert_ne!(Ok(before), after);
}

#[test]
fn changing_only_the_view_does_not_rerank() {
    let mut h = harness_with(None);
    let n = h.state().planner.pipeline.decisions_computed;
    h.get_by_label("View").click();
    h.run_ok();
    h.get_by_label("thresholded (τ)").click();
    h.run_ok();
    h.run_ok();
    assert_eq!(h.state().planner.layer, fitslam_studio::planner::Layer::Thresholded);
    assert_eq!(h.state().planner.pipeline.decisions_computed, n);
}

#[test]
fn table_sorts_by_rho_when_its_header_is_clicked() {
    let mut h = harness_with(None);
    h.get_by_label("ρ [m]").click();
    h.run_ok();
    let app = h.state();
    assert_eq!(app.table.column, fitslam_studio::panels::Column::Rho);
    let d = decision(&h);
    let rows = fitslam_studio::panels::sorted_rows(&d, app.table);
    let rhos: Vec<f64> = rows.iter().filter_map(|&i| d.candidates[i].rho_m).collect();
    assert!(rhos.windows(2).all(|w| w[0] <= w[1]), "{rhos:?}");
    // Clicking a row selects that candidate.
    let first = rows[0];
    h.get_by_label(&format!("#{first}")).click();
    h.run_ok();
    assert_eq!(h.state().planner.selected, Some(first));
}

#[test]
fn dragging_the_robot_moves_it_and_reranks() {
    let mut h = harness_with(None);
    let robot_rect = h.state().widget_rects["robot"];
    let start = robot_rect.center();
    let before = h.state().planner.scene.robot;
    let n = h.state().planner.pipeline.decisions_computed;
    h.drag_at(start);
    h.run_ok();
    for k in 1..=5 {
        h.hover_at(start + egui::vec2(8.0 * k as f32, -4.0 * k as f32));
        h.run_ok();
    }
    h.drop_at(start + egui::vec2(40.0, -20.0));
    h.run_ok();
    let after = h.state().planner.scene.robot;
    assert!(after.x_m > before.x_m && after.y_m > before.y_m, "{before:?} -> {after:?}");
    assert!(h.state().planner.pipeline.decisions_computed > n);
    assert_eq!(decision(&h).robot, after);
}

#[test]
fn rotating_handle_turns_the_robot() {
    let mut h = harness_with(None);
    let handle = h.state().widget_rects["robot_handle"].center();
    let robot = h.state().widget_rects["robot"].center();
    h.drag_at(handle);
    h.run_ok();
    // Move the handle straight above the robot: yaw π/2 (screen y is down).
    let target = robot + egui::vec2(0.0, -40.0);
    h.hover_at(handle.lerp(target, 0.5));
    h.run_ok();
    h.hover_at(target);
    h.run_ok();
    h.drop_at(target);
    h.run_ok();
    let yaw = h.state().planner.scene.robot.yaw_rad;
    assert!((yaw - std::f64::consts::FRAC_PI_2).abs() < 0.05, "yaw {yaw}");
}

#[test]
fn bad_files_give_messages_not_crashes() {
    let mut h = harness_with(None);
    let map_before = h.state().planner.scene.map.source.clone();
    let files = vec![
        IncomingFile {
            name: "broken.ply".into(),
            bytes: Ok(b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n".to_vec()),
            intent: Intent::Landmarks,
        },
        IncomingFile { name: "nonsense.yaml".into(), bytes: Ok(b"foo: [1, 2".to_vec()), intent: Intent::Any },
        IncomingFile { name: "picture.png".into(), bytes: Ok(b"\x89PNG\r\n\x1a\nnot really".to_vec()), intent: Intent::Any },
        IncomingFile { name: "notes.txt".into(), bytes: Ok(b"hello".to_vec()), intent: Intent::Any },
        IncomingFile { name: "gone.pcd".into(), bytes: Err("permission denied".into()), intent: Intent::Any },
    ];
    h.state_mut().load_files(files);
    h.run_ok();
    let app = h.state();
    assert_eq!(app.planner.scene.map.source, map_before, "the scene is untouched");
    let errors: Vec<&str> = app.messages.iter().filter(|m| m.error).map(|m| m.text.as_str()).collect();
    for name in ["broken.ply", "nonsense.yaml", "picture.png", "notes.txt", "gone.pcd"] {
        assert!(errors.iter().any(|e| e.contains(name)), "no message naming {name}: {errors:?}");
    }
    assert!(app.planner.pipeline.ok_decision().is_some());
}

#[test]
fn a_map_yaml_waits_for_its_image_then_loads_with_landmarks() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/maps/jacksboro/");
    let read = |f: &str| std::fs::read(format!("{dir}{f}")).unwrap();
    let mut h = harness_with(Some("courtyard"));
    // The web gives bare names: the YAML alone cannot find its image yet.
    h.state_mut().load_files(vec![IncomingFile { name: "map.yaml".into(), bytes: Ok(read("map.yaml")), intent: Intent::Any }]);
    h.run_ok();
    assert_eq!(h.state().planner.scene.map.source, "courtyard");
    h.state_mut().load_files(vec![
        IncomingFile { name: "map.pgm".into(), bytes: Ok(read("map.pgm")), intent: Intent::Any },
        IncomingFile { name: "landmarks.csv".into(), bytes: Ok(read("landmarks.csv")), intent: Intent::Landmarks },
    ]);
    h.run_ok();
    let app = h.state();
    assert_eq!(app.planner.scene.map.source, "map.yaml");
    assert_eq!(app.planner.scene.map.geometry().width, 400);
    assert_eq!(app.planner.scene.landmarks.source, "landmarks.csv");
    assert!(app.planner.pipeline.ok_decision().is_some_and(|d| d.chosen.is_some()), "{:?}", app.planner.pipeline.decision());
}

#[test]
fn a_dropped_cloud_asks_what_it_is() {
    let mut h = harness_with(Some("courtyard"));
    let ply = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/maps/jacksboro/landmarks.ply")).unwrap();
    h.state_mut().load_files(vec![IncomingFile { name: "lm.ply".into(), bytes: Ok(ply), intent: Intent::Any }]);
    h.run_ok();
    h.get_by_label("Landmarks (for u2)").click();
    h.run_ok();
    assert_eq!(h.state().planner.scene.landmarks.source, "lm.ply");
    assert_eq!(h.state().planner.scene.landmarks.cloud.len(), 1196);
}

#[test]
fn exports_carry_the_params_and_the_ranking() {
    let h = harness_with(None);
    let app = h.state();
    let yaml = app.planner.params.to_yaml();
    assert_eq!(*Params::from_yaml(&yaml, "p.yaml").unwrap(), app.planner.params);
    let d = decision(&h);
    let csv = fitslam_studio::export::ranking_csv(&d);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), d.candidates.len() + 1);
    let chosen = d.chosen.unwrap();
    assert!(lines[1].starts_with(&format!("{chosen},1,")), "{}", lines[1]);
    let json: serde_json::Value = serde_json::from_str(&fitslam_studio::export::ranking_json(&d, &app.planner.params, "m", "l")).unwrap();
    let ranking: Vec<usize> = json["ranking"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as usize).collect();
    assert_eq!(ranking, d.ranking());
    assert_eq!(json["decision"]["chosen"].as_u64(), Some(chosen as u64));
    assert_eq!(json["params"]["u1"]["alpha"].as_f64(), Some(0.35));
}

#[test]
fn tour_steps_set_alpha_and_restore_defaults() {
    let mut h = harness_with(None);
    h.get_by_label("Tour").click();
    h.run_ok();
    assert!(h.state().tour.open);
    for _ in 0..3 {
        h.get_by_label("Next >").click();
        h.run_ok();
    }
    // Step 4 shows α = 1 (path length only).
    assert_eq!(h.state().tour.step, 3);
    assert_eq!(h.state().planner.params.u1.alpha, 1.0);
    let d = decision(&h);
    assert_eq!(d.chosen, Some(nearest(&d)));
    h.get_by_label("Next >").click();
    h.run_ok();
    assert_eq!(h.state().planner.params, Params::default());
}

#[test]
fn native_file_browser_opens_a_map_and_reads_its_image_next_to_it() {
    let mut h = harness_with(Some("courtyard"));
    h.get_by_label("File").click();
    h.run_ok();
    h.get_by_label("Open map (YAML + PGM/PNG, PNG)…").click();
    h.run_ok();
    // Tests run in the studio crate's directory.
    let field = h.get_by_role_and_label(egui::accesskit::Role::TextInput, "File:");
    field.focus();
    h.run_ok();
    h.get_by_role_and_label(egui::accesskit::Role::TextInput, "File:").type_text("../assets/maps/jacksboro/map.yaml");
    h.run_ok();
    h.get_by_label("Open").click();
    h.run_ok();
    let app = h.state();
    assert_eq!(app.planner.scene.map.source, "map.yaml", "{:?}", app.messages);
    assert_eq!(app.planner.scene.map.geometry().width, 400);
    assert!(app.planner.pipeline.ok_decision().is_some());
}

#[test]
fn hazard_sliders_rescore_a_terrain_cloud_map() {
    // A 12° ramp, 3 m × 3 m, a point every 2 cm: its slope hazard is 12/35 at the default
    // maximum (score 0.66, free at τ = 0.5) and 12/15 with a 15° maximum (score 0.2, lethal).
    let slope = 12f64.to_radians().tan();
    let mut csv = String::from("x,y,z\n");
    for i in 0..150 {
        for j in 0..150 {
            let (x, y) = (0.02 * f64::from(i), 0.02 * f64::from(j));
            csv.push_str(&format!("{x},{y},{}\n", slope * x));
        }
    }
    let mut h = harness_with(Some("courtyard"));
    h.state_mut().load_files(vec![IncomingFile { name: "ramp.csv".into(), bytes: Ok(csv.into_bytes()), intent: Intent::TerrainCloud }]);
    h.run_ok();
    assert_eq!(h.state().planner.scene.map.source, "ramp.csv");
    let mean_score = |h: &Harness<'_, StudioApp>| {
        let known: Vec<f32> = h.state().planner.scene.map.score.data.iter().copied().filter(|s| !s.is_nan()).collect();
        assert!(known.len() > 1000, "{} known cells", known.len());
        known.iter().sum::<f32>() / known.len() as f32
    };
    let lethal = |h: &Harness<'_, StudioApp>| h.state().planner.pipeline.occupancy().unwrap().data.iter().filter(|&&v| v == 100).count();
    let before = mean_score(&h);
    assert!((before - (1.0 - 12.0 / 35.0)).abs() < 0.05, "{before}");
    let lethal_before = lethal(&h);
    h.get_by_label("Terrain hazard").click();
    h.run_ok();
    slider(&h, "max slope [°]").set_value_accesskit(15.0);
    h.run_ok();
    h.run_ok();
    assert!((h.state().planner.params.traversability.max_slope_rad.to_degrees() - 15.0).abs() < 1e-9);
    let after = mean_score(&h);
    assert!((after - (1.0 - 12.0 / 15.0)).abs() < 0.05, "{after}");
    assert!(lethal(&h) > lethal_before, "{} !> {lethal_before}", lethal(&h));
}
