//! Marginal covariances from the Bayes tree: a clique's joint propagated down from the root
//! (the conditionals are linear-Gaussian), O(depth · m³); a root variable's from its
//! conditional alone.

use super::*;

impl Isam2 {
    /// The marginal covariance of `id` at θ (body frame, tangent order of [`Variable`]).
    pub fn marginal_covariance(&self, id: VarId) -> Result<DMatrix<f64>, IncrementalError> {
        let c = self.clique_index(id)?;
        let clique = self.cliques[c].as_ref().ok_or(IncrementalError::UnknownVariable(id))?;
        if clique.parent.is_none() {
            let o = self.offset_in(clique, id).ok_or(IncrementalError::UnknownVariable(id))?;
            return clique::root_block_covariance(&clique.factor, clique.frontal_dim, o, self.dim[id.0])
                .ok_or(IncrementalError::NotPositiveDefinite);
        }
        Ok(self.marginal_covariances(&[id])?.remove(0))
    }

    /// The marginal covariances of `ids`, in order. The cliques on the paths from the root to
    /// the requested variables are walked depth first: a clique's joint is computed once, from
    /// its parent's, and dropped as soon as its last needed child has taken its separator block,
    /// so the joints held at once are those of one root-to-leaf path and their pending siblings'
    /// parents, not those of every clique visited (variables sharing ancestors, such as landmarks
    /// seen recently near the root, still cost one propagation).
    pub fn marginal_covariances(&self, ids: &[VarId]) -> Result<Vec<DMatrix<f64>>, IncrementalError> {
        let broken = || IncrementalError::NotPositiveDefinite;
        // Requests per clique, and the needed cliques with their needed children.
        let mut requests: BTreeMap<usize, Vec<(usize, VarId)>> = BTreeMap::new();
        let mut needed_children: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        let mut roots = Vec::new();
        let mut links = Vec::new();
        for (i, &id) in ids.iter().enumerate() {
            let c = self.clique_index(id)?;
            requests.entry(c).or_default().push((i, id));
            let mut at = c;
            while !needed_children.contains_key(&at) {
                needed_children.insert(at, Vec::new());
                match self.cliques[at].as_ref().ok_or_else(broken)?.parent {
                    Some(p) => {
                        links.push((p, at));
                        at = p;
                    }
                    None => roots.push(at),
                }
            }
        }
        for (parent, child) in links {
            needed_children.get_mut(&parent).ok_or_else(broken)?.push(child);
        }
        let mut out: Vec<Option<DMatrix<f64>>> = vec![None; ids.len()];
        // Joints still needed by a child, with how many children have yet to take theirs.
        let mut held: BTreeMap<usize, (DMatrix<f64>, usize)> = BTreeMap::new();
        let mut stack: Vec<usize> = roots;
        while let Some(k) = stack.pop() {
            let cl = self.cliques[k].as_ref().ok_or_else(broken)?;
            let cov_s = match cl.parent {
                None => DMatrix::zeros(0, 0),
                Some(p) => {
                    let pcl = self.cliques[p].as_ref().ok_or_else(broken)?;
                    let (pj, pending) = held.get_mut(&p).ok_or_else(broken)?;
                    let cov_s = self.separator_block(cl, pcl, pj)?;
                    *pending -= 1;
                    if *pending == 0 {
                        held.remove(&p);
                    }
                    cov_s
                }
            };
            let joint = clique::joint_covariance(&cl.factor, cl.frontal_dim, &cov_s).ok_or_else(broken)?;
            for &(i, id) in requests.get(&k).map_or(&[][..], Vec::as_slice) {
                let o = self.offset_in(cl, id).ok_or(IncrementalError::UnknownVariable(id))?;
                let d = self.dim[id.0];
                out[i] = Some(joint.view((o, o), (d, d)).into_owned());
            }
            let children = &needed_children[&k];
            if !children.is_empty() {
                held.insert(k, (joint, children.len()));
                stack.extend(children.iter().rev());
            }
        }
        out.into_iter().map(|c| c.ok_or_else(broken)).collect()
    }

    /// The block of a parent's joint covariance on a child's separator, in the child's order.
    fn separator_block(&self, child: &Clique, parent: &Clique, parent_joint: &DMatrix<f64>) -> Result<DMatrix<f64>, IncrementalError> {
        let ns = child.dim() - child.frontal_dim;
        let mut map = Vec::with_capacity(ns);
        for v in &child.separator {
            let po = self.offset_in(parent, *v).ok_or(IncrementalError::UnknownVariable(*v))?;
            map.extend(po..po + self.dim[v.0]);
        }
        Ok(DMatrix::from_fn(ns, ns, |i, j| parent_joint[(map[i], map[j])]))
    }

    pub(super) fn clique_index(&self, id: VarId) -> Result<usize, IncrementalError> {
        self.clique_of.get(id.0).copied().filter(|&c| c != NONE && self.cliques[c].is_some()).ok_or(IncrementalError::UnknownVariable(id))
    }

    /// Scalar offset of `v` in the clique's rows (frontals, then separator).
    pub(super) fn offset_in(&self, clique: &Clique, v: VarId) -> Option<usize> {
        let mut o = 0;
        for u in clique.variables() {
            if u == v {
                return Some(o);
            }
            o += self.dim[u.0];
        }
        None
    }
}
