//! [`GraphSlam`](super::GraphSlam)'s parameters and constants.

use serde::{Deserialize, Serialize};

#[cfg(doc)]
use crate::slam::backend::{KeyframeUpdate, SlamBackend};
use crate::slam::factors::RobustKernel;
use crate::slam::incremental::Isam2Params;
use crate::slam::optimizer::OptimizerParams;

/// σ of the incremental solver's prior on the first keyframe, on every tangent component (m,
/// rad): the gauge, tight enough that the anchored marginals match the batch solver's fixed
/// first keyframe to ~10⁻⁹ relative.
pub const ANCHOR_SIGMA: f64 = 1e-6;

/// Cauchy scale of the landmark observations, σ of the whitened 3-D residual. An inlier's norm
/// is below √(χ²₃ at 95 %) = 2.8 in 95 % of cases, where the weight 1/(1 + s²/k²) stays ≥ 0.67;
/// a wrong match 1 m off a 3 cm σ (s ≈ 30) weighs 0.02.
pub const OBSERVATION_CAUCHY_K: f64 = 4.0;

/// Which solver keeps [`super::GraphSlam`]'s estimate (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlamSolver {
    /// iSAM2: one Bayes-tree update per keyframe, the exact marginal from the root.
    #[default]
    Incremental,
    /// Sliding-window LM per keyframe, full LM per loop closure, marginals by a full sparse
    /// Cholesky.
    Batch,
}

/// Parameters of [`super::GraphSlam`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GraphSlamParams {
    /// Incremental (iSAM2, default) or batch.
    pub solver: SlamSolver,
    /// The incremental solver's relinearisation and back-substitution thresholds. Default:
    /// GTSAM's ([`Isam2Params::default`]).
    pub isam2: Isam2Params,
    /// Batch: keyframes optimised by a sliding-window update (the most recent ones). Default 10.
    pub window_keyframes: usize,
    /// A landmark seen again after this many keyframes without being seen closes a loop.
    /// Default 20.
    pub loop_closure_gap_keyframes: usize,
    /// After a loop closure marked [`KeyframeUpdate::full`], closures within this many
    /// keyframes are not marked (batch: handled by the window update, the re-observed landmarks
    /// free in it, anchored by their old observations; one revisit re-observes many old
    /// landmarks over several keyframes, and each would otherwise re-run the full problem).
    /// Default 0 (every closure is marked).
    pub full_cooldown_keyframes: usize,
    /// The robust kernel on every landmark observation (wrong data associations). Default
    /// Cauchy with k = 4 (decision 0018): its influence falls back to 0
    /// for a gross mismatch, where Huber's only stops growing.
    pub observation_kernel: RobustKernel,
    /// Batch: stopping rules of each optimisation, and the factorisation of it and of the
    /// marginals ([`Factorisation`](crate::slam::Factorisation)); both solvers: of [`SlamBackend::optimize_full`].
    /// Default: [`OptimizerParams::default`] with 20 iterations.
    pub optimizer: OptimizerParams,
}

impl Default for GraphSlamParams {
    fn default() -> Self {
        Self {
            solver: SlamSolver::default(),
            isam2: Isam2Params::default(),
            window_keyframes: 10,
            loop_closure_gap_keyframes: 20,
            full_cooldown_keyframes: 0,
            observation_kernel: RobustKernel::Cauchy { k: OBSERVATION_CAUCHY_K },
            optimizer: OptimizerParams { max_iterations: 20, ..OptimizerParams::default() },
        }
    }
}
