//! Control "u2 with path length for information": u2 = β · u1 + (1 − β) · ρ̂ over u1's N best,
//! where ρ̂ is the candidate's path length ρ normalised over the N as I_p is
//! (`u2.normalisation`), instead of the Fisher information I_p (notes §5). I_p sums the
//! information at waypoints every few metres along the path, so a longer path collects more of
//! it; if `fit` and `u2_length` choose alike, I_p acts mostly as a reward for going far. The rest
//! (candidates, u1, the N best, ranking by u2) is FIT-SLAM's.

use super::candidates::{PathScore, PlanBuffers, plan, rank_and_choose, score_u2};
use super::{Decision, DecisionInput, GoalSelector, SelectError};
use crate::params::{Params, Strategy, Valid};

/// u2 with ρ in place of I_p.
#[derive(Clone, Debug, Default)]
pub(crate) struct U2Length {
    buffers: PlanBuffers,
}

impl GoalSelector for U2Length {
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError> {
        let mut d = plan(input, params, Strategy::U2Length, &mut self.buffers)?;
        score_u2(&mut d, input, params, PathScore::Length);
        let ranked: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].u2.is_some()).collect();
        rank_and_choose(&mut d, &ranked, |c| -c.u2.unwrap_or(f64::NEG_INFINITY));
        Ok(d)
    }

    fn strategy(&self) -> Strategy {
        Strategy::U2Length
    }
}
