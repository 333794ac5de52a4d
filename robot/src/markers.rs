//! RViz markers of a decision (`visualization_msgs/MarkerArray`), in the map frame:
//!
//! | namespace | type | what |
//! |---|---|---|
//! | `frontiers` | POINTS | every frontier cell of every cluster |
//! | `candidates` | SPHERE_LIST | candidate C_i: green chosen, yellow→orange by rank, grey not ranked, red no path / blacklisted |
//! | `theta_star` | TRIANGLE_LIST | the camera's field of view at Θ* from each scored candidate, `max_depth_m` long |
//! | `path` | LINE_STRIP | the chosen candidate's path |
//! | `goal` | ARROW | the goal pose sent (`publish_only`: the one it would send) |
//! | `blacklist` | SPHERE_LIST | blacklisted goals |
//!
//! The array starts with a DELETEALL so that markers of a previous decision disappear.
//! O(frontier cells + candidates).

use fitslam_core::frontier::Blacklist;
use fitslam_core::ros::pose_of_pose2;
use fitslam_core::select::{Decision, DropReason};
use fitslam_core::{GridGeometry, Params, Pose2};
use fitslam_msgs::{ColorRGBA, Header, Marker, MarkerArray, Point, Vector3};

/// Height markers are drawn at, metres (just above the map).
const Z_M: f64 = 0.05;
/// Segments of each field-of-view fan.
const FAN_SEGMENTS: usize = 8;

const GREEN: ColorRGBA = ColorRGBA::new(0.1, 0.9, 0.2, 1.0);
const GREY: ColorRGBA = ColorRGBA::new(0.6, 0.6, 0.6, 0.8);
const RED: ColorRGBA = ColorRGBA::new(0.9, 0.1, 0.1, 0.9);
const CYAN: ColorRGBA = ColorRGBA::new(0.0, 0.8, 0.9, 0.9);

fn p(x: f64, y: f64) -> Point {
    Point { x, y, z: Z_M }
}

fn marker(header: &Header, ns: &str, type_: i32, scale: f64) -> Marker {
    Marker {
        header: header.clone(),
        ns: ns.into(),
        id: 0,
        type_,
        action: Marker::ADD,
        scale: Vector3 { x: scale, y: scale, z: scale },
        color: ColorRGBA::new(1.0, 1.0, 1.0, 1.0),
        ..Marker::default()
    }
}

/// Colour of the k-th ranked candidate out of n: yellow (best) to orange.
fn rank_color(rank: usize, n: usize) -> ColorRGBA {
    let t = if n > 1 { (rank.saturating_sub(1)) as f32 / (n - 1) as f32 } else { 0.0 };
    ColorRGBA::new(1.0, 0.9 - 0.5 * t, 0.1, 0.9)
}

/// The markers of `decision` (and of the blacklist and the goal actually sent, which may differ
/// from the selector's choice when its cell turned lethal).
pub fn decision_markers(
    decision: &Decision,
    geometry: &GridGeometry,
    blacklist: &Blacklist,
    goal: Option<Pose2>,
    params: &Params,
    header: &Header,
) -> MarkerArray {
    let mut markers = vec![Marker { header: header.clone(), action: Marker::DELETEALL, ..Marker::default() }];

    let mut frontiers = marker(header, "frontiers", Marker::POINTS, geometry.resolution_m);
    frontiers.color = CYAN;
    for c in &decision.candidates {
        for cell in &c.cluster_cells {
            let (x, y) = geometry.center_of(*cell);
            frontiers.points.push(p(x, y));
        }
    }
    markers.push(frontiers);

    let ranked = decision.ranking().len();
    let mut candidates = marker(header, "candidates", Marker::SPHERE_LIST, 0.2);
    for (i, c) in decision.candidates.iter().enumerate() {
        candidates.points.push(p(c.x_m, c.y_m));
        let color = if decision.chosen == Some(i) {
            GREEN
        } else if let Some(r) = c.rank {
            rank_color(r, ranked)
        } else if matches!(c.dropped, Some(DropReason::NoPath) | Some(DropReason::Blacklisted(_))) {
            RED
        } else {
            GREY
        };
        candidates.colors.push(color);
    }
    markers.push(candidates);

    let mut cones = marker(header, "theta_star", Marker::TRIANGLE_LIST, 1.0);
    let (half, depth) = (0.5 * params.camera.hfov_rad, params.camera.max_depth_m);
    for (i, c) in decision.candidates.iter().enumerate() {
        let Some(theta) = c.theta_star_rad else { continue };
        let color = if decision.chosen == Some(i) { ColorRGBA::new(0.1, 0.9, 0.2, 0.35) } else { ColorRGBA::new(1.0, 0.8, 0.1, 0.15) };
        for k in 0..FAN_SEGMENTS {
            let a0 = theta - half + 2.0 * half * k as f64 / FAN_SEGMENTS as f64;
            let a1 = theta - half + 2.0 * half * (k + 1) as f64 / FAN_SEGMENTS as f64;
            cones.points.push(p(c.x_m, c.y_m));
            cones.points.push(p(c.x_m + depth * a0.cos(), c.y_m + depth * a0.sin()));
            cones.points.push(p(c.x_m + depth * a1.cos(), c.y_m + depth * a1.sin()));
            cones.colors.extend([color; 3]);
        }
    }
    if !cones.points.is_empty() {
        markers.push(cones);
    }

    if let Some(c) = decision.chosen_candidate()
        && c.path_m.len() >= 2
    {
        let mut path = marker(header, "path", Marker::LINE_STRIP, 0.05);
        path.color = GREEN;
        path.points = c.path_m.iter().map(|&[x, y]| p(x, y)).collect();
        markers.push(path);
    }

    if let Some(g) = goal {
        let mut arrow = marker(header, "goal", Marker::ARROW, 0.1);
        arrow.scale = Vector3 { x: 0.6, y: 0.12, z: 0.12 };
        arrow.color = GREEN;
        arrow.pose = pose_of_pose2(g);
        arrow.pose.position.z = Z_M;
        markers.push(arrow);
    }

    if !blacklist.is_empty() {
        let mut bl = marker(header, "blacklist", Marker::SPHERE_LIST, 0.15);
        bl.color = RED;
        bl.points = blacklist.entries().iter().map(|e| p(e.x_m, e.y_m)).collect();
        markers.push(bl);
    }
    MarkerArray { markers }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_core::fixtures::corridor_two_frontiers;
    use fitslam_core::frontier::BlacklistReason;
    use fitslam_core::select::{DecisionInput, make_selector};
    use fitslam_core::utility::LandmarkVoxels;

    #[test]
    fn corridor_decision_draws_everything() {
        let w = corridor_two_frontiers(true);
        let params = fitslam_core::params::Valid::<Params>::default();
        let voxels = LandmarkVoxels::new(&w.landmarks, 0.25, 0.05).unwrap();
        let mut bl = Blacklist::new(0.5);
        let d = make_selector(&params.selector).select(&DecisionInput::new(&w.grid, &voxels, w.robot, &bl), &params).unwrap();
        bl.add(1.0, 1.0, BlacklistReason::Failed);
        let m = decision_markers(&d, &w.grid.geometry, &bl, d.goal, &params, &Header::default());
        let ns: Vec<&str> = m.markers.iter().map(|m| m.ns.as_str()).collect();
        assert_eq!(ns, ["", "frontiers", "candidates", "theta_star", "path", "goal", "blacklist"]);
        assert_eq!(m.markers[0].action, Marker::DELETEALL);
        let frontier_cells: usize = d.candidates.iter().map(|c| c.cluster_size).sum();
        assert_eq!(m.markers[1].points.len(), frontier_cells);
        let cand = &m.markers[2];
        assert_eq!(cand.points.len(), d.candidates.len());
        assert_eq!(cand.colors.len(), cand.points.len());
        assert_eq!(cand.colors[d.chosen.unwrap()], GREEN);
        let scored = d.candidates.iter().filter(|c| c.theta_star_rad.is_some()).count();
        assert_eq!(m.markers[3].points.len(), scored * FAN_SEGMENTS * 3);
        // Fans are max_depth_m long.
        let c = &m.markers[3].points;
        assert!(((c[1].x - c[0].x).hypot(c[1].y - c[0].y) - params.camera.max_depth_m).abs() < 1e-9);
        assert_eq!(m.markers[4].points.first().map(|p| (p.x, p.y)), d.chosen_candidate().unwrap().path_m.first().map(|p| (p[0], p[1])));
    }
}
