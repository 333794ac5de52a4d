//! The report of a sweep (notes §8), from its runs' files: `summary.csv`, `summary.md` and the
//! figures, written by `fitslam collect` (and so by `fitslam compare`, which collects at its end).
//! - `unexplored.{png,svg}` and `cov_trace.{png,svg}` (the paper's Figs. 5–6): per strategy, the
//!   mean over seeds and a band from the 25th to the 75th percentile, on a common time grid of
//!   [`GRID_POINTS`] points from 0 to the longest run's end. A run that ended earlier holds its last
//!   value (an explored map stays explored; its covariance stays where it was).
//!   `coverage_distance.{png,svg}`: coverage over the distance driven, on the same kind of grid;
//!   `cov_coverage.{png,svg}`: tr(cov) when each coverage level 0, 1, …, 100 % was first reached,
//!   over the runs that reached it.
//! - `summary.csv`: one row per run (strategy order as planned, then world seed, then seed);
//!   byte-identical wherever and in whatever order the runs were made (no wall times in it).
//! - `summary.md`: per strategy and metric the median, the interquartile range and min–max over
//!   seeds; the coverage milestones (time and distance to 50/75/90/99 %); and per baseline and
//!   metric, paired by seed (same world, same noise), the mean difference to `fit` (to the first
//!   strategy listed when `fit` is not) with a 95 % bootstrap interval, the Wilcoxon signed-rank
//!   p-value and Holm's adjustment over the metrics. The primary metric, named in advance
//!   (docs/experiments.md), is the mean tr(cov) at matched coverage 25–90 %.

use crate::load;
use crate::mission_run::end_reason;
use crate::plot::{self, Curve};
use crate::stats::{Spread, bootstrap_mean_ci, holm, percentile, wilcoxon_signed_rank};
use anyhow::Result;
use fitslam_core::explore::EndReason;
use fitslam_core::params::Strategy;
use fitslam_core::sim::coverage::{
    MATCHED_COVERAGE_PCT, MILESTONES_PCT, Milestone, at_coverage, coverage_pct, mean_at_matched_coverage, milestone,
};
use fitslam_core::sim::{Localisation, MetricsRow, Summary};
use rand::SeedableRng;
use std::fmt::Write as _;
use std::path::Path;

mod worlds;

/// Points of the common time grid of the figures.
pub const GRID_POINTS: usize = 400;

/// What the report says of the sweep as a whole.
#[derive(Clone, Copy)]
pub struct Heading<'a> {
    /// The world's name (its file's `name`).
    pub world: &'a str,
    /// The strategies, in the order planned.
    pub strategies: &'a [Strategy],
    /// The command that plans (or compares) this sweep.
    pub command: &'a str,
    pub localisation: Localisation,
}

/// Writes `summary.csv`, the figures and `summary.md` of `figures` (in plan order) into `out`,
/// and with world seeds `worlds.csv` and `forest.{png,svg}` ([`worlds`]).
pub fn write(out: &Path, heading: &Heading, figures: &[RunFigures]) -> Result<()> {
    load::write(&out.join("summary.csv"), summary_csv(figures).as_bytes())?;
    write_figures(out, heading.world, heading.strategies, figures)?;
    let means = worlds::world_means(heading.strategies, figures);
    let (reference, baselines) = reference_and_baselines(heading.strategies);
    let comparisons = worlds::compare_worlds(&means, reference, &baselines);
    if !means.is_empty() {
        load::write(&out.join("worlds.csv"), worlds::worlds_csv(&means).as_bytes())?;
        worlds::write_forest(out, heading.world, reference, &comparisons)?;
    }
    let mut world_level = String::new();
    if !comparisons.is_empty() {
        worlds::world_level_md(&mut world_level, reference, &comparisons);
    }
    let md = summary_md(heading, figures, &world_level);
    load::write(&out.join("summary.md"), md.as_bytes())
}

/// The files the report writes, as its one-line note names them.
pub fn files(figures: &[RunFigures]) -> String {
    let worlds = if figures.iter().any(|f| f.world_seed.is_some()) { "worlds.csv, forest.png, " } else { "" };
    format!("summary.md, summary.csv, {worlds}unexplored.png, cov_trace.png, coverage_distance.png, cov_coverage.png")
}

/// `fit`, else the first strategy, and the others in order.
fn reference_and_baselines(strategies: &[Strategy]) -> (Strategy, Vec<Strategy>) {
    let reference = strategies.iter().copied().find(|&s| s == Strategy::Fit).unwrap_or(strategies[0]);
    (reference, strategies.iter().copied().filter(|&s| s != reference).collect())
}

/// The figures of one run that the summary uses.
#[derive(Clone, Debug)]
pub struct RunFigures {
    strategy: Strategy,
    /// The world seed, with `--world-seeds`.
    world_seed: Option<u64>,
    seed: u64,
    summary: Summary,
    mean_cov_trace: f64,
    /// Mean tr(cov) and ATE at matched coverage 25–90 %; NaN if the run never reached 90 %.
    matched_cov_trace: f64,
    matched_ate_m: f64,
    /// Where each of [`MILESTONES_PCT`] was reached.
    milestones: [Option<Milestone>; MILESTONES_PCT.len()],
    rows: Vec<MetricsRow>,
}

impl RunFigures {
    pub fn new(strategy: Strategy, world_seed: Option<u64>, seed: u64, summary: Summary, rows: Vec<MetricsRow>) -> Self {
        let mean_cov_trace = if rows.is_empty() { 0.0 } else { rows.iter().map(|r| r.cov_trace).sum::<f64>() / rows.len() as f64 };
        let matched = |get: fn(&MetricsRow) -> f64| mean_at_matched_coverage(&rows, MATCHED_COVERAGE_PCT, get).unwrap_or(f64::NAN);
        let (matched_cov_trace, matched_ate_m) = (matched(|r| r.cov_trace), matched(|r| r.ate_m));
        let milestones = MILESTONES_PCT.map(|level| milestone(&rows, level));
        Self { strategy, world_seed, seed, summary, mean_cov_trace, matched_cov_trace, matched_ate_m, milestones, rows }
    }

    /// Time to 90 % coverage, NaN if never reached.
    fn t90_s(&self) -> f64 {
        self.milestones[2].map_or(f64::NAN, |m| m.time_s)
    }
}

/// A metric of the summary: its name, column header, and how to read it from a run.
struct Metric {
    csv: &'static str,
    header: &'static str,
    get: fn(&RunFigures) -> f64,
}

const METRICS: [Metric; 14] = [
    // The primary metric (docs/experiments.md): u2's purpose is a better-localised robot at the
    // same stage of exploration.
    Metric { csv: "matched_cov_trace", header: "tr(cov) at 25–90 % coverage", get: |r| r.matched_cov_trace },
    Metric { csv: "time_s", header: "end time (s)", get: |r| r.summary.time_s },
    Metric { csv: "t90_s", header: "T_90 (s)", get: RunFigures::t90_s },
    Metric { csv: "unexplored_pct", header: "final unexplored (%)", get: |r| r.summary.unexplored_pct },
    Metric { csv: "mean_cov_trace", header: "mean tr(cov)", get: |r| r.mean_cov_trace },
    Metric { csv: "final_cov_trace", header: "final tr(cov)", get: |r| r.summary.final_cov_trace },
    Metric { csv: "matched_ate_m", header: "ATE at 25–90 % (m)", get: |r| r.matched_ate_m },
    Metric { csv: "ate_rmse_m", header: "ATE RMSE (m)", get: |r| r.summary.ate_rmse_m },
    Metric { csv: "distance_m", header: "distance (m)", get: |r| r.summary.distance_m },
    Metric { csv: "gt_violations", header: "GT violations", get: |r| r.summary.gt_violations as f64 },
    // The simulated bumper (`safety_stop`) that stops the robot before a ground-truth lethal
    // cell: while it never fires, the run is the one without it, so 0 violations is the robot's.
    Metric { csv: "safety_stops", header: "safety stops", get: |r| r.summary.safety_stops as f64 },
    Metric { csv: "loop_closures", header: "loop closures", get: |r| r.summary.loop_closures as f64 },
    // The visual front end's failures (SLAM only, `sim::vision`): where localisation broke down.
    Metric { csv: "tracking_losses", header: "tracking losses", get: |r| r.summary.tracking_losses as f64 },
    Metric { csv: "lost_s", header: "time lost (s)", get: |r| r.summary.lost_s },
];

/// One row per run, strategy order, then world seed order, then seed order (the `world_seed`
/// column only with world seeds).
fn summary_csv(figures: &[RunFigures]) -> String {
    let worlds = figures.iter().any(|f| f.world_seed.is_some());
    let mut s = String::from(if worlds { "strategy,world_seed,seed,end_reason" } else { "strategy,seed,end_reason" });
    for m in &METRICS {
        s.push(',');
        s.push_str(m.csv);
    }
    for level in MILESTONES_PCT {
        let _ = write!(s, ",t{level:.0}_s,d{level:.0}_m");
    }
    s.push_str(",goals_reached,goals_failed,decisions,trap_recoveries\n");
    for f in figures {
        let _ = write!(s, "{},", f.strategy.name());
        if let Some(w) = f.world_seed {
            let _ = write!(s, "{w},");
        }
        let _ = write!(s, "{},{}", f.seed, end_reason(f.summary.end_reason));
        for m in &METRICS {
            let _ = write!(s, ",{:.6e}", (m.get)(f));
        }
        for m in &f.milestones {
            let (t, d) = m.map_or((f64::NAN, f64::NAN), |m| (m.time_s, m.distance_m));
            let _ = write!(s, ",{t:.6e},{d:.6e}");
        }
        let _ =
            writeln!(s, ",{},{},{},{}", f.summary.goals_reached, f.summary.goals_failed, f.summary.decisions, f.summary.trap_recoveries);
    }
    s
}

/// `get` at each grid value of the row's non-decreasing `x` (time or distance): the last row at
/// or before it (the first row before the first).
fn resample(rows: &[MetricsRow], grid: &[f64], x: fn(&MetricsRow) -> f64, get: fn(&MetricsRow) -> f64) -> Vec<f64> {
    let mut k = 0;
    grid.iter()
        .map(|&t| {
            while k + 1 < rows.len() && x(&rows[k + 1]) <= t {
                k += 1;
            }
            rows.get(k).map(get).unwrap_or(f64::NAN)
        })
        .collect()
}

/// `n` evenly spaced values from 0 to `end`.
fn grid_to(end: f64, n: usize) -> Vec<f64> {
    (0..n).map(|k| end * k as f64 / (n - 1) as f64).collect()
}

/// Mean and 25–75 % band per strategy of `sample(run)` (one value per `grid` point, NaN where a
/// run has none) over the runs that have a value there.
fn curves(strategies: &[Strategy], figures: &[RunFigures], grid: &[f64], sample: impl Fn(&RunFigures) -> Vec<f64>) -> Vec<Curve> {
    strategies
        .iter()
        .map(|&s| {
            let runs: Vec<Vec<f64>> = figures.iter().filter(|f| f.strategy == s).map(&sample).collect();
            let column = |k: usize| -> Vec<f64> { runs.iter().map(|r| r[k]).filter(|v| v.is_finite()).collect() };
            let (mut mean, mut lo, mut hi) = (Vec::new(), Vec::new(), Vec::new());
            for k in 0..grid.len() {
                let c = column(k);
                mean.push(if c.is_empty() { f64::NAN } else { c.iter().sum::<f64>() / c.len() as f64 });
                lo.push(percentile(&c, 0.25).unwrap_or(f64::NAN));
                hi.push(percentile(&c, 0.75).unwrap_or(f64::NAN));
            }
            Curve { label: format!("{} (n = {})", s.name(), runs.len()), x: grid.to_vec(), y: mean, band: Some((lo, hi)) }
        })
        .collect()
}

/// Over time: % unexplored and tr(cov) (the paper's Figs. 5–6); over distance: coverage; over
/// coverage: tr(cov) when each level was first reached (a run that never reached it has none).
fn write_figures(out: &std::path::Path, world: &str, strategies: &[Strategy], figures: &[RunFigures]) -> Result<()> {
    let subject = format!("{world} (mean over seeds, band 25–75 %)");
    let last = |x: fn(&MetricsRow) -> f64| figures.iter().filter_map(|f| f.rows.last()).map(x).fold(0.0, f64::max);
    let time = grid_to(last(|r| r.time_s), GRID_POINTS);
    let by_time = |get| curves(strategies, figures, &time, |f| resample(&f.rows, &time, |r| r.time_s, get));
    plot::write_mission_figures(out, &subject, by_time(|r| r.unexplored_pct), by_time(|r| r.cov_trace))?;
    let distance = grid_to(last(|r| r.distance_m), GRID_POINTS);
    let coverage_by_distance = curves(strategies, figures, &distance, |f| resample(&f.rows, &distance, |r| r.distance_m, coverage_pct));
    let levels = grid_to(100.0, 101);
    let cov_by_coverage = curves(strategies, figures, &levels, |f| {
        levels.iter().map(|&l| at_coverage(&f.rows, l, |r| r.cov_trace).unwrap_or(f64::NAN)).collect()
    });
    plot::write_coverage_figures(out, &subject, coverage_by_distance, cov_by_coverage)
}

/// A number for a table: 3 significant digits, plain when 0.01 ≤ |v| < 10⁵.
fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(0.01..1e5).contains(&a) {
        format!("{v:.2e}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// Resamples of the bootstrap intervals.
const BOOTSTRAP_RESAMPLES: usize = 10_000;

/// One table cell: the spread of `values` over the runs where it is defined (NaN: a coverage
/// level never reached), with their count when some are missing.
fn spread_cell(md: &mut String, values: &[f64]) {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    match Spread::of(&finite) {
        Some(sp) => {
            let _ = write!(md, " **{}** [{}–{}] ({}–{})", num(sp.median), num(sp.q25), num(sp.q75), num(sp.min), num(sp.max));
            if finite.len() < values.len() {
                let _ = write!(md, " n = {}", finite.len());
            }
            md.push_str(" |");
        }
        None => md.push_str(" – |"),
    }
}

/// `summary.md`; `world_level` (the primary inference with world seeds, or empty) comes before
/// the seed-paired table.
fn summary_md(heading: &Heading, figures: &[RunFigures], world_level: &str) -> String {
    let Heading { world, strategies, command, localisation } = *heading;
    let values = |s: Strategy, m: &Metric| -> Vec<f64> { figures.iter().filter(|f| f.strategy == s).map(m.get).collect() };
    let mut md = format!("# fitslam compare — {world}\n\n`{command}`\n\n");
    let first: Vec<&RunFigures> = figures.iter().filter(|f| f.strategy == strategies[0]).collect();
    let mut seeds: Vec<u64> = first.iter().map(|f| f.seed).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let worlds: Vec<u64> = first.iter().filter_map(|f| f.world_seed).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    if let (Some(a), Some(b)) = (worlds.first(), worlds.last()) {
        let _ = write!(md, "{} world seeds ({a}–{b}, each a member of the world file's family) × ", worlds.len());
    }
    let _ = writeln!(
        md,
        "{} strategies × {} seeds ({}–{}), localisation `{}`. Each cell: **median** [25–75 %] (min–max) over the seeds \
         (n = k: only k runs have the figure). *finished* = runs that ended with no frontier left (the others hit the time limit, got stuck, or stayed walled in by their map after their recoveries: `trapped`; see summary.csv, which also counts each run's `trap_recoveries`). \
         tr(cov) is the trace of the current pose's covariance (m² + rad²: the 6×6 SLAM marginal with `slam` localisation, the (x, y, θ) one with `odometry`); mean tr(cov) is its average over the run. \
         *At 25–90 % coverage*: the mean over the coverage levels 25, 30, …, 90 % of the value when the run first reached each level \
         (the primary metric: tr(cov) there; a run that never reached 90 % has none). T_90: the time to 90 % coverage.\n",
        strategies.len(),
        seeds.len(),
        seeds.first().copied().unwrap_or(0),
        seeds.last().copied().unwrap_or(0),
        localisation.name(),
    );
    metrics_header(&mut md, &["strategy", "runs", "finished"]);
    for &s in strategies {
        let runs: Vec<&RunFigures> = figures.iter().filter(|f| f.strategy == s).collect();
        let finished = runs.iter().filter(|f| f.summary.end_reason == Some(EndReason::NoFrontier)).count();
        let _ = write!(md, "| {} | {} | {finished} |", s.name(), runs.len());
        for m in &METRICS {
            spread_cell(&mut md, &values(s, m));
        }
        md.push('\n');
    }
    milestones_md(&mut md, strategies, figures);
    md.push_str(world_level);
    let (reference, baselines) = reference_and_baselines(strategies);
    if !baselines.is_empty() {
        paired_md(&mut md, reference, &baselines, figures);
    }
    md
}

/// A table's header: the `lead` columns, then one per metric.
fn metrics_header(md: &mut String, lead: &[&str]) {
    md.push('|');
    for c in lead.iter().copied().chain(METRICS.iter().map(|m| m.header)) {
        let _ = write!(md, " {c} |");
    }
    md.push_str("\n|");
    md.push_str(&"---|".repeat(lead.len() + METRICS.len()));
    md.push('\n');
}

/// Time and distance to each coverage milestone, per strategy.
fn milestones_md(md: &mut String, strategies: &[Strategy], figures: &[RunFigures]) {
    md.push_str(
        "\n## Coverage milestones\n\nTime (s) and distance (m) at which the run first knew 50, 75, 90 and 99 % of the explorable \
         ground (Explore-Bench's T_x): **median** [25–75 %] (min–max) over the runs that reached it, n = k when some did not.\n\n| strategy |",
    );
    for level in MILESTONES_PCT {
        let _ = write!(md, " T_{level:.0} (s) | D_{level:.0} (m) |");
    }
    md.push_str("\n|---|");
    md.push_str(&"---|---|".repeat(MILESTONES_PCT.len()));
    md.push('\n');
    for &s in strategies {
        let runs: Vec<&RunFigures> = figures.iter().filter(|f| f.strategy == s).collect();
        let _ = write!(md, "| {} |", s.name());
        for k in 0..MILESTONES_PCT.len() {
            let at = |get: fn(&Milestone) -> f64| runs.iter().map(|f| f.milestones[k].as_ref().map_or(f64::NAN, get)).collect::<Vec<_>>();
            spread_cell(md, &at(|m| m.time_s));
            spread_cell(md, &at(|m| m.distance_m));
        }
        md.push('\n');
    }
}

/// One cell of the paired table.
struct PairedCell {
    pairs: usize,
    mean: f64,
    ci: (f64, f64),
    p: f64,
}

/// Each baseline against `reference`, paired by seed.
fn paired_md(md: &mut String, reference: Strategy, baselines: &[Strategy], figures: &[RunFigures]) {
    let worlds = figures.iter().any(|f| f.world_seed.is_some());
    let _ = writeln!(
        md,
        "\n## Each baseline against `{r}`, paired by {by}{secondary}\n\nRuns with the same {by} share the world and the sensor noise, so \
         they are compared in pairs: d = `{r}` − baseline per {per} (pairs where both have the figure). Each cell: the mean of d \
         [95 % percentile-bootstrap interval, {BOOTSTRAP_RESAMPLES} resamples], the two-sided Wilcoxon signed-rank p-value \
         (normal approximation, tie and continuity corrections, zero differences dropped), and in bold Holm's adjusted p over \
         the {m} metrics of the row. Negative d: `{r}` lower.\n",
        r = reference.name(),
        m = METRICS.len(),
        by = if worlds { "world seed and seed" } else { "seed" },
        per = if worlds { "pair" } else { "seed" },
        secondary = if worlds { " (secondary: runs of one world are not independent)" } else { "" },
    );
    metrics_header(md, &["baseline"]);
    for (bi, &b) in baselines.iter().enumerate() {
        let cells: Vec<Option<PairedCell>> = METRICS
            .iter()
            .enumerate()
            .map(|(mi, m)| {
                let d = paired_differences(figures, reference, b, m.get);
                let test = wilcoxon_signed_rank(&d)?;
                // One fixed stream per cell: the same summary whatever the run order.
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(((bi as u64) << 32) | mi as u64);
                let ci = bootstrap_mean_ci(&d, 0.95, BOOTSTRAP_RESAMPLES, &mut rng)?;
                Some(PairedCell { pairs: d.len(), mean: d.iter().sum::<f64>() / d.len() as f64, ci, p: test.p })
            })
            .collect();
        let tested: Vec<f64> = cells.iter().flatten().map(|c| c.p).collect();
        let mut adjusted = holm(&tested).into_iter();
        let _ = write!(md, "| {} |", b.name());
        for cell in &cells {
            match cell {
                Some(c) => {
                    let adj = adjusted.next().unwrap_or(f64::NAN);
                    let (n, p, (lo, hi)) = (c.pairs, c.p, c.ci);
                    let _ = write!(md, " {} [{}, {}] p = {p:.3}, **{adj:.3}** (n = {n}) |", num(c.mean), num(lo), num(hi));
                }
                None => md.push_str(" – |"),
            }
        }
        md.push('\n');
    }
}

/// `reference − baseline` per (world seed, seed), over the pairs where both runs have a finite
/// figure.
fn paired_differences(figures: &[RunFigures], reference: Strategy, baseline: Strategy, get: fn(&RunFigures) -> f64) -> Vec<f64> {
    figures
        .iter()
        .filter(|f| f.strategy == reference)
        .filter_map(|r| {
            let b = figures.iter().find(|f| f.strategy == baseline && f.world_seed == r.world_seed && f.seed == r.seed)?;
            let (x, y) = (get(r), get(b));
            (x.is_finite() && y.is_finite()).then_some(x - y)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(time_s: f64, unexplored_pct: f64) -> MetricsRow {
        MetricsRow {
            time_s,
            unexplored_pct,
            cov_trace: 0.0,
            pos_cov_trace: 0.0,
            rot_cov_trace: 0.0,
            ate_m: 0.0,
            distance_m: 0.0,
            loop_closures: 0,
            plan_ms: 0.0,
        }
    }

    #[test]
    fn resample_holds_the_last_value() {
        let rows = [row(0.0, 100.0), row(10.0, 50.0), row(20.0, 30.0)];
        let grid = [0.0, 5.0, 10.0, 15.0, 25.0, 100.0];
        assert_eq!(resample(&rows, &grid, |r| r.time_s, |r| r.unexplored_pct), vec![100.0, 100.0, 50.0, 50.0, 30.0, 30.0]);
        assert!(resample(&[], &grid, |r| r.time_s, |r| r.unexplored_pct).iter().all(|v| v.is_nan()));
    }

    #[test]
    fn numbers_in_tables() {
        assert_eq!(num(0.0), "0");
        assert_eq!(num(1234.4), "1234");
        assert_eq!(num(12.34), "12.3");
        assert_eq!(num(1.234), "1.23");
        assert_eq!(num(0.001234), "1.23e-3");
    }
}
