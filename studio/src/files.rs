//! Getting bytes in and out of the studio, natively and in the browser.
//!
//! In: files dropped on the window (both), the browser's file picker (web), an in-app file
//! browser (native: plain egui over `std::fs`, no system dialog needed). Every file arrives in the
//! [`Inbox`] as a name plus bytes (or a read error), and the app turns it into scene parts with
//! [`crate::loader`]. Out: [`save`] downloads a file in the browser and writes it natively.

use std::sync::{Arc, Mutex};

/// A file handed to the studio: its name (a path natively) and its bytes, or why it could not
/// be read.
#[derive(Clone, Debug)]
pub struct IncomingFile {
    pub name: String,
    pub bytes: Result<Vec<u8>, String>,
    /// What the user asked for when picking it (drops carry no intent).
    pub intent: Intent,
}

/// What a picked file is meant to be, when the user said so.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Intent {
    /// Decide from the extension (clouds: ask).
    #[default]
    Any,
    /// A map (YAML + image, PNG, PGM).
    Map,
    /// A landmark set (PCD, PLY, CSV, LAS).
    Landmarks,
    /// A terrain cloud to compute a traversability map from.
    TerrainCloud,
    /// A parameter file (YAML, TOML).
    Params,
    /// A recorded mission (rosbag2 MCAP).
    Recording,
}

/// Files waiting to be loaded; filled by async readers on the web, drained once per frame.
#[derive(Clone, Debug, Default)]
pub struct Inbox(Arc<Mutex<Vec<IncomingFile>>>);

impl Inbox {
    pub fn push(&self, file: IncomingFile) {
        self.push_all(vec![file]);
    }

    /// Queues files that belong together (one drop, one picker selection) under one lock, so
    /// a frame never drains half of them.
    pub fn push_all(&self, files: Vec<IncomingFile>) {
        if let Ok(mut v) = self.0.lock() {
            v.extend(files);
        }
    }

    /// Takes every file received so far.
    pub fn drain(&self) -> Vec<IncomingFile> {
        self.0.lock().map(|mut v| std::mem::take(&mut *v)).unwrap_or_default()
    }

    /// Queues the files dropped on the window this frame (read asynchronously on the web).
    pub fn take_dropped(&self, ctx: &egui::Context) {
        let dropped = ctx.input_mut(|i| std::mem::take(&mut i.raw.dropped_files));
        if dropped.is_empty() {
            return;
        }
        #[cfg(not(target_arch = "wasm32"))]
        {
            let _ = ctx;
            let batch = dropped.into_iter().map(|file| IncomingFile {
                name: file.path().to_string_lossy().into_owned(),
                bytes: file.bytes(),
                intent: Intent::Any,
            });
            self.push_all(batch.collect());
        }
        #[cfg(target_arch = "wasm32")]
        {
            // One task reads the whole drop and queues it at once (see `push_all`).
            let inbox = self.clone();
            let ctx = ctx.clone();
            wasm_bindgen_futures::spawn_local(async move {
                let mut batch = Vec::with_capacity(dropped.len());
                for file in dropped {
                    let name = file.path().file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                    let bytes = file.bytes_async().await;
                    batch.push(IncomingFile { name, bytes, intent: Intent::Any });
                }
                inbox.push_all(batch);
                ctx.request_repaint();
            });
        }
    }
}

/// The last path component of a name ("a/b/map.pgm" → "map.pgm").
pub fn base_name(name: &str) -> &str {
    name.rsplit(['/', '\\']).next().unwrap_or(name)
}

/// The extensions each intent accepts (lower case, without the dot).
pub fn extensions(intent: Intent) -> &'static [&'static str] {
    match intent {
        Intent::Any => &["yaml", "yml", "pgm", "png", "pcd", "ply", "csv", "las", "laz", "toml", "mcap"],
        Intent::Map => &["yaml", "yml", "pgm", "png"],
        Intent::Landmarks | Intent::TerrainCloud => &["pcd", "ply", "csv", "las", "laz"],
        Intent::Params => &["yaml", "yml", "toml"],
        Intent::Recording => &["mcap"],
    }
}

/// Saves `bytes` as `file_name`: a download in the browser; natively a file in the current
/// directory (the path is returned for the status line).
pub fn save(file_name: &str, mime: &str, bytes: &[u8]) -> Result<String, String> {
    #[cfg(target_arch = "wasm32")]
    {
        crate::browser::download(file_name, mime, bytes)?;
        Ok(file_name.to_string())
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = mime;
        let path = std::env::current_dir().map_err(|e| e.to_string())?.join(file_name);
        std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(path.display().to_string())
    }
}

/// Opens the platform's way of choosing files: the browser's file picker on the web (files
/// arrive in `inbox`), the in-app browser natively (`browser` is opened).
pub fn open_picker(intent: Intent, inbox: &Inbox, ctx: &egui::Context, browser: &mut FileBrowser) {
    #[cfg(target_arch = "wasm32")]
    {
        let _ = browser;
        let (inbox, ctx) = (inbox.clone(), ctx.clone());
        crate::browser::pick_files(extensions(intent), move |batch| {
            inbox.push_all(batch.into_iter().map(|(name, bytes)| IncomingFile { name, bytes, intent }).collect());
            ctx.request_repaint();
        });
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = (inbox, ctx);
        browser.open(intent);
    }
}

/// A minimal native file browser drawn with egui: a directory listing filtered by extension,
/// a path field, Open / Cancel. (The web uses the browser's own picker.)
#[derive(Debug, Default)]
pub struct FileBrowser {
    open: bool,
    intent: Intent,
    dir: std::path::PathBuf,
    path_text: String,
    entries: Vec<(String, bool)>,
    error: Option<String>,
}

impl FileBrowser {
    pub fn is_open(&self) -> bool {
        self.open
    }

    pub fn open(&mut self, intent: Intent) {
        self.open = true;
        self.intent = intent;
        if self.dir.as_os_str().is_empty() {
            self.dir = std::env::current_dir().unwrap_or_default();
        }
        self.refresh();
    }

    fn refresh(&mut self) {
        self.entries.clear();
        self.error = None;
        match std::fs::read_dir(&self.dir) {
            Ok(rd) => {
                let exts = extensions(self.intent);
                for e in rd.flatten() {
                    let name = e.file_name().to_string_lossy().into_owned();
                    let is_dir = e.file_type().map(|t| t.is_dir()).unwrap_or(false);
                    let ext_ok = name.rsplit_once('.').is_some_and(|(_, x)| exts.contains(&x.to_ascii_lowercase().as_str()));
                    if (is_dir || ext_ok) && !name.starts_with('.') {
                        self.entries.push((name, is_dir));
                    }
                }
                self.entries.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
            }
            Err(e) => self.error = Some(format!("{}: {e}", self.dir.display())),
        }
    }

    /// Draws the browser window; chosen files (read with `std::fs`) go to `inbox`.
    pub fn show(&mut self, ctx: &egui::Context, inbox: &Inbox) {
        if !self.open {
            return;
        }
        let mut open = true;
        let mut chosen: Option<std::path::PathBuf> = None;
        let mut go_to: Option<std::path::PathBuf> = None;
        egui::Window::new("Open file").open(&mut open).default_size([460.0, 360.0]).show(ctx, |ui| {
            ui.horizontal(|ui| {
                if ui.button("Up").clicked() {
                    go_to = self.dir.parent().map(|p| p.to_path_buf());
                }
                ui.label(self.dir.display().to_string());
            });
            ui.label(format!("Showing: {}", extensions(self.intent).join(", ")));
            ui.separator();
            egui::ScrollArea::vertical().max_height(240.0).show(ui, |ui| {
                for (name, is_dir) in &self.entries {
                    let label = if *is_dir { format!("{name}/") } else { name.clone() };
                    let r = ui.selectable_label(self.path_text == *name, label);
                    if r.clicked() {
                        if *is_dir {
                            go_to = Some(self.dir.join(name));
                        } else {
                            self.path_text = name.clone();
                        }
                    }
                    if r.double_clicked() && !*is_dir {
                        chosen = Some(self.dir.join(name));
                    }
                }
            });
            if let Some(e) = &self.error {
                ui.colored_label(egui::Color32::LIGHT_RED, e);
            }
            ui.separator();
            ui.horizontal(|ui| {
                let label = ui.label("File:");
                ui.text_edit_singleline(&mut self.path_text).labelled_by(label.id);
                if ui.button("Open").clicked() && !self.path_text.is_empty() {
                    chosen = Some(self.dir.join(&self.path_text));
                }
            });
        });
        if let Some(dir) = go_to {
            self.dir = dir;
            self.path_text.clear();
            self.refresh();
        }
        if let Some(path) = chosen {
            if path.is_dir() {
                self.dir = path;
                self.path_text.clear();
                self.refresh();
            } else {
                let bytes = std::fs::read(&path).map_err(|e| e.to_string());
                inbox.push(IncomingFile { name: path.display().to_string(), bytes, intent: self.intent });
                open = false;
            }
        }
        self.open = open;
    }
}

/// Reads a companion file next to `name` natively (a map YAML's image); `None` on the web or
/// when `name` has no directory.
pub fn read_sibling(name: &str, sibling: &str) -> Option<(String, Result<Vec<u8>, String>)> {
    #[cfg(not(target_arch = "wasm32"))]
    {
        let base = std::path::Path::new(name).parent().filter(|p| !p.as_os_str().is_empty())?;
        let path = if std::path::Path::new(sibling).is_absolute() { std::path::PathBuf::from(sibling) } else { base.join(sibling) };
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()));
        Some((path.display().to_string(), bytes))
    }
    #[cfg(target_arch = "wasm32")]
    {
        let _ = (name, sibling);
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base_names() {
        assert_eq!(base_name("a/b/map.pgm"), "map.pgm");
        assert_eq!(base_name("C:\\maps\\m.yaml"), "m.yaml");
        assert_eq!(base_name("plain"), "plain");
    }
}
