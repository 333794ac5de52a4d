//! Native entry point: `cargo run -p fitslam-studio [-- <built-in asset name>]`.

#[cfg(not(target_arch = "wasm32"))]
fn main() -> eframe::Result<()> {
    let asset = std::env::args().nth(1);
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default().with_inner_size([1400.0, 900.0]).with_title("FIT-SLAM studio"),
        ..Default::default()
    };
    eframe::run_native(
        "FIT-SLAM studio",
        options,
        Box::new(move |cc| Ok(Box::new(fitslam_studio::StudioApp::new(&cc.egui_ctx, asset.as_deref())))),
    )
}

// The web build starts from `fitslam_studio::web::start` (see studio/web/index.html).
#[cfg(target_arch = "wasm32")]
fn main() {}
