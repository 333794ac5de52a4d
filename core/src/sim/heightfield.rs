//! Terrain as a heightfield: ground height z(x, y) on a square grid, bilinear between samples.
//! Built from a real DEM image (grey PNG or PGM, value = metres) scaled to rover size, or
//! procedurally. Lookups O(1).

use crate::grid::GridGeometry;
use crate::io::MapError;
use crate::io::image::decode_image;
use crate::math;
use thiserror::Error;

/// A DEM that could not be read.
#[derive(Debug, Error)]
pub enum HeightfieldError {
    /// The bytes are not a readable PNG or PGM image.
    #[error("{name}: not a readable DEM image: {message}")]
    Png {
        /// The image's name.
        name: String,
        /// The decoder's message.
        message: String,
    },
    /// The scaling or the image's size is unusable.
    #[error("{name}: {message}")]
    Invalid {
        /// The image's name.
        name: String,
        /// What is wrong.
        message: String,
    },
}

/// Ground heights on `geometry`'s cell centres, row-major bottom-up like every layer.
#[derive(Clone, Debug, PartialEq)]
pub struct Heightfield {
    /// The cells (origin, resolution, size) in the map frame.
    pub geometry: GridGeometry,
    /// Height of each cell centre, metres, `geometry.len()` of them.
    pub heights_m: Vec<f64>,
}

/// How a real DEM is brought to rover scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DemScaling {
    /// Ground size of one DEM pixel along x (columns), metres.
    pub pixel_x_m: f64,
    /// Ground size of one DEM pixel along y (rows), metres.
    pub pixel_y_m: f64,
    /// Edge of the square world the DEM's central crop is mapped onto, metres.
    pub world_size_m: f64,
    /// Resolution of the resulting heightfield, metres.
    pub cell_m: f64,
    /// Fraction of the DEM's shorter side the crop spans (0, 1].
    pub crop_fraction: f64,
    /// Where the crop lies, [across, down], each in [0, 1] over the centres that keep the
    /// rotated crop inside the DEM (0.5, 0.5: the central crop).
    pub crop_centre: [f64; 2],
    /// Rotation of the crop about its centre, radians counter-clockwise (world +x along this
    /// bearing on the DEM, 0 = east).
    pub rotation_rad: f64,
}

impl DemScaling {
    /// The whole DEM as one crop in its middle, unrotated, at its own pixel size and scale: the
    /// base of a struct update (`DemScaling { world_size_m, .., ..DemScaling::CENTRAL }`).
    pub const CENTRAL: Self = Self {
        pixel_x_m: 1.0,
        pixel_y_m: 1.0,
        world_size_m: 1.0,
        cell_m: 1.0,
        crop_fraction: 1.0,
        crop_centre: [0.5, 0.5],
        rotation_rad: 0.0,
    };
}

impl Heightfield {
    /// A heightfield from a function of the cell centre.
    pub fn from_fn(geometry: GridGeometry, mut z: impl FnMut(f64, f64) -> f64) -> Self {
        let heights_m = (0..geometry.len())
            .map(|i| {
                let (x, y) = geometry.center_of(geometry.cell_at(i));
                z(x, y)
            })
            .collect();
        Self { geometry, heights_m }
    }

    /// Height at a world point, bilinear between cell centres (clamped at the border); `None`
    /// outside the grid.
    #[inline]
    pub fn height_at(&self, x_m: f64, y_m: f64) -> Option<f64> {
        let g = &self.geometry;
        let (u, v) = ((x_m - g.origin_x_m) / g.resolution_m, (y_m - g.origin_y_m) / g.resolution_m);
        // Inside the grid ⇔ 0 ≤ u < width and 0 ≤ v < height (false for NaN): the same test as
        // `cell_of`, without its two `floor` calls.
        if !(u >= 0.0 && u < g.width as f64 && v >= 0.0 && v < g.height as f64) {
            return None;
        }
        let fx = (u - 0.5).clamp(0.0, (g.width - 1) as f64);
        let fy = (v - 0.5).clamp(0.0, (g.height - 1) as f64);
        // fx, fy ≥ 0: truncation is floor (and needs no libm call).
        let (c0, r0) = (fx as usize, fy as usize);
        let (c1, r1) = ((c0 + 1).min(g.width - 1), (r0 + 1).min(g.height - 1));
        let (tx, ty) = (fx - c0 as f64, fy - r0 as f64);
        let h = |c: usize, r: usize| self.heights_m[r * g.width + c];
        let bottom = h(c0, r0) + (h(c1, r0) - h(c0, r0)) * tx;
        let top = h(c0, r1) + (h(c1, r1) - h(c0, r1)) * tx;
        Some(bottom + (top - bottom) * ty)
    }

    /// Builds a rover-scale heightfield from a grey DEM image, PNG (1–16 bits, palette expanded,
    /// alpha ignored; a grey image saved as RGB(A), every pixel with R = G = B, reads as grey) or
    /// PGM (pixel value = metres; image row 0 is north, i.e. the top). A square crop
    /// (`crop_fraction` of the shorter side, in ground metres), rotated by `rotation_rad` about its
    /// centre and placed by `crop_centre`, is mapped onto a `world_size_m` square with its origin
    /// at (0, 0), and heights are scaled by the same factor as distances, so slopes are the real
    /// terrain's; the lowest point of the crop is at z = 0.
    pub fn from_dem_png(bytes: &[u8], name: &str, scaling: DemScaling) -> Result<Self, HeightfieldError> {
        let invalid = |message: String| HeightfieldError::Invalid { name: name.into(), message };
        let s = scaling;
        for (key, v) in [("pixel_x_m", s.pixel_x_m), ("pixel_y_m", s.pixel_y_m), ("world size_m", s.world_size_m), ("cell_m", s.cell_m)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(format!("DEM scaling: {key} must be a finite number > 0 (got {})", crate::params::Num(v))));
            }
        }
        if !(s.crop_fraction > 0.0 && s.crop_fraction <= 1.0) {
            return Err(invalid(format!("DEM scaling: crop_fraction must be in (0, 1] (got {})", crate::params::Num(s.crop_fraction))));
        }
        if !(s.crop_centre.iter().all(|v| (0.0..=1.0).contains(v)) && s.rotation_rad.is_finite()) {
            return Err(invalid(format!(
                "DEM scaling: crop_centre must be in [0, 1]² and rotation finite (got {:?}, {})",
                s.crop_centre,
                crate::params::Num(s.rotation_rad)
            )));
        }
        // The map images' decoder: PNG (any colour type and depth, expanded) or PGM, with its
        // allocation caps.
        let raster = decode_image(bytes, name).map_err(|e| HeightfieldError::Png {
            name: name.into(),
            message: match e {
                MapError::Image { detail, .. } => detail,
                other => other.to_string(),
            },
        })?;
        let (w, h, channels) = (raster.width, raster.height, raster.channels);
        let value = |col: usize, row: usize| raster.stored_sample(row * w + col, 0);
        if w < 2 || h < 2 {
            return Err(invalid("DEM must be at least 2 × 2 pixels".into()));
        }
        // A grey DEM saved as RGB(A) is read as grey; a colour image has no single height.
        if channels >= 3 {
            for index in 0..w * h {
                let [r, g, b] = [0, 1, 2].map(|c| raster.stored_sample(index, c));
                if r != g || g != b {
                    let (col, row) = (index % w, index / w);
                    return Err(invalid(format!(
                        "DEM must be a grey image: it is RGB and pixel (column {col}, row {row}) has R, G, B = {r}, {g}, {b} (save it as grey)"
                    )));
                }
            }
        }
        // The crop in ground metres: its side, and its centre where the rotated square (half
        // extent `half_m` along each image axis) stays inside the DEM (the middle if it cannot).
        let (ground_w_m, ground_h_m) = ((w as f64 - 1.0) * s.pixel_x_m, (h as f64 - 1.0) * s.pixel_y_m);
        let crop_m = s.crop_fraction * ground_w_m.min(ground_h_m);
        let scale = s.world_size_m / crop_m; // world metres per ground metre
        let (sin, cos) = (math::sin(s.rotation_rad), math::cos(s.rotation_rad));
        let half_m = 0.5 * crop_m * (cos.abs() + sin.abs());
        let place = |extent_m: f64, t: f64| if extent_m >= 2.0 * half_m { half_m + t * (extent_m - 2.0 * half_m) } else { extent_m / 2.0 };
        let (centre_x_m, centre_y_from_top_m) = (place(ground_w_m, s.crop_centre[0]), place(ground_h_m, s.crop_centre[1]));
        let n = (s.world_size_m / s.cell_m).round().max(2.0) as usize;
        let geometry = GridGeometry::new(0.0, 0.0, s.world_size_m / n as f64, n, n);
        let sample = |gx: f64, gy_from_top: f64| -> f64 {
            let fx = (gx / s.pixel_x_m).clamp(0.0, (w - 1) as f64);
            let fy = (gy_from_top / s.pixel_y_m).clamp(0.0, (h - 1) as f64);
            let (c0, r0) = (fx.floor() as usize, fy.floor() as usize);
            let (c1, r1) = ((c0 + 1).min(w - 1), (r0 + 1).min(h - 1));
            let (tx, ty) = (fx - c0 as f64, fy - r0 as f64);
            let a = value(c0, r0) + (value(c1, r0) - value(c0, r0)) * tx;
            let b = value(c0, r1) + (value(c1, r1) - value(c0, r1)) * tx;
            a + (b - a) * ty
        };
        // Unrotated, the crop is offset from its top-left corner (t × the room it has to move in),
        // the arithmetic of worlds made before rotation existed, so they stay the same bit for bit.
        let (corner_x_m, corner_y_from_top_m) = (s.crop_centre[0] * (ground_w_m - crop_m), s.crop_centre[1] * (ground_h_m - crop_m));
        let mut field = Self::from_fn(geometry, |x, y| {
            // World y grows north; image rows grow south.
            if s.rotation_rad == 0.0 {
                return sample(corner_x_m + x / scale, corner_y_from_top_m + (s.world_size_m - y) / scale) * scale;
            }
            // World offset from the crop's centre in ground metres, rotated onto the DEM's east
            // and north.
            let (u, v) = ((x - 0.5 * s.world_size_m) / scale, (y - 0.5 * s.world_size_m) / scale);
            let (east_m, north_m) = (u * cos - v * sin, u * sin + v * cos);
            sample(centre_x_m + east_m, centre_y_from_top_m - north_m) * scale
        });
        let min = field.heights_m.iter().cloned().fold(f64::INFINITY, f64::min);
        field.heights_m.iter_mut().for_each(|z| *z -= min);
        Ok(field)
    }

    /// Slope magnitude at a world point from central differences, radians.
    pub(crate) fn slope_at(&self, x_m: f64, y_m: f64) -> Option<f64> {
        let e = self.geometry.resolution_m;
        let dzdx = (self.height_at(x_m + e, y_m)? - self.height_at(x_m - e, y_m)?) / (2.0 * e);
        let dzdy = (self.height_at(x_m, y_m + e)? - self.height_at(x_m, y_m - e)?) / (2.0 * e);
        Some(math::atan(math::hypot(dzdx, dzdy)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_is_exact_on_a_plane() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 20, 20);
        let hf = Heightfield::from_fn(g, |x, y| 0.3 * x - 0.2 * y + 1.0);
        for &(x, y) in &[(0.5, 0.5), (1.23, 0.77), (0.06, 1.94)] {
            assert!((hf.height_at(x, y).unwrap() - (0.3 * x - 0.2 * y + 1.0)).abs() < 1e-12);
        }
        assert!(hf.height_at(-0.1, 0.5).is_none());
        let slope = hf.slope_at(1.0, 1.0).unwrap();
        assert!((slope - (0.3f64.hypot(0.2)).atan()).abs() < 1e-9);
    }

    #[test]
    fn real_dem_scales_isotropically() {
        let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/terrain/jacksboro_fault_dem.png")).unwrap();
        let s =
            DemScaling { pixel_x_m: 74.0, pixel_y_m: 93.0, world_size_m: 20.0, cell_m: 0.05, crop_fraction: 0.5, ..DemScaling::CENTRAL };
        let hf = Heightfield::from_dem_png(&bytes, "dem.png", s).unwrap();
        assert_eq!(hf.geometry.width, 400);
        let max = hf.heights_m.iter().cloned().fold(0.0, f64::max);
        // crop ≈ 0.5 · 343 · 93 m ≈ 15.9 km → 20 m: scale ≈ 1/800; the real relief (≤ 840 m) becomes ≤ ~1.1 m.
        assert!(max > 0.05 && max < 1.2, "relief {max}");
        assert!(Heightfield::from_dem_png(b"not a png", "x.png", s).is_err());
        // A scaling value out of range is named (an infinite pixel size passed a `> 0` check).
        for (bad, needle) in [
            (DemScaling { pixel_x_m: f64::INFINITY, ..s }, "pixel_x_m must be a finite number > 0 (got inf)"),
            (DemScaling { pixel_y_m: 0.0, ..s }, "pixel_y_m must be a finite number > 0 (got 0)"),
            (DemScaling { world_size_m: f64::NAN, ..s }, "world size_m must be a finite number > 0 (got NaN)"),
            (DemScaling { crop_fraction: 1.5, ..s }, "crop_fraction must be in (0, 1] (got 1.5)"),
        ] {
            let e = Heightfield::from_dem_png(&bytes, "dem.png", bad).unwrap_err().to_string();
            assert!(e.contains("dem.png") && e.contains(needle), "{e}");
        }
    }

    /// A 101 × 101 grey DEM of 1 m pixels whose value is |column − 30|: a valley running
    /// north–south along column 30.
    fn valley_dem() -> Vec<u8> {
        let data: Vec<u8> = (0..101 * 101).map(|i| ((i % 101) as i64 - 30).unsigned_abs() as u8).collect();
        png_of(png::ColorType::Grayscale, png::BitDepth::Eight, (101, 101), &data)
    }

    /// Column of the lowest cell along world row `row` (the field's x of the valley floor).
    fn lowest_col(hf: &Heightfield, row: usize) -> usize {
        let w = hf.geometry.width;
        (0..w).min_by(|&a, &b| hf.heights_m[row * w + a].total_cmp(&hf.heights_m[row * w + b])).unwrap()
    }

    #[test]
    fn the_crop_is_placed_and_rotated_as_asked() {
        let bytes = valley_dem();
        // Crop 0.5 × 100 m = 50 m onto a 50 m world of 1 m cells: scale 1, cell centres at k + 0.5.
        let s = DemScaling { world_size_m: 50.0, crop_fraction: 0.5, ..DemScaling::CENTRAL };
        let field =
            |crop_centre, rotation_rad| Heightfield::from_dem_png(&bytes, "v.png", DemScaling { crop_centre, rotation_rad, ..s }).unwrap();
        // Against the left edge the crop spans columns 0–50: the valley (column 30) at world x ≈ 30.
        assert_eq!(
            lowest_col(&field([0.0, 0.5], 0.0), 10),
            29,
            "cell 29 spans x 29–30; its centre 29.5 is 0.5 from column 30, as cell 30's"
        );
        // Centred: columns 25–75, the valley at x ≈ 5. Against the right edge: columns 50–100,
        // no valley inside; the lowest ground is the left border (x = 0.5 ↔ column 50.5).
        assert_eq!(lowest_col(&field([0.5, 0.5], 0.0), 10), 4);
        assert_eq!(lowest_col(&field([1.0, 0.5], 0.0), 10), 0);
        // Heights follow the DEM at scale 1: in the centred crop, x = 20.5 is column 45.5, 15.5 m
        // above the valley floor; the floor's lowest cell centre (x 4.5 or 5.5) is 0.5 above it.
        let centred = field([0.5, 0.5], 0.0);
        assert!((centred.heights_m[10 * 50 + 20] - 15.0).abs() < 1e-9, "{}", centred.heights_m[10 * 50 + 20]);
        // The unrotated arithmetic and the rotated one agree (a turn of 1e-12 rad takes the latter).
        for centre in [[0.0, 0.5], [0.3, 0.8], [1.0, 0.5]] {
            let (a, b) = (field(centre, 0.0), field(centre, 1e-12));
            assert!(a.heights_m.iter().zip(&b.heights_m).all(|(p, q)| (p - q).abs() < 1e-6), "{centre:?}");
        }
        // A quarter turn about the centre column 50: world +x runs north and world +y west, so
        // the valley (20 m west of the centre) runs along world x at y = 25 + 20 = 45.
        let turned = field([0.5, 0.5], std::f64::consts::FRAC_PI_2);
        let w = 50;
        for col in [3, 25, 46] {
            let lowest_row = (0..w).min_by(|&a, &b| turned.heights_m[a * w + col].total_cmp(&turned.heights_m[b * w + col])).unwrap();
            assert!(lowest_row == 44 || lowest_row == 45, "column {col}: valley at row {lowest_row}");
        }
    }

    fn png_of(color: png::ColorType, depth: png::BitDepth, (w, h): (u32, u32), data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(color);
        enc.set_depth(depth);
        enc.write_header().unwrap().write_image_data(data).unwrap();
        out
    }

    #[test]
    fn a_grey_dem_saved_as_rgb_or_pgm_reads_as_grey_and_a_colour_one_is_refused() {
        use png::{BitDepth, ColorType};
        let grey: Vec<u8> = (0..12).map(|i| (i * 20) as u8).collect(); // 4 × 3 pixels
        let s = DemScaling { pixel_x_m: 1.0, pixel_y_m: 1.0, world_size_m: 1.0, cell_m: 0.25, crop_fraction: 1.0, ..DemScaling::CENTRAL };
        let reference = Heightfield::from_dem_png(&png_of(ColorType::Grayscale, BitDepth::Eight, (4, 3), &grey), "g.png", s).unwrap();
        assert!(reference.heights_m.iter().any(|&z| z > 0.0));
        let rgb: Vec<u8> = grey.iter().flat_map(|&v| [v, v, v]).collect();
        let from_rgb = Heightfield::from_dem_png(&png_of(ColorType::Rgb, BitDepth::Eight, (4, 3), &rgb), "c.png", s).unwrap();
        assert_eq!(from_rgb.heights_m, reference.heights_m);
        let pgm = crate::io::image::write_pgm(4, 3, &grey, "dem");
        assert_eq!(Heightfield::from_dem_png(&pgm, "g.pgm", s).unwrap().heights_m, reference.heights_m);
        // 16 bits, RGBA with alpha: the same heights as the 16-bit grey image.
        let grey16: Vec<u8> = grey.iter().flat_map(|&v| [v, 7]).collect();
        let rgba16: Vec<u8> = grey.iter().flat_map(|&v| [v, 7, v, 7, v, 7, 255, 255]).collect();
        let reference16 =
            Heightfield::from_dem_png(&png_of(ColorType::Grayscale, BitDepth::Sixteen, (4, 3), &grey16), "g16.png", s).unwrap();
        let from_rgba16 = Heightfield::from_dem_png(&png_of(ColorType::Rgba, BitDepth::Sixteen, (4, 3), &rgba16), "c16.png", s).unwrap();
        assert_eq!(from_rgba16.heights_m, reference16.heights_m);
        assert_ne!(reference16.heights_m, reference.heights_m);
        let mut colour = rgb.clone();
        colour[3 * 6 + 1] += 1; // pixel 6 (column 2, row 1, grey 120): G differs
        let e = Heightfield::from_dem_png(&png_of(ColorType::Rgb, BitDepth::Eight, (4, 3), &colour), "c.png", s).unwrap_err();
        assert_eq!(
            e.to_string(),
            "c.png: DEM must be a grey image: it is RGB and pixel (column 2, row 1) has R, G, B = 120, 121, 120 (save it as grey)"
        );
    }
}
