//! FIT-SLAM's selector (notes §5–6, paper §II-D): u1 over every reachable candidate, u2 over the
//! N best by u1, goal = argmax u2 (ties by candidate index). Cost: the pipeline's (see
//! [`super::candidates`]).
//!
//! The same selector with [`PathScore::Length`] is the control `u2_length`: u2 = β · u1 +
//! (1 − β) · ρ̂, ρ̂ the path length normalised over the N as I_p is (`u2.normalisation`), instead
//! of the Fisher information I_p. I_p sums the information at waypoints every few metres along the
//! path, so a longer path collects more of it; if `fit` and `u2_length` choose alike, I_p acts
//! mostly as a reward for going far.
//!
//! With [`PathScore::TrackedShare`] it is the positive control `u2_truth`: I_p replaced by the
//! share of views along the path (every `u2.tracked_spacing_m`, and the goal at Θ*) that hold at
//! least `u2.tracked_min_voxels` landmark voxels, normalised the same way. The simulator gives it
//! the world's true landmarks, mapped or not ([`Strategy::reads_true_landmarks`]): a choice that
//! knows where the visual front end will starve, which an information model can only approach.

use super::candidates::{PathScore, PlanBuffers, plan, rank_by_u2, score_u2, set_goal_heading};
use super::{Decision, DecisionInput, GoalSelector, SelectError};
use crate::params::{Params, Strategy, Valid};

/// FIT-SLAM: u1 then u2 (by default with I_p, the paper's).
#[derive(Clone, Debug)]
pub struct FitSlam {
    score: PathScore,
    buffers: PlanBuffers,
}

impl Default for FitSlam {
    fn default() -> Self {
        Self::with_path_score(PathScore::Fisher)
    }
}

impl FitSlam {
    /// u2 weighing u1 against `score` (the paper's: [`PathScore::Fisher`]).
    pub fn with_path_score(score: PathScore) -> Self {
        Self { score, buffers: PlanBuffers::default() }
    }
}

impl GoalSelector for FitSlam {
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError> {
        let mut d = plan(input, params, self.strategy(), &mut self.buffers)?;
        score_u2(&mut d, input, params, self.score);
        rank_by_u2(&mut d);
        set_goal_heading(&mut d, params.selector.fit_heading);
        Ok(d)
    }

    fn strategy(&self) -> Strategy {
        match self.score {
            PathScore::Fisher => Strategy::Fit,
            PathScore::Length => Strategy::U2Length,
            PathScore::TrackedShare => Strategy::U2Truth,
        }
    }
}
