//! Headless UI tests (egui_kittest): the studio's widgets found by label, driven like a user.

use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use fitslam_studio::StudioApp;

fn harness() -> Harness<'static, StudioApp> {
    let ctx = egui::Context::default();
    let app = StudioApp::new(&ctx, None);
    Harness::builder().with_size(egui::vec2(1400.0, 900.0)).build_ui_state(|ui, app: &mut StudioApp| app.show(ui), app)
}

#[test]
fn starts_with_a_decision_on_the_builtin_asset() {
    let h = harness();
    let app = h.state();
    let d = app.pipeline.ok_decision().expect("a decision on start");
    assert!(d.chosen.is_some(), "a goal is chosen");
    assert!(d.ranking().len() >= 2, "several candidates ranked: {}", d.ranking().len());
    assert!(app.title().starts_with("fitslam: chosen="), "{}", app.title());
}

#[test]
fn dump_tree() {
    let h = harness();
    let n = h.get_by_label("α");
    println!("{:?} value={:?}", n, n.value());
}

#[test]
fn glyphs_probe() {
    let ctx = egui::Context::default();
    let mut out = ctx.run_ui(egui::RawInput::default(), |_ui| {});
    out.textures_delta.clear();
    let chars = "§°·×ΔΘΦαβγθρστ–—…→↔−≥⏶⏷▶◀★✖⬆📁⭐⏴⏵";
    ctx.fonts_mut(|f| {
        for c in chars.chars() {
            println!("{c} {}", f.has_glyph(&egui::FontId::proportional(14.0), c));
        }
    });
}
