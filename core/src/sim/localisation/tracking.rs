//! Visual tracking and its loss (ORB-SLAM's tracking states, at keyframes). A keyframe that
//! matches fewer than `min_tracked` mapped landmarks loses tracking: its observations are
//! dropped and the pose comes from wheel odometry alone (with its slip on slopes). While lost,
//! a keyframe that matches `relocalise_min` mapped landmarks relocalises (its observations join
//! the map like a loop closure); one with `new_map_min` features starts a new map segment from
//! its new landmarks only, linked to the old segment by the odometry across the loss and joined
//! to the old landmarks at their first re-observation. Thresholds: [`VisionParams`]. O(features).

use crate::sim::camera::CameraObservation;
use crate::sim::vision::VisionParams;

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
}

impl VisualTracking {
    pub fn new(params: &VisionParams) -> Self {
        Self {
            min_tracked: params.min_tracked,
            relocalise_min: params.relocalise_min,
            new_map_min: params.new_map_min,
            stats: TrackingStats::default(),
        }
    }

    pub fn stats(&self) -> TrackingStats {
        self.stats
    }

    /// Time passes: counted as lost while tracking is lost.
    pub fn tick(&mut self, dt_s: f64) {
        if self.stats.lost {
            self.stats.lost_s += dt_s;
        }
    }

    /// A keyframe's features: keeps in `features` those the SLAM may use (`is_mapped` tells the
    /// landmarks already in the map).
    pub(crate) fn at_keyframe(&mut self, features: &mut Vec<CameraObservation>, is_mapped: impl Fn(u64) -> bool) {
        let mapped = features.iter().filter(|o| is_mapped(o.landmark_id)).count();
        if !self.stats.lost {
            if mapped >= self.min_tracked {
                return;
            }
            self.stats.losses += 1;
            self.stats.lost = true;
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
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

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
        t.at_keyframe(&mut f, mapped);
        assert_eq!((f.len(), t.stats().lost), (4, false));
        // 2 mapped, 1 new: lost; nothing is used; time counts.
        let mut f = features([1, 2, 300]);
        t.at_keyframe(&mut f, mapped);
        assert!(f.is_empty() && t.stats().lost && t.stats().losses == 1);
        t.tick(0.5);
        t.tick(0.25);
        // 4 mapped (< 5) and 3 new (< 4): still lost, not counted twice.
        let mut f = features([1, 2, 3, 4, 301, 302, 303]);
        t.at_keyframe(&mut f, mapped);
        assert!(f.is_empty() && t.stats().losses == 1 && t.stats().lost);
        // 5 mapped: relocalised, all used.
        let mut f = features([1, 2, 3, 4, 5, 400]);
        t.at_keyframe(&mut f, mapped);
        assert_eq!((f.len(), t.stats().relocalisations, t.stats().lost), (6, 1, false));
        t.tick(1.0);
        assert_eq!(t.stats().lost_s, 0.75);
        // Lost again with 4 new features: a new map segment at once, from the new ones only.
        let mut f = features([7, 500, 501, 502, 503]);
        t.at_keyframe(&mut f, mapped);
        let s = t.stats();
        assert_eq!((s.losses, s.new_maps, s.lost), (2, 1, false));
        assert_eq!(f.iter().map(|o| o.landmark_id).collect::<Vec<_>>(), vec![500, 501, 502, 503]);
    }
}
