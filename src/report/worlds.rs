//! World-level inference (docs/experiments.md, Method): with `--world-seeds` the world, not the
//! run, is the unit. Runs of one world share its ground, so their outcomes are not independent
//! draws; the world explains most of the variance of log tr(cov) on the committed families.
//! - `worlds.csv`: per strategy and world, the geometric mean over its seeds of each metric.
//! - Per baseline against the reference (`fit`) on the primary metric: the world-level ratio
//!   R = exp(mean_w ln(ref_w / base_w)), the geometric mean over worlds of the ratio of the
//!   worlds' geometric means; a 95 % cluster-bootstrap interval (worlds resampled with
//!   replacement, each carrying its runs: the percentile interval of the mean log ratio, back
//!   through exp); the two-sided Wilcoxon signed-rank p over the worlds' log ratios; Holm over the
//!   baselines (the declared primary comparisons of one family); and the smallest ratio the test
//!   detects with 80 % power at this number of worlds and this spread.
//! - `forest.{png,svg}`: per baseline each world's ratio and R with its interval, log scale.

use super::{BOOTSTRAP_RESAMPLES, METRICS, RunFigures, num};
use crate::plot::Plot;
use crate::plot::forest::{Forest, ForestRow};
use crate::stats::{bootstrap_mean_ci, detectable_ratio, geometric_mean, holm, sample_sd, wilcoxon_signed_rank};
use anyhow::Result;
use fitslam_core::params::Strategy;
use rand::SeedableRng;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// One strategy in one world: the geometric mean over its seeds of each of [`METRICS`].
#[derive(Clone, Debug, PartialEq)]
pub struct WorldMeans {
    pub strategy: Strategy,
    pub world_seed: u64,
    pub runs: usize,
    pub values: [f64; METRICS.len()],
}

/// Per strategy (in `strategies` order), then world seed: the world means of `figures`; empty
/// without world seeds.
pub fn world_means(strategies: &[Strategy], figures: &[RunFigures]) -> Vec<WorldMeans> {
    let mut out = Vec::new();
    for &s in strategies {
        let mut by_world: BTreeMap<u64, Vec<&RunFigures>> = BTreeMap::new();
        for f in figures.iter().filter(|f| f.strategy == s) {
            if let Some(w) = f.world_seed {
                by_world.entry(w).or_default().push(f);
            }
        }
        for (world_seed, runs) in by_world {
            let values = std::array::from_fn(|m| geometric_mean(&runs.iter().map(|f| (METRICS[m].get)(f)).collect::<Vec<_>>()));
            out.push(WorldMeans { strategy: s, world_seed, runs: runs.len(), values });
        }
    }
    out
}

/// `worlds.csv`: `strategy,world_seed,runs` and one column per metric (summary.csv's names).
pub fn worlds_csv(means: &[WorldMeans]) -> String {
    let mut s = String::from("strategy,world_seed,runs");
    for m in &METRICS {
        let _ = write!(s, ",{}", m.csv);
    }
    s.push('\n');
    for w in means {
        let _ = write!(s, "{},{},{}", w.strategy.name(), w.world_seed, w.runs);
        for v in &w.values {
            let _ = write!(s, ",{v:.6e}");
        }
        s.push('\n');
    }
    s
}

/// The reference against one baseline on the primary metric, world by world.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldComparison {
    pub baseline: Strategy,
    /// (world seed, ln(reference / baseline)) over the worlds where both are finite and positive.
    pub log_ratios: Vec<(u64, f64)>,
    /// exp of the mean log ratio.
    pub ratio: f64,
    /// 95 % cluster-bootstrap interval of the ratio.
    pub ci: (f64, f64),
    /// Two-sided Wilcoxon signed-rank p over the worlds' log ratios.
    pub p: f64,
    /// Holm's adjustment over the baselines.
    pub p_holm: f64,
    /// The ratio (> 1) whose inverse or itself the test detects with 80 % power (module doc).
    pub detectable: f64,
}

/// Each baseline against `reference` on the primary metric ([`METRICS`]\[0\]); a baseline with
/// fewer than two comparable worlds is left out.
pub fn compare_worlds(means: &[WorldMeans], reference: Strategy, baselines: &[Strategy]) -> Vec<WorldComparison> {
    let primary =
        |s: Strategy| -> BTreeMap<u64, f64> { means.iter().filter(|w| w.strategy == s).map(|w| (w.world_seed, w.values[0])).collect() };
    let reference_means = primary(reference);
    let mut out: Vec<WorldComparison> = Vec::new();
    for (bi, &baseline) in baselines.iter().enumerate() {
        let base = primary(baseline);
        let log_ratios: Vec<(u64, f64)> = reference_means
            .iter()
            .filter_map(|(&w, &r)| {
                let b = *base.get(&w)?;
                (r.is_finite() && b.is_finite() && r > 0.0 && b > 0.0).then(|| (w, (r / b).ln()))
            })
            .collect();
        let d: Vec<f64> = log_ratios.iter().map(|&(_, l)| l).collect();
        if d.len() < 2 {
            continue;
        }
        let Some(test) = wilcoxon_signed_rank(&d) else { continue };
        // A fixed stream per baseline, apart from the seed-paired table's streams.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x574f_524c_4400_0000 | bi as u64);
        let Some((lo, hi)) = bootstrap_mean_ci(&d, 0.95, BOOTSTRAP_RESAMPLES, &mut rng) else { continue };
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        out.push(WorldComparison {
            baseline,
            ratio: mean.exp(),
            ci: (lo.exp(), hi.exp()),
            p: test.p,
            p_holm: f64::NAN,
            detectable: detectable_ratio(sample_sd(&d), d.len()),
            log_ratios,
        });
    }
    let adjusted = holm(&out.iter().map(|c| c.p).collect::<Vec<_>>());
    for (c, adj) in out.iter_mut().zip(adjusted) {
        c.p_holm = adj;
    }
    out
}

/// The world-level section of `summary.md`.
pub fn world_level_md(md: &mut String, reference: Strategy, comparisons: &[WorldComparison]) {
    let _ = writeln!(
        md,
        "\n## World level: each baseline against `{r}`, the world as the unit\n\n\
         The primary inference. Per world, the geometric mean over its seeds of tr(cov) at 25–90 % coverage (worlds.csv); \
         ratio = `{r}` / baseline: the geometric mean over worlds of the worlds' ratios (below 1: `{r}` lower), with a 95 % \
         cluster-bootstrap interval (worlds resampled, {BOOTSTRAP_RESAMPLES} resamples), the two-sided Wilcoxon signed-rank p \
         over the worlds' log ratios, Holm's adjustment over the baselines listed (the declared primary comparisons), and the \
         ratio this many worlds detect with 80 % power at the observed spread (a true ratio below 1/R or above R). \
         forest.png shows each world. Every other metric, and the seed-paired table below, is secondary.\n\n\
         | baseline | worlds | ratio [95 % CI] | p | Holm p | detectable at 80 % |\n|---|---|---|---|---|---|",
        r = reference.name()
    );
    for c in comparisons {
        let _ = writeln!(
            md,
            "| {} | {} | {} [{}, {}] | {:.3} | **{:.3}** | 1/{} or {} |",
            c.baseline.name(),
            c.log_ratios.len(),
            num(c.ratio),
            num(c.ci.0),
            num(c.ci.1),
            c.p,
            c.p_holm,
            num(c.detectable),
            num(c.detectable)
        );
    }
}

/// `forest.{png,svg}`: per baseline its worlds' ratios and the world-level ratio with its interval.
pub fn write_forest(out: &Path, world: &str, reference: Strategy, comparisons: &[WorldComparison]) -> Result<()> {
    let rows = comparisons
        .iter()
        .map(|c| ForestRow {
            label: format!("{} / {}", reference.name(), c.baseline.name()),
            points: c.log_ratios.iter().map(|&(_, l)| l.exp()).collect(),
            estimate: c.ratio,
            ci: c.ci,
        })
        .collect();
    Forest {
        title: format!("World-level ratios on tr(cov) at 25–90 % coverage — {world}"),
        x_label: format!("{} / baseline (geometric mean over seeds per world; log scale)", reference.name()),
        rows,
    }
    .write(out, "forest")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn means(strategy: Strategy, primary: &[(u64, f64)]) -> Vec<WorldMeans> {
        primary
            .iter()
            .map(|&(world_seed, v)| {
                let mut values = [1.0; METRICS.len()];
                values[0] = v;
                WorldMeans { strategy, world_seed, runs: 2, values }
            })
            .collect()
    }

    #[test]
    fn world_ratio_by_hand() {
        // Worlds 1–4: fit / random = 0.5, 0.5, 0.5, 2 → ln ratios −ln 2 ×3, +ln 2 → mean −ln 2 / 2
        // → ratio 2^−½ = 0.707107. World 5 has no random figure and is left out.
        let mut m = means(Strategy::Fit, &[(1, 1.0), (2, 2.0), (3, 3.0), (4, 8.0), (5, 1.0)]);
        m.extend(means(Strategy::Random, &[(1, 2.0), (2, 4.0), (3, 6.0), (4, 4.0)]));
        let c = compare_worlds(&m, Strategy::Fit, &[Strategy::Random]);
        assert_eq!(c.len(), 1);
        let c = &c[0];
        assert_eq!(c.log_ratios.iter().map(|&(w, _)| w).collect::<Vec<_>>(), vec![1, 2, 3, 4]);
        assert!((c.ratio - 0.5f64.sqrt()).abs() < 1e-12, "{}", c.ratio);
        // The interval lies within the range of the worlds' ratios and holds the estimate.
        assert!(0.5 - 1e-12 <= c.ci.0 && c.ci.0 <= c.ratio && c.ratio <= c.ci.1 && c.ci.1 <= 2.0 + 1e-12, "{:?}", c.ci);
        // One baseline: Holm changes nothing.
        assert_eq!(c.p, c.p_holm);
    }

    #[test]
    fn holm_runs_over_the_baselines() {
        let mut m = means(Strategy::Fit, &(1..=8).map(|w| (w, 1.0)).collect::<Vec<_>>());
        m.extend(means(Strategy::Random, &(1..=8).map(|w| (w, 2.0 + w as f64)).collect::<Vec<_>>()));
        m.extend(means(Strategy::Greedy, &(1..=8).map(|w| (w, if w % 2 == 0 { 0.5 } else { 1.5 + w as f64 })).collect::<Vec<_>>()));
        let c = compare_worlds(&m, Strategy::Fit, &[Strategy::Random, Strategy::Greedy]);
        assert_eq!(c.len(), 2);
        let raw: Vec<f64> = c.iter().map(|c| c.p).collect();
        assert_eq!(c.iter().map(|c| c.p_holm).collect::<Vec<_>>(), holm(&raw));
        // fit lower in every world against random: the smallest p the test gives 8 worlds.
        assert!(c[0].ratio < 1.0 && c[0].p < 0.05);
    }

    #[test]
    fn worlds_csv_has_one_row_per_strategy_and_world() {
        let mut m = means(Strategy::Fit, &[(1, 1e-3), (2, 2e-3)]);
        m.extend(means(Strategy::Random, &[(1, 3e-3)]));
        let csv = worlds_csv(&m);
        let lines: Vec<&str> = csv.lines().collect();
        assert!(lines[0].starts_with("strategy,world_seed,runs,matched_cov_trace,time_s,"));
        assert_eq!(lines.len(), 4);
        assert!(lines[1].starts_with("fit,1,2,1.000000e-3,1.000000e0,"));
        assert!(lines[3].starts_with("random,1,2,3.000000e-3,"));
    }
}
