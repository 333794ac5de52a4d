//! ROS map_server maps: a YAML description plus a PGM or PNG image → [`OccupancyGrid`], and the
//! reverse (map_saver's trinary YAML + PGM).
//!
//! Pixel → cell, as ROS 2's `nav2_map_server` (`map_io.cpp`, `loadMapFromFile`) does it:
//! - `shade` ∈ [0, 1] is the pixel's brightness: the gray value, or the mean of R, G, B, divided
//!   by the image's maximum (255, 65535, or the PGM's maxval). In trinary mode an image with an
//!   alpha channel averages alpha in as a fourth channel (gray+alpha: (3·g + a)/4).
//! - `p = 1 − shade` (the "occupancy" probability), or `p = shade` when `negate` is set.
//! - trinary: `p > occupied_thresh` → 100; else `p < free_thresh` → 0; else −1.
//! - scale: a pixel that is not fully opaque → −1; `p > occupied_thresh` → 100;
//!   `p < free_thresh` → 0; else `round((p − free_thresh) / (occupied_thresh − free_thresh) · 100)`
//!   (ROS 1's map_server wrote `1 + 98·ratio` here; we follow ROS 2, which the brief asks for).
//! - raw: `v = round(shade · 255)` (negate ignored); `v` in 0..=100 is the cell value, else −1.
//!
//! Image row 0 is the top of the map (highest y); grid row 0 is the bottom, so row `r` of the
//! image becomes grid row `height − 1 − r`. The YAML origin is the world pose of the lower-left
//! pixel's lower-left corner; a non-zero yaw (beyond 1e-9 rad) is refused, the grid being
//! axis-aligned. O(W·H) time, one W·H grid allocation plus the decoded image.
//!
//! YAML keys (as map_server): `image`, `resolution`, `origin` ([x, y, yaw]), `occupied_thresh`,
//! `free_thresh` and `negate` (0/1 or true/false) are required; `mode` (trinary | scale | raw)
//! defaults to trinary; other keys are ignored. We also require resolution > 0 and
//! 0 ≤ free_thresh < occupied_thresh ≤ 1.

use super::MapError;
use super::image::{decode_image, write_pgm};
use crate::grid::{CellClass, GridGeometry, OccupancyGrid};
use serde_yaml::Value;

/// Largest |yaw| treated as zero: yaw written through a quaternion round trip is rarely exactly 0.
const YAW_TOLERANCE_RAD: f64 = 1e-9;

/// Most `[` / `{` open at once. libyaml's scanner takes time quadratic in the flow nesting depth
/// (32 KB of `[` takes tens of seconds), and serde_yaml refuses a document nested deeper than 128
/// levels anyway, after scanning all of it. Counted over the raw bytes, comments and strings
/// included: a map file holds one `[x, y, yaw]`.
const MAX_FLOW_DEPTH: usize = 128;

/// Whether more than `limit` `[` / `{` are open at some point of `text`.
fn flow_nesting_exceeds(text: &str, limit: usize) -> bool {
    let mut depth = 0usize;
    for b in text.bytes() {
        match b {
            b'[' | b'{' => depth += 1,
            b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
        if depth > limit {
            return true;
        }
    }
    false
}

/// How pixel values become cell values (map_server's `mode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapMode {
    /// 100 / 0 / −1 by thresholds (the default).
    #[default]
    Trinary,
    /// Thresholds, and a linear 0..100 ramp between them; transparent pixels unknown.
    Scale,
    /// The pixel value itself (0..=100; anything else unknown).
    Raw,
}

/// Thresholds and interpretation of a map image (the image-related YAML keys).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapThresholds {
    /// Occupancy probability above which a cell is lethal (map_server default files: 0.65).
    pub occupied_thresh: f64,
    /// Occupancy probability below which a cell is free (map_saver writes 0.196 / 0.25).
    pub free_thresh: f64,
    /// Whether white means occupied.
    pub negate: bool,
    /// How pixel values become cell values.
    pub mode: MapMode,
}

impl Default for MapThresholds {
    /// map_saver's values: occupied 0.65, free 0.196, not negated, trinary.
    fn default() -> Self {
        Self { occupied_thresh: 0.65, free_thresh: 0.196, negate: false, mode: MapMode::Trinary }
    }
}

/// The contents of a map_server YAML file.
#[derive(Clone, Debug, PartialEq)]
pub struct MapYaml {
    /// The image file name as written (relative names are relative to the YAML's directory).
    pub image: String,
    /// Cell edge, metres.
    pub resolution_m: f64,
    /// `[x_m, y_m, yaw_rad]` of the lower-left corner of the lower-left pixel.
    pub origin: [f64; 3],
    /// Occupancy probability above which a cell is lethal, in (`free_thresh`, 1].
    pub occupied_thresh: f64,
    /// Occupancy probability below which a cell is free, in [0, `occupied_thresh`).
    pub free_thresh: f64,
    /// Whether white means occupied.
    pub negate: bool,
    /// How pixel values become cell values (trinary when the YAML has no `mode`).
    pub mode: MapMode,
}

impl MapYaml {
    /// Parses map_server YAML. `name` (the YAML's file name) is used in error messages.
    /// Does not check the yaw (see [`load_map`]), so a caller can still read the image name.
    pub fn parse(bytes: &[u8], name: &str) -> Result<Self, MapError> {
        let yaml_err = |detail: String| MapError::Yaml { name: name.to_string(), detail };
        let text = std::str::from_utf8(super::without_bom(bytes)).map_err(|e| yaml_err(format!("not UTF-8 ({e})")))?;
        if flow_nesting_exceeds(text, MAX_FLOW_DEPTH) {
            return Err(yaml_err(format!("more than {MAX_FLOW_DEPTH} '[' or '{{' open at once")));
        }
        let doc: Value = serde_yaml::from_str(text).map_err(|e| yaml_err(e.to_string()))?;
        let map = doc.as_mapping().ok_or_else(|| yaml_err("the document is not a mapping of keys".to_string()))?;
        let get = |key: &'static str| map.get(key).filter(|v| !v.is_null()).ok_or(MapError::MissingKey { name: name.to_string(), key });
        let bad = |key: &'static str, detail: String| MapError::BadValue { name: name.to_string(), key, detail };

        let image = match get("image")? {
            Value::String(s) if !s.trim().is_empty() => s.trim().to_string(),
            Value::String(_) => return Err(bad("image", "is empty".to_string())),
            other => return Err(bad("image", format!("expected a file name, got {}", describe(other)))),
        };
        let resolution_m = number(get("resolution")?).ok_or_else(|| bad("resolution", "expected a number".to_string()))?;
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return Err(bad("resolution", format!("must be a positive number of metres, got {resolution_m}")));
        }
        let origin_v = get("origin")?;
        let origin_seq =
            origin_v.as_sequence().ok_or_else(|| bad("origin", format!("expected [x, y, yaw], got {}", describe(origin_v))))?;
        if origin_seq.len() != 3 {
            return Err(bad("origin", format!("expected 3 numbers [x, y, yaw], got {}", origin_seq.len())));
        }
        let mut origin = [0.0; 3];
        for (slot, v) in origin.iter_mut().zip(origin_seq) {
            *slot = number(v)
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad("origin", format!("expected finite numbers, got {}", describe(v))))?;
        }
        let thresh = |key: &'static str| -> Result<f64, MapError> {
            let v = number(get(key)?).ok_or_else(|| bad(key, "expected a number".to_string()))?;
            if !(0.0..=1.0).contains(&v) {
                return Err(bad(key, format!("{v} is not in [0, 1]")));
            }
            Ok(v)
        };
        let occupied_thresh = thresh("occupied_thresh")?;
        let free_thresh = thresh("free_thresh")?;
        if free_thresh >= occupied_thresh {
            return Err(bad("free_thresh", format!("{free_thresh} is not below occupied_thresh {occupied_thresh}")));
        }
        let negate = match get("negate")? {
            Value::Bool(b) => *b,
            Value::Number(n) if n.as_i64() == Some(0) => false,
            Value::Number(n) if n.as_i64() == Some(1) => true,
            other => return Err(bad("negate", format!("expected 0, 1, true or false, got {}", describe(other)))),
        };
        let mode = match map.get("mode") {
            None | Some(Value::Null) => MapMode::Trinary,
            Some(Value::String(s)) => match s.trim() {
                "trinary" => MapMode::Trinary,
                "scale" => MapMode::Scale,
                "raw" => MapMode::Raw,
                other => return Err(bad("mode", format!("expected trinary, scale or raw, got '{other}'"))),
            },
            Some(other) => return Err(bad("mode", format!("expected trinary, scale or raw, got {}", describe(other)))),
        };
        Ok(Self { image, resolution_m, origin, occupied_thresh, free_thresh, negate, mode })
    }

    /// The thresholds and mode of this map.
    pub fn thresholds(&self) -> MapThresholds {
        MapThresholds { occupied_thresh: self.occupied_thresh, free_thresh: self.free_thresh, negate: self.negate, mode: self.mode }
    }
}

/// A YAML number (integer or float) as f64.
fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Number(n) => n.as_f64(),
        _ => None,
    }
}

fn describe(v: &Value) -> String {
    match v {
        Value::Null => "nothing".to_string(),
        Value::Bool(b) => format!("{b}"),
        Value::Number(n) => format!("{n}"),
        Value::String(s) => format!("'{}'", s.chars().take(40).collect::<String>()),
        Value::Sequence(_) => "a list".to_string(),
        Value::Mapping(_) => "a mapping".to_string(),
        Value::Tagged(_) => "a tagged value".to_string(),
    }
}

/// Loads a map_server map: the YAML's bytes and file name, the image's bytes and file name
/// (read the image named by [`MapYaml::parse`]`(..).image`).
///
/// # Examples
///
/// A 3 × 2 map at 0.5 m whose lower-left corner is at (−1, −1): image row 0 is the map's top
/// row; black is occupied, white free, mid-grey unknown.
///
/// ```
/// use fitslam_core::grid::{Cell, FREE, LETHAL, UNKNOWN};
/// use fitslam_core::io::MapError;
/// use fitslam_core::load_map;
///
/// let yaml = b"image: map.pgm\nresolution: 0.5\norigin: [-1.0, -1.0, 0.0]\n\
///     occupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n";
/// let mut pgm = b"P5\n3 2\n255\n".to_vec();
/// pgm.extend_from_slice(&[0, 254, 128, 254, 254, 254]); // top row, then bottom row
/// let grid = load_map(yaml, "map.yaml", &pgm, "map.pgm")?;
///
/// assert_eq!((grid.geometry.width, grid.geometry.height), (3, 2));
/// assert_eq!(grid.get(Cell::new(0, 1)), Some(&LETHAL)); // top-left pixel
/// assert_eq!(grid.get(Cell::new(2, 1)), Some(&UNKNOWN));
/// assert_eq!(grid.at_world(-0.75, -0.75), Some(&FREE)); // bottom-left cell's centre
///
/// // A YAML without a required key names it.
/// let error = load_map(b"image: map.pgm\nresolution: 0.5\n", "map.yaml", &pgm, "map.pgm").unwrap_err();
/// assert!(matches!(error, MapError::MissingKey { key: "origin", .. }), "{error}");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn load_map(yaml_bytes: &[u8], yaml_name: &str, image_bytes: &[u8], image_name: &str) -> Result<OccupancyGrid, MapError> {
    let yaml = MapYaml::parse(yaml_bytes, yaml_name)?;
    let yaw_rad = yaml.origin[2];
    if yaw_rad.abs() > YAW_TOLERANCE_RAD {
        return Err(MapError::RotatedOrigin { name: yaml_name.to_string(), yaw_rad });
    }
    load_map_image(image_bytes, image_name, yaml.resolution_m, [yaml.origin[0], yaml.origin[1]], &yaml.thresholds())
}

/// Loads a bare PGM or PNG (recognised by content) as a grid with the given cell size, lower-left
/// corner `origin_xy_m` and thresholds.
pub fn load_map_image(
    image_bytes: &[u8],
    image_name: &str,
    resolution_m: f64,
    origin_xy_m: [f64; 2],
    thresholds: &MapThresholds,
) -> Result<OccupancyGrid, MapError> {
    let bad = |key: &'static str, detail: String| MapError::BadValue { name: image_name.to_string(), key, detail };
    if !(resolution_m.is_finite() && resolution_m > 0.0) {
        return Err(bad("resolution", format!("must be a positive number of metres, got {resolution_m}")));
    }
    if !(origin_xy_m[0].is_finite() && origin_xy_m[1].is_finite()) {
        return Err(bad("origin", "must be finite".to_string()));
    }
    let MapThresholds { occupied_thresh, free_thresh, negate, mode } = *thresholds;
    if !(0.0 <= free_thresh && free_thresh < occupied_thresh && occupied_thresh <= 1.0) {
        return Err(bad("free_thresh", format!("need 0 ≤ free_thresh ({free_thresh}) < occupied_thresh ({occupied_thresh}) ≤ 1")));
    }
    let raster = decode_image(image_bytes, image_name)?;
    let (width, height) = (raster.width, raster.height);
    let geometry = GridGeometry::new(origin_xy_m[0], origin_xy_m[1], resolution_m, width, height);
    let mut data = vec![crate::grid::UNKNOWN; width * height];
    let average_alpha = mode == MapMode::Trinary && raster.has_alpha();
    for image_row in 0..height {
        let grid_row = height - 1 - image_row;
        for col in 0..width {
            let (color, alpha) = raster.pixel(image_row * width + col);
            let shade = if average_alpha { (3.0 * color + alpha) / 4.0 } else { color };
            let p = if negate { shade } else { 1.0 - shade };
            data[grid_row * width + col] = match mode {
                MapMode::Trinary => trinary(p, occupied_thresh, free_thresh),
                MapMode::Scale => {
                    if alpha < 1.0 {
                        crate::grid::UNKNOWN
                    } else if p > occupied_thresh {
                        crate::grid::LETHAL
                    } else if p < free_thresh {
                        crate::grid::FREE
                    } else {
                        ((p - free_thresh) / (occupied_thresh - free_thresh) * 100.0).round() as i8
                    }
                }
                MapMode::Raw => {
                    let v = (shade * 255.0).round();
                    if (0.0..=100.0).contains(&v) { v as i8 } else { crate::grid::UNKNOWN }
                }
            };
        }
    }
    Ok(OccupancyGrid { geometry, data })
}

#[inline]
fn trinary(p: f64, occupied_thresh: f64, free_thresh: f64) -> i8 {
    if p > occupied_thresh {
        crate::grid::LETHAL
    } else if p < free_thresh {
        crate::grid::FREE
    } else {
        crate::grid::UNKNOWN
    }
}

/// map_saver's trinary pixel values.
const SAVED_FREE: u8 = 254;
const SAVED_LETHAL: u8 = 0;
const SAVED_UNKNOWN: u8 = 205;

/// Writes `grid` as map_saver does in trinary mode: returns the YAML text (naming
/// `image_file_name`, thresholds 0.65 / 0.196, negate 0) and the binary PGM bytes. Each cell is
/// classified with [`CellClass::of`] (≥ 50 lethal, 0–49 free, < 0 unknown) and written as
/// 0 (lethal), 254 (free) or 205 (unknown); loading the pair gives back 100 / 0 / −1.
/// Missing cells (if `data` is shorter than the geometry) are written unknown.
pub fn save_map(grid: &OccupancyGrid, image_file_name: &str) -> (String, Vec<u8>) {
    let g = &grid.geometry;
    let (width, height) = (g.width, g.height);
    let mut pixels = Vec::with_capacity(width * height);
    for image_row in 0..height {
        let grid_row = height - 1 - image_row;
        for col in 0..width {
            let v = grid.data.get(grid_row * width + col).copied();
            pixels.push(match v.map(CellClass::of) {
                Some(CellClass::Free) => SAVED_FREE,
                Some(CellClass::Lethal) => SAVED_LETHAL,
                Some(CellClass::Unknown) | None => SAVED_UNKNOWN,
            });
        }
    }
    let t = MapThresholds::default();
    let image_quoted = serde_yaml::to_string(image_file_name).unwrap_or_else(|_| format!("{image_file_name:?}"));
    let yaml = format!(
        "image: {}\nmode: trinary\nresolution: {:?}\norigin: [{:?}, {:?}, 0.0]\nnegate: 0\noccupied_thresh: {:?}\nfree_thresh: {:?}\n",
        image_quoted.trim_end(),
        g.resolution_m,
        g.origin_x_m,
        g.origin_y_m,
        t.occupied_thresh,
        t.free_thresh
    );
    let comment = format!("fitslam map, {:?} m/cell", g.resolution_m);
    (yaml, write_pgm(width, height, &pixels, &comment))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Cell;
    use proptest::prelude::*;

    const YAML: &str = "image: map.pgm\nresolution: 0.5\norigin: [-1.0, 2, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

    /// A 3 × 2 P5 image: top row 0 (black), 205, 254; bottom row 255, 100, 180.
    fn pgm() -> Vec<u8> {
        let mut b = b"P5\n3 2\n255\n".to_vec();
        b.extend_from_slice(&[0, 205, 254, 255, 100, 180]);
        b
    }

    #[test]
    fn trinary_follows_map_server_and_flips_rows() {
        let g = load_map(YAML.as_bytes(), "map.yaml", &pgm(), "map.pgm").unwrap();
        assert_eq!(g.geometry, GridGeometry::new(-1.0, 2.0, 0.5, 3, 2));
        // p = (255 − v)/255: 0 → 1 (lethal); 205 → 0.196078 (not < 0.196: unknown); 254 → 0.0039 (free).
        assert_eq!(g.get(Cell::new(0, 1)), Some(&100));
        assert_eq!(g.get(Cell::new(1, 1)), Some(&-1));
        assert_eq!(g.get(Cell::new(2, 1)), Some(&0));
        // bottom image row → grid row 0: 255 → 0 free; 100 → 0.608 unknown; 180 → 0.294 unknown.
        assert_eq!(g.data[..3], [0, -1, -1]);
        assert_eq!(g.at_world(-0.9, 2.1), Some(&0));
    }

    #[test]
    fn negate_swaps_black_and_white() {
        let y = YAML.replace("negate: 0", "negate: true");
        let g = load_map(y.as_bytes(), "map.yaml", &pgm(), "map.pgm").unwrap();
        // p = v/255: 0 → free, 205 → 0.804 lethal, 254 → lethal; 255 → lethal, 100 → 0.392 unknown, 180 → 0.706 lethal.
        assert_eq!(g.data, vec![100, -1, 100, 0, 100, 100]);
    }

    #[test]
    fn scale_mode_ramps_between_thresholds() {
        let y = YAML.replace("negate: 0", "negate: 0\nmode: scale");
        let g = load_map(y.as_bytes(), "map.yaml", &pgm(), "map.pgm").unwrap();
        // 205: p = 50/255 = 0.19608 ≥ 0.196 → round((0.19608 − 0.196)/(0.454)·100) = round(0.017) = 0.
        // 100: p = 0.60784 → round(0.41184/0.454·100) = round(90.71) = 91.
        // 180: p = 0.29412 → round(0.09812/0.454·100) = round(21.61) = 22.
        assert_eq!(g.data, vec![0, 91, 22, 100, 0, 0]);
    }

    #[test]
    fn raw_mode_is_the_value_itself() {
        let y = YAML.replace("negate: 0", "negate: 1\nmode: raw");
        let mut b = b"P2\n4 1\n255\n0 57 100 101\n".to_vec();
        let g = load_map(y.as_bytes(), "map.yaml", &b, "r.pgm").unwrap();
        assert_eq!(g.data, vec![0, 57, 100, -1]);
        b = b"P2\n2 1\n1000\n100 400\n".to_vec(); // 16-bit maxval: shade·255 = 25.5 → 26, 102 → unknown
        let g = load_map(y.as_bytes(), "map.yaml", &b, "r.pgm").unwrap();
        assert_eq!(g.data, vec![26, -1]);
    }

    #[test]
    fn sixteen_bit_pgm_thresholds_on_maxval() {
        let mut b = b"P5\n2 1\n65535\n".to_vec();
        b.extend_from_slice(&[0x00, 0x00, 0xFF, 0xFF]);
        let g = load_map(YAML.as_bytes(), "map.yaml", &b, "m.pgm").unwrap();
        assert_eq!(g.data, vec![100, 0]);
    }

    #[test]
    fn png_alpha_rules_per_mode() {
        // gray+alpha pixels: (g=255, a=0) and (g=255, a=255).
        let mut png = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut png, 2, 1);
            enc.set_color(png::ColorType::GrayscaleAlpha);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().unwrap();
            w.write_image_data(&[255, 0, 255, 255]).unwrap();
            w.finish().unwrap();
        }
        // trinary: shade = (3·1 + 0)/4 = 0.75 → p = 0.25: unknown; opaque white: free.
        let g = load_map(YAML.as_bytes(), "m.yaml", &png, "m.png").unwrap();
        assert_eq!(g.data, vec![-1, 0]);
        // scale: a transparent pixel is unknown.
        let y = YAML.replace("negate: 0", "negate: 0\nmode: scale");
        let g = load_map(y.as_bytes(), "m.yaml", &png, "m.png").unwrap();
        assert_eq!(g.data, vec![-1, 0]);
    }

    #[test]
    fn rgb_png_uses_the_channel_mean() {
        // mean(0, 0, 255) = 85 → p = 0.667 > 0.65: lethal; mean(255, 255, 0) = 170 → p = 0.333: unknown.
        let png = crate::io::write_png_rgb8(2, 1, &[0, 0, 255, 255, 255, 0]).unwrap();
        let g = load_map(YAML.as_bytes(), "m.yaml", &png, "m.png").unwrap();
        assert_eq!(g.data, vec![100, -1]);
    }

    #[test]
    fn yaml_errors_name_file_and_key() {
        let e = load_map(b"resolution: 0.05\n", "map.yaml", &pgm(), "m.pgm").unwrap_err();
        assert_eq!(e.to_string(), "map.yaml: missing required key 'image'");
        let e = MapYaml::parse(YAML.replace("origin: [-1.0, 2, 0.0]", "origin: [1, 2]").as_bytes(), "m.yaml").unwrap_err();
        assert_eq!(e.to_string(), "m.yaml: key 'origin': expected 3 numbers [x, y, yaw], got 2");
        let e = MapYaml::parse(YAML.replace("0.5", "-0.5").as_bytes(), "m.yaml").unwrap_err();
        assert!(matches!(e, MapError::BadValue { key: "resolution", .. }), "{e}");
        let e = MapYaml::parse(format!("{YAML}mode: fancy\n").as_bytes(), "m.yaml").unwrap_err();
        assert!(e.to_string().contains("expected trinary, scale or raw, got 'fancy'"), "{e}");
        let e = MapYaml::parse(YAML.replace("negate: 0", "negate: 2").as_bytes(), "m.yaml").unwrap_err();
        assert!(matches!(e, MapError::BadValue { key: "negate", .. }), "{e}");
        let e = MapYaml::parse(YAML.replace("0.196", "0.7").as_bytes(), "m.yaml").unwrap_err();
        assert!(matches!(e, MapError::BadValue { key: "free_thresh", .. }), "{e}");
        let e = MapYaml::parse(b"image: [a", "m.yaml").unwrap_err();
        assert!(matches!(e, MapError::Yaml { .. }), "{e}");
        let e = MapYaml::parse(b"- 1\n- 2\n", "m.yaml").unwrap_err();
        assert!(e.to_string().starts_with("m.yaml: invalid YAML"), "{e}");
        let e = MapYaml::parse(YAML.replace("negate: 0\n", "").as_bytes(), "m.yaml").unwrap_err();
        assert_eq!(e.to_string(), "m.yaml: missing required key 'negate'");
    }

    #[test]
    fn alias_bomb_is_an_error_not_a_blowup() {
        let mut y = String::from("a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n");
        for i in 1..12 {
            let p = i - 1;
            y.push_str(&format!("a{i}: &a{i} [*a{p}, *a{p}, *a{p}, *a{p}, *a{p}, *a{p}, *a{p}, *a{p}, *a{p}, *a{p}]\n"));
        }
        assert!(matches!(MapYaml::parse(y.as_bytes(), "bomb.yaml"), Err(MapError::Yaml { .. })));
    }

    /// fuzz: a YAML of 8,000 nested `[` took 2.6 s in libyaml's scanner (quadratic in the depth;
    /// AFL's inputs of 25 KB took 20 s) before serde_yaml refused it as too deep.
    #[test]
    fn deep_flow_nesting_is_refused_before_scanning() {
        let deep = format!("image: m.pgm\norigin: {}", "[".repeat(8_000));
        let e = MapYaml::parse(deep.as_bytes(), "deep.yaml").unwrap_err();
        assert_eq!(e.to_string(), "deep.yaml: invalid YAML: more than 128 '[' or '{' open at once");
        let e = MapYaml::parse("{".repeat(129).as_bytes(), "deep.yaml").unwrap_err();
        assert!(e.to_string().ends_with("more than 128 '[' or '{' open at once"), "{e}");
        // Many collections one after another are not deep; brackets closed in comments neither.
        let items = vec!["[[1], {a: 2}]"; 500].join(", ");
        let wide = format!("{YAML}extra: [{items}]\n# {}\n", "[]".repeat(200));
        assert_eq!(MapYaml::parse(wide.as_bytes(), "wide.yaml").unwrap(), MapYaml::parse(YAML.as_bytes(), "m.yaml").unwrap());
    }

    #[test]
    fn rotated_origin_is_refused_but_parse_still_works() {
        let y = YAML.replace("0.0]", "0.3]");
        let parsed = MapYaml::parse(y.as_bytes(), "m.yaml").unwrap();
        assert_eq!(parsed.image, "map.pgm");
        assert_eq!(parsed.origin, [-1.0, 2.0, 0.3]);
        let e = load_map(y.as_bytes(), "m.yaml", &pgm(), "m.pgm").unwrap_err();
        assert!(matches!(e, MapError::RotatedOrigin { yaw_rad, .. } if yaw_rad == 0.3));
        assert!(e.to_string().starts_with("m.yaml: origin yaw 0.3 rad is not zero"), "{e}");
    }

    #[test]
    fn parse_reads_defaults_and_extra_keys() {
        let y = format!("{YAML}unknown_key: 7\n");
        let m = MapYaml::parse(y.as_bytes(), "m.yaml").unwrap();
        assert_eq!(m.mode, MapMode::Trinary);
        assert!(!m.negate);
        assert_eq!(m.resolution_m, 0.5);
        assert_eq!(m.thresholds(), MapThresholds { occupied_thresh: 0.65, free_thresh: 0.196, negate: false, mode: MapMode::Trinary });
    }

    #[test]
    fn save_map_writes_map_saver_values() {
        let geometry = GridGeometry::new(1.5, -2.0, 0.05, 2, 2);
        let grid = OccupancyGrid::from_vec(geometry, vec![0, 100, -1, 49]).unwrap();
        let (yaml, pgm) = save_map(&grid, "out.pgm");
        let m = MapYaml::parse(yaml.as_bytes(), "out.yaml").unwrap();
        assert_eq!(m.image, "out.pgm");
        assert_eq!(m.origin, [1.5, -2.0, 0.0]);
        // Top image row is grid row 1: (-1 → 205, 49 → free 254); then grid row 0: (0 → 254, 100 → 0).
        assert_eq!(&pgm[pgm.len() - 4..], &[205, 254, 254, 0]);
        let back = load_map(yaml.as_bytes(), "out.yaml", &pgm, "out.pgm").unwrap();
        assert_eq!(back.data, vec![0, 100, -1, 0]);
        assert_eq!(back.geometry, geometry);
    }

    proptest! {
        #[test]
        fn save_load_roundtrip_keeps_classes(w in 1usize..30, h in 1usize..30, ox in -100.0f64..100.0, oy in -100.0f64..100.0, res in 0.01f64..2.0, seed in any::<u64>()) {
            let data: Vec<i8> = (0..w * h).map(|i| [0i8, 100, -1, 30, 70][((seed >> (i % 60)) as usize + i) % 5]).collect();
            let grid = OccupancyGrid::from_vec(GridGeometry::new(ox, oy, res, w, h), data.clone()).unwrap();
            let (yaml, pgm) = save_map(&grid, "a b:c.pgm");
            prop_assert_eq!(MapYaml::parse(yaml.as_bytes(), "y").unwrap().image, "a b:c.pgm");
            let back = load_map(yaml.as_bytes(), "y", &pgm, "p").unwrap();
            prop_assert_eq!(back.geometry, grid.geometry);
            for (a, b) in data.iter().zip(&back.data) {
                prop_assert_eq!(CellClass::of(*a), CellClass::of(*b));
            }
        }

        #[test]
        fn arbitrary_yaml_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
            let _ = MapYaml::parse(&bytes, "x.yaml");
        }

        #[test]
        fn mutated_yaml_never_panics(pos in any::<prop::sample::Index>(), byte in any::<u8>()) {
            let mut b = YAML.as_bytes().to_vec();
            let i = pos.index(b.len());
            b[i] = byte;
            let _ = load_map(&b, "x.yaml", &pgm(), "x.pgm");
        }
    }
}
