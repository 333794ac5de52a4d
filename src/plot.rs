//! Line plots over time as SVG and PNG with `plotters`: title, axis labels with units, legend,
//! and optionally a shaded band per curve (used by `compare` for the spread over seeds).
//!
//! Text is drawn with DejaVu Sans embedded in the binary (`assets/fonts/`, Bitstream Vera
//! licence) through plotters' `ab_glyph` backend, so the PNGs have text on a machine without any
//! system font. The SVGs carry `<text>` elements (the viewer's sans-serif font).

pub mod forest;

use crate::load;
use anyhow::{Result, anyhow};
use fitslam_core::io;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// DejaVu Sans 2.37 (Debian `fonts-dejavu-core`); licence in `assets/fonts/LICENSE-DejaVu.txt`.
static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

/// Pixel size of the PNG (and the SVG's view box).
pub const SIZE_PX: (u32, u32) = (900, 560);

/// Matplotlib's "tab10" colours, assigned to curves in order.
const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// One curve: `y` over `x`; `band` = (lower, upper) at the same `x`, shaded.
#[derive(Clone, Debug)]
pub struct Curve {
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub band: Option<(Vec<f64>, Vec<f64>)>,
}

/// A figure of curves.
#[derive(Clone, Debug)]
pub struct Figure {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// Fixed y range; default: from 0 (or the lowest value if negative) to the highest + 5 %.
    pub y_range: Option<(f64, f64)>,
    pub curves: Vec<Curve>,
}

fn register_font() -> Result<()> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
    if ok { Ok(()) } else { Err(anyhow!("the embedded font cannot be read")) }
}

fn finite(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.filter(|x| x.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)))
}

/// Tick labels: plain with 0–1 decimals from 1 up, 3 decimals in [0.1, 1), scientific with 3
/// significant digits below 0.1 or from 10⁵ (so close ticks of small values stay distinct).
fn tick(v: &f64) -> String {
    let a = v.abs();
    if *v == 0.0 {
        "0".into()
    } else if !(0.1..1e5).contains(&a) {
        format!("{v:.2e}")
    } else if a < 1.0 {
        format!("{v:.3}")
    } else if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

/// A figure drawn by plotters at [`SIZE_PX`], written as SVG and PNG.
pub trait Plot {
    /// Draws the figure on `root`.
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static;

    /// The figure as an SVG document.
    fn svg(&self) -> Result<String> {
        register_font()?;
        let mut s = String::new();
        self.draw(SVGBackend::with_string(&mut s, SIZE_PX).into_drawing_area())?;
        Ok(s)
    }

    /// The figure as a PNG (RGB8).
    fn png(&self) -> Result<Vec<u8>> {
        register_font()?;
        let (w, h) = SIZE_PX;
        let mut rgb = vec![255u8; w as usize * h as usize * 3];
        self.draw(BitMapBackend::with_buffer(&mut rgb, SIZE_PX).into_drawing_area())?;
        Ok(io::write_png_rgb8(w as usize, h as usize, &rgb)?)
    }

    /// Writes `DIR/STEM.svg` and `DIR/STEM.png`.
    fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        load::write(&dir.join(format!("{stem}.svg")), self.svg()?.as_bytes())?;
        load::write(&dir.join(format!("{stem}.png")), &self.png()?)
    }
}

impl Figure {
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let (_, t_hi) = finite(self.curves.iter().flat_map(|c| c.x.iter().copied()));
        let t = (0.0, if t_hi.is_finite() && t_hi > 0.0 { t_hi } else { 1.0 });
        let y = self.y_range.unwrap_or_else(|| {
            let all = self.curves.iter().flat_map(|c| {
                let band = c.band.iter().flat_map(|(lo, hi)| lo.iter().chain(hi.iter()));
                c.y.iter().chain(band).copied()
            });
            let (lo, hi) = finite(all);
            if !lo.is_finite() {
                return (0.0, 1.0);
            }
            let lo = lo.min(0.0);
            if hi - lo < 1e-12 { (lo, lo + 1.0) } else { (lo, hi + 0.05 * (hi - lo)) }
        });
        (t, y)
    }
}

impl Plot for Figure {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plot: {e:?}");
        root.fill(&WHITE).map_err(e)?;
        let ((t0, t1), (y0, y1)) = self.ranges();
        let mut chart = ChartBuilder::on(&root)
            .caption(&self.title, (FAMILY, 22))
            .margin(14)
            .x_label_area_size(48)
            .y_label_area_size(78)
            .build_cartesian_2d(t0..t1, y0..y1)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .axis_desc_style((FAMILY, 16))
            .label_style((FAMILY, 14))
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .max_light_lines(2)
            .light_line_style(RGBColor(238, 238, 238))
            .draw()
            .map_err(e)?;
        for (k, c) in self.curves.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            if let Some((lo, hi)) = &c.band {
                let mut ring: Vec<(f64, f64)> = c.x.iter().copied().zip(lo.iter().copied()).collect();
                ring.extend(c.x.iter().copied().zip(hi.iter().copied()).rev());
                chart.draw_series(std::iter::once(Polygon::new(ring, colour.mix(0.18).filled()))).map_err(e)?;
            }
            let points = c.x.iter().copied().zip(c.y.iter().copied()).filter(|(t, y)| t.is_finite() && y.is_finite());
            chart
                .draw_series(LineSeries::new(points, colour.stroke_width(2)))
                .map_err(e)?
                .label(c.label.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 22, y)], colour.stroke_width(3)));
        }
        chart
            .configure_series_labels()
            .label_font((FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(e)?;
        root.present().map_err(e)?;
        Ok(())
    }
}

/// The y label of cov_trace plots: the trace of the pose covariance (6×6 with SLAM, (x, y, θ) with
/// odometry) adds m² and rad².
const COV_TRACE_LABEL: &str = "tr(cov) (m² + rad²)";

/// The two figures of a mission or a comparison (notes §8), `DIR/unexplored.{svg,png}` and
/// `DIR/cov_trace.{svg,png}`: % unexplored and tr(cov) over time; `subject` ends both titles.
pub fn write_mission_figures(dir: &Path, subject: &str, unexplored: Vec<Curve>, cov_trace: Vec<Curve>) -> Result<()> {
    let figure = |what: &str, y_label: &str, y_range, curves| Figure {
        title: format!("{what} — {subject}"),
        x_label: "time (s)".into(),
        y_label: y_label.into(),
        y_range,
        curves,
    };
    figure("Unexplored area", "unexplored (% of explorable cells)", Some((0.0, 100.0)), unexplored).write(dir, "unexplored")?;
    figure("Pose covariance trace", COV_TRACE_LABEL, None, cov_trace).write(dir, "cov_trace")
}

/// The two figures of a comparison over progress, `DIR/coverage_distance.{svg,png}` (coverage
/// over the distance driven) and `DIR/cov_coverage.{svg,png}` (tr(cov) over coverage).
pub fn write_coverage_figures(dir: &Path, subject: &str, coverage_by_distance: Vec<Curve>, cov_by_coverage: Vec<Curve>) -> Result<()> {
    Figure {
        title: format!("Coverage over distance — {subject}"),
        x_label: "distance driven (m)".into(),
        y_label: "coverage (% of explorable cells)".into(),
        y_range: Some((0.0, 100.0)),
        curves: coverage_by_distance,
    }
    .write(dir, "coverage_distance")?;
    Figure {
        title: format!("Pose covariance over coverage — {subject}"),
        x_label: "coverage first reached (% of explorable cells)".into(),
        y_label: COV_TRACE_LABEL.into(),
        y_range: None,
        curves: cov_by_coverage,
    }
    .write(dir, "cov_coverage")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure() -> Figure {
        Figure {
            title: "Unexplored area".into(),
            x_label: "time (s)".into(),
            y_label: "unexplored (%)".into(),
            y_range: None,
            curves: vec![Curve {
                label: "fit".into(),
                x: vec![0.0, 10.0, 20.0],
                y: vec![100.0, 60.0, 20.0],
                band: Some((vec![100.0, 50.0, 10.0], vec![100.0, 70.0, 30.0])),
            }],
        }
    }

    #[test]
    fn svg_has_title_labels_and_legend() {
        let s = figure().svg().unwrap();
        for text in ["Unexplored area", "time (s)", "unexplored (%)", "\nfit\n", "<polygon"] {
            assert!(s.contains(text), "{text} missing");
        }
    }

    #[test]
    fn png_has_dark_text_pixels_in_the_title_area() {
        let png = figure().png().unwrap();
        assert!(png.starts_with(b"\x89PNG"));
        // The title band (top 40 px) of the rendered buffer must contain dark (text) pixels.
        let (w, h) = SIZE_PX;
        let mut rgb = vec![255u8; w as usize * h as usize * 3];
        figure().draw(BitMapBackend::with_buffer(&mut rgb, SIZE_PX).into_drawing_area()).unwrap();
        let dark = rgb[..w as usize * 40 * 3].chunks(3).filter(|p| p.iter().all(|&c| c < 100)).count();
        assert!(dark > 50, "only {dark} dark pixels in the title band");
    }

    #[test]
    fn ticks_stay_distinct_for_small_values() {
        assert_eq!(tick(&0.0), "0");
        assert_eq!(tick(&0.0015), "1.50e-3");
        assert_eq!(tick(&0.002), "2.00e-3");
        assert_eq!(tick(&0.25), "0.250");
        assert_eq!(tick(&20.0), "20");
        assert_eq!(tick(&12.5), "12.5");
        assert_eq!(tick(&2.0e5), "2.00e5");
    }

    #[test]
    fn empty_and_flat_figures_still_render() {
        let mut f = figure();
        f.curves[0].y = vec![0.0; 3];
        f.curves[0].band = None;
        assert!(f.png().is_ok());
        f.curves.clear();
        assert!(f.svg().is_ok());
    }
}
