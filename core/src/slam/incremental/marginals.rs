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

    /// Computes the joint covariance of clique `c` and of every ancestor not in `joints` yet:
    /// a clique's joint from its separator's block of its parent's joint (the conditionals are
    /// linear-Gaussian), the root's from its conditional alone.
    pub(super) fn fill_joints(&self, c: usize, joints: &mut BTreeMap<usize, DMatrix<f64>>) -> Result<(), IncrementalError> {
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
