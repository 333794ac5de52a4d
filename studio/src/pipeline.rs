//! Scene + parameters → decision, through `fitslam_core` only, with each stage cached so that a
//! change re-runs only what depends on it:
//!
//! | stage | core call | re-run when |
//! |---|---|---|
//! | thresholded grid | `traversability::to_occupancy(score, τ)` | map, τ |
//! | landmark voxels | `utility::LandmarkVoxels::new` | landmarks, voxel size, σ_l |
//! | decision | `explore::Explorer::decide_traced`: the robot's policy (selector, retry ladder, set-back) on the scene | any input or parameter |
//! | inflated grid (display only) | `grid::inflate_lethal` | thresholded grid, robot radius |
//!
//! The explorer is made afresh for every decision (the scene's blacklist, no trail, no goal
//! reached; the random selectors from their seed), so the same inputs always give the same
//! decision, and it is the decision the robot node and the simulator would make on them.

use crate::scene::Scene;
use fitslam_core::explore::{Action, ExploreParams, Explorer, Situation, TracedDecision};
use fitslam_core::grid::{OccupancyGrid, inflate_lethal};
use fitslam_core::params::Valid;
use fitslam_core::select::Decision;
use fitslam_core::traversability::to_occupancy;
use fitslam_core::utility::LandmarkVoxels;
use fitslam_core::{Params, Pose2};
use web_time::Instant;

/// Revision counters of the scene's parts; the app bumps one whenever it edits that part.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Revisions {
    pub map: u64,
    pub landmarks: u64,
    /// Robot pose, boundary, blacklist.
    pub layout: u64,
}

/// Wall-clock time of the last run of each stage, milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    pub threshold_ms: f64,
    pub voxels_ms: f64,
    pub decision_ms: f64,
    /// Sum of the stages that ran in the last update (what a slider move cost).
    pub last_update_ms: f64,
}

/// Cache key of the voxels: landmarks revision, voxel size and σ_l bits.
type VoxelKey = (u64, u64, u64);
/// Cache key of the decision: everything it depends on (robot pose as bits).
type DecisionKey = (Revisions, Params, ExploreParams, [u64; 3]);

/// The cached stages.
#[derive(Default)]
pub struct Pipeline {
    occupancy: Option<((u64, u64), OccupancyGrid)>,
    voxels: Option<(VoxelKey, Result<LandmarkVoxels, String>)>,
    /// The explorer's traced decision, its ranking (the last attempt's) or why there is none.
    decision: Option<(DecisionKey, Result<Decision, String>, Option<TracedDecision>)>,
    inflated: Option<((u64, u64, u64), OccupancyGrid)>,
    /// Incremented whenever the decision is recomputed.
    pub decision_revision: u64,
    pub timings: Timings,
    /// How many decisions were computed (for tests: a cache hit does not count).
    pub decisions_computed: u64,
}

fn bits(v: f64) -> u64 {
    v.to_bits()
}

impl Pipeline {
    /// Brings every stage up to date; returns whether the decision was recomputed.
    pub fn update(&mut self, scene: &Scene, revs: Revisions, params: &Params, explore: &ExploreParams) -> bool {
        let mut spent_ms = 0.0;
        let occ_key = (revs.map, bits(params.traversability.tau));
        if self.occupancy.as_ref().is_none_or(|(k, _)| *k != occ_key) {
            let t = Instant::now();
            let grid = to_occupancy(&scene.map.score, params.traversability.tau);
            self.timings.threshold_ms = ms_since(t);
            spent_ms += self.timings.threshold_ms;
            self.occupancy = Some((occ_key, grid));
        }
        let vox_key = (revs.landmarks, bits(params.u2.voxel_m), bits(params.u2.sigma_landmark_m));
        if self.voxels.as_ref().is_none_or(|(k, _)| *k != vox_key) {
            let t = Instant::now();
            let v = LandmarkVoxels::new(&scene.landmarks.cloud, params.u2.voxel_m, params.u2.sigma_landmark_m)
                .map_err(|e| format!("landmarks {}: {e}", scene.landmarks.source));
            self.timings.voxels_ms = ms_since(t);
            spent_ms += self.timings.voxels_ms;
            self.voxels = Some((vox_key, v));
        }
        let pose = pose_bits(scene.robot);
        let dec_key = (revs, params.clone(), explore.clone(), pose);
        let mut recomputed = false;
        if self.decision.as_ref().is_none_or(|(k, _, _)| *k != dec_key) {
            let t = Instant::now();
            let (ranking, traced) = match (&self.occupancy, &self.voxels) {
                (Some((_, grid)), Some((_, Ok(voxels)))) => match decide(scene, grid, voxels, params, explore) {
                    Ok(traced) => (ranking_of(&traced), Some(traced)),
                    Err(e) => (Err(e), None),
                },
                (_, Some((_, Err(e)))) => (Err(e.clone()), None),
                _ => (Err("internal: stage missing".to_string()), None),
            };
            self.timings.decision_ms = ms_since(t);
            spent_ms += self.timings.decision_ms;
            self.decision = Some((dec_key, ranking, traced));
            self.decision_revision += 1;
            self.decisions_computed += 1;
            recomputed = true;
        }
        if spent_ms > 0.0 {
            self.timings.last_update_ms = spent_ms;
        }
        recomputed
    }

    /// The ranking the explorer acted on, or why there is none.
    pub fn decision(&self) -> Option<&Result<Decision, String>> {
        self.decision.as_ref().map(|(_, d, _)| d)
    }

    /// The explorer's whole answer: its action and every attempt of the retry ladder.
    pub fn traced(&self) -> Option<&TracedDecision> {
        self.decision.as_ref().and_then(|(_, _, t)| t.as_ref())
    }

    /// What the robot would do on this scene.
    pub fn action(&self) -> Option<&Action> {
        self.traced().map(|t| &t.action)
    }

    /// The current decision if it succeeded.
    pub fn ok_decision(&self) -> Option<&Decision> {
        self.decision().and_then(|d| d.as_ref().ok())
    }

    /// The thresholded grid (after [`Self::update`]).
    pub fn occupancy(&self) -> Option<&OccupancyGrid> {
        self.occupancy.as_ref().map(|(_, g)| g)
    }

    /// The voxels (after [`Self::update`]).
    pub fn voxels(&self) -> Option<&LandmarkVoxels> {
        self.voxels.as_ref().and_then(|(_, v)| v.as_ref().ok())
    }

    /// Revision key of the thresholded grid, for texture caching.
    pub fn occupancy_key(&self) -> Option<(u64, u64)> {
        self.occupancy.as_ref().map(|(k, _)| *k)
    }

    /// The thresholded grid inflated by the robot radius (computed on demand, for display: the
    /// selector inflates internally).
    pub fn inflated(&mut self, radius_m: f64) -> Option<(&OccupancyGrid, (u64, u64, u64))> {
        let ((m, t), occ) = self.occupancy.as_ref()?;
        let key = (*m, *t, bits(radius_m));
        if self.inflated.as_ref().is_none_or(|(k, _)| *k != key) {
            self.inflated = Some((key, inflate_lethal(occ, radius_m)));
        }
        self.inflated.as_ref().map(|(k, g)| (g, *k))
    }
}

/// The explorer's decision on the scene, as the robot would make it from a fresh start: the
/// scene's blacklist, no trail, no goal reached, no position uncertainty, the map its own.
fn decide(
    scene: &Scene,
    grid: &OccupancyGrid,
    voxels: &LandmarkVoxels,
    params: &Params,
    explore: &ExploreParams,
) -> Result<TracedDecision, String> {
    let params = Valid::new(params.clone()).map_err(|e| format!("parameters: {e}"))?;
    let explore = Valid::new(explore.clone()).map_err(|e| format!("exploration parameters: {e}"))?;
    let mut explorer = Explorer::new(explore, params).with_blacklist(scene.blacklist.clone());
    Ok(explorer.decide_traced(&mut grid.clone(), &Situation::one_off(voxels, scene.robot, Some(&scene.boundary))))
}

/// The ranking of a traced decision: the last attempt's, or the selector's error.
fn ranking_of(traced: &TracedDecision) -> Result<Decision, String> {
    match traced.attempts.last().map(|a| &a.outcome) {
        Some(Ok(d)) => Ok(d.clone()),
        Some(Err(e)) => Err(e.to_string()),
        None => Err("internal: no attempt".to_string()),
    }
}

fn pose_bits(p: Pose2) -> [u64; 3] {
    [bits(p.x_m), bits(p.y_m), bits(p.yaw_rad)]
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
