//! Goal blacklist and end of mission (notes §3).
//!
//! Blacklisted: candidates with no path, goals the robot failed to reach (aborted, timed out),
//! and goals selected in an earlier iteration that are still frontier goals now. Matching is by
//! radius, not exact coordinates: a point is blacklisted when its Euclidean distance to an entry
//! is ≤ `radius_m`, because the same frontier's median cell moves a little from one map update to
//! the next. The mission ends when no non-blacklisted candidate remains in the boundary
//! (candidates are already restricted to the boundary by detection).
//!
//! O(E) per query for E entries (one per failed or selected goal: tens to hundreds per mission).

#[cfg(test)]
use super::FrontierCluster;
#[cfg(test)]
use crate::grid::{Cell, GridGeometry};
use serde::{Deserialize, Serialize};

/// Why a goal was blacklisted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BlacklistReason {
    /// The planner found no path to the candidate.
    NoPath,
    /// The robot failed to reach the goal (aborted, timed out).
    Failed,
    /// Selected in an earlier iteration and still a frontier goal now.
    Reselected,
}

/// One blacklisted goal position (map frame, metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlacklistEntry {
    /// Goal x, map frame, metres.
    pub x_m: f64,
    /// Goal y, map frame, metres.
    pub y_m: f64,
    /// Why it was blacklisted.
    pub reason: BlacklistReason,
}

/// Blacklisted goals, matched within a radius.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Blacklist {
    radius_m: f64,
    entries: Vec<BlacklistEntry>,
}

impl Blacklist {
    /// An empty blacklist matching within `radius_m` (a negative or NaN radius is taken as 0:
    /// exact matches only).
    pub fn new(radius_m: f64) -> Self {
        Self { radius_m: if radius_m >= 0.0 { radius_m } else { 0.0 }, entries: Vec::new() }
    }

    /// The matching radius, metres.
    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    /// Adds a goal. Non-finite coordinates are ignored (they could never match). Entries are
    /// kept in insertion order, duplicates included (the log shows every decision).
    pub fn add(&mut self, x_m: f64, y_m: f64, reason: BlacklistReason) {
        if x_m.is_finite() && y_m.is_finite() {
            self.entries.push(BlacklistEntry { x_m, y_m, reason });
        }
    }

    /// The reason of the nearest entry within the radius of (x_m, y_m) (ties: the earliest
    /// added), or `None` if the point is not blacklisted.
    pub fn contains(&self, x_m: f64, y_m: f64) -> Option<BlacklistReason> {
        let r2 = self.radius_m * self.radius_m;
        let mut best: Option<(f64, BlacklistReason)> = None;
        for e in &self.entries {
            let d2 = (e.x_m - x_m).powi(2) + (e.y_m - y_m).powi(2);
            if d2 <= r2 && best.is_none_or(|(b, _)| d2 < b) {
                best = Some((d2, e.reason));
            }
        }
        best.map(|(_, reason)| reason)
    }

    #[cfg(test)]
    /// [`Self::contains`] at the centre of `cell`.
    pub(crate) fn contains_cell(&self, geometry: &GridGeometry, cell: Cell) -> Option<BlacklistReason> {
        let (x_m, y_m) = geometry.center_of(cell);
        self.contains(x_m, y_m)
    }

    /// Removes every entry added for `reason` (e.g. the `NoPath` ones once the map they were
    /// judged on is forgotten); returns how many. The others keep their order.
    pub(crate) fn remove_reason(&mut self, reason: BlacklistReason) -> usize {
        let before = self.entries.len();
        self.entries.retain(|e| e.reason != reason);
        before - self.entries.len()
    }

    /// Every entry, in insertion order.
    pub fn entries(&self) -> &[BlacklistEntry] {
        &self.entries
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there is no entry.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
/// The clusters whose candidate is not blacklisted, in their original order (cloned).
pub(crate) fn filter_blacklisted(clusters: &[FrontierCluster], blacklist: &Blacklist, geometry: &GridGeometry) -> Vec<FrontierCluster> {
    clusters.iter().filter(|c| blacklist.contains_cell(geometry, c.candidate).is_none()).cloned().collect()
}

#[cfg(test)]
/// Splits `clusters` into those whose candidate is allowed and those blacklisted, with the reason;
/// both in their original order.
pub(crate) fn partition_blacklisted(
    clusters: Vec<FrontierCluster>,
    blacklist: &Blacklist,
    geometry: &GridGeometry,
) -> (Vec<FrontierCluster>, Vec<(FrontierCluster, BlacklistReason)>) {
    let mut allowed = Vec::new();
    let mut rejected = Vec::new();
    for c in clusters {
        match blacklist.contains_cell(geometry, c.candidate) {
            None => allowed.push(c),
            Some(reason) => rejected.push((c, reason)),
        }
    }
    (allowed, rejected)
}

#[cfg(test)]
/// End of mission: true when no cluster has a non-blacklisted candidate (including when there
/// are no clusters at all).
pub(crate) fn end_of_mission(clusters: &[FrontierCluster], blacklist: &Blacklist, geometry: &GridGeometry) -> bool {
    clusters.iter().all(|c| blacklist.contains_cell(geometry, c.candidate).is_some())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_within_radius_not_exactly() {
        let mut b = Blacklist::new(5.0);
        b.add(1.0, 1.0, BlacklistReason::NoPath);
        assert_eq!(b.contains(1.0, 1.0), Some(BlacklistReason::NoPath));
        // 3-4-5 triangle (exact in binary): on the radius matches, just beyond does not.
        assert_eq!(b.contains(4.0, 5.0), Some(BlacklistReason::NoPath));
        assert_eq!(b.contains(4.0, 5.001), None);
        assert_eq!(b.contains(1.0, -4.001), None);
        assert_eq!(b.contains(f64::NAN, 1.0), None);
    }

    #[test]
    fn nearest_entry_gives_the_reason() {
        let mut b = Blacklist::new(1.0);
        b.add(0.0, 0.0, BlacklistReason::Failed);
        b.add(0.8, 0.0, BlacklistReason::Reselected);
        b.add(f64::INFINITY, 0.0, BlacklistReason::NoPath);
        assert_eq!(b.len(), 2);
        assert_eq!(b.contains(0.3, 0.0), Some(BlacklistReason::Failed));
        assert_eq!(b.contains(0.5, 0.0), Some(BlacklistReason::Reselected));
        // Equidistant: the earliest.
        assert_eq!(b.contains(0.4, 0.0), Some(BlacklistReason::Failed));
        assert_eq!(b.entries()[1], BlacklistEntry { x_m: 0.8, y_m: 0.0, reason: BlacklistReason::Reselected });
    }

    #[test]
    fn zero_radius_is_exact_and_negative_radius_is_zero() {
        let mut b = Blacklist::new(-1.0);
        assert_eq!(b.radius_m(), 0.0);
        b.add(2.0, 3.0, BlacklistReason::Failed);
        assert!(b.contains(2.0, 3.0).is_some());
        assert!(b.contains(2.0, 3.000001).is_none());
    }

    #[test]
    fn removing_a_reason_keeps_the_others_in_order() {
        let mut b = Blacklist::new(0.5);
        b.add(0.0, 0.0, BlacklistReason::NoPath);
        b.add(1.0, 0.0, BlacklistReason::Failed);
        b.add(2.0, 0.0, BlacklistReason::NoPath);
        b.add(3.0, 0.0, BlacklistReason::Reselected);
        assert_eq!(b.remove_reason(BlacklistReason::NoPath), 2);
        assert_eq!(
            b.entries().iter().map(|e| (e.x_m, e.reason)).collect::<Vec<_>>(),
            [(1.0, BlacklistReason::Failed), (3.0, BlacklistReason::Reselected)]
        );
        assert_eq!(b.contains(0.0, 0.0), None);
        assert_eq!(b.remove_reason(BlacklistReason::NoPath), 0);
    }

    #[test]
    fn reasons_serialize_in_snake_case() {
        let s = serde_json::to_string(&[BlacklistReason::NoPath, BlacklistReason::Failed, BlacklistReason::Reselected]).unwrap();
        assert_eq!(s, r#"["no_path","failed","reselected"]"#);
    }

    #[test]
    fn filtering_and_end_of_mission() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 100, 100);
        let cl = |c: i32, r: i32| FrontierCluster::from_ordered_cells(vec![Cell::new(c, r)]).unwrap();
        // Candidate centres: (0.55, 0.55) and (5.05, 5.05).
        let clusters = vec![cl(5, 5), cl(50, 50)];
        let mut b = Blacklist::new(0.5);
        assert!(!end_of_mission(&clusters, &b, &g));
        assert!(end_of_mission(&[], &b, &g));
        b.add(0.9, 0.55, BlacklistReason::NoPath); // 0.35 m from the first candidate
        assert_eq!(filter_blacklisted(&clusters, &b, &g), vec![cl(50, 50)]);
        assert!(!end_of_mission(&clusters, &b, &g));
        let (allowed, rejected) = partition_blacklisted(clusters.clone(), &b, &g);
        assert_eq!(allowed, vec![cl(50, 50)]);
        assert_eq!(rejected, vec![(cl(5, 5), BlacklistReason::NoPath)]);
        b.add(5.05, 5.6, BlacklistReason::Failed); // 0.55 m away: no match yet
        assert!(!end_of_mission(&clusters, &b, &g));
        b.add(5.05, 5.5, BlacklistReason::Failed); // 0.45 m away
        assert!(end_of_mission(&clusters, &b, &g));
        assert!(filter_blacklisted(&clusters, &b, &g).is_empty());
    }
}
