//! The browser services the studio uses while it runs: the file picker, downloads, and
//! publishing the current state where a page script (or a test) can read it. They know nothing
//! of the studio's types: callers hand in what they need and get plain values back.

use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::*;

/// A file read in the browser: its name and its bytes, or why it could not be read.
pub type ReadFile = (String, Result<Vec<u8>, String>);

/// Opens the browser's file picker for files ending in one of `extensions` (lower case, no
/// dot); the chosen files are read and handed to `on_read` together, in one call.
pub fn pick_files(extensions: &[&str], on_read: impl Fn(Vec<ReadFile>) + Clone + 'static) {
    let Some(document) = web_sys::window().and_then(|w| w.document()) else { return };
    let Ok(input) = document.create_element("input").map(|e| e.unchecked_into::<web_sys::HtmlInputElement>()) else {
        return;
    };
    input.set_type("file");
    input.set_multiple(true);
    let accept: Vec<String> = extensions.iter().map(|e| format!(".{e}")).collect();
    input.set_accept(&accept.join(","));
    let _ = input.style().set_property("display", "none");
    let _ = document.body().map(|b| b.append_child(&input));
    let input_in_cb = input.clone();
    let on_change = Closure::<dyn FnMut(web_sys::Event)>::new(move |_e: web_sys::Event| {
        if let Some(files) = input_in_cb.files() {
            let files: Vec<web_sys::File> = (0..files.length()).filter_map(|i| files.get(i)).collect();
            let on_read = on_read.clone();
            // One task reads the whole selection and hands it over at once, so a map's YAML and
            // its image always reach the loader in the same batch.
            wasm_bindgen_futures::spawn_local(async move {
                let mut batch = Vec::with_capacity(files.len());
                for file in files {
                    let bytes = wasm_bindgen_futures::JsFuture::from(file.array_buffer())
                        .await
                        .map(|buf| js_sys::Uint8Array::new(&buf).to_vec())
                        .map_err(|e| format!("{e:?}"));
                    batch.push((file.name(), bytes));
                }
                on_read(batch);
            });
        }
        input_in_cb.remove();
    });
    input.set_onchange(Some(on_change.as_ref().unchecked_ref()));
    on_change.forget();
    input.click();
}

/// Offers `bytes` as a download named `file_name`.
pub fn download(file_name: &str, mime: &str, bytes: &[u8]) -> Result<(), String> {
    let err = |e: JsValue| format!("download failed: {e:?}");
    let document = web_sys::window().and_then(|w| w.document()).ok_or("no document")?;
    let parts = js_sys::Array::of1(&js_sys::Uint8Array::from(bytes));
    let opts = web_sys::BlobPropertyBag::new();
    opts.set_type(mime);
    let blob = web_sys::Blob::new_with_u8_array_sequence_and_options(&parts, &opts).map_err(err)?;
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
