//! A mission's metrics (notes §8): one row and one pose of each trajectory every
//! `metrics_period_s`, the final [`Summary`], and their writers (CSV, TUM).
//!
//! The unexplored share counts explorable ground-truth cells still unknown in the robot's map,
//! from the map's known/unknown flags (no estimate needed: O(cells whose disc changed) per row).

use super::localisation::{Localisation, PoseCovariance};
use super::world::World;
use super::world_sim::BodyPose;
use crate::explore::EndReason;
use crate::params::{Strategy, TraversabilityParams};
use crate::traversability::TraversabilityMap;
use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};

/// One metrics row.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MetricsRow {
    /// Mission time, seconds.
    pub time_s: f64,
    /// Explorable cells still unknown in the robot's map, % of the explorable cells.
    pub unexplored_pct: f64,
    /// Trace of the whole pose covariance: `pos_cov_trace + rot_cov_trace` (m² plus rad²).
    pub cov_trace: f64,
    /// Trace of the pose covariance's position block, m².
    pub pos_cov_trace: f64,
    /// Trace of the pose covariance's rotation block, rad².
    pub rot_cov_trace: f64,
    /// |estimated − true| position, metres.
    pub ate_m: f64,
    /// Distance driven so far, metres.
    pub distance_m: f64,
    /// Loop closures so far (0 without SLAM).
    pub loop_closures: u64,
    /// Wall time of the decisions since the previous row, ms (0 without a clock). Not
    /// deterministic: keep it out of byte-compared files.
    pub plan_ms: f64,
}

/// A timestamped 3D pose for TUM trajectories.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StampedPose {
    /// Mission time, seconds.
    pub time_s: f64,
    /// Body position (x, y, z) in the world frame, metres.
    pub position_m: [f64; 3],
    /// Body-to-world rotation as a unit quaternion (x, y, z, w).
    pub quaternion_xyzw: [f64; 4],
}

impl StampedPose {
    fn of((p, r): BodyPose, time_s: f64) -> Self {
        let q = UnitQuaternion::from_rotation_matrix(&r);
        StampedPose { time_s, position_m: [p.x, p.y, p.z], quaternion_xyzw: [q.i, q.j, q.k, q.w] }
    }
}

/// A mission's figures so far (final once it has ended); `summary.json` (read back by
/// `fitslam collect`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The world's name.
    pub world: String,
    /// The goal selector used.
    pub strategy: Strategy,
    /// The localisation used.
    pub localisation: Localisation,
    /// The mission's RNG seed.
    pub seed: u64,
    /// Why the mission ended; `None` while it runs.
    pub end_reason: Option<EndReason>,
    /// Mission time, seconds.
    pub time_s: f64,
    /// Explorable cells still unknown at the last row, % (100 before the first row).
    pub unexplored_pct: f64,
    /// Ground-truth explorable cells of the world.
    pub explorable_cells: usize,
    /// Distance driven, metres.
    pub distance_m: f64,
    /// Root mean square of the rows' position error, metres.
    pub ate_rmse_m: f64,
    /// [`MetricsRow::cov_trace`] at the last row (0 before the first row).
    pub final_cov_trace: f64,
    /// Loop closures (0 without SLAM).
    pub loop_closures: u64,
    /// Selector runs (every retry counts).
    pub decisions: u64,
    /// Goals reached.
    pub goals_reached: u64,
    /// Goals failed (timed out, aborted, rejected, stopped by the bumper).
    pub goals_failed: u64,
    /// Blacklisted goal cells at the end.
    pub blacklist_len: usize,
    /// Times the body entered ground-truth untraversable terrain.
    pub gt_violations: u64,
    /// Times the bumper stopped the robot.
    pub safety_stops: u64,
    /// Recoveries from a trap ([`crate::explore::ExploreParams::trap_recoveries`]).
    pub trap_recoveries: u64,
    /// Paths planned with a tight inflation ([`crate::explore::ExploreParams::tight_inflations_m`]):
    /// to a new goal, or to the current one when periodic replanning found it only so.
    pub tight_plans: u64,
    /// Selector runs that failed even after footprint clearing.
    pub planning_errors: u64,
    /// Landmarks in the robot's landmark map (the SLAM's landmarks with SLAM).
    pub landmarks_mapped: usize,
    /// Lidar scans taken.
    pub scans: u64,
    /// SLAM keyframes (0 without SLAM).
    pub keyframes: usize,
    /// Traversability map rebuilds after loop closures.
    pub reregistrations: u64,
    /// Keyframe updates whose optimisation or covariance failed (the keyframe was kept).
    pub slam_errors: u64,
    /// Visual tracking losses, recoveries by relocalisation and by a new map segment, and the
    /// time spent lost, seconds (SLAM only; `VisualTracking`).
    pub tracking_losses: u64,
    /// Tracking recoveries by re-observing mapped landmarks.
    pub relocalisations: u64,
    /// Tracking recoveries by a new map segment.
    pub new_maps: u64,
    /// Time spent lost, seconds.
    pub lost_s: f64,
    /// Features matched to the wrong landmark (SLAM only; [`super::vision`]).
    pub wrong_associations: u64,
    /// The pose graph's links and loop closures (zeros for the other localisations).
    #[serde(flatten)]
    pub links: crate::slam::LinkStats,
    /// Wall time of every selector run, ms (0 without a clock; not deterministic).
    pub total_plan_ms: f64,
}

/// What one row records.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sample {
    /// Mission time, seconds.
    pub time_s: f64,
    /// The localisation's pose covariance.
    pub covariance: PoseCovariance,
    /// The true body pose: position in the world frame (metres) and body-to-world rotation.
    pub truth: BodyPose,
    /// The estimated body pose, as `truth`.
    pub estimate: BodyPose,
    /// Distance driven so far, metres.
    pub distance_m: f64,
    /// Loop closures so far (0 without SLAM).
    pub loop_closures: u64,
    /// Wall time of every decision so far, ms.
    pub total_plan_ms: f64,
}

/// The rows and trajectories of a mission so far.
#[derive(Clone, Debug, Default)]
pub(crate) struct Metrics {
    rows: Vec<MetricsRow>,
    trajectory_gt: Vec<StampedPose>,
    trajectory_est: Vec<StampedPose>,
    sq_err_sum: f64,
    next_s: f64,
    /// Ground-truth explorable cells that are known in the robot's map.
    known_explorable: usize,
    /// `total_plan_ms` at the last row.
    plan_ms_recorded: f64,
}

impl Metrics {
    /// Whether a row is due at `time_s`.
    pub fn due(&self, time_s: f64) -> bool {
        time_s >= self.next_s - 1e-9
    }

    /// Records a row; the next one is due `period_s` later. The unexplored share is counted on
    /// `map` (its known flags brought up to date) against `world`'s explorable cells.
    pub fn record(&mut self, s: &Sample, map: &mut TraversabilityMap, params: &TraversabilityParams, world: &World, period_s: f64) {
        let unexplored_pct = self.unexplored_pct(map, params, world);
        let ate = (s.estimate.0 - s.truth.0).norm();
        self.sq_err_sum += ate * ate;
        let (pos, rot) = (s.covariance.pos_trace, s.covariance.rot_trace);
        self.rows.push(MetricsRow {
            time_s: s.time_s,
            unexplored_pct,
            cov_trace: pos + rot,
            pos_cov_trace: pos,
            rot_cov_trace: rot,
            ate_m: ate,
            distance_m: s.distance_m,
            loop_closures: s.loop_closures,
            plan_ms: s.total_plan_ms - self.plan_ms_recorded,
        });
        self.plan_ms_recorded = s.total_plan_ms;
        self.trajectory_gt.push(StampedPose::of(s.truth, s.time_s));
        self.trajectory_est.push(StampedPose::of(s.estimate, s.time_s));
        self.next_s = s.time_s + period_s;
    }

    fn unexplored_pct(&mut self, map: &mut TraversabilityMap, params: &TraversabilityParams, world: &World) -> f64 {
        let (explorable, known) = (&world.explorable, &mut self.known_explorable);
        map.refresh_known(params, |i, k| {
            if explorable[i] {
                if k {
                    *known += 1;
                } else {
                    *known -= 1;
                }
            }
        });
        let n = world.explorable_count;
        if n == 0 { 0.0 } else { 100.0 * (n - self.known_explorable) as f64 / n as f64 }
    }

    /// The rows recorded, in time order.
    pub fn rows(&self) -> &[MetricsRow] {
        &self.rows
    }

    /// The true trajectory, one pose per row.
    pub fn trajectory_gt(&self) -> &[StampedPose] {
        &self.trajectory_gt
    }

    /// The estimated trajectory, one pose per row.
    pub fn trajectory_est(&self) -> &[StampedPose] {
        &self.trajectory_est
    }

    /// Root mean square of the rows' ATE, metres (0 without rows).
    pub fn ate_rmse_m(&self) -> f64 {
        if self.rows.is_empty() { 0.0 } else { (self.sq_err_sum / self.rows.len() as f64).sqrt() }
    }
}

/// Metrics as CSV (without `plan_ms`: byte-identical for a seed).
pub fn metrics_csv(rows: &[MetricsRow]) -> String {
    let mut s = format!("{METRICS_HEADER}\n");
    for r in rows {
        s.push_str(&format!(
            "{:.1},{:.4},{:.6e},{:.6e},{:.6e},{:.5},{:.4},{}\n",
            r.time_s, r.unexplored_pct, r.cov_trace, r.pos_cov_trace, r.rot_cov_trace, r.ate_m, r.distance_m, r.loop_closures
        ));
    }
    s
}

/// What is wrong with a `metrics.csv` ([`read_metrics_csv`]).
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum MetricsCsvError {
    /// Not UTF-8 text.
    #[error("not UTF-8 text")]
    NotText,
    /// The first line is not [`METRICS_HEADER`].
    #[error("the header is not `{METRICS_HEADER}`")]
    Header,
    /// A row with the wrong number of fields or a field that is not a number.
    #[error("line {line}: {problem}")]
    Row {
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        problem: String,
    },
}

/// The header line of [`metrics_csv`].
pub const METRICS_HEADER: &str = "time_s,unexplored_pct,cov_trace,pos_cov_trace,rot_cov_trace,ate_m,distance_m,loop_closures";

/// Reads the rows [`metrics_csv`] wrote (to its precision; `plan_ms` is 0: timing.csv has it).
pub fn read_metrics_csv(bytes: &[u8]) -> Result<Vec<MetricsRow>, MetricsCsvError> {
    let text = std::str::from_utf8(bytes).map_err(|_| MetricsCsvError::NotText)?;
    let mut lines = text.lines();
    if lines.next() != Some(METRICS_HEADER) {
        return Err(MetricsCsvError::Header);
    }
    let mut rows = Vec::new();
    for (k, line) in lines.enumerate() {
        let bad = |problem: String| MetricsCsvError::Row { line: k + 2, problem };
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 8 {
            return Err(bad(format!("{} fields, expected 8", fields.len())));
        }
        let mut v = [0.0; 7];
        for (x, f) in v.iter_mut().zip(&fields) {
            *x = f.parse::<f64>().map_err(|_| bad(format!("{f:?} is not a number")))?;
        }
        let loop_closures = fields[7].parse::<u64>().map_err(|_| bad(format!("{:?} is not a count", fields[7])))?;
        let [time_s, unexplored_pct, cov_trace, pos_cov_trace, rot_cov_trace, ate_m, distance_m] = v;
        rows.push(MetricsRow {
            time_s,
            unexplored_pct,
            cov_trace,
            pos_cov_trace,
            rot_cov_trace,
            ate_m,
            distance_m,
            loop_closures,
            plan_ms: 0.0,
        });
    }
    Ok(rows)
}

/// Timing as CSV (`time_s,plan_ms`): wall time, not reproducible.
pub fn timing_csv(rows: &[MetricsRow]) -> String {
    let mut s = String::from("time_s,plan_ms\n");
    for r in rows {
        s.push_str(&format!("{:.1},{:.3}\n", r.time_s, r.plan_ms));
    }
    s
}

/// A trajectory in TUM format (`t x y z qx qy qz qw`).
pub fn tum(poses: &[StampedPose]) -> String {
    let mut s = String::new();
    for p in poses {
        let [x, y, z] = p.position_m;
        let [qx, qy, qz, qw] = p.quaternion_xyzw;
        s.push_str(&format!("{:.3} {x:.5} {y:.5} {z:.5} {qx:.6} {qy:.6} {qz:.6} {qw:.6}\n", p.time_s));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_written_row_reads_back_to_its_printed_digits() {
        let text = format!("{METRICS_HEADER}\n12.5,40.1234,1.234560e-2,1.000000e-2,2.345600e-3,0.01234,5.6789,3\n");
        let rows = read_metrics_csv(text.as_bytes()).unwrap();
        assert_eq!(rows.len(), 1);
        let r = rows[0];
        assert_eq!(
            (r.time_s, r.unexplored_pct, r.cov_trace, r.ate_m, r.distance_m, r.loop_closures),
            (12.5, 40.1234, 0.0123456, 0.01234, 5.6789, 3)
        );
        assert_eq!((r.pos_cov_trace, r.rot_cov_trace, r.plan_ms), (0.01, 0.0023456, 0.0));
        assert_eq!(metrics_csv(&rows), text);
    }

    #[test]
    fn bad_files_name_their_problem() {
        assert_eq!(read_metrics_csv(b"\xff\xfe"), Err(MetricsCsvError::NotText));
        assert_eq!(read_metrics_csv(b"time_s,x\n"), Err(MetricsCsvError::Header));
        assert_eq!(read_metrics_csv(b""), Err(MetricsCsvError::Header));
        let short = format!("{METRICS_HEADER}\n1,2,3\n");
        assert!(matches!(read_metrics_csv(short.as_bytes()), Err(MetricsCsvError::Row { line: 2, .. })));
        let nan_count = format!("{METRICS_HEADER}\n1,2,3,4,5,6,7,-1\n");
        assert!(read_metrics_csv(nan_count.as_bytes()).unwrap_err().to_string().contains("line 2"));
        let word = format!("{METRICS_HEADER}\n1,2,3,4,5,6,7,1\n1,2,x,4,5,6,7,1\n");
        assert!(read_metrics_csv(word.as_bytes()).unwrap_err().to_string().contains("line 3: \"x\""));
    }

    proptest! {
        /// What `metrics_csv` writes reads back to rows that it writes the same way.
        #[test]
        fn writing_what_was_read_gives_the_same_text(
            rows in proptest::collection::vec((0.0f64..1e4, 0.0f64..100.0, 0.0f64..1e3, 0.0f64..10.0, 0.0f64..1e3, 0u64..1000), 0..20)
        ) {
            let rows: Vec<MetricsRow> = rows
                .into_iter()
                .map(|(t, u, c, a, d, l)| MetricsRow { time_s: t, unexplored_pct: u, cov_trace: c, pos_cov_trace: c / 2.0, rot_cov_trace: c / 3.0, ate_m: a, distance_m: d, loop_closures: l, plan_ms: 1.0 })
                .collect();
            let text = metrics_csv(&rows);
            let back = read_metrics_csv(text.as_bytes()).unwrap();
            prop_assert_eq!(back.len(), rows.len());
            prop_assert_eq!(metrics_csv(&back), text);
        }
    }
}
