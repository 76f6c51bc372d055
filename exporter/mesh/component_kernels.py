"""Connected components of an undirected graph, compiled: union-find (Tarjan, "Efficiency of a
good but not linear set union algorithm", 1975) with path halving, each union linking the larger
root under the smaller, so every component's root is its lowest node (the labels
``scipy.sparse.csgraph.connected_components`` orders its components by)."""

from __future__ import annotations

import numpy as np

from .jit import kernel


@kernel
def root(parent, a):  # pragma: no cover - compiled
    """The root of node ``a`` in the union-find forest ``parent`` (n,) int64, halving its path."""
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@kernel
def _lowest(n, left, right):  # pragma: no cover - compiled
    parent = np.arange(n)
    for e in range(left.shape[0]):
        a, b = left[e], right[e]
        while parent[a] != a:  # find with path halving
            parent[a] = parent[parent[a]]
            a = parent[a]
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        if a < b:
            parent[b] = a
        elif b < a:
            parent[a] = b
    for i in range(n):  # parents are lower than their children: one pass in order settles all
        parent[i] = parent[parent[i]]
    return parent


def lowest_member(n: int, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """(n,) int64: the lowest node of every node's connected component in the undirected graph
    on nodes 0..n-1 with edges ``left[i] -- right[i]`` (int arrays of one length)."""
    left = np.ascontiguousarray(left, np.int64).reshape(-1)
    right = np.ascontiguousarray(right, np.int64).reshape(-1)
    if len(left) != len(right):
        raise ValueError("lowest_member: edge ends of different lengths")
    if len(left) and (min(left.min(), right.min()) < 0 or max(left.max(), right.max()) >= n):
        raise ValueError("lowest_member: a node index is out of range")
    return _lowest(int(n), left, right)
