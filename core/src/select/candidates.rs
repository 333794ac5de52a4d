//! The planning pipeline shared by every selector (notes §3–5, §7: the baselines use the same
//! traversability map, frontiers, clusters, blacklist and planner as FIT-SLAM).
//!
//! 1. [`prepare`]: inflate the thresholded grid by the robot radius (the cells the robot has
//!    driven on that are free before inflation stay free: `DecisionInput::traversed`); find the robot's cell
//!    (error if the pose is non-finite or outside the map); if that cell is not free on the
//!    inflated grid, snap to the nearest free cell within `radius_m` + one cell (centre to centre,
//!    ties by flat index) and record it, else error.
//! 2. [`frontiers_and_distances`]: WFD frontiers and clusters on the inflated grid, sorted by
//!    the candidate's flat cell index;
//! 3. in the same call, ONE Dijkstra from the robot's cell on the inflated grid for every ρ_i and
//!    path (notes §4) — one flood does both when unknown space is impassable.
//! 4. [`score_u1`]: per candidate — blacklisted (dropped), no path (dropped; the caller
//!    blacklists it), else path, rays on the *un-inflated* grid, Θ*, ΔE; then u1 over all
//!    scored candidates.
//! 5. [`score_u2`] (FIT-SLAM): u2 on the N best by u1.
//!
//! Cost: inflation O(B r²), the flood O(n) over the n reachable cells (plus WFD's O(n) with
//! `allow_unknown`), u1 O(C·R·L) for C candidates, R rays of L cells, u2 O(N·K·V) (see
//! [`crate::utility::u2`]). The three grid-sized buffers (inflated grid, frontier state layer,
//! cost window: ≈ 20 MB on a 2000 × 2000 map) live in the selector's [`PlanBuffers`] and are
//! reused from one decision to the next.

use super::report::{CandidateReport, Decision, DropReason};
use super::{DecisionInput, SelectError};
use crate::frontier::{FrontierCluster, cluster_frontier_cells, detect_frontiers_with};
use crate::grid::{Cell, CellClass, OccupancyGrid, free_traversed, inflate_lethal_into};
use crate::params::{GoalHeading, Params, Strategy, Valid, check_radius_cells, check_waypoint_spacing};
use crate::path::{DistanceField, SearchBuffers, dijkstra_to_reusing, dijkstra_with_frontiers};
use crate::utility::u2::{CameraGround, arrival_heading_rad};
use crate::utility::{FovWindows, PathView, RayFan, normalise_path_information, path_information, path_tracked_share, u1_scores, u2_score};

/// The grid-sized scratch storage of a decision, kept by a selector between decisions so that
/// one decision neither allocates nor page-faults them afresh (measured in docs/benchmarks.md,
/// Decision). Only capacity carries over: every step overwrites what it reads.
#[derive(Clone, Debug, Default)]
pub struct PlanBuffers {
    inflated: Vec<i8>,
    frontier_state: Vec<u8>,
    search: SearchBuffers,
}

impl PlanBuffers {
    /// Takes the storage of a finished decision's inflated grid and distance field back.
    pub fn recycle(&mut self, prepared: Prepared, field: DistanceField) {
        self.inflated = prepared.inflated.data;
        self.search = field.into_buffers();
    }
}

/// Output of [`prepare`]: the planning grid and the start cell.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The thresholded grid inflated by the robot radius.
    pub inflated: OccupancyGrid,
    /// The cell planning starts from.
    pub robot_cell: Cell,
    /// The cell under the robot's pose.
    pub requested_robot_cell: Cell,
    /// Whether `robot_cell` differs from `requested_robot_cell`.
    pub start_snapped: bool,
}

/// Step 1: check the input against the map, inflate (into `buffers`' storage), locate (and if
/// needed snap) the robot.
pub fn prepare(input: &DecisionInput, params: &Valid<Params>, buffers: &mut PlanBuffers) -> Result<Prepared, SelectError> {
    let g = input.grid.geometry;
    if input.grid.data.len() != g.len() {
        return Err(SelectError::GridSizeMismatch { data_len: input.grid.data.len(), cells: g.len() });
    }
    if let Some(&index) = input.traversed.iter().find(|&&i| i >= g.len()) {
        return Err(SelectError::TraversedOutsideGrid { index, cells: g.len() });
    }
    if !input.robot.is_finite() {
        return Err(SelectError::RobotPoseNotFinite);
    }
    // The map's own resolution may differ from the parameters' grid: the kernels are sized on it.
    check_radius_cells("robot.radius_m", params.robot.radius_m, g.resolution_m)?;
    check_waypoint_spacing(params.waypoint_spacing_m(), g.resolution_m)?;
    let requested =
        g.cell_of(input.robot.x_m, input.robot.y_m).ok_or(SelectError::RobotOutsideMap { x_m: input.robot.x_m, y_m: input.robot.y_m })?;
    let mut inflated = OccupancyGrid { geometry: g, data: std::mem::take(&mut buffers.inflated) };
    inflate_lethal_into(input.grid, params.robot.radius_m, &mut inflated);
    free_traversed(input.grid, input.traversed, &mut inflated);
    let free = |c: Cell| g.index(c).is_some_and(|i| CellClass::of(inflated.data[i]) == CellClass::Free);
    if free(requested) {
        return Ok(Prepared { inflated, robot_cell: requested, requested_robot_cell: requested, start_snapped: false });
    }
    let max_m = params.robot.radius_m + g.resolution_m;
    let r = (max_m / g.resolution_m).floor() as i32;
    let r2 = (max_m / g.resolution_m).powi(2) + 1e-9;
    let mut best: Option<(i64, usize, Cell)> = None;
    for dr in -r..=r {
        for dc in -r..=r {
            let d2 = i64::from(dc * dc + dr * dr);
            if d2 as f64 > r2 {
                continue;
            }
            let c = Cell::new(requested.col + dc, requested.row + dr);
            if let (true, Some(i)) = (free(c), g.index(c))
                && best.is_none_or(|(bd, bi, _)| (d2, i) < (bd, bi))
            {
                best = Some((d2, i, c));
            }
        }
    }
    match best {
        Some((_, _, c)) => Ok(Prepared { inflated, robot_cell: c, requested_robot_cell: requested, start_snapped: true }),
        None => Err(SelectError::RobotBlocked { cell: requested, search_radius_m: max_m }),
    }
}

/// Steps 2–3: the frontier clusters on the inflated grid (sorted by the candidate's flat index)
/// and the distance field from the robot's cell. With unknown space impassable (the default),
/// ONE flood gives both ([`dijkstra_with_frontiers`]: WFD's reached set is the planner's). With
/// `planner.allow_unknown` the planner reaches more than WFD does, so WFD runs first and the
/// Dijkstra stops once every candidate is settled.
pub fn frontiers_and_distances(
    input: &DecisionInput,
    prepared: &Prepared,
    params: &Params,
    buffers: &mut PlanBuffers,
) -> Result<(Vec<FrontierCluster>, DistanceField), SelectError> {
    let (grid, start) = (&prepared.inflated, prepared.robot_cell);
    let buffer = std::mem::take(&mut buffers.search);
    let state = &mut buffers.frontier_state;
    let (mut clusters, field) = if params.planner.allow_unknown {
        let clusters = detect_frontiers_with(grid, start, input.boundary, &params.frontier, state)?;
        let targets: Vec<Cell> = clusters.iter().map(|c| c.candidate).collect();
        (clusters, dijkstra_to_reusing(grid, start, true, &targets, buffer)?)
    } else {
        let (field, frontier) = dijkstra_with_frontiers(grid, start, buffer)?;
        (cluster_frontier_cells(&grid.geometry, &frontier, input.boundary, &params.frontier, state)?, field)
    };
    let g = grid.geometry;
    clusters.sort_by_key(|c| g.index(c.candidate).unwrap_or(usize::MAX));
    Ok((clusters, field))
}

/// Step 4: the candidate reports with ρ, path, rays, Θ*, ΔE and u1 (see the module doc).
pub fn score_u1(
    input: &DecisionInput,
    prepared: &Prepared,
    clusters: Vec<FrontierCluster>,
    field: &DistanceField,
    params: &Params,
    strategy: Strategy,
) -> Result<Decision, SelectError> {
    let g = input.grid.geometry;
    let fan = RayFan::new(params.u1.delta_theta_rad, params.camera.max_depth_m, g.resolution_m, params.u1.gamma)?.for_width(g.width);
    let windows = FovWindows::new(fan.angles_rad(), params.camera.hfov_rad);
    let mut candidates = Vec::with_capacity(clusters.len());
    let mut gains = Vec::with_capacity(fan.len());
    for cluster in clusters {
        let (x_m, y_m) = g.center_of(cluster.candidate);
        let mut c = CandidateReport::new(cluster.candidate, x_m, y_m, cluster.cells);
        c.rho_m = field.distance_m(c.cell);
        if let Some(reason) = input.blacklist.contains(x_m, y_m) {
            c.dropped = Some(DropReason::Blacklisted(reason));
        } else if let Some(corners) = field.corners_to(c.cell) {
            c.path_m = corners.iter().map(|&cell| g.center_of(cell).into()).collect();
            fan.cast(input.grid, c.cell, &mut gains);
            if let Some(best) = windows.best(fan.angles_rad(), &gains) {
                c.delta_e_bits = Some(best.delta_e_bits);
                c.theta_star_rad = Some(best.theta_rad);
            }
            c.ray_gains_bits = gains.clone();
        } else {
            c.dropped = Some(DropReason::NoPath);
        }
        candidates.push(c);
    }
    let scored: Vec<usize> = (0..candidates.len()).filter(|&i| candidates[i].dropped.is_none()).collect();
    let rho: Vec<f64> = scored.iter().map(|&i| candidates[i].rho_m.unwrap_or(f64::INFINITY)).collect();
    let de: Vec<f64> = scored.iter().map(|&i| candidates[i].delta_e_bits.unwrap_or(0.0)).collect();
    let mut u1 = Vec::with_capacity(scored.len());
    u1_scores(&rho, &de, params.u1.alpha, g.resolution_m, &mut u1);
    for (&i, &u) in scored.iter().zip(&u1) {
        candidates[i].u1 = Some(u);
    }
    let order = order_by(&scored, |i| -candidates[i].u1.unwrap_or(f64::NEG_INFINITY));
    for (k, &i) in order.iter().enumerate() {
        candidates[i].u1_rank = Some(k + 1);
    }
    Ok(Decision {
        strategy,
        chosen: None,
        goal: None,
        robot: input.robot,
        robot_cell: prepared.robot_cell,
        requested_robot_cell: prepared.requested_robot_cell,
        start_snapped: prepared.start_snapped,
        ray_angles_rad: fan.angles_rad().to_vec(),
        candidates,
    })
}

/// What u2 weighs against u1 (notes §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathScore {
    /// I_p: the Fisher information of the landmarks the camera sees along the path (the paper's).
    Fisher,
    /// The path length ρ (the control `u2_length`): no waypoints are computed.
    Length,
    /// The share of views along the path that hold enough landmark voxels
    /// (`path_tracked_share`; the control `u2_truth`, given the world's landmarks).
    TrackedShare,
}

/// Step 5 (FIT-SLAM): waypoints, path information (or, with [`PathScore::Length`], the path
/// length) and u2 on the N best candidates by u1, normalised as `u2.normalisation` says; the
/// other scored candidates are dropped as [`DropReason::NotInTopN`].
pub fn score_u2(decision: &mut Decision, input: &DecisionInput, params: &Params, score: PathScore) {
    let top: Vec<usize> = {
        let mut t: Vec<usize> =
            (0..decision.candidates.len()).filter(|&i| decision.candidates[i].u1_rank.is_some_and(|r| r <= params.u2.top_n)).collect();
        t.sort_by_key(|&i| decision.candidates[i].u1_rank);
        t
    };
    for c in decision.candidates.iter_mut() {
        if c.u1_rank.is_some_and(|r| r > params.u2.top_n) {
            c.dropped = Some(DropReason::NotInTopN);
        }
    }
    let ground = CameraGround {
        flat_z_m: input.ground_z_m,
        known: input.ground.filter(|_| params.u2.follow_terrain),
        occlusion: params.u2.occlusion,
    };
    let view = PathView {
        voxels: input.landmarks,
        camera: &params.camera,
        camera_height_m: params.robot.camera_height_m,
        ground,
        spacing_m: params.waypoint_spacing_m(),
        sigma_bearing_rad: params.u2.sigma_bearing_rad,
    };
    let mut raw = Vec::with_capacity(top.len());
    for &i in &top {
        let c = &mut decision.candidates[i];
        let ip = match score {
            PathScore::Fisher => path_information(&c.path_m, c.theta_star_rad.unwrap_or(0.0), &view, &mut c.waypoints),
            PathScore::Length => c.rho_m.unwrap_or(0.0),
            PathScore::TrackedShare => {
                // At least a cell of the decision's map, which may be coarser than the parameters' grid.
                let dense = PathView { spacing_m: params.u2.tracked_spacing_m.max(input.grid.geometry.resolution_m), ..view };
                path_tracked_share(&c.path_m, c.theta_star_rad.unwrap_or(0.0), &dense, params.u2.tracked_min_voxels, &mut c.waypoints)
            }
        };
        c.path_info_raw = Some(ip);
        raw.push(ip);
    }
    let mut norm = Vec::with_capacity(raw.len());
    normalise_path_information(&raw, params.u2.normalisation, &mut norm);
    for (&i, &ip) in top.iter().zip(&norm) {
        let c = &mut decision.candidates[i];
        c.path_info = Some(ip);
        c.u2 = c.u1.map(|u| u2_score(u, ip, params.u2.beta));
    }
}

/// Ranks the candidates u2 scored by decreasing u2 and chooses the first ([`rank_and_choose`]);
/// returns them.
pub fn rank_by_u2(decision: &mut Decision) -> Vec<usize> {
    let ranked: Vec<usize> = (0..decision.candidates.len()).filter(|&i| decision.candidates[i].u2.is_some()).collect();
    rank_and_choose(decision, &ranked, |c| -c.u2.unwrap_or(f64::NEG_INFINITY));
    ranked
}

/// Steps 1–4: everything but u2, with the grid-sized storage in `buffers`.
pub fn plan(input: &DecisionInput, params: &Valid<Params>, strategy: Strategy, buffers: &mut PlanBuffers) -> Result<Decision, SelectError> {
    let prepared = prepare(input, params, buffers)?;
    let (clusters, field) = frontiers_and_distances(input, &prepared, params, buffers)?;
    let decision = score_u1(input, &prepared, clusters, &field, params, strategy);
    buffers.recycle(prepared, field);
    decision
}

/// Assigns ranks 1.. to `indices` in increasing `key` (ties by candidate index), sets `chosen`
/// and `goal` to rank 1.
pub fn rank_and_choose(decision: &mut Decision, indices: &[usize], key: impl Fn(&CandidateReport) -> f64) {
    let order = order_by(indices, |i| key(&decision.candidates[i]));
    for (k, &i) in order.iter().enumerate() {
        decision.candidates[i].rank = Some(k + 1);
    }
    choose(decision, order.first().copied());
}

/// Sets `chosen` and `goal` (candidate cell centre, Θ*).
pub fn choose(decision: &mut Decision, chosen: Option<usize>) {
    decision.chosen = chosen;
    decision.goal = chosen.map(|i| {
        let c = &decision.candidates[i];
        crate::pose::Pose2::new(c.x_m, c.y_m, c.theta_star_rad.unwrap_or(0.0))
    });
}

/// The goal's heading ([`GoalHeading`]): with `arrival`, the chosen path's heading at its end
/// instead of Θ* (unchanged for a path of no length).
pub(crate) fn set_goal_heading(decision: &mut Decision, heading: GoalHeading) {
    if heading != GoalHeading::Arrival {
        return;
    }
    let Some(yaw) = decision.chosen_candidate().and_then(|c| arrival_heading_rad(&c.path_m)) else { return };
    if let Some(goal) = decision.goal.as_mut() {
        goal.yaw_rad = yaw;
    }
}

/// `indices` sorted by increasing key, ties (and NaN keys, last) by index.
fn order_by(indices: &[usize], key: impl Fn(usize) -> f64) -> Vec<usize> {
    let mut v: Vec<(f64, usize)> = indices.iter().map(|&i| (key(i), i)).collect();
    v.sort_by(|a, b| {
        let ka = if a.0.is_nan() { f64::INFINITY } else { a.0 };
        let kb = if b.0.is_nan() { f64::INFINITY } else { b.0 };
        ka.total_cmp(&kb).then(a.1.cmp(&b.1))
    });
    v.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_by_breaks_ties_by_index() {
        assert_eq!(order_by(&[4, 1, 3, 2], |i| if i == 3 { 0.0 } else { 1.0 }), vec![3, 1, 2, 4]);
        assert_eq!(order_by(&[0, 1, 2], |i| if i == 0 { f64::NAN } else { -(i as f64) }), vec![2, 1, 0]);
    }
}
