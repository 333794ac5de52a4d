//! Constrained elimination ordering of the variables an update re-eliminates (iSAM2's
//! constrained COLAMD, Kaess et al. 2012 §5.1): the variables of the new factors are eliminated
//! last, so they end in the root clique, where the next update will find them, and among them
//! the new variables (the newest pose) last of all. Within a group, exact minimum degree in the
//! graph with its fill. Returns the order and every variable's separator, the column structures
//! of the symbolic Cholesky factor, from the elimination tree: `sep(v) = {u ∈ adj(v) : u after
//! v} ∪ ⋃_{c child of v} sep(c) \ {v}` (Liu 1990, the row-merge form).
//!
//! Cost: the ordering's explicit fill, O(Σ_v Σ_{u ∈ sep(v)} (|adj(u)| + |sep(v)|)), plus
//! O(Σ_v |sep(v)| log |sep(v)|) for the structure. (faer's AMD on the whole top, partitioned by
//! group afterwards, costs less to compute but gave more fill: the missions ran slower.)

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The result of [`eliminate`] on `n` local variables.
#[derive(Debug)]
pub(super) struct Elimination {
    /// Local variables in elimination order.
    pub order: Vec<usize>,
    /// Per local variable: its neighbours at its elimination, sorted by elimination position.
    pub separators: Vec<Vec<usize>>,
}

/// Eliminates local variables `0..n` of `dim[v]` scalars each, connected by the hyperedges
/// `edges` (each the local variables of one factor), group by increasing `group[v]`.
pub(super) fn eliminate(n: usize, edges: &[Vec<usize>], group: &[u8], dim: &[usize]) -> Elimination {
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for e in edges {
        for &a in e {
            adj[a].extend(e.iter().copied().filter(|&b| b != a));
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    let order = minimum_degree(&adj, group, dim);
    let mut position = vec![0; n];
    for (p, &v) in order.iter().enumerate() {
        position[v] = p;
    }
    let mut separators: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut mark = vec![usize::MAX; n];
    for &v in &order {
        let mut sep = Vec::new();
        mark[v] = v;
        for &u in &adj[v] {
            if position[u] > position[v] && mark[u] != v {
                mark[u] = v;
                sep.push(u);
            }
        }
        for &c in &children[v] {
            for &u in &separators[c] {
                if mark[u] != v {
                    mark[u] = v;
                    sep.push(u);
                }
            }
        }
        sep.sort_unstable_by_key(|&u| position[u]);
        if let Some(&parent) = sep.first() {
            children[parent].push(v);
        }
        separators[v] = sep;
    }
    Elimination { order, separators }
}

/// Exact minimum-degree order of the graph `adj` (sorted neighbour lists, no self loops) with
/// explicit fill, group by increasing `group`, within a group by the scalar degree
/// `Σ_{u ∈ adj(v)} dim[u]` (the rows a variable's elimination adds to its clique: a pose of six
/// scalars weighs twice a landmark of three), ties by the smaller index (the older variable).
/// Sorted-vector adjacency: an elimination costs O(Σ_{u ∈ adj(v)} (|adj(u)| + |adj(v)|)).
fn minimum_degree(adj: &[Vec<usize>], group: &[u8], dim: &[usize]) -> Vec<usize> {
    let n = adj.len();
    let mut adj: Vec<Vec<usize>> = adj.to_vec();
    let degree = |a: &[usize]| a.iter().map(|&u| dim[u]).sum::<usize>();
    let mut deg: Vec<usize> = adj.iter().map(|a| degree(a)).collect();
    let mut heap: BinaryHeap<Reverse<(u8, usize, usize)>> = (0..n).map(|v| Reverse((group[v], deg[v], v))).collect();
    let mut done = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut merged = Vec::new();
    while let Some(Reverse((_, d, v))) = heap.pop() {
        if done[v] || d != deg[v] {
            continue; // eliminated, or a stale degree
        }
        done[v] = true;
        order.push(v);
        let nv = std::mem::take(&mut adj[v]);
        for &u in &nv {
            // adj(u) ← adj(u) ∪ adj(v) \ {u, v}, both sorted.
            merged.clear();
            let (a, b) = (&adj[u], &nv);
            let (mut i, mut j) = (0, 0);
            while i < a.len() || j < b.len() {
                let x = match (a.get(i), b.get(j)) {
                    (Some(&x), Some(&y)) if x == y => {
                        i += 1;
                        j += 1;
                        x
                    }
                    (Some(&x), Some(&y)) if x < y => {
                        i += 1;
                        x
                    }
                    (Some(&x), None) => {
                        i += 1;
                        x
                    }
                    (_, Some(&y)) => {
                        j += 1;
                        y
                    }
                    (None, None) => break,
                };
                if x != u && x != v {
                    merged.push(x);
                }
            }
            std::mem::swap(&mut adj[u], &mut merged);
            deg[u] = degree(&adj[u]);
            heap.push(Reverse((group[u], deg[u], u)));
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chain_is_eliminated_from_its_ends_with_the_constrained_last() {
        // 0 - 1 - 2 - 3 - 4, with 2 constrained: it must come last.
        let edges: Vec<Vec<usize>> = (0..4).map(|i| vec![i, i + 1]).collect();
        let mut group = vec![0; 5];
        group[2] = 1;
        let e = eliminate(5, &edges, &group, &[1; 5]);
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

    /// The separators are the symbolic factor's column structures: checked against an
    /// explicit elimination game (eliminate in the given order, joining each variable's
    /// remaining neighbours) on a random graph.
    #[test]
    fn separators_are_the_elimination_game_in_that_order() {
        let n = 40;
        let mut edges = Vec::new();
        let mut x: u64 = 12345;
        for _ in 0..90 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let (a, b, c) = ((x >> 33) as usize % n, (x >> 45) as usize % n, (x >> 20) as usize % n);
            let mut e = vec![a, b, c];
            e.sort_unstable();
            e.dedup();
            edges.push(e);
        }
        let group: Vec<u8> = (0..n).map(|v| [0, 1, 0, 0, 2, 0, 0][v % 7]).collect();
        let e = eliminate(n, &edges, &group, &vec![2; n]);
        let mut sorted = e.order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "a permutation");
        assert!(e.order.windows(2).all(|w| group[w[0]] <= group[w[1]]), "by group");
        let mut adj = vec![std::collections::BTreeSet::new(); n];
        for f in &edges {
            for &a in f {
                adj[a].extend(f.iter().copied().filter(|&b| b != a));
            }
        }
        for &v in &e.order {
            let nv: Vec<usize> = std::mem::take(&mut adj[v]).into_iter().collect();
            for &u in &nv {
                adj[u].remove(&v);
                adj[u].extend(nv.iter().copied().filter(|&w| w != u));
            }
            let mut ours = e.separators[v].clone();
            ours.sort_unstable();
            assert_eq!(ours, nv, "separator of {v}");
        }
    }

    #[test]
    fn fill_joins_the_neighbours_of_an_eliminated_variable() {
        // A star around 0 with 0 first (leaves constrained): the leaves become a clique.
        let edges = vec![vec![0, 1], vec![0, 2], vec![0, 3]];
        let e = eliminate(4, &edges, &[0, 1, 1, 1], &[3; 4]);
        assert_eq!(e.order[0], 0);
        assert_eq!(e.separators[0].len(), 3);
        assert_eq!(e.separators[e.order[1]].len(), 2);
    }
}
