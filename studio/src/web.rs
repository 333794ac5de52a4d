//! The browser entry points: [`start`] runs the studio in a page's canvas, [`run_mission`] runs
//! a whole mission for page scripts. The browser services the studio uses while it runs (file
//! picker, downloads, publishing its state) are in [`crate::browser`].

use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::*;

/// Starts the studio in the canvas with id `canvas_id`. The built-in asset to show first can be
/// chosen with the page's `?asset=<name>` query.
#[wasm_bindgen]
pub async fn start(canvas_id: String) -> Result<(), JsValue> {
    let document = web_sys::window().and_then(|w| w.document()).ok_or("no document")?;
    let canvas = document
        .get_element_by_id(&canvas_id)
        .ok_or_else(|| format!("no element with id {canvas_id}"))?
        .dyn_into::<web_sys::HtmlCanvasElement>()
        .map_err(|_| format!("{canvas_id} is not a canvas"))?;
    let asset = query_param("asset");
    let runner = eframe::WebRunner::new();
    let result = runner
        .start(
            canvas,
            eframe::WebOptions::default(),
            Box::new(move |cc| Ok(Box::new(crate::StudioApp::new(&cc.egui_ctx, asset.as_deref())))),
        )
        .await;
    // Keep the runner alive for the page's lifetime.
    std::mem::forget(runner);
    result
}

/// Runs one whole mission on a built-in world at once and returns its `metrics.csv`,
/// `trajectory_est.tum` and end as JSON (`sim_runner::run_to_end`). `strategy` and
/// `localisation` are the CLI's names (`fit`, `ground_truth` or `ground-truth`, …);
/// `sim_params_toml`, when given, is what `fitslam explore --sim-params` reads. Blocks the page
/// for the mission's length (seconds for the paper world with ground truth).
#[wasm_bindgen]
pub fn run_mission(world: &str, strategy: &str, seed: u64, localisation: &str, sim_params_toml: Option<String>) -> Result<String, JsValue> {
    // The CLI's names are serde's snake_case with '-' for '_'.
    let json_name = |s: &str| serde_json::Value::String(s.replace('-', "_")).to_string();
    let strategy = serde_json::from_str(&json_name(strategy)).map_err(|e| format!("strategy '{strategy}': {e}"))?;
    let localisation = serde_json::from_str(&json_name(localisation)).map_err(|e| format!("localisation '{localisation}': {e}"))?;
    let mission_params = match sim_params_toml {
        Some(text) => fitslam_core::sim::MissionParams::from_toml(&text, "sim_params_toml").map_err(|e| e.to_string())?,
        None => Default::default(),
    };
    let whole = crate::sim_runner::run_to_end(world, strategy, seed, localisation, mission_params)?;
    serde_json::to_string(&whole).map_err(|e| e.to_string().into())
}

fn query_param(key: &str) -> Option<String> {
    let search = web_sys::window()?.location().search().ok()?;
    web_sys::UrlSearchParams::new_with_str(&search).ok()?.get(key)
}
