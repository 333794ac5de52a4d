//! Rerun logging (`--rerun-save FILE.rrd`, `--rerun-connect URL`): the map, the landmarks, the
//! candidates, the chosen path, the goal, the robot and the metrics, on a `time` timeline of
//! seconds since the node started.
//!
//! | entity | archetype | when |
//! |---|---|---|
//! | `map/occupancy` | Image (free white, lethal black, unknown grey; 1 px = 1 cell, +y up) | each new map, at a decision |
//! | `map/candidates`, `map/path`, `map/goal`, `map/robot` | Points2D / LineStrips2D in map pixels | each decision |
//! | `world/landmarks` | Points3D (map frame, metres) | each new landmark map, at a decision |
//! | `world/candidates`, `world/path`, `world/goal`, `world/robot` | Points3D / LineStrips3D | each decision |
//! | `metrics/*` | Scalars: decision time, candidates, ranked, blacklist, goals, known area | each status (1 Hz) |
//! | `log` | TextLog | every log line |

use crate::config::ConfigFile;
use crate::node::{ExplorerNode, Level, LogLine};
use crate::ros::Observer;
use fitslam_core::grid::{CellClass, GridGeometry};
use std::path::Path;
use thiserror::Error;

/// Why rerun logging could not start.
#[derive(Debug, Error)]
pub enum RerunError {
    #[error("rerun: {0}")]
    Rerun(String),
}

/// Logs the explorer to a rerun recording.
pub struct RerunLogger {
    rec: rerun::RecordingStream,
    maps_logged: u64,
    landmarks_logged: usize,
}

/// Map metres → image pixels (row 0 at the top, so +y is up in the viewer).
fn to_px(g: &GridGeometry, x_m: f64, y_m: f64) -> [f32; 2] {
    let u = (x_m - g.origin_x_m) / g.resolution_m;
    let v = g.height as f64 - (y_m - g.origin_y_m) / g.resolution_m;
    [u as f32, v as f32]
}

impl RerunLogger {
    /// Saves to `save` and/or streams to a viewer at `connect` (both may be given).
    pub fn new(save: Option<&Path>, connect: Option<&str>, cfg: &ConfigFile) -> Result<Self, RerunError> {
        let err = |e: &dyn std::fmt::Display| RerunError::Rerun(e.to_string());
        let builder = rerun::RecordingStreamBuilder::new("fitslam_robot");
        let rec = match (save, connect) {
            (Some(path), None) => builder.save(path).map_err(|e| err(&e))?,
            (None, Some(url)) => builder.connect_grpc_opts(url).map_err(|e| err(&e))?,
            (Some(path), Some(url)) => {
                let uri: rerun::external::re_uri::ProxyUri = url.parse().map_err(|e| err(&e))?;
                let file = rerun::sink::FileSink::new(path).map_err(|e| err(&e))?;
                builder.set_sinks((file, rerun::sink::GrpcSink::new(uri))).map_err(|e| err(&e))?
            }
            (None, None) => return Err(RerunError::Rerun("neither a file nor a viewer given".into())),
        };
        let _ = rec.log_static("config", &rerun::TextDocument::new(cfg.to_yaml()));
        Ok(Self { rec, maps_logged: 0, landmarks_logged: usize::MAX })
    }

    fn log_map(&mut self, e: &ExplorerNode) {
        let Some(map) = e.map() else { return };
        if e.stats().maps == self.maps_logged {
            return;
        }
        self.maps_logged = e.stats().maps;
        let g = map.geometry;
        let mut rgb = vec![0u8; g.width * g.height * 3];
        for row in 0..g.height {
            // Image row 0 is the top: the map's last row.
            let src = (g.height - 1 - row) * g.width;
            for col in 0..g.width {
                let v = match CellClass::of(map.data[src + col]) {
                    CellClass::Free => 255,
                    CellClass::Lethal => 0,
                    CellClass::Unknown => 128,
                };
                rgb[(row * g.width + col) * 3..][..3].fill(v);
            }
        }
        let _ = self.rec.log("map/occupancy", &rerun::Image::from_rgb24(rgb, [g.width as u32, g.height as u32]));
    }
}

impl Observer for RerunLogger {
    fn on_decision(&mut self, e: &ExplorerNode, now_s: f64) {
        self.rec.set_duration_secs("time", now_s);
        self.log_map(e);
        let pts = e.landmark_points();
        if pts.len() != self.landmarks_logged {
            self.landmarks_logged = pts.len();
            let p: Vec<[f32; 3]> = pts.iter().map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect();
            let _ = self.rec.log("world/landmarks", &rerun::Points3D::new(p).with_radii([0.03]).with_colors([[200, 120, 255]]));
        }
        let (Some(d), Some(map)) = (e.last_decision(), e.map()) else { return };
        let g = map.geometry;
        let color = |i: usize| -> [u8; 3] {
            let c = &d.candidates[i];
            if d.chosen == Some(i) {
                [30, 230, 60]
            } else if c.rank.is_some() {
                [255, 200, 30]
            } else if c.dropped.is_some() {
                [230, 30, 30]
            } else {
                [150, 150, 150]
            }
        };
        let colors: Vec<[u8; 3]> = (0..d.candidates.len()).map(color).collect();
        let px: Vec<[f32; 2]> = d.candidates.iter().map(|c| to_px(&g, c.x_m, c.y_m)).collect();
        let xyz: Vec<[f32; 3]> = d.candidates.iter().map(|c| [c.x_m as f32, c.y_m as f32, 0.05]).collect();
        let labels: Vec<String> = d
            .candidates
            .iter()
            .map(|c| match (c.rank, c.u2.or(c.u1)) {
                (Some(r), Some(u)) => format!("#{r} u={u:.2}"),
                _ => String::new(),
            })
            .collect();
        let _ = self.rec.log("map/candidates", &rerun::Points2D::new(px).with_colors(colors.clone()).with_radii([2.0]).with_labels(labels));
        let _ = self.rec.log("world/candidates", &rerun::Points3D::new(xyz).with_colors(colors).with_radii([0.12]));
        let path = d.chosen_candidate().map(|c| c.path_m.clone()).unwrap_or_default();
        let path_px: Vec<[f32; 2]> = path.iter().map(|p| to_px(&g, p[0], p[1])).collect();
        let path_xyz: Vec<[f32; 3]> = path.iter().map(|p| [p[0] as f32, p[1] as f32, 0.05]).collect();
        let _ = self.rec.log("map/path", &rerun::LineStrips2D::new([path_px]).with_colors([[30, 230, 60]]));
        let _ = self.rec.log("world/path", &rerun::LineStrips3D::new([path_xyz]).with_colors([[30, 230, 60]]).with_radii([0.03]));
        if let Some(goal) = e.shown_goal() {
            let (c, s) = (goal.yaw_rad.cos() as f32, goal.yaw_rad.sin() as f32);
            let _ = self.rec.log(
                "world/goal",
                &rerun::Arrows3D::from_vectors([[0.5 * c, 0.5 * s, 0.0]])
                    .with_origins([[goal.x_m as f32, goal.y_m as f32, 0.05]])
                    .with_colors([[30, 230, 60]]),
            );
            let _ = self
                .rec
                .log("map/goal", &rerun::Points2D::new([to_px(&g, goal.x_m, goal.y_m)]).with_radii([4.0]).with_colors([[30, 230, 60]]));
        }
        let r = d.robot;
        let _ = self
            .rec
            .log("world/robot", &rerun::Points3D::new([[r.x_m as f32, r.y_m as f32, 0.1]]).with_radii([0.2]).with_colors([[40, 120, 255]]));
        let _ = self.rec.log("map/robot", &rerun::Points2D::new([to_px(&g, r.x_m, r.y_m)]).with_radii([4.0]).with_colors([[40, 120, 255]]));
    }

    fn on_status(&mut self, e: &ExplorerNode, now_s: f64) {
        self.rec.set_duration_secs("time", now_s);
        let s = e.status(now_s);
        let known_m2 = e.map().map_or(0.0, |m| {
            let cell_m2 = m.geometry.resolution_m * m.geometry.resolution_m;
            m.data.iter().filter(|&&v| v >= 0).count() as f64 * cell_m2
        });
        for (name, v) in [
            ("metrics/decision_ms", s.stats.last_decision_ms),
            ("metrics/candidates", s.candidates as f64),
            ("metrics/ranked", s.ranked as f64),
            ("metrics/blacklisted", s.blacklisted as f64),
            ("metrics/goals_sent", s.stats.goals_sent as f64),
            ("metrics/goals_succeeded", s.stats.succeeded as f64),
            ("metrics/known_area_m2", known_m2),
        ] {
            let _ = self.rec.log(name, &rerun::Scalars::single(v));
        }
    }

    fn on_log(&mut self, lines: &[LogLine]) {
        for l in lines {
            self.rec.set_duration_secs("time", l.t_s);
            let level = match l.level {
                Level::Info => rerun::TextLogLevel::INFO,
                Level::Warn => rerun::TextLogLevel::WARN,
                Level::Error => rerun::TextLogLevel::ERROR,
            };
            let _ = self.rec.log("log", &rerun::TextLog::new(l.text.as_str()).with_level(level));
        }
    }
}

impl Drop for RerunLogger {
    fn drop(&mut self) {
        let _ = self.rec.flush_blocking();
    }
}
