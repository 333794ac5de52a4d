//! What a decision returns: the whole ranking, not only the winner (style: "every decision is
//! inspectable"). The CLI prints it as JSON, the studio draws it, the robot logs it.

use crate::frontier::BlacklistReason;
use crate::grid::Cell;
use crate::params::Strategy;
use crate::pose::Pose2;
use crate::utility::WaypointReport;
use serde::Serialize;

/// Why a candidate is not ranked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DropReason {
    /// No path from the robot on the inflated grid: the caller should blacklist it
    /// ([`BlacklistReason::NoPath`]).
    NoPath,
    /// Within the blacklist radius of a blacklisted goal.
    Blacklisted(BlacklistReason),
    /// FIT-SLAM only: not among the N best by u1, so u2 was not computed.
    NotInTopN,
}

/// One frontier cluster's candidate C_i and every quantity computed for it. Fields that were
/// not computed for this candidate (dropped early, or a strategy that does not use them) are
/// `None` / empty.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CandidateReport {
    /// Candidate cell (median of the cluster).
    pub cell: Cell,
    /// Candidate cell centre, metres (map frame).
    pub x_m: f64,
    /// Candidate cell centre y, metres (map frame).
    pub y_m: f64,
    /// Number of frontier cells in the cluster.
    pub cluster_size: usize,
    /// The cluster's cells, ordered along the frontier.
    pub cluster_cells: Vec<Cell>,
    /// Path length ρ_i from the robot's cell, metres; `None` if unreachable.
    pub rho_m: Option<f64>,
    /// The shortest path as a polyline of cell centres (metres) from the robot's cell to the
    /// candidate, collinear cells removed (lossless). Empty if unreachable.
    pub path_m: Vec<[f64; 2]>,
    /// ΔE_i, bits: the best window's summed ray gain (notes §5).
    pub delta_e_bits: Option<f64>,
    /// Θ*, radians in [0, 2π): the goal heading.
    pub theta_star_rad: Option<f64>,
    /// ΔE^θ per ray, bits, in the order of [`Decision::ray_angles_rad`].
    pub ray_gains_bits: Vec<f64>,
    /// u1 (notes §5), normalised over the scored candidates.
    pub u1: Option<f64>,
    /// 1-based rank by u1 among the scored candidates (ties by candidate index).
    pub u1_rank: Option<usize>,
    /// u2 waypoints with their camera poses, voxels seen and information (FIT-SLAM top N only).
    pub waypoints: Vec<WaypointReport>,
    /// I_p = Σ_k I_{w_k}, before normalisation.
    pub path_info_raw: Option<f64>,
    /// I_p normalised over the top N (max or mean).
    pub path_info: Option<f64>,
    /// u2 = β·u1 + (1 − β)·I_p (notes §6).
    pub u2: Option<f64>,
    /// 1-based rank by the strategy's final score (FIT-SLAM: u2 over the top N; greedy: ρ;
    /// u1-only: u1; random: 1 for the drawn candidate). `None` if not ranked.
    pub rank: Option<usize>,
    /// Why the candidate was not scored or not ranked.
    pub dropped: Option<DropReason>,
}

impl CandidateReport {
    /// A report with only the cluster filled in.
    pub fn new(cell: Cell, x_m: f64, y_m: f64, cluster_cells: Vec<Cell>) -> Self {
        Self {
            cell,
            x_m,
            y_m,
            cluster_size: cluster_cells.len(),
            cluster_cells,
            rho_m: None,
            path_m: Vec::new(),
            delta_e_bits: None,
            theta_star_rad: None,
            ray_gains_bits: Vec::new(),
            u1: None,
            u1_rank: None,
            waypoints: Vec::new(),
            path_info_raw: None,
            path_info: None,
            u2: None,
            rank: None,
            dropped: None,
        }
    }

    /// Whether the candidate was scored by u1 (reachable and not blacklisted).
    pub fn is_scored(&self) -> bool {
        self.u1.is_some()
    }
}

/// One goal decision.
///
/// # Examples
///
/// The whole ranking, not only the winner:
///
/// ```
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::frontier::Blacklist;
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{make_selector, DecisionInput, Params, Valid};
///
/// let world = corridor_two_frontiers(true);
/// let params = Valid::new(Params::default())?; // FIT-SLAM
/// let voxels = LandmarkVoxels::new(&world.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m)?;
/// let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
/// let input = DecisionInput::new(&world.grid, &voxels, world.robot, &blacklist);
/// let decision = make_selector(&params.selector).select(&input, &params)?;
///
/// assert!(decision.candidates.len() >= 2); // a frontier at each end of the corridor
/// let ranking = decision.ranking();
/// assert_eq!(ranking.first().copied(), decision.chosen);
/// let best = decision.chosen_candidate().ok_or("a candidate is chosen")?;
/// assert_eq!(best.rank, Some(1));
/// for &i in &ranking {
///     let c = &decision.candidates[i];
///     // Every ranked candidate carries its path length, u1 and (FIT-SLAM) u2.
///     assert!(c.rho_m.is_some() && c.u1.is_some() && c.u2.is_some());
///     assert!(c.u2 <= best.u2);
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Decision {
    /// The selector that made it.
    pub strategy: Strategy,
    /// Index into `candidates` of the chosen goal; `None` when no candidate can be ranked (end of
    /// mission: no reachable, non-blacklisted frontier left).
    pub chosen: Option<usize>,
    /// The chosen goal pose: candidate cell centre and Θ*.
    pub goal: Option<Pose2>,
    /// The robot's pose as given.
    pub robot: Pose2,
    /// The cell planning starts from (after snapping).
    pub robot_cell: Cell,
    /// The cell under the robot's pose.
    pub requested_robot_cell: Cell,
    /// Whether the robot's cell was lethal (or unknown) on the inflated grid and planning
    /// started from the nearest free cell within the robot radius plus one cell instead.
    pub start_snapped: bool,
    /// Ray angles Θ, radians, shared by every candidate's `ray_gains_bits`.
    pub ray_angles_rad: Vec<f64>,
    /// Every frontier cluster's candidate, sorted by cell index (row-major flat index).
    pub candidates: Vec<CandidateReport>,
}

impl Decision {
    /// The chosen candidate's report.
    pub fn chosen_candidate(&self) -> Option<&CandidateReport> {
        self.chosen.and_then(|i| self.candidates.get(i))
    }

    #[cfg(test)]
    /// Positions (metres) of the candidates with no path: the caller blacklists them with
    /// [`BlacklistReason::NoPath`].
    pub(crate) fn unreachable_m(&self) -> Vec<[f64; 2]> {
        self.candidates.iter().filter(|c| c.dropped == Some(DropReason::NoPath)).map(|c| [c.x_m, c.y_m]).collect()
    }

    /// Candidates in rank order (ranked ones only).
    pub fn ranking(&self) -> Vec<usize> {
        let mut r: Vec<usize> = (0..self.candidates.len()).filter(|&i| self.candidates[i].rank.is_some()).collect();
        r.sort_by_key(|&i| (self.candidates[i].rank, i));
        r
    }
}
