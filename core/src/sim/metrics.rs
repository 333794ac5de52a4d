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
use serde::Serialize;

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

/// A mission's figures so far (final once it has ended).
#[derive(Clone, Debug, PartialEq, Serialize)]
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
    let mut s = String::from("time_s,unexplored_pct,cov_trace,pos_cov_trace,rot_cov_trace,ate_m,distance_m,loop_closures\n");
    for r in rows {
        s.push_str(&format!(
            "{:.1},{:.4},{:.6e},{:.6e},{:.6e},{:.5},{:.4},{}\n",
            r.time_s, r.unexplored_pct, r.cov_trace, r.pos_cov_trace, r.rot_cov_trace, r.ate_m, r.distance_m, r.loop_closures
        ));
    }
    s
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
