//! Incremental smoothing and mapping on a Bayes tree: iSAM2 (M. Kaess, H. Johannsson, R.
//! Roberts, V. Ila, J. Leonard, F. Dellaert, "iSAM2: Incremental smoothing and mapping using the
//! Bayes tree", IJRR 31(2), 2012, Alg. 4–7).
//!
//! The solver keeps a linearisation point θ, the Gauss-Newton step Δ from it (the estimate is
//! θ ⊕ Δ) and the Bayes tree of the linearised system. An [`Isam2::update`]:
//! 1. *Fluid relinearisation* (Alg. 6; every [`Isam2Params::relinearize_skip`] updates): every
//!    variable whose `max_i |Δ_i|` reaches [`Isam2Params::relinearize_threshold`] moves its
//!    linearisation point to θ ⊕ Δ; the cliques of the factors on it are marked.
//! 2. The cliques of the variables the new factors touch are marked; the marked cliques and
//!    their paths to the root (the *top*) are removed. Their subtrees (*orphans*) stay, with the
//!    marginal factors they pass up.
//!    When the top holds at least 65 % of the variables, the whole tree is
//!    removed (GTSAM's batch step), so the ordering is no longer constrained by old subtrees.
//! 3. The top's factors are relinearised at θ, its variables re-ordered by constrained minimum
//!    degree with the new factors' variables last (`ordering`), eliminated into new cliques
//!    (`clique`), and the orphans re-attached (Alg. 5).
//! 4. *Partial back-substitution* (Alg. 7): Δ is recomputed from the roots down, into every new
//!    clique, and below an unchanged clique only where a frontal's step moved by more than
//!    [`Isam2Params::wildfire_threshold`].
//!
//! An update costs the elimination of the top (its cliques' `m² · |F|`), not of the graph. The
//! marginal covariance of a variable ([`Isam2::marginal_covariance`]) is the joint of its clique
//! propagated down from the root (the conditionals are linear-Gaussian), O(depth · m³); a
//! variable of the root clique (the newest pose, by the constrained ordering) costs
//! O(|F_root|² · dim). All covariances are at θ, in the body frame, tangent (δt, δφ).

mod back_substitution;
mod clique;
mod eliminate;
pub mod g2o_replay;
mod marginals;
mod ordering;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use self::clique::{Clique, LowerPacked};
pub use self::g2o_replay::{G2oReplay, ReplayError};
use super::factors::{Factor, FactorError, Jacobian, MAX_FACTOR_KEYS};
use super::graph::{FactorGraph, GraphError};
use super::values::{Values, VarId, Variable};

const NONE: usize = usize::MAX;

/// A fraction of the variables; an update whose top holds at least this many re-orders and
/// re-eliminates the whole graph (GTSAM's `kBatchThreshold` in `ISAM2::update`).
const BATCH_THRESHOLD: f64 = 0.65;

/// Why an iSAM2 update or query failed.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum IncrementalError {
    /// Elimination met a non-positive pivot: a gauge freedom or an unobserved variable.
    #[error("the linearised system is not positive definite (a gauge freedom or an unobserved variable?)")]
    NotPositiveDefinite,
    /// A factor or query names a variable the solver does not hold.
    #[error("factor refers to variable {0:?}, which does not exist")]
    UnknownVariable(VarId),
    /// A variable added by an update that none of the update's factors constrains.
    #[error("new variable {0:?} is in no new factor")]
    Unconstrained(VarId),
    /// A factor could not be evaluated at the estimate.
    #[error(transparent)]
    Factor(#[from] FactorError),
    /// A factor could not be added to the graph.
    #[error(transparent)]
    Graph(#[from] GraphError),
}

/// iSAM2's parameters (GTSAM's `ISAM2Params`, same defaults; the supernode relaxation is ours).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Isam2Params {
    /// A variable is relinearised when the max-abs of its step Δ reaches this (tangent units:
    /// m and rad). Default 0.1.
    pub relinearize_threshold: f64,
    /// Relinearisation is checked every this many updates (1 = every update). Default 10.
    pub relinearize_skip: usize,
    /// Back-substitution stops below an unchanged clique whose frontals' steps moved by at most
    /// this (max-abs; 0 recomputes every clique whose input changed). Default 0.001.
    pub wildfire_threshold: f64,
    /// A clique absorbs an elimination-tree child whose separator has at least this many
    /// scalars (a relaxed supernode: explicit zeros instead of the child's marginal factor, when
    /// that stores no more; fundamental supernodes are always merged). Default 96 (16 poses):
    /// where a chain of small cliques would each store a copy of a large marginal factor.
    /// Not in GTSAM.
    pub relax_min_separator: usize,
    /// Largest frontal block, scalars, a relaxed absorption may make (0 never relaxes), so that
    /// an update touching the clique re-eliminates little more. Default 48 (8 poses).
    pub relax_max_frontal: usize,
}

impl Default for Isam2Params {
    fn default() -> Self {
        Self { relinearize_threshold: 0.1, relinearize_skip: 10, wildfire_threshold: 0.001, relax_min_separator: 96, relax_max_frontal: 48 }
    }
}

/// What one update did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct UpdateReport {
    /// Variables whose linearisation point moved.
    pub relinearized: usize,
    /// Variables re-eliminated (the top's).
    pub reeliminated: usize,
    /// Cliques in the tree after the update.
    pub cliques: usize,
}

/// The incremental smoother: factors, linearisation point, step and Bayes tree.
///
/// # Examples
///
/// A planar pose chain grown one pose per update, then closed by a loop: each update
/// re-eliminates only what the new factors touch, and the last pose's marginal shrinks once the
/// loop is closed.
///
/// ```
/// use fitslam_core::slam::factors::{BetweenSe2, PriorSe2};
/// use fitslam_core::slam::{Factor, GaussianNoise, Isam2Params, Se2, VarId, Variable};
/// use fitslam_core::Isam2;
/// use std::f64::consts::FRAC_PI_2;
///
/// let odometry_noise = GaussianNoise::from_sigmas(&[0.05, 0.05, 0.01])?; // m, m, rad
/// let mut isam = Isam2::new(Isam2Params::default());
/// // x0 at the origin, anchored by a prior.
/// let prior: Box<dyn Factor> = Box::new(PriorSe2::new(VarId(0), Se2::identity(), GaussianNoise::isotropic(3, 1e-3)?));
/// isam.update(&[Variable::Se2(Se2::identity())], vec![prior])?;
/// // Three sides of a 1 m square, turning left at each corner; each new pose starts off by 10 cm.
/// let side = Se2::new(1.0, 0.0, FRAC_PI_2);
/// for k in 1..4 {
///     let initial = isam.estimate_of(VarId(k - 1)).and_then(|v| match v {
///         Variable::Se2(p) => Some(p * side * Se2::new(0.1, 0.0, 0.0)),
///         _ => None,
///     });
///     let initial = initial.ok_or("the previous pose")?;
///     let odometry: Box<dyn Factor> = Box::new(BetweenSe2::new(VarId(k - 1), VarId(k), side, odometry_noise));
///     isam.update(&[Variable::Se2(initial)], vec![odometry])?;
/// }
/// assert_eq!(isam.len(), 4);
/// let x3 = VarId(3);
/// let open_trace = isam.marginal_covariance(x3)?.trace();
///
/// // The fourth side closes the square: a factor between existing poses, no new variable.
/// let closure: Box<dyn Factor> = Box::new(BetweenSe2::new(x3, VarId(0), side, odometry_noise));
/// isam.update(&[], vec![closure])?;
/// let Some(Variable::Se2(p3)) = isam.estimate_of(x3) else { panic!("x3 is an SE(2) pose") };
/// assert!((p3.x_m - 0.0).abs() < 0.05 && (p3.y_m - 1.0).abs() < 0.05); // the square's corner
/// assert!(isam.marginal_covariance(x3)?.trace() < open_trace);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct Isam2 {
    params: Isam2Params,
    graph: FactorGraph,
    theta: Values,
    /// Δ, every variable's block at `offset[v]`.
    delta: Vec<f64>,
    offset: Vec<usize>,
    dim: Vec<usize>,
    factors_of: Vec<Vec<usize>>,
    /// Elimination position (increasing over the solver's life: a re-eliminated variable gets a
    /// new one above every orphan's).
    position: Vec<usize>,
    clique_of: Vec<usize>,
    cliques: Vec<Option<Clique>>,
    free_slots: Vec<usize>,
    roots: Vec<usize>,
    next_position: usize,
    updates: usize,
    /// Scratch per variable: index in the top, or scalar offset in the clique being assembled.
    scratch: Vec<usize>,
    /// Per variable: changed in the current back-substitution (reused between updates).
    changed: Vec<bool>,
    /// Scratch per factor: the update that last collected it.
    factor_stamp: Vec<usize>,
}

impl Isam2 {
    /// An empty solver.
    pub fn new(params: Isam2Params) -> Self {
        Self {
            params,
            graph: FactorGraph::new(),
            theta: Values::new(),
            delta: Vec::new(),
            offset: Vec::new(),
            dim: Vec::new(),
            factors_of: Vec::new(),
            position: Vec::new(),
            clique_of: Vec::new(),
            cliques: Vec::new(),
            free_slots: Vec::new(),
            roots: Vec::new(),
            next_position: 0,
            updates: 0,
            scratch: Vec::new(),
            changed: Vec::new(),
            factor_stamp: Vec::new(),
        }
    }

    /// Its parameters.
    pub fn params(&self) -> &Isam2Params {
        &self.params
    }

    /// Every factor added so far.
    pub fn graph(&self) -> &FactorGraph {
        &self.graph
    }

    /// The linearisation point θ.
    pub fn linearization_point(&self) -> &Values {
        &self.theta
    }

    /// Number of variables; the next new variable gets this id.
    pub fn len(&self) -> usize {
        self.theta.len()
    }

    /// Whether it holds no variable.
    pub fn is_empty(&self) -> bool {
        self.theta.is_empty()
    }

    /// The step of variable `id` (empty for an unknown id).
    pub fn delta_of(&self, id: VarId) -> &[f64] {
        match self.offset.get(id.0) {
            Some(&o) => &self.delta[o..o + self.dim[id.0]],
            None => &[],
        }
    }

    /// The estimate θ ⊕ Δ of one variable.
    pub fn estimate_of(&self, id: VarId) -> Option<Variable> {
        self.theta.get(id).map(|v| v.retract(self.delta_of(id)))
    }

    /// The estimate θ ⊕ Δ of every variable.
    pub fn estimate(&self) -> Values {
        let mut out = self.theta.clone();
        for v in 0..self.theta.len() {
            out.retract_in_place(VarId(v), self.delta_of(VarId(v)));
        }
        out
    }

    /// Σ eᵀ Ω e of every factor at the estimate.
    pub fn chi2(&self) -> Result<f64, FactorError> {
        self.graph.chi2(&self.estimate())
    }

    /// Variables of the root cliques (the last eliminated; the newest, by the ordering).
    pub fn root_variables(&self) -> Vec<VarId> {
        self.roots.iter().filter_map(|&r| self.cliques[r].as_ref()).flat_map(|c| c.frontals.iter().copied()).collect()
    }

    /// Adds `new_variables` (ids `len()..`, at their initial estimates) and `new_factors` (on
    /// any variables, each new variable in at least one), then runs one iSAM2 step. On an error
    /// before the elimination nothing changed; a failed elimination leaves the solver unusable.
    pub fn update(&mut self, new_variables: &[Variable], new_factors: Vec<Box<dyn Factor>>) -> Result<UpdateReport, IncrementalError> {
        let due = self.params.relinearize_skip > 0 && (self.updates + 1).is_multiple_of(self.params.relinearize_skip);
        self.update_with(new_variables, new_factors, due.then_some(self.params.relinearize_threshold))
    }

    /// An update without new factors that relinearises every variable whose step reaches
    /// `threshold` now, whatever [`Isam2Params::relinearize_skip`] says (GTSAM's
    /// `force_relinearize`); with 0 every variable that moved, so that repeated calls are
    /// Gauss-Newton iterations on the whole problem.
    pub fn relinearize(&mut self, threshold: f64) -> Result<UpdateReport, IncrementalError> {
        self.update_with(&[], Vec::new(), Some(threshold))
    }

    fn update_with(
        &mut self,
        new_variables: &[Variable],
        new_factors: Vec<Box<dyn Factor>>,
        relinearize_at: Option<f64>,
    ) -> Result<UpdateReport, IncrementalError> {
        let n_old = self.theta.len();
        let n_all = n_old + new_variables.len();
        let mut covered = vec![false; new_variables.len()];
        for f in &new_factors {
            let keys = f.keys();
            if keys.is_empty() {
                return Err(GraphError::NoKeys.into());
            }
            if keys.len() > MAX_FACTOR_KEYS {
                return Err(GraphError::TooManyKeys(keys.len()).into());
            }
            for (i, k) in keys.iter().enumerate() {
                if k.0 >= n_all {
                    return Err(IncrementalError::UnknownVariable(*k));
                }
                if keys[..i].contains(k) {
                    return Err(GraphError::DuplicateKey(*k).into());
                }
                if k.0 >= n_old {
                    covered[k.0 - n_old] = true;
                }
            }
        }
        if let Some(i) = covered.iter().position(|c| !c) {
            return Err(IncrementalError::Unconstrained(VarId(n_old + i)));
        }
        self.updates += 1;
        let mut marked: Vec<usize> = Vec::new();

        // 1. Fluid relinearisation (GTSAM: `maxDelta >= threshold`).
        let mut relinearized = 0;
        if let Some(threshold) = relinearize_at {
            for v in 0..n_old {
                let (o, d) = (self.offset[v], self.dim[v]);
                let max = self.delta[o..o + d].iter().fold(0.0f64, |m, x| m.max(x.abs()));
                if max < threshold || max == 0.0 {
                    continue;
                }
                relinearized += 1;
                self.theta.retract_in_place(VarId(v), &self.delta[o..o + d]);
                self.delta[o..o + d].fill(0.0);
                for &f in &self.factors_of[v] {
                    marked.push(self.clique_of_factor(f));
                }
            }
        }

        // 2. New variables and factors; mark the cliques of the variables they touch.
        for var in new_variables {
            let d = var.dim();
            self.theta.push(*var);
            self.offset.push(self.delta.len());
            self.dim.push(d);
            self.delta.extend(std::iter::repeat_n(0.0, d));
            self.factors_of.push(Vec::new());
            self.position.push(NONE);
            self.clique_of.push(NONE);
            self.scratch.push(NONE);
        }
        let first_new_factor = self.graph.len();
        for f in new_factors {
            for k in f.keys() {
                self.factors_of[k.0].push(self.graph.len());
                if self.clique_of[k.0] != NONE {
                    marked.push(self.clique_of[k.0]);
                }
            }
            self.graph.add_boxed(f)?;
            self.factor_stamp.push(0);
        }

        // 3. Remove the top: the marked cliques and their ancestors.
        let mut removed = vec![false; self.cliques.len()];
        let mut top_vars: Vec<VarId> = (n_old..n_all).map(VarId).collect();
        let mut removed_list = Vec::new();
        while let Some(c) = marked.pop() {
            if removed[c] {
                continue;
            }
            removed[c] = true;
            removed_list.push(c);
            if let Some(clique) = &self.cliques[c] {
                top_vars.extend(clique.frontals.iter().copied());
                if let Some(p) = clique.parent {
                    marked.push(p);
                }
            }
        }
        // GTSAM's batch step: when the top holds most of the graph, the whole graph is
        // re-ordered and re-eliminated (the kept subtrees' old ordering would constrain it).
        if (top_vars.len() as f64) >= BATCH_THRESHOLD * n_all as f64 {
            for (c, clique) in self.cliques.iter().enumerate() {
                if !removed[c]
                    && let Some(clique) = clique
                {
                    removed[c] = true;
                    removed_list.push(c);
                    top_vars.extend(clique.frontals.iter().copied());
                }
            }
        }
        let mut orphans = Vec::new();
        for &c in &removed_list {
            if let Some(clique) = &self.cliques[c] {
                orphans.extend(clique.children.iter().copied().filter(|&ch| !removed[ch]));
            }
        }
        self.roots.retain(|&r| !removed[r]);
        for &c in &removed_list {
            self.cliques[c] = None;
            self.free_slots.push(c);
        }
        if top_vars.is_empty() {
            return Ok(UpdateReport { relinearized, reeliminated: 0, cliques: self.clique_count() });
        }
        top_vars.sort_unstable();
        let reeliminated = top_vars.len();
        let new_cliques = self.reeliminate(&top_vars, &orphans, first_new_factor, n_old)?;

        // 4. Partial back-substitution from the roots.
        let mut replaced = vec![false; self.cliques.len()];
        for &c in &new_cliques {
            replaced[c] = true;
        }
        self.back_substitute(&replaced);
        Ok(UpdateReport { relinearized, reeliminated, cliques: self.clique_count() })
    }

    fn clique_count(&self) -> usize {
        self.cliques.iter().filter(|c| c.is_some()).count()
    }

    /// The clique a factor's linearisation lives in: that of its earliest-eliminated variable.
    fn clique_of_factor(&self, f: usize) -> usize {
        let keys = self.graph.keys_of(f);
        let mut best = keys[0].0;
        for k in keys {
            if self.position[k.0] < self.position[best] {
                best = k.0;
            }
        }
        self.clique_of[best]
    }
}
