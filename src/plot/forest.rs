//! A forest plot: one row per comparison, its worlds' ratios as small dots and the pooled ratio
//! as a diamond with its interval, on a log ratio axis with a line at 1 (no difference).

use super::{COLOURS, FAMILY, Plot};
use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;

/// One comparison.
#[derive(Clone, Debug)]
pub struct ForestRow {
    pub label: String,
    /// Each unit's ratio (a world's), drawn as a dot.
    pub points: Vec<f64>,
    /// The pooled ratio and its interval.
    pub estimate: f64,
    pub ci: (f64, f64),
}

/// A forest plot of ratios.
#[derive(Clone, Debug)]
pub struct Forest {
    pub title: String,
    pub x_label: String,
    pub rows: Vec<ForestRow>,
}

/// A ratio on the axis: 3 significant digits.
fn ratio_tick(v: f64) -> String {
    if !(0.01..100.0).contains(&v) {
        format!("{v:.2e}")
    } else {
        format!(
            "{:.*}",
            if v >= 10.0 {
                1
            } else if v >= 1.0 {
                2
            } else {
                3
            },
            v
        )
    }
}

impl Forest {
    /// The x range: every finite positive value, padded by 10 % of its log span, holding 1.
    fn range(&self) -> (f64, f64) {
        let all = self.rows.iter().flat_map(|r| r.points.iter().copied().chain([r.estimate, r.ci.0, r.ci.1]));
        let (lo, hi) = all.filter(|v| v.is_finite() && *v > 0.0).fold((1.0f64, 1.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        let pad = ((hi / lo).ln() * 0.1).max(0.05).exp();
        (lo / pad, hi * pad)
    }
}

impl Plot for Forest {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plot: {e:?}");
        root.fill(&WHITE).map_err(e)?;
        // Drawn in ln(ratio), labelled as ratios: a log axis whose ticks stay dense on a narrow range.
        let (x0, x1) = self.range();
        let (l0, l1) = (x0.ln(), x1.ln());
        let ln = |v: f64| (v.is_finite() && v > 0.0).then(|| v.ln());
        let n = self.rows.len().max(1) as f64;
        let mut chart = ChartBuilder::on(&root)
            .caption(&self.title, (FAMILY, 20))
            .margin(14)
            .x_label_area_size(48)
            .y_label_area_size(10)
            .build_cartesian_2d(l0..l1, 0.3..n + 0.7)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .axis_desc_style((FAMILY, 15))
            .label_style((FAMILY, 14))
            .x_labels(9)
            .x_label_formatter(&|v: &f64| ratio_tick(v.exp()))
            .y_labels(0)
            .disable_y_mesh()
            .max_light_lines(1)
            .light_line_style(RGBColor(238, 238, 238))
            .draw()
            .map_err(e)?;
        chart.draw_series(std::iter::once(PathElement::new([(0.0, 0.3), (0.0, n + 0.7)], BLACK.stroke_width(1)))).map_err(e)?;
        for (k, r) in self.rows.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            // Row k from the top: its label, its units' dots (spread a little in y so that equal
            // ratios stay visible), then the pooled ratio's diamond on its interval.
            let y = n - k as f64;
            chart.draw_series(std::iter::once(Text::new(r.label.clone(), (l0, y + 0.38), (FAMILY, 15)))).map_err(e)?;
            let m = r.points.len().max(1) as f64;
            let dots = r
                .points
                .iter()
                .enumerate()
                .filter_map(|(i, &v)| Some((i, ln(v)?)))
                .map(|(i, x)| Circle::new((x, y + 0.1 + 0.16 * ((i as f64 + 0.5) / m - 0.5)), 3, colour.mix(0.6).filled()));
            chart.draw_series(dots).map_err(e)?;
            if let (Some(lo), Some(hi)) = (ln(r.ci.0), ln(r.ci.1)) {
                chart.draw_series(std::iter::once(PathElement::new([(lo, y - 0.2), (hi, y - 0.2)], BLACK.stroke_width(2)))).map_err(e)?;
            }
            if let Some(x) = ln(r.estimate) {
                let diamond = Polygon::new(vec![(-7, 0), (0, -7), (7, 0), (0, 7)], BLACK.filled());
                chart.draw_series(std::iter::once(EmptyElement::at((x, y - 0.2)) + diamond)).map_err(e)?;
            }
        }
        root.present().map_err(e)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn forest() -> Forest {
        Forest {
            title: "World-level ratios".into(),
            x_label: "fit / baseline".into(),
            rows: vec![
                ForestRow { label: "fit / random".into(), points: vec![0.5, 0.8, 1.2], estimate: 0.78, ci: (0.55, 1.1) },
                ForestRow { label: "fit / greedy".into(), points: vec![2.0, f64::NAN], estimate: 2.0, ci: (2.0, 2.0) },
            ],
        }
    }

    #[test]
    fn range_holds_every_value_and_one() {
        let (lo, hi) = forest().range();
        assert!(lo < 0.5 && hi > 2.0, "{lo} {hi}");
        let only_above =
            Forest { rows: vec![ForestRow { label: "a".into(), points: vec![3.0], estimate: 3.0, ci: (2.0, 4.0) }], ..forest() };
        let (lo, _) = only_above.range();
        assert!(lo < 1.0, "1 stays on the axis: {lo}");
    }

    #[test]
    fn svg_names_the_rows_and_png_is_a_png() {
        let f = forest();
        let svg = f.svg().unwrap();
        assert!(svg.contains("fit / random") && svg.contains("fit / greedy") && svg.contains("World-level ratios"), "row labels");
        assert!(f.png().unwrap().starts_with(b"\x89PNG"));
    }
}
