//! Partial ("wildfire") back-substitution (iSAM2 Alg. 7): Δ recomputed from the roots down,
//! only where a clique was re-eliminated or a separator variable changed.

use super::*;

impl Isam2 {
    /// Wildfire back-substitution (Alg. 7) from every root. A clique is solved again when it was
    /// re-eliminated in this update or when any of its separator variables changed (by the
    /// running intersection property its subtree is otherwise untouched, as in GTSAM's
    /// `optimizeWildfireNode`); its frontals take the new values, and count as changed, only
    /// when the largest change reaches `wildfire_threshold`.
    pub(super) fn back_substitute(&mut self, replaced: &[bool]) {
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
            clique::solve_conditional(&clique.factor, clique.frontal_dim, &x_s, &mut x_f);
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
}
