//! Visual tracking and its loss (ORB-SLAM's tracking states, at keyframes). A keyframe that
//! matches fewer than `min_tracked` mapped landmarks loses tracking: its observations are
//! dropped and the pose comes from wheel odometry alone (with its slip on slopes). While lost,
//! a keyframe that matches `relocalise_min` mapped landmarks relocalises (its observations join
//! the map like a loop closure); one with `new_map_min` features starts a new map segment from
//! its new landmarks only, linked to the old segment by the odometry across the loss and joined
//! to the old landmarks at their first re-observation. Thresholds: [`VisionParams`]. O(features).

use crate::sim::camera::CameraObservation;
use crate::sim::vision::VisionParams;
use nalgebra::Point3;
use serde::Serialize;

/// Radius around the robot over which a loss's ground texture is counted, metres (the front
/// end's full-detection range).
pub const LOSS_GROUND_RADIUS_M: f64 = 1.5;

/// One loss of visual tracking and the ground it happened on (the simulator's truth): what the
/// tracking-loss log (`tracking_losses.csv`) holds per loss.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TrackingLoss {
    /// Mission time, seconds.
    pub time_s: f64,
    /// True position, world frame, metres.
    pub x_m: f64,
    /// True position, world frame, metres.
    pub y_m: f64,
    /// True yaw rate over the last control tick, rad/s (a turn in place shows here).
    pub yaw_rate_radps: f64,
    /// Features the keyframe kept.
    pub features: usize,
    /// Of them, matched to mapped landmarks (below `min_tracked`: the loss).
    pub mapped: usize,
    /// The world's landmarks per m² within [`LOSS_GROUND_RADIUS_M`] of the robot: how textured
    /// the ground is there (0 on bare ground).
    pub ground_landmarks_per_m2: f64,
    /// Distance from the robot to the nearest mapped landmark (true positions), metres; infinite
    /// with none mapped.
    pub nearest_mapped_m: f64,
    /// How long tracking stayed lost, seconds (0: regained at the same keyframe); NaN when it
    /// was not regained by the mission's end.
    pub lost_for_s: f64,
}

impl TrackingLoss {
    /// The loss at (`x_m`, `y_m`) among the world's `landmarks` (their index is their id), of
    /// which `is_mapped` tells the mapped ones. O(landmarks).
    pub(crate) fn at(
        (time_s, x_m, y_m, yaw_rate_radps): (f64, f64, f64, f64),
        (features, mapped): (usize, usize),
        landmarks: &[Point3<f64>],
        is_mapped: impl Fn(u64) -> bool,
    ) -> Self {
        let mut near = 0usize;
        let mut nearest_mapped_m = f64::INFINITY;
        for (id, p) in landmarks.iter().enumerate() {
            let d = crate::math::hypot(p.x - x_m, p.y - y_m);
            near += usize::from(d <= LOSS_GROUND_RADIUS_M);
            if d < nearest_mapped_m && is_mapped(id as u64) {
                nearest_mapped_m = d;
            }
        }
        let area_m2 = std::f64::consts::PI * LOSS_GROUND_RADIUS_M * LOSS_GROUND_RADIUS_M;
        let ground_landmarks_per_m2 = near as f64 / area_m2;
        Self { time_s, x_m, y_m, yaw_rate_radps, features, mapped, ground_landmarks_per_m2, nearest_mapped_m, lost_for_s: f64::NAN }
    }
}

/// Header of `tracking_losses.csv`.
pub const TRACKING_LOSSES_HEADER: &str =
    "time_s,x_m,y_m,yaw_rate_radps,features,mapped,ground_landmarks_per_m2,nearest_mapped_m,lost_for_s";

/// `tracking_losses.csv`: one row per loss, in time order ([`TRACKING_LOSSES_HEADER`]; `inf`
/// where nothing was mapped, `NaN` for a loss not regained).
pub fn tracking_losses_csv(losses: &[TrackingLoss]) -> String {
    let mut s = format!("{TRACKING_LOSSES_HEADER}\n");
    for l in losses {
        s.push_str(&format!(
            "{:.1},{:.3},{:.3},{:.4},{},{},{:.3},{:.3},{:.1}\n",
            l.time_s, l.x_m, l.y_m, l.yaw_rate_radps, l.features, l.mapped, l.ground_landmarks_per_m2, l.nearest_mapped_m, l.lost_for_s
        ));
    }
    s
}

/// Tracking counters of a mission.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct TrackingStats {
    /// Times tracking was lost.
    pub losses: u64,
    /// Recoveries by re-observing mapped landmarks.
    pub relocalisations: u64,
    /// Recoveries by a new map segment.
    pub new_maps: u64,
    /// Time spent lost, seconds.
    pub lost_s: f64,
    /// Whether tracking is lost now.
    pub lost: bool,
}

/// The tracking state machine; see the module doc.
#[derive(Clone, Debug)]
pub(crate) struct VisualTracking {
    min_tracked: usize,
    relocalise_min: usize,
    new_map_min: usize,
    stats: TrackingStats,
    /// Time since the start (the sum of the ticks), seconds.
    elapsed_s: f64,
    /// The tracking-loss log, in time order.
    losses: Vec<TrackingLoss>,
}

impl VisualTracking {
    pub fn new(params: &VisionParams) -> Self {
        Self {
            min_tracked: params.min_tracked,
            relocalise_min: params.relocalise_min,
            new_map_min: params.new_map_min,
            stats: TrackingStats::default(),
            elapsed_s: 0.0,
            losses: Vec::new(),
        }
    }

    /// Every loss so far; the open one, if tracking is lost now, has `lost_for_s` NaN.
    pub fn losses(&self) -> &[TrackingLoss] {
        &self.losses
    }

    pub fn stats(&self) -> TrackingStats {
        self.stats
    }

    /// Time passes: counted as lost while tracking is lost.
    pub fn tick(&mut self, dt_s: f64) {
        self.elapsed_s += dt_s;
        if self.stats.lost {
            self.stats.lost_s += dt_s;
        }
    }

    /// A keyframe's features: keeps in `features` those the SLAM may use (`is_mapped` tells the
    /// landmarks already in the map). A loss is logged with `loss_at(time_s, features, mapped
    /// matches)`, its ground's context; its duration when tracking is regained.
    pub(crate) fn at_keyframe(
        &mut self,
        features: &mut Vec<CameraObservation>,
        is_mapped: impl Fn(u64) -> bool,
        loss_at: impl FnOnce(f64, usize, usize) -> TrackingLoss,
    ) {
        let mapped = features.iter().filter(|o| is_mapped(o.landmark_id)).count();
        if !self.stats.lost {
            if mapped >= self.min_tracked {
                return;
            }
            self.stats.losses += 1;
            self.stats.lost = true;
            self.losses.push(loss_at(self.elapsed_s, features.len(), mapped));
        }
        if mapped >= self.relocalise_min {
            self.stats.relocalisations += 1;
            self.stats.lost = false;
        } else if features.len() - mapped >= self.new_map_min {
            self.stats.new_maps += 1;
            self.stats.lost = false;
            features.retain(|o| !is_mapped(o.landmark_id));
        } else {
            features.clear();
        }
        if !self.stats.lost
            && let Some(open) = self.losses.last_mut()
        {
            open.lost_for_s = self.elapsed_s - open.time_s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    /// A loss with no ground context.
    fn blank(time_s: f64, features: usize, mapped: usize) -> TrackingLoss {
        TrackingLoss::at((time_s, 0.0, 0.0, 0.0), (features, mapped), &[], |_| false)
    }

    fn features(ids: impl IntoIterator<Item = u64>) -> Vec<CameraObservation> {
        ids.into_iter()
            .map(|landmark_id| CameraObservation { landmark_id, point_in_robot: Vector3::x(), covariance: Matrix3::identity() })
            .collect()
    }

    #[test]
    fn loses_on_few_mapped_matches_and_recovers_by_relocalisation_or_a_new_map() {
        let params = VisionParams { min_tracked: 3, relocalise_min: 5, new_map_min: 4, ..VisionParams::default() };
        let mut t = VisualTracking::new(&params);
        // Ids below 100 are mapped.
        let mapped = |id: u64| id < 100;
        // 3 mapped: tracking holds, everything is used.
        let mut f = features([1, 2, 3, 200]);
        t.at_keyframe(&mut f, mapped, blank);
        assert_eq!((f.len(), t.stats().lost), (4, false));
        // 2 mapped, 1 new: lost; nothing is used; time counts.
        let mut f = features([1, 2, 300]);
        t.at_keyframe(&mut f, mapped, blank);
        assert_eq!((t.losses().len(), t.losses()[0].features, t.losses()[0].mapped), (1, 3, 2));
        assert!(t.losses()[0].lost_for_s.is_nan(), "open");
        assert!(f.is_empty() && t.stats().lost && t.stats().losses == 1);
        t.tick(0.5);
        t.tick(0.25);
        // 4 mapped (< 5) and 3 new (< 4): still lost, not counted twice.
        let mut f = features([1, 2, 3, 4, 301, 302, 303]);
        t.at_keyframe(&mut f, mapped, blank);
        assert_eq!(t.losses().len(), 1, "no new loss");
        assert!(f.is_empty() && t.stats().losses == 1 && t.stats().lost);
        // 5 mapped: relocalised, all used.
        let mut f = features([1, 2, 3, 4, 5, 400]);
        t.at_keyframe(&mut f, mapped, blank);
        assert_eq!((f.len(), t.stats().relocalisations, t.stats().lost), (6, 1, false));
        assert_eq!(t.losses()[0].lost_for_s, 0.75, "lost over the two ticks");
        t.tick(1.0);
        assert_eq!(t.stats().lost_s, 0.75);
        // Lost again with 4 new features: a new map segment at once, from the new ones only.
        let mut f = features([7, 500, 501, 502, 503]);
        t.at_keyframe(&mut f, mapped, blank);
        assert_eq!((t.losses().len(), t.losses()[1].features, t.losses()[1].mapped, t.losses()[1].lost_for_s), (2, 5, 1, 0.0));
        assert_eq!(t.losses()[1].time_s, 1.75);
        let s = t.stats();
        assert_eq!((s.losses, s.new_maps, s.lost), (2, 1, false));
        assert_eq!(f.iter().map(|o| o.landmark_id).collect::<Vec<_>>(), vec![500, 501, 502, 503]);
    }

    #[test]
    fn a_loss_records_its_grounds_texture_and_the_nearest_mapped_landmark_by_hand() {
        // Four landmarks: two within 1.5 m of the robot at (0, 0) (at 1 m and 1.5 m), one at
        // 2 m, one at 5 m; ids 2 and 3 mapped.
        let world = [Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, -1.5, 0.2), Point3::new(0.0, 2.0, 0.0), Point3::new(3.0, 4.0, 0.0)];
        let l = TrackingLoss::at((12.0, 0.0, 0.0, 0.5), (8, 2), &world, |id| id >= 2);
        assert!((l.ground_landmarks_per_m2 - 2.0 / (std::f64::consts::PI * 2.25)).abs() < 1e-12);
        assert_eq!(l.nearest_mapped_m, 2.0);
        assert_eq!((l.features, l.mapped, l.time_s, l.yaw_rate_radps), (8, 2, 12.0, 0.5));
        let none = TrackingLoss::at((0.0, 10.0, 10.0, 0.0), (0, 0), &world, |_| false);
        assert_eq!((none.ground_landmarks_per_m2, none.nearest_mapped_m), (0.0, f64::INFINITY));
        assert!(l.lost_for_s.is_nan(), "not regained yet");
        let regained = TrackingLoss { lost_for_s: 3.5, ..l };
        let csv = tracking_losses_csv(&[regained, none]);
        let lines: Vec<&str> = csv.lines().collect();
        let rows = ["12.0,0.000,0.000,0.5000,8,2,0.283,2.000,3.5", "0.0,10.000,10.000,0.0000,0,0,0.000,inf,NaN"];
        assert_eq!(lines, [&[TRACKING_LOSSES_HEADER][..], &rows[..]].concat());
    }
}
