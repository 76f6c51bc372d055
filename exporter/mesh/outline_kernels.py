"""Outline loops of many face regions at once, compiled (the walk of
:func:`exporter.simplify.planar._region_loops`): a region's outline is its half-edges whose
reverse the region lacks; it is a set of closed loops exactly when their sources are unique,
their targets are unique and every target is a source. Each loop is walked from its first
outline half-edge in face order, skipping dropped vertices. One region at a time, with
per-vertex scratch arrays (the half-edges leaving a vertex as a linked list): no sort. Integers only: the former numpy and
Python form (``tests/test_outline_kernels.py`` keeps it as the reference) is matched exactly."""

from __future__ import annotations

import numpy as np

from .jit import kernel
from .sorted_kernels import run_end


@kernel
def outline_loops(half, half_region, region_count, k, droppable):  # pragma: no cover - compiled
    """``(bad (count,) bool, vertices (n,), bounds (l + 1,), loop_region (l,))`` for the directed
    half-edges ``half`` (h, 2) int64 (ids below ``k``) of regions ``half_region`` (h,) ascending:
    every loop's kept vertices are ``vertices[bounds[i]:bounds[i + 1]]``; ``bad``: pinched, open,
    without outline, or a loop under 3 kept vertices (such regions' loops are listed too, to be
    ignored)."""
    h = half.shape[0]
    head = np.full(k, -1)  # per vertex: a half-edge leaving it (this region), -1 none
    after = np.empty(h, np.int64)  # the next half-edge leaving the same vertex
    leaving = np.full(k, -1)  # per vertex: the outline half-edge leaving it
    entered = np.zeros(k, np.bool_)  # per vertex: an outline half-edge ends there
    outline = np.zeros(h, np.bool_)
    following = np.empty(h, np.int64)
    seen = np.zeros(h, np.bool_)
    bad = np.ones(region_count, np.bool_)
    vertices = np.empty(h, np.int64)
    bounds = np.zeros(h + 1, np.int64)
    loop_region = np.empty(h, np.int64)
    loops = 0
    count = 0
    lo = 0
    while lo < h:
        region, hi = half_region[lo], run_end(half_region, lo)
        for e in range(lo, hi):
            after[e] = head[half[e, 0]]
            head[half[e, 0]] = e
        broken = False
        found = False
        for e in range(lo, hi):
            a, b = half[e, 0], half[e, 1]
            f = head[b]
            while f >= 0 and half[f, 1] != a:
                f = after[f]
            if f < 0:  # no reverse in the region: an outline half-edge
                outline[e] = True
                found = True
                broken |= leaving[a] >= 0 or entered[b]
                leaving[a] = e
                entered[b] = True
        for e in range(lo, hi):
            if outline[e]:
                following[e] = leaving[half[e, 1]]
                broken |= following[e] < 0
        broken |= not found
        if not broken:
            for first in range(lo, hi):
                if not outline[first] or seen[first]:
                    continue
                e = first
                while not seen[e]:
                    seen[e] = True
                    v = half[e, 0]
                    if not droppable[v]:
                        vertices[count] = v
                        count += 1
                    e = following[e]
                broken |= count - bounds[loops] < 3
                loop_region[loops] = region
                loops += 1
                bounds[loops] = count
        bad[region] = broken
        for e in range(lo, hi):  # clear the scratch for the next region
            head[half[e, 0]] = -1
            leaving[half[e, 0]] = -1
            entered[half[e, 1]] = False
        lo = hi
    return bad, vertices[:count], bounds[: loops + 1], loop_region[:loops]
