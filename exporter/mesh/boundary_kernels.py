"""The open boundary of a triangle mesh, compiled: the edges used by exactly one face side (as
(low, high) vertex pairs, ascending) and the number of loops they form (connected components of
those edges; only vertices on an edge count), and the sides on it. Sides are matched through per-vertex lists (the
sides whose lower end is that vertex), so only the few border keys are sorted. Integers only:
the former numpy form (``tests/test_boundary_kernels.py`` keeps it as the reference) is matched
exactly."""

from __future__ import annotations

import numpy as np

from .component_kernels import root
from .jit import kernel
from .sorted_kernels import stable_order


@kernel
def once_sides(faces, vertex_count):  # pragma: no cover - compiled
    """(s,) int64 ascending: the sides ``3 f + i`` (corner i of face f to corner i + 1) of
    ``faces`` (m, 3) int64 (ids in 0..vertex_count) whose undirected edge no other side uses."""
    m = faces.shape[0]
    low = np.empty(3 * m, np.int64)
    high = np.empty(3 * m, np.int64)
    head = np.full(vertex_count + 1, -1)  # per vertex: a side whose lower end it is
    after = np.empty(3 * m, np.int64)  # the next side with the same lower end
    for f in range(m):
        for i in range(3):
            s = 3 * f + i
            a, b = faces[f, i], faces[f, (i + 1) % 3]
            low[s], high[s] = min(a, b), max(a, b)
            after[s] = head[low[s]]
            head[low[s]] = s
    sides = np.empty(3 * m, np.int64)
    count = 0
    for s in range(3 * m):
        uses = 0
        r = head[low[s]]
        while r >= 0:
            uses += high[r] == high[s]
            r = after[r]
        if uses == 1:
            sides[count] = s
            count += 1
    return sides[:count]


@kernel
def border_loops(faces, vertex_count):  # pragma: no cover - compiled
    """``(edges (e, 2) int64, loops)`` of ``faces`` (m, 3) int64 with ids in 0..vertex_count."""
    base = vertex_count + 1
    sides = once_sides(faces, vertex_count)
    count = sides.shape[0]
    keys = np.empty(count, np.int64)
    for e in range(count):
        a, b = faces[sides[e] // 3, sides[e] % 3], faces[sides[e] // 3, (sides[e] % 3 + 1) % 3]
        keys[e] = min(a, b) * base + max(a, b)
    order = stable_order(keys)
    edges = np.empty((count, 2), np.int64)
    parent = np.full(base, -1)
    loops = 0
    for e in range(count):
        key = keys[order[e]]
        a, b = key // base, key % base
        edges[e, 0], edges[e, 1] = a, b
        for v in (a, b):
            if parent[v] < 0:
                parent[v] = v
                loops += 1
        ra, rb = root(parent, a), root(parent, b)
        if ra != rb:
            parent[ra] = rb
            loops -= 1
    return edges, loops
