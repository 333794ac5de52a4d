//! Re-elimination of the top (iSAM2 Alg. 5): the top's variables ordered, eliminated into new
//! cliques and the orphans re-attached; each clique's joint assembled from its factors and its
//! children's marginal factors, then its frontals eliminated ([`super::clique`]).

use super::*;

impl Isam2 {
    /// Orders, eliminates and links the top's variables (sorted by id); returns the new cliques.
    pub(super) fn reeliminate(
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

        // Supernodes: a variable's clique absorbs each elimination-tree child's clique whenever
        // the merged clique stores no more than the two apart ([`absorbs`]): always when the
        // child's separator is the variable and its own separator (a fundamental supernode), and
        // also when the child's separator lacks a few of them, at the cost of explicit zeros
        // instead of the child's marginal factor (a relaxed supernode, as CHOLMOD amalgamates).
        let mut rank = vec![0; top.len()];
        for (r, &l) in elim.order.iter().enumerate() {
            rank[l] = r;
        }
        let scalars = |vars: &[usize]| vars.iter().map(|&l| dim[l]).sum::<usize>();
        let mut clique_of_local = vec![NONE; top.len()];
        let mut groups: Vec<(Vec<usize>, Vec<usize>)> = Vec::new();
        let mut alive: Vec<bool> = Vec::new();
        let mut etree_children: Vec<Vec<usize>> = vec![Vec::new(); top.len()];
        for &l in &elim.order {
            let sep = &elim.separators[l];
            let sep_dim = scalars(sep);
            let mut frontals = vec![l];
            let mut frontal_dim = dim[l];
            for &c in &etree_children[l] {
                let g = clique_of_local[c];
                let child_frontal_dim = scalars(&groups[g].0);
                let child_sep_dim = scalars(&groups[g].1);
                let fundamental = child_sep_dim == dim[l] + sep_dim && frontals.len() == 1;
                if fundamental || absorbs(&self.params, frontal_dim, sep_dim, child_frontal_dim, child_sep_dim) {
                    frontals.append(&mut groups[g].0);
                    frontal_dim += child_frontal_dim;
                    alive[g] = false;
                }
            }
            frontals.sort_unstable_by_key(|&v| rank[v]);
            let g = groups.len();
            for &v in &frontals {
                clique_of_local[v] = g;
            }
            groups.push((frontals, sep.clone()));
            alive.push(true);
            if let Some(&p) = sep.first() {
                etree_children[p].push(l);
            }
        }
        let groups: Vec<(Vec<usize>, Vec<usize>)> = {
            let mut renumber = vec![NONE; groups.len()];
            let mut kept = Vec::new();
            for (g, group) in groups.into_iter().enumerate() {
                if alive[g] {
                    renumber[g] = kept.len();
                    kept.push(group);
                }
            }
            for c in &mut clique_of_local {
                *c = renumber[*c];
            }
            kept
        };
        let mut slots = Vec::with_capacity(groups.len());
        for (frontals, sep) in &groups {
            let frontals: Vec<VarId> = frontals.iter().map(|&l| top[l]).collect();
            let separator: Vec<VarId> = sep.iter().map(|&l| top[l]).collect();
            let frontal_dim = frontals.iter().map(|v| self.dim[v.0]).sum();
            let clique = Clique { frontals, separator, parent: None, children: Vec::new(), frontal_dim, factor: LowerPacked::default() };
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
    pub(super) fn eliminate_clique(&mut self, slot: usize, factors: &[usize]) -> Result<(), IncrementalError> {
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
            for j in 0..map.len() {
                // Column nf + j of the child's factor: rows nf + j.. of its marginal factor, then
                // the rhs (row cm).
                let col = child.factor.column(nf + j);
                for i in j..map.len() {
                    let value = col[i - j];
                    let (gi, gj) = (map[i].max(map[j]), map[i].min(map[j]));
                    a[(gi, gj)] += value;
                }
                a[(m, map[j])] += col[cm - nf - j];
            }
        }
        for v in clique.variables() {
            self.scratch[v.0] = NONE;
        }
        clique::eliminate_frontals(&mut a, clique.frontal_dim)?;
        clique.factor = LowerPacked::from_lower(&a);
        self.cliques[slot] = Some(clique);
        Ok(())
    }
}

/// Whether a clique of `frontal_dim` + `sep_dim` scalars absorbs (a relaxed supernode) a child
/// clique of `child_frontal_dim` frontal and `child_sep_dim` separator scalars, the separator
/// within the clique's variables: when the child's marginal factor is large
/// ([`Isam2Params::relax_min_separator`], where a chain of small cliques would each store a copy
/// of it), the merged frontal block stays small ([`Isam2Params::relax_max_frontal`]) and the
/// merged clique's packed factor is no larger than the two apart. O(1).
fn absorbs(params: &Isam2Params, frontal_dim: usize, sep_dim: usize, child_frontal_dim: usize, child_sep_dim: usize) -> bool {
    let packed = |m: usize| (m + 1) * (m + 2) / 2;
    let dim = frontal_dim + sep_dim;
    child_sep_dim >= params.relax_min_separator
        && frontal_dim + child_frontal_dim <= params.relax_max_frontal
        && packed(dim + child_frontal_dim) <= packed(dim) + packed(child_frontal_dim + child_sep_dim)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand values: a 6-scalar pose with a 120-scalar separator absorbing a 3-scalar landmark
    /// whose separator is 118 of those scalars stores 130·131/2 = 8515 instead of
    /// 127·128/2 + 122·123/2 = 8128 + 7503.
    #[test]
    fn a_large_separator_is_absorbed_when_the_merge_stores_less() {
        let p = Isam2Params::default();
        assert!(absorbs(&p, 6, 120, 3, 118));
        // A small separator stays a clique of its own (its marginal factor is cheap).
        assert!(!absorbs(&p, 6, 30, 3, 28));
        // The frontal block would exceed 48 scalars.
        assert!(!absorbs(&p, 42, 120, 12, 118));
        // The child's separator is a small part of the clique's, so the zeros outweigh its
        // factor: 1019·1020/2 = 519690 > 1007·1008/2 + 109·110/2 = 513523.
        assert!(!absorbs(&p, 6, 1000, 12, 96));
        assert!(!absorbs(&Isam2Params { relax_max_frontal: 0, ..p }, 6, 120, 3, 118));
    }
}
