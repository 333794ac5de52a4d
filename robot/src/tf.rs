//! A minimal tf2 buffer: the latest transform of every parent → child edge of the tree (from
//! `/tf` and `/tf_static`) and lookups along the tree between any two frames.
//!
//! Latest-only, no interpolation in time: the node plans at about 1 Hz on poses that change by
//! centimetres between two messages, so the newest edge is what tf2's `lookupTransform(...,
//! TimePointZero)` would return too. A lookup also says when its oldest non-static edge was
//! received, which is how a pose that stops updating is detected.
//!
//! Lookup: O(depth) to walk both frames up to the root (depth ≤ [`MAX_DEPTH`]).

use fitslam_core::ros::{ConvertError, isometry_of_transform};
use fitslam_msgs::TransformStamped;
use nalgebra::Isometry3;
use std::collections::HashMap;

/// Deepest tree walked (guards against cycles in bad input).
pub const MAX_DEPTH: usize = 64;

#[derive(Clone, Debug)]
struct Edge {
    parent: String,
    parent_from_child: Isometry3<f64>,
    /// Message stamp, seconds.
    stamp_s: f64,
    /// When it was received (caller's clock), seconds; `None` for static edges.
    received_s: Option<f64>,
}

/// A lookup result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lookup {
    /// `target_from_source`.
    pub transform: Isometry3<f64>,
    /// Reception time of the oldest non-static edge on the path; `None` if all are static.
    pub oldest_received_s: Option<f64>,
}

/// Latest transforms by child frame.
#[derive(Clone, Debug, Default)]
pub struct TfBuffer {
    edges: HashMap<String, Edge>,
}

/// Frame names without a leading slash (tf2 ignores it).
pub fn normalise_frame(frame: &str) -> &str {
    frame.trim_start_matches('/')
}

impl TfBuffer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Inserts one transform received at `received_s`. A transform older (by stamp) than the
    /// edge already held is ignored (late message) and `Ok(false)` returned. Invalid ones (NaN,
    /// zero quaternion, empty or equal frame names) are errors.
    pub fn insert(&mut self, t: &TransformStamped, is_static: bool, received_s: f64) -> Result<bool, ConvertError> {
        let parent = normalise_frame(&t.header.frame_id);
        let child = normalise_frame(&t.child_frame_id);
        if parent.is_empty() || child.is_empty() || parent == child {
            return Err(ConvertError::NonFinite("transform frame names (empty or equal)"));
        }
        let iso = isometry_of_transform(&t.transform)?;
        let stamp_s = t.header.stamp.as_secs_f64();
        if let Some(old) = self.edges.get(child) {
            // Zero stamps ("now") always replace; otherwise a strictly older stamp is late.
            if !is_static && stamp_s != 0.0 && stamp_s < old.stamp_s {
                return Ok(false);
            }
        }
        self.edges.insert(
            child.to_owned(),
            Edge { parent: parent.to_owned(), parent_from_child: iso, stamp_s, received_s: (!is_static).then_some(received_s) },
        );
        Ok(true)
    }

    /// Path from `frame` to the root: (frame, root_from_frame, oldest received).
    fn to_root(&self, frame: &str) -> Vec<(String, Isometry3<f64>, Option<f64>)> {
        let mut out = vec![(frame.to_owned(), Isometry3::identity(), None)];
        let mut cur = frame.to_owned();
        let mut acc = Isometry3::identity();
        let mut oldest: Option<f64> = None;
        for _ in 0..MAX_DEPTH {
            let Some(e) = self.edges.get(&cur) else { break };
            acc = e.parent_from_child * acc;
            if let Some(r) = e.received_s {
                oldest = Some(oldest.map_or(r, |o: f64| o.min(r)));
            }
            cur = e.parent.clone();
            out.push((cur.clone(), acc, oldest));
        }
        out
    }

    /// `target_from_source`, if both frames are in one tree.
    pub fn lookup(&self, target: &str, source: &str) -> Option<Lookup> {
        let (target, source) = (normalise_frame(target), normalise_frame(source));
        if target == source {
            return Some(Lookup { transform: Isometry3::identity(), oldest_received_s: None });
        }
        let up_s = self.to_root(source);
        let up_t = self.to_root(target);
        // First frame on the source's way up that the target's way up also reaches.
        for (frame, anc_from_source, rec_s) in &up_s {
            if let Some((_, anc_from_target, rec_t)) = up_t.iter().find(|(f, _, _)| f == frame) {
                let oldest = match (rec_s, rec_t) {
                    (Some(a), Some(b)) => Some(a.min(*b)),
                    (a, b) => a.or(*b),
                };
                return Some(Lookup { transform: anc_from_target.inverse() * anc_from_source, oldest_received_s: oldest });
            }
        }
        None
    }

    /// The frames from `frame` up to its tree's root, `frame` first.
    fn chain<'a>(&'a self, frame: &'a str) -> Vec<&'a str> {
        let mut out = vec![frame];
        let mut cur = frame;
        for _ in 0..MAX_DEPTH {
            let Some(e) = self.edges.get(cur) else { break };
            cur = &e.parent;
            out.push(cur);
        }
        out
    }

    /// The root of `frame`'s tree (`frame` itself when it has no parent).
    pub fn root(&self, frame: &str) -> String {
        self.chain(normalise_frame(frame)).last().map_or_else(String::new, |f| (*f).to_owned())
    }

    /// The least recently received non-static edge between `target` and `source`, as
    /// (parent, child, received at): the link that makes a lookup stale.
    pub fn stalest_link(&self, target: &str, source: &str) -> Option<(String, String, f64)> {
        let (up_s, up_t) = (self.chain(normalise_frame(source)), self.chain(normalise_frame(target)));
        let common = up_s.iter().find(|f| up_t.contains(f))?;
        let below = |up: &[&str]| up.iter().take_while(|f| *f != common).map(|f| (*f).to_owned()).collect::<Vec<_>>();
        let children = [below(&up_s), below(&up_t)].concat();
        children
            .iter()
            .filter_map(|c| self.edges.get(c).and_then(|e| e.received_s.map(|r| (e.parent.clone(), c.clone(), r))))
            .min_by(|a, b| a.2.total_cmp(&b.2))
    }

    /// Number of edges held.
    pub fn len(&self) -> usize {
        self.edges.len()
    }

    pub fn is_empty(&self) -> bool {
        self.edges.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_msgs::{Header, Quaternion, Time, Transform, Vector3};
    use nalgebra::Point3;

    fn tf(parent: &str, child: &str, x: f64, y: f64, yaw: f64, stamp_s: f64) -> TransformStamped {
        TransformStamped {
            header: Header::new(Time::from_secs_f64(stamp_s), parent),
            child_frame_id: child.into(),
            transform: Transform { translation: Vector3 { x, y, z: 0.0 }, rotation: Quaternion::from_yaw(yaw) },
        }
    }

    #[test]
    fn chains_compose_and_invert() {
        let mut b = TfBuffer::new();
        // map → odom: +1 m in x; odom → base_link: +2 m in y, yaw 90°.
        b.insert(&tf("map", "odom", 1.0, 0.0, 0.0, 1.0), false, 10.0).unwrap();
        b.insert(&tf("/odom", "base_link", 0.0, 2.0, std::f64::consts::FRAC_PI_2, 1.0), false, 12.0).unwrap();
        b.insert(&tf("base_link", "laser", 0.5, 0.0, 0.0, 0.0), true, 0.0).unwrap();
        let l = b.lookup("map", "base_link").unwrap();
        let p = l.transform * Point3::origin();
        assert!((p - Point3::new(1.0, 2.0, 0.0)).norm() < 1e-12);
        assert_eq!(l.oldest_received_s, Some(10.0));
        // The laser 0.5 m ahead of base_link, which faces +y in map.
        let p = b.lookup("map", "laser").unwrap().transform * Point3::origin();
        assert!((p - Point3::new(1.0, 2.5, 0.0)).norm() < 1e-12);
        // Inverse direction.
        let p = b.lookup("laser", "map").unwrap().transform * Point3::new(1.0, 2.5, 0.0);
        assert!(p.coords.norm() < 1e-12);
        // Sibling lookup through the common ancestor; static-only paths have no age.
        assert_eq!(b.lookup("laser", "laser").unwrap().oldest_received_s, None);
        assert_eq!(b.lookup("base_link", "laser").unwrap().oldest_received_s, None);
        assert!(b.lookup("map", "camera").is_none());
        // map → odom was received at 10 s, odom → base_link at 12 s: map → odom is the stale one.
        assert_eq!(b.stalest_link("map", "laser"), Some(("map".into(), "odom".into(), 10.0)));
        assert_eq!(b.stalest_link("base_link", "laser"), None);
        assert_eq!(b.root("laser"), "map");
        assert_eq!(b.root("camera"), "camera");
    }

    #[test]
    fn late_and_invalid_transforms_are_refused() {
        let mut b = TfBuffer::new();
        assert_eq!(b.insert(&tf("map", "odom", 1.0, 0.0, 0.0, 5.0), false, 1.0), Ok(true));
        assert_eq!(b.insert(&tf("map", "odom", 9.0, 0.0, 0.0, 4.0), false, 2.0), Ok(false));
        let p = b.lookup("map", "odom").unwrap().transform * Point3::origin();
        assert_eq!(p.x, 1.0);
        assert!(b.insert(&tf("map", "odom", f64::NAN, 0.0, 0.0, 6.0), false, 2.0).is_err());
        assert!(b.insert(&tf("map", "map", 0.0, 0.0, 0.0, 6.0), false, 2.0).is_err());
        assert!(b.insert(&tf("", "x", 0.0, 0.0, 0.0, 6.0), false, 2.0).is_err());
    }

    #[test]
    fn cycles_do_not_hang() {
        let mut b = TfBuffer::new();
        b.insert(&tf("a", "b", 1.0, 0.0, 0.0, 1.0), false, 0.0).unwrap();
        b.insert(&tf("b", "a", 1.0, 0.0, 0.0, 1.0), false, 0.0).unwrap();
        // Either answer is acceptable; it must return.
        let _ = b.lookup("a", "c");
        let _ = b.lookup("a", "b");
    }
}
