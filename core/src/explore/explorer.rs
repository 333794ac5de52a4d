//! The explorer: one decision on the robot's map, with the retry chain, goal keeping and the
//! goals' book-keeping (notes §3, §7).
//!
//! A decision runs the selector ([`crate::select`]) on the thresholded map. When it finds no
//! goal, it is made again on a changed input, each retry only when the one before found
//! nothing, so that the usual decision is always the plain one (docs/decisions/0001–0005):
//! 1. the robot is blocked in its map (`SelectError::RobotBlocked`): again with the cells within
//!    the robot radius plus one cell free ([`super::ExploreParams::clear_footprint`]);
//! 2. no goal: again with the robot's trail free after inflation
//!    ([`super::ExploreParams::reuse_trail`]);
//! 3. still none: again, trail open, with lethal cells inflated by each tight radius in turn
//!    ([`super::ExploreParams::tight_inflations_m`]);
//! 4. still none: trapped (every free cell it reaches lies within `trapped_radius_m`, judged at
//!    the last radius tried) → [`Action::Recover`] (at most `trap_recoveries` times, then
//!    [`EndReason::Trapped`]), else [`EndReason::NoFrontier`].
//!
//! Candidates with no path are blacklisted `NoPath`; a goal chosen near a goal reached before
//! blacklists that one (`Reselected`) and the decision is made again; a failed goal is
//! blacklisted `Failed`. At periodic replanning the current goal is kept while the nearest
//! reachable candidate lies within the blacklist radius of it. Paths end short of unknown ground
//! by the position's uncertainty (`set_back`).
//!
//! Cost: one selector run per attempt (at most 5 + the number of tight radii), plus one
//! inflation (O(cells · disc)) for the trap check when nothing is found.

use super::action::{Action, ActiveGoal, EndReason, ExploreStats, Plan, Situation, WaitReason};
use super::params::ExploreParams;
use super::trail::Trail;
use crate::frontier::{Blacklist, BlacklistReason, enclosed_within, recovery_radius_m};
use crate::grid::{Cell, FREE, OccupancyGrid, fill_disc, free_traversed, inflate_lethal};
use crate::math;
use crate::params::{Params, Valid};
use crate::path::set_back;
use crate::pose::Pose2;
use crate::select::{Decision, DecisionInput, DropReason, GoalSelector, SelectError, make_selector};
use serde::Serialize;

/// The exploration policy's state.
///
/// # Examples
///
/// One decision in a corridor with a frontier at each end and landmarks only to the east:
///
/// ```
/// use fitslam_core::explore::Attempt;
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{Action, ExploreParams, Explorer, Params, Situation, Valid};
///
/// let mut world = corridor_two_frontiers(true);
/// let planner = Valid::new(Params::default())?; // FIT-SLAM
/// let voxels = LandmarkVoxels::new(&world.landmarks, planner.u2.voxel_m, planner.u2.sigma_landmark_m)?;
/// let mut explorer = Explorer::new(Valid::new(ExploreParams::default())?, planner);
///
/// let situation = Situation::one_off(&voxels, world.robot, None);
/// let traced = explorer.decide_traced(&mut world.grid, &situation);
/// let Action::Goal(plan) = &traced.action else { panic!("expected a goal, got {:?}", traced.action) };
/// assert!(plan.goal.goal.x_m > world.robot.x_m); // east, towards the landmarks
/// assert!(plan.rho_m > 0.0 && !plan.path_m.is_empty());
///
/// // The plain attempt found the goal: no retry was needed, and its ranking is kept.
/// assert_eq!(traced.attempts.len(), 1);
/// assert_eq!(traced.attempts[0].attempt, Attempt::Plain);
/// let ranking = traced.decision().expect("the plain attempt ranked candidates");
/// assert_eq!(ranking.chosen, Some(plan.candidate));
/// assert_eq!(explorer.goal(), Some(plan.goal));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Explorer {
    params: Valid<ExploreParams>,
    /// The planner's parameters (the selector's strategy and seed among them).
    planner: Valid<Params>,
    selector: Box<dyn GoalSelector>,
    blacklist: Blacklist,
    trail: Trail,
    /// The goals reached so far (notes §3: one selected again while still a frontier goal is
    /// blacklisted).
    reached: Vec<[f64; 2]>,
    goal: Option<ActiveGoal>,
    /// Decisions in a row that found no plan.
    failed_decisions: u32,
    stats: ExploreStats,
    last_decision: Option<Decision>,
    /// A wall clock in milliseconds, only to time the decisions (the core has no clock).
    clock: Option<Box<dyn FnMut() -> f64>>,
}

impl Explorer {
    /// An explorer with these parameters; the selector is `planner.selector`'s.
    pub fn new(params: Valid<ExploreParams>, planner: Valid<Params>) -> Self {
        Self {
            selector: make_selector(&planner.selector),
            blacklist: Blacklist::new(planner.frontier.blacklist_radius_m),
            trail: Trail::default(),
            reached: Vec::new(),
            goal: None,
            failed_decisions: 0,
            stats: ExploreStats::default(),
            last_decision: None,
            clock: None,
            params,
            planner,
        }
    }

    /// The same explorer with `blacklist` as its blacklist so far (a scene's, in the studio).
    pub fn with_blacklist(mut self, blacklist: Blacklist) -> Self {
        self.blacklist = blacklist;
        self
    }

    /// A wall clock in milliseconds, used only to fill the timing statistics.
    pub fn set_clock(&mut self, clock: Box<dyn FnMut() -> f64>) {
        self.clock = Some(clock);
    }

    /// The exploration policy's parameters.
    pub fn params(&self) -> &Valid<ExploreParams> {
        &self.params
    }

    /// The planner's parameters.
    pub fn planner(&self) -> &Valid<Params> {
        &self.planner
    }

    /// The goals given up on so far.
    pub fn blacklist(&self) -> &Blacklist {
        &self.blacklist
    }

    /// The goal being pursued, if any.
    pub fn goal(&self) -> Option<ActiveGoal> {
        self.goal
    }

    /// Counters of the decisions and goals so far.
    pub fn stats(&self) -> &ExploreStats {
        &self.stats
    }

    /// The last decision that ranked candidates (whole ranking), if any.
    pub fn last_decision(&self) -> Option<&Decision> {
        self.last_decision.as_ref()
    }

    /// The robot's trail ([`ExploreParams::reuse_trail`]; empty when it is off).
    pub fn trail(&mut self) -> &mut Trail {
        &mut self.trail
    }

    /// The robot's centre is at (x, y), map frame, driven there from its last position: extends
    /// the trail (when `reuse_trail`).
    pub fn record_position(&mut self, x_m: f64, y_m: f64) {
        if self.params.reuse_trail {
            self.trail.push(x_m, y_m);
        }
    }

    /// The robot's centre drove from `from` to `to` (estimated poses, map frame): extends the
    /// trail (when `reuse_trail`; a new stroke where the estimate jumped since the last motion).
    pub(crate) fn record_motion(&mut self, from: Pose2, to: Pose2) {
        if self.params.reuse_trail {
            self.trail.drove([from.x_m, from.y_m], [to.x_m, to.y_m]);
        }
    }

    /// The current goal was reached (and faced): remembered, so that choosing it again
    /// blacklists it.
    pub fn goal_reached(&mut self) {
        self.stats.goals_reached += 1;
        if let Some(g) = self.goal.take() {
            self.reached.push([g.goal.x_m, g.goal.y_m]);
        }
    }

    /// The current goal failed (timed out, aborted, rejected, bumper): blacklisted `Failed`.
    pub fn goal_failed(&mut self) {
        if let Some(g) = self.goal.take() {
            self.blacklist.add(g.goal.x_m, g.goal.y_m, BlacklistReason::Failed);
            self.stats.goals_failed += 1;
        }
    }

    /// The current goal is given up without blame (lost in transport, its cell no longer free):
    /// the next decision may choose it again.
    pub fn goal_dropped(&mut self) {
        self.goal = None;
    }

    /// One decision on `grid`, the robot's thresholded map (its footprint is cleared in it when
    /// the robot is blocked: `grid` is then what the decision planned on).
    pub fn decide(&mut self, grid: &mut OccupancyGrid, s: &Situation) -> Action {
        self.decide_timed(grid, s, None)
    }

    /// [`Self::decide`], with every attempt of the retry ladder and the selector's answer to it:
    /// what the studio and `fitslam select` show, so that they show what the robot would do.
    /// Costs a copy of each ranking.
    pub fn decide_traced(&mut self, grid: &mut OccupancyGrid, s: &Situation) -> TracedDecision {
        let mut attempts = Vec::new();
        let action = self.decide_timed(grid, s, Some(&mut attempts));
        TracedDecision { action, attempts }
    }

    fn decide_timed(&mut self, grid: &mut OccupancyGrid, s: &Situation, trace: Option<&mut Vec<AttemptRecord>>) -> Action {
        let started = self.stats.total_plan_ms;
        let action = self.decide_untimed(grid, s, trace);
        self.stats.last_decide_ms = self.stats.total_plan_ms - started;
        action
    }

    fn decide_untimed(&mut self, grid: &mut OccupancyGrid, s: &Situation, mut trace: Option<&mut Vec<AttemptRecord>>) -> Action {
        let g = grid.geometry;
        let margin_m = self.params.goal_setback.margin_m(s.position_var_m2, 0.0);
        let mut ladder = Ladder { footprint_cleared: false, trail_open: false, tight: None };
        let mut attempt = Attempt::Plain;
        // At most: footprint clearing, trail, each tight inflation, and a few goals re-chosen.
        for _ in 0..5 + self.params.tight_inflations_m.len() {
            match attempt {
                Attempt::Plain | Attempt::Reselected { .. } => {}
                Attempt::ClearFootprint => {
                    let clear_m = self.planner.robot.radius_m + g.resolution_m;
                    fill_disc(grid, s.robot.x_m, s.robot.y_m, clear_m, FREE);
                    ladder.footprint_cleared = true;
                    self.stats.footprint_clearings += 1;
                }
                Attempt::OpenTrail => ladder.trail_open = true,
                Attempt::TightInflation { index, radius_m } => ladder.tight = Some((index, self.planner.with_robot_radius_m(radius_m))),
            }
            let params = ladder.tight.as_ref().map_or(&self.planner, |(_, p)| p);
            let t0 = self.clock.as_mut().map(|c| c());
            let input = DecisionInput {
                grid,
                landmarks: s.landmarks,
                robot: s.robot,
                boundary: s.boundary,
                blacklist: &self.blacklist,
                ground_z_m: s.ground_z_m,
                ground: s.ground,
                traversed: if ladder.trail_open { self.trail.cells(&g) } else { &[] },
            };
            let result = self.selector.select(&input, params);
            if let (Some(t0), Some(c)) = (t0, self.clock.as_mut()) {
                self.stats.total_plan_ms += c() - t0;
            }
            self.stats.decisions += 1;
            if let Some(t) = trace.as_deref_mut() {
                t.push(AttemptRecord { attempt, outcome: result.clone() });
            }
            let inflation_m = params.robot.radius_m;
            match self.judge(result, &ladder, inflation_m, grid, s, margin_m) {
                Judged::Answer(action) => return action,
                Judged::Retry(next) => attempt = next,
            }
        }
        // Every retry re-chose a reached goal: treat as a failure and look around.
        self.failed_decision(WaitReason::Reselected)
    }

    /// What the selector's answer on the ladder's current rung means: an answer, or the next
    /// rung to try (module docs).
    fn judge(
        &mut self,
        result: Result<Decision, SelectError>,
        ladder: &Ladder,
        inflation_m: f64,
        grid: &OccupancyGrid,
        s: &Situation,
        margin_m: f64,
    ) -> Judged {
        let decision = match result {
            Ok(d) => d,
            // Blocked in its own map (speckle under the robot): plan again on its footprint.
            Err(SelectError::RobotBlocked { .. }) if self.params.clear_footprint && !ladder.footprint_cleared => {
                return Judged::Retry(Attempt::ClearFootprint);
            }
            Err(e) => {
                self.stats.planning_errors += 1;
                let action = self.failed_decision(WaitReason::NoPlan(e));
                if matches!(action, Action::Wait(_)) {
                    self.goal = None;
                }
                return Judged::Answer(action);
            }
        };
        for c in &decision.candidates {
            if c.dropped == Some(DropReason::NoPath) {
                self.blacklist.add(c.x_m, c.y_m, BlacklistReason::NoPath);
            }
        }
        let route = Route { inflation_m, on_trail: ladder.trail_open, tight: ladder.tight.is_some(), margin_m };
        if s.replanning
            && let Some(current) = self.goal
            && let Some(k) = self.still_a_candidate(&decision, current.goal)
        {
            self.failed_decisions = 0;
            self.stats.tight_plans += u64::from(route.tight);
            let plan = self.plan(&decision, k, current.goal, route, grid);
            self.last_decision = Some(decision);
            return Judged::Answer(Action::Keep(plan));
        }
        let Some(chosen) = decision.chosen else {
            // No goal: plan again with the cells the robot drove on open.
            if self.params.reuse_trail && !ladder.trail_open && !self.trail.cells(&grid.geometry).is_empty() {
                return Judged::Retry(Attempt::OpenTrail);
            }
            // Then with each tight inflation smaller than the last radius tried (the trail
            // still open).
            let radii = &self.params.tight_inflations_m;
            let tried = ladder.tight.as_ref().map_or(0, |(index, _)| index + 1);
            if let Some(index) = (tried..radii.len()).find(|&k| radii[k] < inflation_m) {
                return Judged::Retry(Attempt::TightInflation { index, radius_m: radii[index] });
            }
            let start = decision.robot_cell;
            self.last_decision = Some(decision);
            return Judged::Answer(self.nothing_left(grid, start, inflation_m, s.can_forget_map));
        };
        let c = &decision.candidates[chosen];
        // A goal chosen again where the robot already went: blacklist and retry.
        let radius_m = self.blacklist.radius_m();
        if let Some(k) = self.reached.iter().position(|p| math::hypot(c.x_m - p[0], c.y_m - p[1]) <= radius_m) {
            let [x_m, y_m] = self.reached.remove(k);
            self.blacklist.add(x_m, y_m, BlacklistReason::Reselected);
            return Judged::Retry(Attempt::Reselected { x_m, y_m });
        }
        let goal = decision.goal.unwrap_or(Pose2 { x_m: c.x_m, y_m: c.y_m, yaw_rad: s.robot.yaw_rad });
        self.stats.tight_plans += u64::from(route.tight);
        let plan = self.plan(&decision, chosen, goal, route, grid);
        self.goal = Some(plan.goal);
        self.failed_decisions = 0;
        self.last_decision = Some(decision);
        Judged::Answer(Action::Goal(plan))
    }

    /// One more decision in a row without a plan: [`EndReason::Stuck`] after
    /// `max_failed_decisions` of them.
    fn failed_decision(&mut self, why: WaitReason) -> Action {
        self.failed_decisions += 1;
        if self.failed_decisions >= self.params.max_failed_decisions { Action::Done(EndReason::Stuck) } else { Action::Wait(why) }
    }

    /// The candidate of `decision` that is the current goal `goal` still: the nearest reachable
    /// one (ranked, or only beyond the top N), if within the blacklist radius of it.
    fn still_a_candidate(&self, decision: &Decision, goal: Pose2) -> Option<usize> {
        let distance = |k: usize| {
            let c = &decision.candidates[k];
            math::hypot(c.x_m - goal.x_m, c.y_m - goal.y_m)
        };
        (0..decision.candidates.len())
            .filter(|&k| {
                let c = &decision.candidates[k];
                c.rho_m.is_some() && c.dropped.is_none_or(|d| d == DropReason::NotInTopN)
            })
            .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
            .filter(|&k| distance(k) <= self.blacklist.radius_m())
    }

    /// The plan to `goal` along candidate `k`'s path, planned and set back as `route` says.
    fn plan(&mut self, decision: &Decision, k: usize, goal: Pose2, route: Route, grid: &OccupancyGrid) -> Plan {
        let c = &decision.candidates[k];
        let goal = ActiveGoal { goal, inflation_m: route.inflation_m, on_trail: route.on_trail };
        self.goal = self.goal.map(|_| goal);
        Plan { goal, path_m: set_back(&c.path_m, grid, route.margin_m), rho_m: c.rho_m.unwrap_or(0.0), candidate: k, tight: route.tight }
    }

    /// No candidate is left after every retry: the mission is done, unless the map walls the
    /// robot in (judged from `start`, the planner's start cell, at `inflation_m`, the last radius
    /// tried).
    fn nothing_left(&mut self, grid: &OccupancyGrid, start: Cell, inflation_m: f64, can_forget_map: bool) -> Action {
        if !self.trapped(grid, start, inflation_m) {
            return Action::Done(EndReason::NoFrontier);
        }
        if !can_forget_map {
            return Action::Wait(WaitReason::Trapped);
        }
        if self.stats.trap_recoveries >= u64::from(self.params.trap_recoveries) {
            return Action::Done(EndReason::Trapped);
        }
        self.stats.trap_recoveries += 1;
        // "No path" was judged on the map the adapter now forgets.
        self.blacklist.remove_reason(BlacklistReason::NoPath);
        self.goal = None;
        Action::Recover { radius_m: recovery_radius_m(self.params.trapped_radius_m, &self.planner) }
    }

    /// Whether the robot is walled in by `grid` inflated by `inflation_m` (the trail open): every
    /// free cell it reaches from `start` lies within [`ExploreParams::trapped_radius_m`].
    fn trapped(&mut self, grid: &OccupancyGrid, start: Cell, inflation_m: f64) -> bool {
        let r = self.params.trapped_radius_m;
        if r <= 0.0 {
            return false;
        }
        let mut inflated = inflate_lethal(grid, inflation_m);
        free_traversed(grid, self.trail.cells(&grid.geometry), &mut inflated);
        enclosed_within(&inflated, start, r)
    }
}

/// One step of the retry ladder (module docs; ARCHITECTURE.md, "When a decision finds no goal"):
/// what an attempt changed before the selector ran again. Each step keeps what the steps before
/// it opened.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "step", rename_all = "snake_case")]
pub enum Attempt {
    /// The decision on the robot's map as it is.
    Plain,
    /// 1. The robot was blocked in its map: its footprint cleared ([`ExploreParams::clear_footprint`]).
    ClearFootprint,
    /// 2. No goal: the robot's trail free after inflation ([`ExploreParams::reuse_trail`]).
    OpenTrail,
    /// 3. Still none: lethal cells inflated by `tight_inflations_m[index]` = `radius_m`
    ///    ([`ExploreParams::tight_inflations_m`]).
    TightInflation {
        /// Index into [`ExploreParams::tight_inflations_m`].
        index: usize,
        /// The inflation radius, metres.
        radius_m: f64,
    },
    /// The goal chosen lay where the robot had been: that goal blacklisted `Reselected`, the
    /// same input again.
    Reselected {
        /// x of the goal reached before and now blacklisted, map frame, metres.
        x_m: f64,
        /// y of that goal, map frame, metres.
        y_m: f64,
    },
}

/// One attempt of a decision and the selector's answer to it.
#[derive(Clone, Debug, PartialEq)]
pub struct AttemptRecord {
    /// What was tried.
    pub attempt: Attempt,
    /// The selector's answer (its whole ranking), or why it gave none.
    pub outcome: Result<Decision, SelectError>,
}

/// A decision with every attempt it took ([`Explorer::decide_traced`]).
///
/// # Examples
///
/// A robot blocked in its own map: the plain attempt fails, clearing the footprint finds a goal.
///
/// ```
/// use fitslam_core::explore::Attempt;
/// use fitslam_core::fixtures::corridor_two_frontiers;
/// use fitslam_core::grid::{fill_disc, LETHAL};
/// use fitslam_core::select::SelectError;
/// use fitslam_core::utility::LandmarkVoxels;
/// use fitslam_core::{Action, ExploreParams, Explorer, Params, Situation, Valid};
///
/// let mut world = corridor_two_frontiers(true);
/// let planner = Valid::new(Params::default())?;
/// let voxels = LandmarkVoxels::new(&world.landmarks, planner.u2.voxel_m, planner.u2.sigma_landmark_m)?;
/// // Registration speckle all over the robot's footprint blocks the plain decision.
/// let (x_m, y_m) = (world.robot.x_m, world.robot.y_m);
/// fill_disc(&mut world.grid, x_m, y_m, 0.3, LETHAL);
/// let mut explorer = Explorer::new(Valid::new(ExploreParams::default())?, planner);
/// let traced = explorer.decide_traced(&mut world.grid, &Situation::one_off(&voxels, world.robot, None));
///
/// assert!(matches!(traced.attempts[0].outcome, Err(SelectError::RobotBlocked { .. })));
/// assert_eq!(traced.attempts[1].attempt, Attempt::ClearFootprint);
/// assert!(matches!(traced.action, Action::Goal(_)), "{:?}", traced.action);
/// assert!(traced.decision().is_some()); // the ranking the goal came from
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct TracedDecision {
    /// What the explorer answers (what the robot would do).
    pub action: Action,
    /// The attempts in order; the last one decided the action.
    pub attempts: Vec<AttemptRecord>,
}

impl TracedDecision {
    /// The ranking the action was decided on: the last attempt's, when it ranked candidates.
    pub fn decision(&self) -> Option<&Decision> {
        self.attempts.last().and_then(|a| a.outcome.as_ref().ok())
    }
}

/// What the rungs of the ladder taken so far have opened.
struct Ladder {
    footprint_cleared: bool,
    trail_open: bool,
    /// The tight radius in use: its index and the planner's parameters with it.
    tight: Option<(usize, Valid<Params>)>,
}

/// How a plan is made on the current rung.
#[derive(Clone, Copy)]
struct Route {
    inflation_m: f64,
    on_trail: bool,
    tight: bool,
    /// The set-back from unknown ground, metres.
    margin_m: f64,
}

/// A selector answer judged: the explorer's answer, or the next attempt.
enum Judged {
    Answer(Action),
    Retry(Attempt),
}
