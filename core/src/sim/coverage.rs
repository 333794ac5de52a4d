//! Exploration progress read from a mission's metrics rows: coverage milestones (Explore-Bench's
//! T_x: the time and distance at which x % of the explorable ground is known; Xu et al., ICRA
//! 2022) and figures at matched coverage, which compare strategies at the same stage of
//! exploration rather than at the same time (a strategy that explores faster would otherwise be
//! judged on a later, larger map).
//!
//! Coverage = 100 − `unexplored_pct`. A level is reached at the first row whose coverage is at
//! least the level; rows come every `metrics_period_s`, so times are that coarse.

use super::metrics::MetricsRow;

/// The milestones `fitslam compare` reports, coverage %.
pub const MILESTONES_PCT: [f64; 4] = [50.0, 75.0, 90.0, 99.0];

/// The matched-coverage levels of the primary metric: 25, 30, …, 90 %.
pub const MATCHED_COVERAGE_PCT: MatchedLevels = MatchedLevels { from_pct: 25.0, to_pct: 90.0, step_pct: 5.0 };

/// Where a coverage level was first reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Milestone {
    /// Mission time, seconds.
    pub time_s: f64,
    /// Distance driven, metres.
    pub distance_m: f64,
}

/// Coverage % of a row.
pub fn coverage_pct(row: &MetricsRow) -> f64 {
    100.0 - row.unexplored_pct
}

/// The first row reaching `level_pct`, as a milestone; `None` if the run never did.
pub fn milestone(rows: &[MetricsRow], level_pct: f64) -> Option<Milestone> {
    first_reaching(rows, level_pct).map(|r| Milestone { time_s: r.time_s, distance_m: r.distance_m })
}

/// `get` of the first row reaching `level_pct`; `None` if the run never did.
pub fn at_coverage(rows: &[MetricsRow], level_pct: f64, get: fn(&MetricsRow) -> f64) -> Option<f64> {
    first_reaching(rows, level_pct).map(get)
}

fn first_reaching(rows: &[MetricsRow], level_pct: f64) -> Option<&MetricsRow> {
    rows.iter().find(|r| coverage_pct(r) >= level_pct - 1e-9)
}

/// Evenly spaced coverage levels, both ends included.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchedLevels {
    /// The first level, %.
    pub from_pct: f64,
    /// The last level, %.
    pub to_pct: f64,
    /// Spacing of the levels, %, > 0.
    pub step_pct: f64,
}

impl MatchedLevels {
    /// The levels, `from_pct` first.
    pub fn levels(&self) -> Vec<f64> {
        let n = ((self.to_pct - self.from_pct) / self.step_pct + 1e-9).floor() as usize;
        (0..=n).map(|k| self.from_pct + k as f64 * self.step_pct).collect()
    }
}

/// The mean of `get` over the rows that first reach each level: the figure at matched coverage.
/// `None` if the run never reached the last level (its mean would cover an easier, earlier
/// part of the exploration only).
pub fn mean_at_matched_coverage(rows: &[MetricsRow], levels: MatchedLevels, get: fn(&MetricsRow) -> f64) -> Option<f64> {
    let values: Option<Vec<f64>> = levels.levels().iter().map(|&l| first_reaching(rows, l).map(get)).collect();
    let values = values?;
    Some(values.iter().sum::<f64>() / values.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(time_s: f64, unexplored_pct: f64, distance_m: f64, cov_trace: f64) -> MetricsRow {
        MetricsRow {
            time_s,
            unexplored_pct,
            cov_trace,
            pos_cov_trace: 0.0,
            rot_cov_trace: 0.0,
            ate_m: 0.0,
            distance_m,
            loop_closures: 0,
            plan_ms: 0.0,
        }
    }

    #[test]
    fn milestones_are_the_first_row_at_or_above_the_level() {
        // Coverage 0, 40, 60, 80, 95 % at t = 0, 10, 20, 30, 40 s.
        let rows = [
            row(0.0, 100.0, 0.0, 0.0),
            row(10.0, 60.0, 4.0, 0.0),
            row(20.0, 40.0, 9.0, 0.0),
            row(30.0, 20.0, 15.0, 0.0),
            row(40.0, 5.0, 22.0, 0.0),
        ];
        assert_eq!(milestone(&rows, 50.0), Some(Milestone { time_s: 20.0, distance_m: 9.0 }));
        assert_eq!(milestone(&rows, 60.0), Some(Milestone { time_s: 20.0, distance_m: 9.0 }));
        assert_eq!(milestone(&rows, 90.0), Some(Milestone { time_s: 40.0, distance_m: 22.0 }));
        assert_eq!(milestone(&rows, 99.0), None);
        assert_eq!(milestone(&[], 50.0), None);
    }

    #[test]
    fn matched_levels_and_the_mean_over_them() {
        assert_eq!(MATCHED_COVERAGE_PCT.levels().len(), 14);
        assert_eq!(MATCHED_COVERAGE_PCT.levels().last(), Some(&90.0));
        let levels = MatchedLevels { from_pct: 25.0, to_pct: 75.0, step_pct: 25.0 };
        assert_eq!(levels.levels(), vec![25.0, 50.0, 75.0]);
        // Coverage 30 % (tr 1), 50 % (tr 2), 80 % (tr 6): level 25 → row 1, 50 → row 2,
        // 75 → row 3: (1 + 2 + 6) / 3 = 3.
        let rows = [row(0.0, 100.0, 0.0, 9.0), row(1.0, 70.0, 0.0, 1.0), row(2.0, 50.0, 0.0, 2.0), row(3.0, 20.0, 0.0, 6.0)];
        assert_eq!(mean_at_matched_coverage(&rows, levels, |r| r.cov_trace), Some(3.0));
        // A run that stops at 50 % has no figure.
        assert_eq!(mean_at_matched_coverage(&rows[..3], levels, |r| r.cov_trace), None);
    }
}
