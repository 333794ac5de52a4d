//! Constrained minimum-degree elimination of the variables an update re-eliminates (iSAM2's
//! constrained COLAMD, Kaess et al. 2012 §5.1): the variables of the new factors are eliminated
//! last, so they end in the root clique, where the next update will find them; the others are
//! eliminated by increasing degree in the graph with its fill. Returns the order and every
//! variable's separator (its neighbours when it is eliminated), the rows of the symbolic
//! Cholesky factor.
//!
//! Exact degrees with explicit fill: O(Σ_v |sep(v)|² log n), small for pose graphs, whose
//! separators hold a few poses.

use std::cmp::Reverse;
use std::collections::{BTreeSet, BinaryHeap};

/// The result of [`eliminate`] on `n` local variables.
#[derive(Debug)]
pub(super) struct Elimination {
    /// Local variables in elimination order.
    pub order: Vec<usize>,
    /// Per local variable: its neighbours at its elimination, sorted by elimination position.
    pub separators: Vec<Vec<usize>>,
}

/// Eliminates local variables `0..n` connected by the hyperedges `edges` (each the local
/// variables of one factor), every variable with `constrained[v]` after every other one; ties by
/// degree are broken by the smaller index (the older variable).
pub(super) fn eliminate(n: usize, edges: &[Vec<usize>], constrained: &[bool]) -> Elimination {
    let mut adj: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
    for e in edges {
        for &a in e {
            for &b in e {
                if a != b {
                    adj[a].insert(b);
                }
            }
        }
    }
    let key = |v: usize, deg: usize| Reverse((usize::from(constrained[v]), deg, v));
    let mut heap: BinaryHeap<Reverse<(usize, usize, usize)>> = (0..n).map(|v| key(v, adj[v].len())).collect();
    let mut done = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut neighbours = vec![Vec::new(); n];
    while let Some(Reverse((_, deg, v))) = heap.pop() {
        if done[v] || deg != adj[v].len() {
            continue; // eliminated, or a stale degree
        }
        done[v] = true;
        order.push(v);
        let nv: Vec<usize> = std::mem::take(&mut adj[v]).into_iter().collect();
        for &u in &nv {
            adj[u].remove(&v);
            for &w in &nv {
                if w != u {
                    adj[u].insert(w);
                }
            }
            heap.push(key(u, adj[u].len()));
        }
        neighbours[v] = nv;
    }
    let mut position = vec![0; n];
    for (p, &v) in order.iter().enumerate() {
        position[v] = p;
    }
    for sep in &mut neighbours {
        sep.sort_unstable_by_key(|&u| position[u]);
    }
    Elimination { order, separators: neighbours }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chain_is_eliminated_from_its_ends_with_the_constrained_last() {
        // 0 - 1 - 2 - 3 - 4, with 2 constrained: it must come last.
        let edges: Vec<Vec<usize>> = (0..4).map(|i| vec![i, i + 1]).collect();
        let mut constrained = vec![false; 5];
        constrained[2] = true;
        let e = eliminate(5, &edges, &constrained);
        let mut position = [0; 5];
        for (p, &v) in e.order.iter().enumerate() {
            position[v] = p;
        }
        assert_eq!(*e.order.last().unwrap(), 2);
        // A chain has no fill: every separator holds at most two variables, each eliminated later.
        for v in 0..5 {
            assert!(e.separators[v].len() <= 2);
            assert!(e.separators[v].iter().all(|&u| position[u] > position[v]));
        }
    }

    #[test]
    fn fill_joins_the_neighbours_of_an_eliminated_variable() {
        // A star around 0 with 0 first (leaves constrained): the leaves become a clique.
        let edges = vec![vec![0, 1], vec![0, 2], vec![0, 3]];
        let e = eliminate(4, &edges, &[false, true, true, true]);
        assert_eq!(e.order[0], 0);
        assert_eq!(e.separators[0].len(), 3);
        assert_eq!(e.separators[e.order[1]].len(), 2);
    }
}
