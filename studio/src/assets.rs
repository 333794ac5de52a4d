//! Built-in scenes: embedded in the binary (the web build has no files), listed in the
//! "Built-in" menu. The first one is what the studio shows on start.
//!
//! | name | what |
//! |---|---|
//! | jacksboro | the realistic scene of `assets/maps/jacksboro` (real DEM, rocks, LiDAR-built map, landmarks); its score layer from `score.png` |
//! | courtyard | made here: graded traversability scores so that τ visibly changes the map |
//! | corridor | `fitslam_core::fixtures::corridor_two_frontiers`: greedy goes west, FIT-SLAM east |
//! | synthetic | `fitslam_core::fixtures::synthetic_world` (small, seed 1) |
//!
//! Embedded files are parsed by the same core loaders as user files; a test builds every one.

use crate::files::{IncomingFile, Intent};
use crate::loader::{self, Loaded};
use crate::scene::{Landmarks, MapKind, MapLayers, Scene};
use fitslam_core::fixtures;
use fitslam_core::grid::{Grid, GridGeometry};
use fitslam_core::sim::hash_unit;
use fitslam_core::{PointCloud, Pose2};
use nalgebra::Point3;

macro_rules! asset {
    ($path:literal) => {
        include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/maps/", $path))
    };
}

const JACKSBORO_YAML: &[u8] = asset!("jacksboro/map.yaml");
const JACKSBORO_PGM: &[u8] = asset!("jacksboro/map.pgm");
const JACKSBORO_LANDMARKS: &[u8] = asset!("jacksboro/landmarks.ply");
const JACKSBORO_SCENE: &[u8] = asset!("jacksboro/scene.toml");
const JACKSBORO_SCORE: &[u8] = asset!("jacksboro/score.png");

/// A built-in scene the user can pick.
#[derive(Clone, Copy, Debug)]
pub struct BuiltIn {
    /// Name shown in the menu (also accepted by `?asset=` on the web).
    pub name: &'static str,
    /// One line shown as a tooltip.
    pub description: &'static str,
    build: fn(blacklist_radius_m: f64) -> Result<Scene, String>,
}

impl BuiltIn {
    /// Builds the scene. Built-in data is checked by tests, so an error here is a bug in the
    /// asset, reported like any loading error.
    pub fn build(&self, blacklist_radius_m: f64) -> Result<Scene, String> {
        (self.build)(blacklist_radius_m)
    }
}

/// Every built-in scene; the first is the default.
pub fn builtins() -> &'static [BuiltIn] {
    &BUILTINS
}

/// Looks a built-in up by name (case-insensitive).
pub fn builtin(name: &str) -> Option<&'static BuiltIn> {
    BUILTINS.iter().find(|b| b.name.eq_ignore_ascii_case(name))
}

static BUILTINS: [BuiltIn; 4] = [
    BuiltIn {
        name: "jacksboro",
        description: "20 m × 20 m of a real DEM (Jacksboro fault) at rover scale, rocks, LiDAR-built traversability map, 1196 landmarks",
        build: jacksboro,
    },
    BuiltIn {
        name: "courtyard",
        description: "16 m × 12 m synthetic courtyard with graded scores (τ matters), 400 landmarks",
        build: synthetic_courtyard,
    },
    BuiltIn {
        name: "corridor",
        description: "core fixture: a corridor open at both ends, landmarks only to the east (greedy goes west, FIT-SLAM east)",
        build: corridor,
    },
    BuiltIn {
        name: "synthetic",
        description: "core fixture: 20 m × 20 m synthetic world at 0.1 m, 2000 landmarks (seed 1)",
        build: synthetic_small,
    },
];

fn file(name: &str, bytes: &[u8], intent: Intent) -> IncomingFile {
    IncomingFile { name: name.to_string(), bytes: Ok(bytes.to_vec()), intent }
}

/// The start pose written in a scene.toml (`start = [x, y, yaw]`).
fn start_pose(scene_toml: &[u8]) -> Option<Pose2> {
    let v: toml::Value = toml::from_str(std::str::from_utf8(fitslam_core::io::without_bom(scene_toml)).ok()?).ok()?;
    let s = v.get("start")?.as_array()?;
    let num = |k: usize| s.get(k).and_then(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64)));
    Some(Pose2::new(num(0)?, num(1)?, num(2).unwrap_or(0.0)))
}

fn jacksboro(blacklist_radius_m: f64) -> Result<Scene, String> {
    let files = vec![
        file("jacksboro/map.yaml", JACKSBORO_YAML, Intent::Map),
        file("jacksboro/map.pgm", JACKSBORO_PGM, Intent::Map),
        file("jacksboro/landmarks.ply", JACKSBORO_LANDMARKS, Intent::Landmarks),
    ];
    let (mut map, mut landmarks) = (None, None);
    for r in loader::load_batch(files, &mut loader::Pairing::default(), &fitslam_core::Params::default()) {
        match r? {
            Loaded::Map(m) => map = Some(m),
            Loaded::Landmarks(l) => landmarks = Some(l),
            other => return Err(format!("unexpected {other:?}")),
        }
    }
    let mut map = map.ok_or("jacksboro: no map")?;
    map.source = "jacksboro".into();
    // The traversability score the map was thresholded from, so that τ acts on this scene too.
    map.score = score_from_rgb_png(JACKSBORO_SCORE, map.geometry())?;
    map.kind = MapKind::Traversability;
    let mut landmarks = landmarks.ok_or("jacksboro: no landmarks")?;
    landmarks.source = "jacksboro landmarks".into();
    Ok(Scene::new(map, landmarks, start_pose(JACKSBORO_SCENE), blacklist_radius_m))
}

/// The score layer back from a PNG written with `traversability::score_to_rgb` (top row first,
/// on `geometry`): `score_rgb` maps s ∈ [0, 0.5] to (255, 510·s, 0) and s ∈ [0.5, 1] to
/// (510·(1 − s), 255, 0), unknown to grey (128, 128, 128); so s = g/510 when g < 255, else
/// 1 − r/510 (exact to ±1/1020), and a non-zero blue channel is unknown.
pub fn score_from_rgb_png(bytes: &[u8], geometry: GridGeometry) -> Result<Grid<f32>, String> {
    let err = |e: png::DecodingError| format!("score.png: {e}");
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().map_err(err)?;
    let mut buf = vec![0u8; reader.output_buffer_size().ok_or("score.png: too large")?];
    let info = reader.next_frame(&mut buf).map_err(err)?;
    let (w, h) = (info.width as usize, info.height as usize);
    if info.color_type != png::ColorType::Rgb || info.bit_depth != png::BitDepth::Eight {
        return Err(format!("score.png: expected 8-bit RGB, got {:?} {:?}", info.color_type, info.bit_depth));
    }
    if (w, h) != (geometry.width, geometry.height) {
        return Err(format!("score.png is {w} × {h}, the map {} × {}", geometry.width, geometry.height));
    }
    let mut data = vec![f32::NAN; w * h];
    for image_row in 0..h {
        let row = h - 1 - image_row;
        for col in 0..w {
            let k = (image_row * w + col) * 3;
            let (r, g, b) = (f32::from(buf[k]), f32::from(buf[k + 1]), buf[k + 2]);
            data[row * w + col] = if b != 0 {
                f32::NAN
            } else if g < 255.0 {
                g / 510.0
            } else {
                1.0 - r / 510.0
            };
        }
    }
    Grid::from_vec(geometry, data).ok_or_else(|| "score.png: size mismatch".to_string())
}

fn from_fixture(w: fixtures::SyntheticWorld, name: &str, blacklist_radius_m: f64) -> Scene {
    let mut map = MapLayers::from_occupancy(&w.grid, name);
    map.kind = MapKind::Synthetic;
    let landmarks = Landmarks { cloud: w.landmarks, source: format!("{name} landmarks") };
    Scene::new(map, landmarks, Some(w.robot), blacklist_radius_m)
}

fn corridor(blacklist_radius_m: f64) -> Result<Scene, String> {
    Ok(from_fixture(fixtures::corridor_two_frontiers(true), "corridor", blacklist_radius_m))
}

fn synthetic_small(blacklist_radius_m: f64) -> Result<Scene, String> {
    Ok(from_fixture(fixtures::synthetic_world(&fixtures::SyntheticWorldSpec::small(1)), "synthetic", blacklist_radius_m))
}

/// Axis-aligned boxes (min x, min y, max x, max y) of the courtyard's obstacles, metres.
const OBSTACLES: [[f64; 4]; 7] = [
    [3.0, 7.0, 4.2, 8.0],
    [6.5, 2.0, 7.0, 4.5],
    [10.0, 6.5, 12.5, 7.0],
    [11.5, 2.0, 12.5, 3.0],
    [5.0, 9.5, 9.0, 10.0],
    [13.5, 8.5, 14.5, 9.5],
    [1.5, 3.5, 2.3, 4.3],
];

/// Ground patches with an intermediate score (rough, sloped): lethal only when τ exceeds it.
const ROUGH: [([f64; 4], f32); 3] = [([8.0, 3.0, 9.5, 4.5], 0.45), ([4.5, 4.5, 5.8, 6.0], 0.7), ([9.5, 8.0, 11.0, 9.0], 0.3)];

fn synthetic_courtyard(blacklist_radius_m: f64) -> Result<Scene, String> {
    let geometry = GridGeometry::new(0.0, 0.0, 0.05, 320, 240);
    let (w_m, h_m) = (16.0, 12.0);
    let robot = Pose2::new(6.0, 6.0, 0.3);
    // The part explored so far: within 4.5 m of the trajectory (2, 2) → (6, 6) → (9, 5).
    let trajectory = [[2.0, 2.0], [6.0, 6.0], [9.0, 5.5]];
    let explored = |x: f64, y: f64| distance_to_polyline(x, y, &trajectory) <= 4.5;
    let inside_box = |x: f64, y: f64, b: &[f64; 4]| x >= b[0] && x < b[2] && y >= b[1] && y < b[3];
    let mut data = Vec::with_capacity(geometry.len());
    for row in 0..geometry.height {
        for col in 0..geometry.width {
            let (x, y) = geometry.center_of(fitslam_core::Cell::new(col as i32, row as i32));
            let wall = x < 0.2 || y < 0.2 || x > w_m - 0.2 || y > h_m - 0.2;
            let score = if !explored(x, y) {
                f32::NAN
            } else if wall || OBSTACLES.iter().any(|b| inside_box(x, y, b)) {
                0.0
            } else if let Some((_, s)) = ROUGH.iter().find(|(b, _)| inside_box(x, y, b)) {
                // A little texture so that the score layer reads as terrain.
                s + 0.08 * (hash_unit(col as i64, row as i64, 7) as f32 - 0.5)
            } else {
                0.9 + 0.1 * hash_unit(col as i64 / 4, row as i64 / 4, 3) as f32
            };
            data.push(score);
        }
    }
    let score = Grid::from_vec(geometry, data).ok_or("synthetic map size mismatch")?;
    let map = MapLayers::from_score(score, "courtyard", MapKind::Synthetic);
    let landmarks = Landmarks { cloud: courtyard_landmarks(w_m, h_m), source: "courtyard landmarks".into() };
    Ok(Scene::new(map, landmarks, Some(robot), blacklist_radius_m))
}

/// 400 landmarks on the walls and obstacle faces, 0.1–1.9 m high (deterministic).
fn courtyard_landmarks(w_m: f64, h_m: f64) -> PointCloud {
    let walls = [[0.0, 0.0, w_m, 0.2], [0.0, h_m - 0.2, w_m, h_m], [0.0, 0.0, 0.2, h_m], [w_m - 0.2, 0.0, w_m, h_m]];
    let boxes: Vec<[f64; 4]> = walls.iter().chain(OBSTACLES.iter()).copied().collect();
    let perimeters: Vec<f64> = boxes.iter().map(|b| 2.0 * ((b[2] - b[0]) + (b[3] - b[1]))).collect();
    let total: f64 = perimeters.iter().sum();
    let mut points = Vec::with_capacity(400);
    for i in 0..400i64 {
        // Pick a box by perimeter, then a point on its outline.
        let mut t = hash_unit(i, 0, 11) * total;
        let mut k = 0;
        while k + 1 < boxes.len() && t > perimeters[k] {
            t -= perimeters[k];
            k += 1;
        }
        let b = boxes[k];
        let (bw, bh) = (b[2] - b[0], b[3] - b[1]);
        let (x, y) = if t < bw {
            (b[0] + t, b[1])
        } else if t < bw + bh {
            (b[2], b[1] + t - bw)
        } else if t < 2.0 * bw + bh {
            (b[2] - (t - bw - bh), b[3])
        } else {
            (b[0], b[3] - (t - 2.0 * bw - bh))
        };
        let z = 0.1 + 1.8 * hash_unit(i, 1, 11);
        points.push(Point3::new(x, y, z));
    }
    PointCloud::from_points(points)
}

fn distance_to_polyline(x: f64, y: f64, pts: &[[f64; 2]]) -> f64 {
    pts.windows(2)
        .map(|s| {
            let ([ax, ay], [bx, by]) = (s[0], s[1]);
            let (dx, dy) = (bx - ax, by - ay);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 { (((x - ax) * dx + (y - ay) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            ((x - ax - t * dx).powi(2) + (y - ay - t * dy).powi(2)).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_core::grid::CellClass;
    use fitslam_core::traversability::{score_rgb, to_occupancy};

    #[test]
    fn score_rgb_inverts_within_half_a_step() {
        for k in 0..=1000 {
            let s = k as f32 / 1000.0;
            let [r, g, b] = score_rgb(s);
            assert_eq!(b, 0);
            let back = if g < 255 { f32::from(g) / 510.0 } else { 1.0 - f32::from(r) / 510.0 };
            assert!((back - s).abs() <= 1.0 / 1020.0 + 1e-6, "{s} -> {back}");
        }
    }

    #[test]
    fn jacksboro_score_thresholds_to_its_map() {
        // The decoded score, thresholded at the asset's τ (the default 0.5), gives back map.pgm's
        // classes: scores are decoded to ±1/1020, so only cells that close to τ may differ.
        let occ = fitslam_core::io::load_map(JACKSBORO_YAML, "map.yaml", JACKSBORO_PGM, "map.pgm").unwrap();
        let score = score_from_rgb_png(JACKSBORO_SCORE, occ.geometry).unwrap();
        let again = to_occupancy(&score, 0.5);
        let mut differ = 0;
        for i in 0..occ.data.len() {
            if CellClass::of(occ.data[i]) != CellClass::of(again.data[i]) {
                assert!((score.data[i] - 0.5).abs() <= 1.0 / 1020.0 + 1e-6, "cell {i}: {} vs {}", occ.data[i], score.data[i]);
                differ += 1;
            }
        }
        // Such cells are few (67 of 60,487 known when written: scores pile up at exactly 0.5).
        let known = occ.data.iter().filter(|&&v| v >= 0).count();
        assert!(differ * 100 < known, "{differ} of {known} known cells differ");
        assert!(score.data.iter().any(|s| !s.is_nan() && *s > 0.05 && *s < 0.95), "graded scores");
    }
}
