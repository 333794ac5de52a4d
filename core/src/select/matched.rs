//! Controls "random at FIT-SLAM's distance": they separate an informed choice from going far.
//! Each decision ranks the candidates as FIT-SLAM does (u1, u2 over the N best), takes the path
//! length ρ* of the goal FIT-SLAM would choose, and draws uniformly (seeded ChaCha8, one draw per
//! decision, as [`super::random`]) among the candidates of its pool whose ρ lies within ±0.2 · ρ*
//! (FIT-SLAM's own goal always does). Over a mission its path lengths follow FIT-SLAM's; what its
//! paths see does not. The drawn candidate gets rank 1, the others none; u1, I_p and u2 stay
//! reported. The pool (`MatchPool`):
//! - `matched`: every reachable, non-blacklisted candidate, so `fit − matched` mixes u2's
//!   information with u1's ranking;
//! - `matched_top`: u1's N best only, the candidates u2 itself chooses among, so
//!   `fit − matched_top` is u2's information alone.

use super::candidates::{PathScore, PlanBuffers, choose, plan, rank_by_u2, score_u2, set_goal_heading};
use super::{Decision, DecisionInput, GoalSelector, SelectError};
use crate::params::{Params, Strategy, Valid};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Half-width of the path-length band the draw is made in, relative to FIT-SLAM's ρ*: wide
/// enough to hold several candidates on a typical map, narrow enough that a mission's distances
/// stay FIT-SLAM's.
pub(crate) const LENGTH_TOLERANCE: f64 = 0.2;

/// The candidates a length-matched draw is made among (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MatchPool {
    /// Every reachable candidate (`matched`).
    Reachable,
    /// u1's N best (`matched_top`).
    TopN,
}

/// Uniform among the candidates of a pool at FIT-SLAM's path length.
#[derive(Clone, Debug)]
pub(crate) struct LengthMatched {
    rng: ChaCha8Rng,
    pool: MatchPool,
    buffers: PlanBuffers,
}

impl LengthMatched {
    /// A selector drawing from `pool`, its draws determined by `seed`.
    pub fn new(seed: u64, pool: MatchPool) -> Self {
        Self { rng: ChaCha8Rng::seed_from_u64(seed), pool, buffers: PlanBuffers::default() }
    }
}

impl GoalSelector for LengthMatched {
    fn select(&mut self, input: &DecisionInput, params: &Valid<Params>) -> Result<Decision, SelectError> {
        let mut d = plan(input, params, self.strategy(), &mut self.buffers)?;
        let reachable: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].is_scored()).collect();
        score_u2(&mut d, input, params, PathScore::Fisher);
        let ranked = rank_by_u2(&mut d);
        let Some(rho_fit) = d.chosen.and_then(|i| d.candidates[i].rho_m) else {
            return Ok(d);
        };
        let pool: Vec<usize> = match self.pool {
            MatchPool::Reachable => reachable,
            MatchPool::TopN => ranked,
        };
        let pool: Vec<usize> = pool
            .into_iter()
            .filter(|&i| d.candidates[i].rho_m.is_some_and(|rho| (rho - rho_fit).abs() <= LENGTH_TOLERANCE * rho_fit))
            .collect();
        for c in d.candidates.iter_mut() {
            c.rank = None;
        }
        let chosen = (!pool.is_empty()).then(|| pool[self.rng.random_range(0..pool.len())]);
        if let Some(i) = chosen {
            let c = &mut d.candidates[i];
            c.rank = Some(1);
            c.dropped = None;
        }
        choose(&mut d, chosen);
        set_goal_heading(&mut d, params.selector.baseline_heading);
        Ok(d)
    }

    fn strategy(&self) -> Strategy {
        match self.pool {
            MatchPool::Reachable => Strategy::Matched,
            MatchPool::TopN => Strategy::MatchedTop,
        }
    }
}
