//! The browser entry point and the few browser services the studio needs: the file picker,
//! downloads, and publishing the current ranking where a page script (or a test) can read it.

use crate::files::{Inbox, IncomingFile, Intent, extensions};
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
        None => fitslam_core::sim::MissionParams::default(),
    };
    let whole = crate::sim_runner::run_to_end(world, strategy, seed, localisation, mission_params)?;
    serde_json::to_string(&whole).map_err(|e| e.to_string().into())
}

fn query_param(key: &str) -> Option<String> {
    let search = web_sys::window()?.location().search().ok()?;
    web_sys::UrlSearchParams::new_with_str(&search).ok()?.get(key)
}

/// Opens the browser's file picker; chosen files are read and queued in `inbox`.
pub fn pick_files(intent: Intent, inbox: Inbox, ctx: egui::Context) {
    let Some(document) = web_sys::window().and_then(|w| w.document()) else { return };
    let Ok(input) = document.create_element("input").map(|e| e.unchecked_into::<web_sys::HtmlInputElement>()) else {
        return;
    };
    input.set_type("file");
    input.set_multiple(true);
    let accept: Vec<String> = extensions(intent).iter().map(|e| format!(".{e}")).collect();
    input.set_accept(&accept.join(","));
    let _ = input.style().set_property("display", "none");
    let _ = document.body().map(|b| b.append_child(&input));
    let input_in_cb = input.clone();
    let on_change = Closure::<dyn FnMut(web_sys::Event)>::new(move |_e: web_sys::Event| {
        if let Some(files) = input_in_cb.files() {
            let files: Vec<web_sys::File> = (0..files.length()).filter_map(|i| files.get(i)).collect();
            let (inbox, ctx) = (inbox.clone(), ctx.clone());
            // One task reads the whole selection and queues it at once, so a map's YAML and its
            // image always reach the loader in the same batch.
            wasm_bindgen_futures::spawn_local(async move {
                let mut batch = Vec::with_capacity(files.len());
                for file in files {
                    let bytes = wasm_bindgen_futures::JsFuture::from(file.array_buffer())
                        .await
                        .map(|buf| js_sys::Uint8Array::new(&buf).to_vec())
                        .map_err(|e| format!("{e:?}"));
                    batch.push(IncomingFile { name: file.name(), bytes, intent });
                }
                inbox.push_all(batch);
                ctx.request_repaint();
            });
        }
        input_in_cb.remove();
    });
    input.set_onchange(Some(on_change.as_ref().unchecked_ref()));
    on_change.forget();
    input.click();
}

/// Offers `text` as a download named `file_name`.
pub fn download(file_name: &str, mime: &str, text: &str) -> Result<(), String> {
    let err = |e: JsValue| format!("download failed: {e:?}");
    let document = web_sys::window().and_then(|w| w.document()).ok_or("no document")?;
    let parts = js_sys::Array::of1(&JsValue::from_str(text));
    let opts = web_sys::BlobPropertyBag::new();
    opts.set_type(mime);
    let blob = web_sys::Blob::new_with_str_sequence_and_options(&parts, &opts).map_err(err)?;
    let url = web_sys::Url::create_object_url_with_blob(&blob).map_err(err)?;
    let a = document.create_element("a").map_err(err)?.unchecked_into::<web_sys::HtmlAnchorElement>();
    a.set_href(&url);
    a.set_download(file_name);
    a.click();
    let _ = web_sys::Url::revoke_object_url(&url);
    Ok(())
}

/// Publishes the studio's state for page scripts and tests: `document.title` gets a short
/// digest, `window.fitslam` an object with `ranking` (JSON text), `stats` (JSON text) and
/// `widgets` (JSON text: rectangles of named widgets in CSS pixels).
pub fn publish(title: &str, ranking_json: &str, stats_json: &str, widgets_json: &str) {
    let Some(window) = web_sys::window() else { return };
    if let Some(document) = window.document()
        && document.title() != title
    {
        document.set_title(title);
    }
    let obj = js_sys::Object::new();
    let set = |k: &str, v: &str| {
        let _ = js_sys::Reflect::set(&obj, &JsValue::from_str(k), &JsValue::from_str(v));
    };
    set("ranking", ranking_json);
    set("stats", stats_json);
    set("widgets", widgets_json);
    let _ = js_sys::Reflect::set(&window, &JsValue::from_str("fitslam"), &obj);
}
