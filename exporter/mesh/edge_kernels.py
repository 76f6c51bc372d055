"""Every face side's undirected edge key in ascending order, compiled: sides bucketed by their
lower vertex (counting sort, sides in index order), each bucket sorted stably by the higher
vertex (insertion sort: buckets hold a few sides; merge sort at a fan's apex), so the order is
exactly ``np.argsort(keys, kind="stable")``'s (``tests/test_edge_kernels.py`` keeps the numpy
form as the reference)."""

from __future__ import annotations

import numpy as np

from .jit import kernel
from .sorted_kernels import stable_order


@kernel
def edge_key_order(faces, vertex_count):  # pragma: no cover - compiled
    """``(keys (3m,) int64 ascending, order (3m,) int64)`` of ``faces`` (m, 3) int64 (ids below
    ``vertex_count``): side ``3 f + i`` runs from corner i of face f to the next, its key is
    ``low * vertex_count + high``; ``order`` the stable permutation that sorts the keys."""
    n = 3 * faces.shape[0]
    low = np.empty(n, np.int64)
    high = np.empty(n, np.int64)
    start = np.zeros(vertex_count + 1, np.int64)
    for s in range(n):
        a, b = faces[s // 3, s % 3], faces[s // 3, (s % 3 + 1) % 3]
        low[s], high[s] = min(a, b), max(a, b)
        start[low[s] + 1] += 1
    for v in range(vertex_count):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    order = np.empty(n, np.int64)
    for s in range(n):
        order[fill[low[s]]] = s
        fill[low[s]] += 1
    for v in range(vertex_count):
        if start[v + 1] - start[v] > 32:  # a fan's apex: merge sort, not quadratic
            bucket = order[start[v] : start[v + 1]].copy()
            by_high = stable_order(high[bucket])
            for i in range(bucket.shape[0]):
                order[start[v] + i] = bucket[by_high[i]]
            continue
        for i in range(start[v] + 1, start[v + 1]):  # insertion sort by high, stable
            s = order[i]
            j = i
            while j > start[v] and high[order[j - 1]] > high[s]:
                order[j] = order[j - 1]
                j -= 1
            order[j] = s
    keys = np.empty(n, np.int64)
    for i in range(n):
        keys[i] = low[order[i]] * vertex_count + high[order[i]]
    return keys, order


@kernel
def edge_counts(faces, vertex_count):  # pragma: no cover - compiled
    """``(edges (e, 2) int64, uses (e,) int64)``: the undirected edges of ``faces`` (m, 3) int64
    (ids below ``vertex_count``) as ascending (low, high) pairs and how many sides use each."""
    keys, _ = edge_key_order(faces, vertex_count)
    n = keys.shape[0]
    distinct = 0
    for i in range(n):
        distinct += i == 0 or keys[i] != keys[i - 1]
    edges = np.empty((distinct, 2), np.int64)
    uses = np.zeros(distinct, np.int64)
    e = -1
    for i in range(n):
        if i == 0 or keys[i] != keys[i - 1]:
            e += 1
            edges[e, 0], edges[e, 1] = keys[i] // vertex_count, keys[i] % vertex_count
        uses[e] += 1
    return edges, uses
