//! Greedy baseline (notes §7): the reachable, non-blacklisted candidate with the smallest path
//! length ρ (ties by candidate index). Every scored candidate is ranked by ρ. u1 is still
//! reported (it is cheap and shows what FIT-SLAM would have weighed).

use super::candidates::{PlanBuffers, plan, rank_and_choose, set_goal_heading};
use super::{Decision, DecisionInput, GoalSelector, SelectError};
use crate::params::{Params, Strategy, Valid};

/// Nearest candidate by path length.
#[derive(Clone, Debug, Default)]
pub struct Greedy {
    buffers: PlanBuffers,
}

impl GoalSelector for Greedy {
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError> {
        let mut d = plan(input, params, Strategy::Greedy, &mut self.buffers)?;
        let scored: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].is_scored()).collect();
        rank_and_choose(&mut d, &scored, |c| c.rho_m.unwrap_or(f64::INFINITY));
        set_goal_heading(&mut d, params.selector.baseline_heading);
        Ok(d)
    }

    fn strategy(&self) -> Strategy {
        Strategy::Greedy
    }
}
