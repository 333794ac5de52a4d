//! Random baseline (notes §7): uniform among the reachable, non-blacklisted candidates, drawn
//! from a seeded ChaCha8 generator owned by the selector (same seed, same sequence of
//! decisions). One draw per decision with at least one candidate; the drawn candidate gets
//! rank 1 and the others no rank.

use super::candidates::{PlanBuffers, choose, plan, set_goal_heading};
use super::{Decision, DecisionInput, GoalSelector, SelectError};
use crate::params::{Params, Strategy, Valid};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Uniform among reachable candidates.
#[derive(Clone, Debug)]
pub(crate) struct RandomSelector {
    rng: ChaCha8Rng,
    buffers: PlanBuffers,
}

impl RandomSelector {
    /// A selector whose draws are determined by `seed`.
    pub fn new(seed: u64) -> Self {
        Self { rng: ChaCha8Rng::seed_from_u64(seed), buffers: PlanBuffers::default() }
    }
}

impl GoalSelector for RandomSelector {
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError> {
        let mut d = plan(input, params, Strategy::Random, &mut self.buffers)?;
        let scored: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].is_scored()).collect();
        let chosen = (!scored.is_empty()).then(|| scored[self.rng.random_range(0..scored.len())]);
        if let Some(i) = chosen {
            d.candidates[i].rank = Some(1);
        }
        choose(&mut d, chosen);
        set_goal_heading(&mut d, params.selector.baseline_heading);
        Ok(d)
    }

    fn strategy(&self) -> Strategy {
        Strategy::Random
    }
}
