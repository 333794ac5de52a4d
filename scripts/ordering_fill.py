#!/usr/bin/env python3
"""Flops of one Cholesky factorisation of a SLAM graph's information matrix under different
elimination orders: faer's AMD order (as the back end factorises it) against METIS's nested
dissection (PyPI `pymetis`, not a dependency of the project: `pip install pymetis`).

Input: the structure file `cargo bench --bench slam_bound -- --structure-out FILE` writes
(`v <var> <dim> <position>` per free variable, `f <var> <var> ...` per factor).

The symbolic factorisation runs on variables (blocks): for each variable j in elimination order,
the variables below it in its column of L are its later neighbours and its elimination-tree
children's columns less j; its parent is the first of them. A block of d columns with m rows
below costs d^3/3 + m d^2 + m^2 d flops (the formula of `Marginals::factor_stats`, there per
faer supernode; supernodes of several variables cost about the same, relaxed ones a little more).

Usage: python3 scripts/ordering_fill.py STRUCTURE_FILE
"""

import sys


def read_structure(path):
    dims, position, factors = {}, {}, []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                var, dim, pos = map(int, parts[1:4])
                dims[var], position[var] = dim, pos
            elif parts[0] == "f":
                factors.append([int(k) for k in parts[1:]])
    return dims, position, factors


def adjacency(dims, factors):
    adj = {v: set() for v in dims}
    for keys in factors:
        free = [k for k in keys if k in dims]
        for a in free:
            for b in free:
                if a != b:
                    adj[a].add(b)
    return adj


def factor_flops(order, dims, adj):
    """Flops and stored entries of the block Cholesky factor eliminated in `order`."""
    rank = {v: i for i, v in enumerate(order)}
    children = {v: [] for v in order}
    flops = entries = 0.0
    for v in order:
        below = {u for u in adj[v] if rank[u] > rank[v]}
        for c in children[v]:
            below |= c
        below.discard(v)
        d = dims[v]
        m = sum(dims[u] for u in below)
        flops += d**3 / 3 + m * d * d + m * m * d
        entries += d * (d + 1) / 2 + m * d
        if below:
            parent = min(below, key=rank.__getitem__)
            children[parent].append(below)
        children[v] = None  # merged: free the memory
    return flops, entries


def main():
    import pymetis

    dims, position, factors = read_structure(sys.argv[1])
    adj = adjacency(dims, factors)
    n = sum(dims.values())
    print(f"{len(dims)} free variables, {n} unknowns, {len(factors)} factors")
    amd = sorted(dims, key=position.__getitem__)
    flops, entries = factor_flops(amd, dims, adj)
    print(f"faer's AMD order:        {flops / 1e9:.4g} GFlop, {entries:.4g} factor entries")
    index = {v: i for i, v in enumerate(amd)}
    graph = [[index[u] for u in sorted(adj[v], key=index.__getitem__)] for v in amd]
    perm, _ = pymetis.nested_dissection(adjacency=graph, vweights=[dims[v] for v in amd])
    nd = [amd[i] for i in perm]
    nd_flops, nd_entries = factor_flops(nd, dims, adj)
    print(f"METIS nested dissection: {nd_flops / 1e9:.4g} GFlop, {nd_entries:.4g} factor entries")
    print(f"ratio (METIS / AMD): {nd_flops / flops:.3f} in flops, {nd_entries / entries:.3f} in entries")


if __name__ == "__main__":
    main()
