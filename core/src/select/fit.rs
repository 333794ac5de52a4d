//! FIT-SLAM's selector (notes §5–6, paper §II-D): u1 over every reachable candidate, u2 over the
//! N best by u1, goal = argmax u2 (ties by candidate index). Cost: the pipeline's (see
//! [`super::candidates`]).

use super::candidates::{PathScore, PlanBuffers, plan, rank_and_choose, score_u2};
use super::{Decision, DecisionInput, GoalSelector, SelectError};
use crate::params::{Params, Strategy, Valid};

/// FIT-SLAM: u1 then u2.
#[derive(Clone, Debug, Default)]
pub struct FitSlam {
    buffers: PlanBuffers,
}

impl GoalSelector for FitSlam {
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError> {
        let mut d = plan(input, params, Strategy::Fit, &mut self.buffers)?;
        score_u2(&mut d, input, params, PathScore::Fisher);
        let ranked: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].u2.is_some()).collect();
        rank_and_choose(&mut d, &ranked, |c| -c.u2.unwrap_or(f64::NEG_INFINITY));
        Ok(d)
    }

    fn strategy(&self) -> Strategy {
        Strategy::Fit
    }
}
