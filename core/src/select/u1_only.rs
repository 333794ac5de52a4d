//! Ablation "u1 only" (notes §7; FIT-SLAM with β = 1): the candidate with the largest u1 (ties
//! by candidate index). Every scored candidate is ranked by u1.

use super::candidates::{PlanBuffers, plan, rank_and_choose, set_goal_heading};
use super::{Decision, DecisionInput, GoalSelector, SelectError};
use crate::params::{Params, Strategy, Valid};

/// Largest u1.
#[derive(Clone, Debug, Default)]
pub(crate) struct U1Only {
    buffers: PlanBuffers,
}

impl GoalSelector for U1Only {
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError> {
        let mut d = plan(input, params, Strategy::U1, &mut self.buffers)?;
        let scored: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].is_scored()).collect();
        rank_and_choose(&mut d, &scored, |c| -c.u1.unwrap_or(f64::NEG_INFINITY));
        set_goal_heading(&mut d, params.selector.fit_heading);
        Ok(d)
    }

    fn strategy(&self) -> Strategy {
        Strategy::U1
    }
}
