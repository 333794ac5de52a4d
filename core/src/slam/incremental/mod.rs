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
//!    When the top holds at least [`BATCH_THRESHOLD`] of the variables, the whole tree is
//!    removed (GTSAM's batch step), so the ordering is no longer constrained by old subtrees.
//! 3. The top's factors are relinearised at θ, its variables re-ordered by constrained minimum
//!    degree with the new factors' variables last ([`ordering`]), eliminated into new cliques
//!    ([`clique`]), and the orphans re-attached (Alg. 5).
//! 4. *Partial back-substitution* (Alg. 7): Δ is recomputed from the roots down, into every new
//!    clique, and below an unchanged clique only where a frontal's step moved by more than
//!    [`Isam2Params::wildfire_threshold`].
//!
//! An update costs the elimination of the top (its cliques' `m² · |F|`), not of the graph. The
//! marginal covariance of a variable ([`Isam2::marginal_covariance`]) is the joint of its clique
//! propagated down from the root (the conditionals are linear-Gaussian), O(depth · m³); a
//! variable of the root clique (the newest pose, by the constrained ordering) costs
//! O(|F_root|² · dim). All covariances are at θ, in the body frame, tangent (δt, δφ).

mod clique;
pub mod g2o_replay;
mod ordering;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use self::clique::Clique;
pub use self::g2o_replay::{G2oReplay, ReplayError};
use super::factors::{Factor, FactorError, Jacobian, MAX_FACTOR_KEYS};
use super::graph::{FactorGraph, GraphError};
use super::values::{Values, VarId, Variable};

const NONE: usize = usize::MAX;

/// A fraction of the variables; an update whose top holds at least this many re-orders and
/// re-eliminates the whole graph (GTSAM's `kBatchThreshold` in `ISAM2::update`).
const BATCH_THRESHOLD: f64 = 0.65;

#[derive(Clone, Debug, Error, PartialEq)]
pub enum IncrementalError {
    #[error("the linearised system is not positive definite (a gauge freedom or an unobserved variable?)")]
    NotPositiveDefinite,
    #[error("factor refers to variable {0:?}, which does not exist")]
    UnknownVariable(VarId),
    #[error("new variable {0:?} is in no new factor")]
    Unconstrained(VarId),
    #[error(transparent)]
    Factor(#[from] FactorError),
    #[error(transparent)]
    Graph(#[from] GraphError),
}

/// iSAM2's parameters (GTSAM's `ISAM2Params`, same defaults).
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
}

impl Default for Isam2Params {
    fn default() -> Self {
        Self { relinearize_threshold: 0.1, relinearize_skip: 10, wildfire_threshold: 0.001 }
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

    /// Orders, eliminates and links the top's variables (sorted by id); returns the new cliques.
    fn reeliminate(
        &mut self,
        top: &[VarId],
        orphans: &[usize],
        first_new_factor: usize,
        first_new_variable: usize,
    ) -> Result<Vec<usize>, IncrementalError> {
        for (i, v) in top.iter().enumerate() {
            self.scratch[v.0] = i;
        }
        // The top's factors: those with every key in the top.
        let stamp = self.updates;
        let mut factors = Vec::new();
        let mut edges: Vec<Vec<usize>> = Vec::new();
        // Ordering groups: 0 the rest, 1 the new factors' variables, 2 the new variables.
        let mut group: Vec<u8> = top.iter().map(|v| if v.0 >= first_new_variable { 2 } else { 0 }).collect();
        for v in top {
            for &f in &self.factors_of[v.0] {
                if self.factor_stamp[f] == stamp {
                    continue;
                }
                let keys = self.graph.keys_of(f);
                if keys.iter().all(|k| self.scratch[k.0] != NONE) {
                    self.factor_stamp[f] = stamp;
                    factors.push(f);
                    let local: Vec<usize> = keys.iter().map(|k| self.scratch[k.0]).collect();
                    if f >= first_new_factor {
                        for &l in &local {
                            group[l] = group[l].max(1);
                        }
                    }
                    edges.push(local);
                }
            }
        }
        for &o in orphans {
            if let Some(c) = &self.cliques[o] {
                edges.push(c.separator.iter().map(|k| self.scratch[k.0]).collect());
            }
        }
        let dim: Vec<usize> = top.iter().map(|v| self.dim[v.0]).collect();
        let elim = ordering::eliminate(top.len(), &edges, &group, &dim);
        for v in top {
            self.scratch[v.0] = NONE;
        }
        for &l in &elim.order {
            self.position[top[l].0] = self.next_position;
            self.next_position += 1;
        }

        // Supernodes: a variable joins the clique of an elimination-tree child whose separator
        // is the variable and the variable's own separator.
        let mut clique_of_local = vec![NONE; top.len()];
        let mut groups: Vec<(Vec<usize>, Vec<usize>)> = Vec::new();
        let mut etree_children: Vec<Vec<usize>> = vec![Vec::new(); top.len()];
        for &l in &elim.order {
            let sep = &elim.separators[l];
            let merge = etree_children[l].iter().copied().find(|&c| elim.separators[c].len() == sep.len() + 1);
            let g = match merge {
                Some(c) => {
                    let g = clique_of_local[c];
                    groups[g].0.push(l);
                    groups[g].1.clone_from(sep);
                    g
                }
                None => {
                    groups.push((vec![l], sep.clone()));
                    groups.len() - 1
                }
            };
            clique_of_local[l] = g;
            if let Some(&p) = sep.first() {
                etree_children[p].push(l);
            }
        }
        let mut slots = Vec::with_capacity(groups.len());
        for (frontals, sep) in &groups {
            let frontals: Vec<VarId> = frontals.iter().map(|&l| top[l]).collect();
            let separator: Vec<VarId> = sep.iter().map(|&l| top[l]).collect();
            let frontal_dim = frontals.iter().map(|v| self.dim[v.0]).sum();
            let clique = Clique { frontals, separator, parent: None, children: Vec::new(), frontal_dim, matrix: DMatrix::zeros(0, 0) };
            let slot = match self.free_slots.pop() {
                Some(s) => {
                    self.cliques[s] = Some(clique);
                    s
                }
                None => {
                    self.cliques.push(Some(clique));
                    self.cliques.len() - 1
                }
            };
            slots.push(slot);
        }
        for (g, (frontals, _)) in groups.iter().enumerate() {
            for &l in frontals {
                self.clique_of[top[l].0] = slots[g];
            }
        }
        // Tree links: a clique's parent holds its separator's earliest variable.
        let mut links: Vec<(usize, usize)> = Vec::new();
        for (g, (_, sep)) in groups.iter().enumerate() {
            match sep.first() {
                Some(&l) => links.push((slots[g], slots[clique_of_local[l]])),
                None => self.roots.push(slots[g]),
            }
        }
        for &o in orphans {
            if let Some(c) = &self.cliques[o]
                && let Some(first) = c.separator.iter().min_by_key(|k| self.position[k.0])
            {
                links.push((o, self.clique_of[first.0]));
            }
        }
        for &(child, parent) in &links {
            if let Some(c) = self.cliques[child].as_mut() {
                c.parent = Some(parent);
            }
            if let Some(p) = self.cliques[parent].as_mut() {
                p.children.push(child);
            }
        }
        // Each top factor goes to the clique of its earliest-eliminated variable.
        let mut factors_in: Vec<Vec<usize>> = vec![Vec::new(); groups.len()];
        let mut group_of_slot = vec![NONE; self.cliques.len()];
        for (g, &s) in slots.iter().enumerate() {
            group_of_slot[s] = g;
        }
        for &f in &factors {
            let g = group_of_slot[self.clique_of_factor(f)];
            if g != NONE {
                factors_in[g].push(f);
            }
        }
        // Children before parents: by the elimination position of the last frontal (a clique's
        // is before its parent's first separator variable, a frontal of the parent).
        let mut by_last: Vec<usize> = (0..groups.len()).collect();
        by_last.sort_unstable_by_key(|&g| groups[g].0.last().map_or(0, |&l| self.position[top[l].0]));
        for g in by_last {
            self.eliminate_clique(slots[g], &factors_in[g])?;
        }
        Ok(slots)
    }

    /// Assembles a clique's joint from its factors (linearised at θ) and its children's
    /// marginal factors, then eliminates its frontals.
    fn eliminate_clique(&mut self, slot: usize, factors: &[usize]) -> Result<(), IncrementalError> {
        let Some(mut clique) = self.cliques[slot].take() else { return Ok(()) };
        let mut m = 0;
        for v in clique.variables() {
            self.scratch[v.0] = m;
            m += self.dim[v.0];
        }
        let mut a = DMatrix::zeros(m + 1, m + 1);
        let mut jac = [Jacobian::zeros(); MAX_FACTOR_KEYS];
        let mut wj = [Jacobian::zeros(); MAX_FACTOR_KEYS];
        for &fi in factors {
            let f = &self.graph.factors()[fi];
            let e = f.linearize(&self.theta, &mut jac)?;
            let noise = f.noise();
            let rows = noise.dim();
            let (r, row_scale, _) = noise.linearized(&e);
            let keys = f.keys();
            for k in 0..keys.len() {
                wj[k] = noise.sqrt_information() * jac[k] * row_scale;
            }
            for (p, kp) in keys.iter().enumerate() {
                let (op, dp) = (self.scratch[kp.0], self.dim[kp.0]);
                for i in 0..dp {
                    let mut s = 0.0;
                    for row in 0..rows {
                        s -= wj[p][(row, i)] * r[row];
                    }
                    a[(m, op + i)] += s;
                }
                for (q, kq) in keys.iter().enumerate() {
                    let (oq, dq) = (self.scratch[kq.0], self.dim[kq.0]);
                    if oq > op {
                        continue;
                    }
                    for j in 0..dq {
                        for i in 0..dp {
                            if op + i < oq + j {
                                continue;
                            }
                            let mut s = 0.0;
                            for row in 0..rows {
                                s += wj[p][(row, i)] * wj[q][(row, j)];
                            }
                            a[(op + i, oq + j)] += s;
                        }
                    }
                }
            }
        }
        for &ch in &clique.children {
            let Some(child) = &self.cliques[ch] else { continue };
            let (nf, cm) = (child.frontal_dim, child.dim());
            // Scalar row of every separator scalar of the child, in this clique.
            let mut map = Vec::with_capacity(cm - nf);
            for v in &child.separator {
                let o = self.scratch[v.0];
                map.extend(o..o + self.dim[v.0]);
            }
            let cs = child.matrix.as_slice();
            let stride = cm + 1;
            for j in 0..map.len() {
                for i in j..map.len() {
                    let value = cs[(nf + j) * stride + nf + i];
                    let (gi, gj) = (map[i].max(map[j]), map[i].min(map[j]));
                    a[(gi, gj)] += value;
                }
                a[(m, map[j])] += cs[(nf + j) * stride + cm];
            }
        }
        for v in clique.variables() {
            self.scratch[v.0] = NONE;
        }
        clique::eliminate_frontals(&mut a, clique.frontal_dim)?;
        clique.matrix = a;
        self.cliques[slot] = Some(clique);
        Ok(())
    }

    /// Wildfire back-substitution (Alg. 7) from every root. A clique is solved again when it was
    /// re-eliminated in this update or when any of its separator variables changed (by the
    /// running intersection property its subtree is otherwise untouched, as in GTSAM's
    /// `optimizeWildfireNode`); its frontals take the new values, and count as changed, only
    /// when the largest change reaches `wildfire_threshold`.
    fn back_substitute(&mut self, replaced: &[bool]) {
        let mut stack: Vec<usize> = self.roots.clone();
        let mut changed = std::mem::take(&mut self.changed);
        changed.clear();
        changed.resize(self.dim.len(), false);
        let mut x_s = Vec::new();
        let mut x_f = Vec::new();
        while let Some(c) = stack.pop() {
            let Some(clique) = &self.cliques[c] else { continue };
            if !replaced[c] && !clique.separator.iter().any(|v| changed[v.0]) {
                continue;
            }
            x_s.clear();
            for v in &clique.separator {
                let o = self.offset[v.0];
                x_s.extend_from_slice(&self.delta[o..o + self.dim[v.0]]);
            }
            x_f.clear();
            x_f.resize(clique.frontal_dim, 0.0);
            clique::solve_conditional(&clique.matrix, clique.frontal_dim, &x_s, &mut x_f);
            let mut change = 0.0f64;
            let mut k = 0;
            for v in &clique.frontals {
                let o = self.offset[v.0];
                for i in 0..self.dim[v.0] {
                    change = change.max((self.delta[o + i] - x_f[k]).abs());
                    k += 1;
                }
            }
            if replaced[c] || change >= self.params.wildfire_threshold {
                let mut k = 0;
                for v in &clique.frontals {
                    let o = self.offset[v.0];
                    let d = self.dim[v.0];
                    self.delta[o..o + d].copy_from_slice(&x_f[k..k + d]);
                    changed[v.0] = true;
                    k += d;
                }
            }
            stack.extend(clique.children.iter().copied());
        }
        self.changed = changed;
    }

    /// The marginal covariance of `id` at θ (body frame, tangent order of [`Variable`]).
    pub fn marginal_covariance(&self, id: VarId) -> Result<DMatrix<f64>, IncrementalError> {
        let c = self.clique_index(id)?;
        let clique = self.cliques[c].as_ref().ok_or(IncrementalError::UnknownVariable(id))?;
        if clique.parent.is_none() {
            let o = self.offset_in(clique, id).ok_or(IncrementalError::UnknownVariable(id))?;
            return clique::root_block_covariance(&clique.matrix, clique.frontal_dim, o, self.dim[id.0])
                .ok_or(IncrementalError::NotPositiveDefinite);
        }
        Ok(self.marginal_covariances(&[id])?.remove(0))
    }

    /// The marginal covariances of `ids`, in order. Each clique's joint on the paths to the
    /// root is computed once for the whole call, so variables sharing ancestors (landmarks seen
    /// recently sit near the root) cost one propagation.
    pub fn marginal_covariances(&self, ids: &[VarId]) -> Result<Vec<DMatrix<f64>>, IncrementalError> {
        let mut joints: BTreeMap<usize, DMatrix<f64>> = BTreeMap::new();
        let mut out = Vec::with_capacity(ids.len());
        for &id in ids {
            let c = self.clique_index(id)?;
            self.fill_joints(c, &mut joints)?;
            let clique = self.cliques[c].as_ref().ok_or(IncrementalError::UnknownVariable(id))?;
            let o = self.offset_in(clique, id).ok_or(IncrementalError::UnknownVariable(id))?;
            let d = self.dim[id.0];
            out.push(joints[&c].view((o, o), (d, d)).into_owned());
        }
        Ok(out)
    }

    fn clique_index(&self, id: VarId) -> Result<usize, IncrementalError> {
        self.clique_of.get(id.0).copied().filter(|&c| c != NONE && self.cliques[c].is_some()).ok_or(IncrementalError::UnknownVariable(id))
    }

    /// Scalar offset of `v` in the clique's rows (frontals, then separator).
    fn offset_in(&self, clique: &Clique, v: VarId) -> Option<usize> {
        let mut o = 0;
        for u in clique.variables() {
            if u == v {
                return Some(o);
            }
            o += self.dim[u.0];
        }
        None
    }

    /// Computes the joint covariance of clique `c` and of every ancestor not in `joints` yet:
    /// a clique's joint from its separator's block of its parent's joint (the conditionals are
    /// linear-Gaussian), the root's from its conditional alone.
    fn fill_joints(&self, c: usize, joints: &mut BTreeMap<usize, DMatrix<f64>>) -> Result<(), IncrementalError> {
        let broken = || IncrementalError::NotPositiveDefinite;
        let mut path = Vec::new();
        let mut at = Some(c);
        while let Some(k) = at.filter(|k| !joints.contains_key(k)) {
            path.push(k);
            at = self.cliques[k].as_ref().ok_or_else(broken)?.parent;
        }
        for &k in path.iter().rev() {
            let cl = self.cliques[k].as_ref().ok_or_else(broken)?;
            let ns = cl.dim() - cl.frontal_dim;
            let cov_s = match cl.parent {
                None => DMatrix::zeros(0, 0),
                Some(p) => {
                    let (pcl, pj) = (self.cliques[p].as_ref().ok_or_else(broken)?, &joints[&p]);
                    let mut map = Vec::with_capacity(ns);
                    for v in &cl.separator {
                        let po = self.offset_in(pcl, *v).ok_or(IncrementalError::UnknownVariable(*v))?;
                        map.extend(po..po + self.dim[v.0]);
                    }
                    DMatrix::from_fn(ns, ns, |i, j| pj[(map[i], map[j])])
                }
            };
            let joint = clique::joint_covariance(&cl.matrix, cl.frontal_dim, &cov_s).ok_or_else(broken)?;
            joints.insert(k, joint);
        }
        Ok(())
    }
}
