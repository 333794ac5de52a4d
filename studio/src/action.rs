//! What the views hand back to the app. A view draws and edits only the state it is given;
//! what reaches further (writing a file, loading a mission into the Planner mode) it returns as
//! an [`Action`], which the app applies once the view is drawn. The rectangles of named widgets
//! go to [`WidgetRects`] (published on the web for page scripts and tests).

use std::collections::BTreeMap;

/// A request from a view to the app.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Write the parameters as the robot node's YAML file.
    ExportParams,
    /// Write the ranking as JSON (`true`) or CSV.
    ExportRanking { json: bool },
    /// Load mission lane `i`'s current state into the Planner mode and switch to it.
    OpenLaneInPlanner(usize),
    /// Show the open recording at this instant, seconds from its start.
    ShowInstant(f64),
    /// Close the open recording (the scene stays).
    CloseRecording,
    /// Write the scene as files `fitslam select` reads.
    ExportScene,
}

/// Screen rectangles of named widgets this frame.
pub type WidgetRects = BTreeMap<&'static str, egui::Rect>;
