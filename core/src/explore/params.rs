//! The exploration policy's parameters: one struct, nested unchanged as `explore` into the
//! simulator's parameters (`MissionParams`) and the robot node's configuration (`node.explore`).

use crate::params::{InvalidParam, Num, Validate, check_non_negative, check_positive};
use crate::path::GoalSetback;
use serde::{Deserialize, Serialize};

/// Most radii in [`ExploreParams::tight_inflations_m`]: each is one more decision whenever a
/// decision finds no goal.
pub(crate) const MAX_TIGHT_INFLATIONS: usize = 8;

/// How the explorer chooses, keeps and retries goals (see [`super::Explorer`]).
///
/// # Examples
///
/// ```
/// use fitslam_core::{ExploreParams, Valid};
///
/// let indoor = ExploreParams { tight_inflations_m: vec![0.20, 0.10], ..ExploreParams::default() };
/// assert!(Valid::new(indoor).is_ok());
/// // Radii must shrink: each retry squeezes through narrower gaps than the one before.
/// let growing = ExploreParams { tight_inflations_m: vec![0.10, 0.20], ..ExploreParams::default() };
/// let error = Valid::new(growing).unwrap_err();
/// assert_eq!(error.key, "tight_inflations_m[1]");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExploreParams {
    /// Each path ends short of unknown ground by a multiple of the position estimate's standard
    /// deviation (`set_back`): a robot unsure of its position could otherwise
    /// drive past a frontier goal into ground no sensor has seen (docs/decisions/0004). 0 with a
    /// pose without covariance. Defaults 2 σ, at most 1 m.
    pub goal_setback: GoalSetback,
    /// Footprint clearing, as robot costmaps do, when the planner finds the robot blocked (no
    /// free cell of the inflated grid within its radius plus one cell): the decision is made
    /// again with the cells within that distance of the robot free (it stands on that ground), so
    /// registration speckle under the robot cannot block every plan. Only then: cleared on every
    /// decision, a lethal edge just ahead of the robot would be planned through
    /// (docs/decisions/0001). Default true.
    pub clear_footprint: bool,
    /// The robot may go back the way it came: when a decision finds no goal, it is made again
    /// with every cell the robot's centre has driven on ([`super::Trail`]), while free in the
    /// thresholded map, free in the planner's inflated grid (and in the trap check), and the
    /// path check then ignores lethal cells beside such cells for that path. The robot was
    /// there, so the inflation of lethal cells mapped since (a doorway's jambs, seen better from
    /// inside the room) must not shut it in; cells its map holds lethal themselves stay closed.
    /// Only then: open at every decision, the trail leads paths along edges the robot once
    /// stopped at (docs/decisions/0002). Default true.
    pub reuse_trail: bool,
    /// Squeezing through: when a decision finds no goal even with the trail open, it is made
    /// again with lethal cells inflated by each of these radii in turn, metres, instead of
    /// `robot.radius_m`, until one finds a goal (the path check and the trap check of that path
    /// then use that radius too). The robot radius on top of the disc's band of lethal cells
    /// along a wall shuts doorways narrower than about 0.95 m at the defaults; 0.20 m passes
    /// ≈ 0.85 m. A second radius of 0.10 m (radius − disc radius: a cell is lethal when its disc
    /// holds a hazard, so that still keeps the body off hazards in a perfect map) passes 0.7 m,
    /// but on open terrain it also chases scraps of ground at drops the map does not show yet
    /// (docs/decisions/0003): add it for indoor maps with narrow doors. Each > 0 and smaller
    /// than the one before, at most 8; radii at least `robot.radius_m`
    /// are skipped; empty turns the retry off. Default [0.20].
    pub tight_inflations_m: Vec<f64>,
    /// Decisions in a row without a plan before the mission ends as
    /// [`super::EndReason::Stuck`], ≥ 1. Default 30.
    pub max_failed_decisions: u32,
    /// A decision with no frontier goal ends the mission as [`super::EndReason::Trapped`] instead
    /// of [`super::EndReason::NoFrontier`] when every free cell the robot can reach in its
    /// inflated map lies within this distance, metres (a pocket a few robot lengths wide; a
    /// finished map's reachable space spans what was explored), ≥ 0. 0 turns the distinction
    /// off. Default 2.
    pub trapped_radius_m: f64,
    /// Times a trapped robot recovers before the mission ends [`super::EndReason::Trapped`]: as
    /// Nav2's clear-costmap recovery does, it forgets its map within
    /// `recovery_radius_m` of itself and maps it again (docs/decisions/0005).
    /// 0: no recovery. Default 2.
    pub trap_recoveries: u32,
}

impl Default for ExploreParams {
    fn default() -> Self {
        Self {
            goal_setback: GoalSetback::default(),
            clear_footprint: true,
            reuse_trail: true,
            tight_inflations_m: vec![0.20],
            max_failed_decisions: 30,
            trapped_radius_m: 2.0,
            trap_recoveries: 2,
        }
    }
}

/// The keys of [`ExploreParams`]: a configuration file that still has one of them beside the
/// `explore` table (where they were before it existed) is told where it moved.
pub const EXPLORE_KEYS: &[&str] = &[
    "goal_setback",
    "clear_footprint",
    "reuse_trail",
    "tight_inflations_m",
    "max_failed_decisions",
    "trapped_radius_m",
    "trap_recoveries",
];

impl Validate for ExploreParams {
    /// Checks every field; the error names the first bad one (`tight_inflations_m[1]`; the
    /// simulator's file adds `explore.`, the node's `node.explore.`).
    fn validate(&self) -> Result<(), InvalidParam> {
        self.goal_setback.validate().map_err(|e| e.under("goal_setback."))?;
        check_tight_inflations("tight_inflations_m", &self.tight_inflations_m)?;
        if self.max_failed_decisions == 0 {
            return Err(InvalidParam::new("max_failed_decisions", "must be ≥ 1"));
        }
        check_non_negative("trapped_radius_m", self.trapped_radius_m)
    }
}

/// `Ok` when `radii` (named `name`) is a valid [`ExploreParams::tight_inflations_m`]: at most
/// [`MAX_TIGHT_INFLATIONS`], each finite and > 0, each smaller than the one before.
pub(crate) fn check_tight_inflations(name: &str, radii: &[f64]) -> Result<(), InvalidParam> {
    if radii.len() > MAX_TIGHT_INFLATIONS {
        return Err(InvalidParam::new(name, format!("{} radii, over the limit of {MAX_TIGHT_INFLATIONS}", radii.len())));
    }
    for (i, &r) in radii.iter().enumerate() {
        check_positive(&format!("{name}[{i}]"), r)?;
        if i > 0 && r >= radii[i - 1] {
            let reason = format!("must be smaller than the radius before it ({}; got {})", Num(radii[i - 1]), Num(r));
            return Err(InvalidParam::new(format!("{name}[{i}]"), reason));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_name_their_key() {
        assert_eq!(ExploreParams::default().validate(), Ok(()));
        let p = ExploreParams { tight_inflations_m: vec![0.2, 0.3], ..ExploreParams::default() };
        let e = p.validate().unwrap_err().under("explore.");
        assert_eq!(e.key, "explore.tight_inflations_m[1]");
        assert!(e.to_string().contains("smaller than the radius before it"), "{e}");
        let p = ExploreParams { max_failed_decisions: 0, ..ExploreParams::default() };
        assert_eq!(p.validate().unwrap_err().key, "max_failed_decisions");
        let p = ExploreParams { goal_setback: GoalSetback { max_m: -1.0, ..GoalSetback::default() }, ..ExploreParams::default() };
        assert_eq!(p.validate().unwrap_err().key, "goal_setback.max_m");
        let p = ExploreParams { tight_inflations_m: vec![0.5; MAX_TIGHT_INFLATIONS + 1], ..ExploreParams::default() };
        assert!(p.validate().unwrap_err().to_string().contains("over the limit"));
    }

    #[test]
    fn explore_keys_are_the_struct_fields() {
        let v = serde_json::to_value(ExploreParams::default()).unwrap();
        let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        let mut listed = EXPLORE_KEYS.to_vec();
        listed.sort_unstable();
        assert_eq!(keys, listed);
    }
}
