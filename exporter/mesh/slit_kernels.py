"""Vertices lying inside border sides, compiled: every border point against every border side.

A point is inside a side (start a, unit direction u, length L) when its offset o = p - a has
``along = o . u`` in (tolerance, L - tolerance) and ``|o|^2 - along^2 <= tolerance^2``, and it is
neither end of the side. The arithmetic and the order of the hits (point by point, sides in
order) are those of the former numpy blocks (sums over x, y, z left to right), so the same
pairs and parameters come out (tests/test_slits.py, tests/test_slit_kernels.py). Metres.
"""

from __future__ import annotations

import numpy as np

from .geometry import row_norms
from .jit import kernel


@kernel
def _hits(positions, ids, start, end, a, unit, length, tolerance):  # pragma: no cover - compiled
    p, s = ids.shape[0], start.shape[0]
    capacity = 16
    side = np.empty(capacity, np.int64)
    vertex = np.empty(capacity, np.int64)
    t = np.empty(capacity)
    count = 0
    for i in range(p):
        v = ids[i]
        px, py, pz = positions[v, 0], positions[v, 1], positions[v, 2]
        for j in range(s):
            ox, oy, oz = px - a[0, j], py - a[1, j], pz - a[2, j]
            along = ox * unit[0, j] + oy * unit[1, j] + oz * unit[2, j]
            off2 = ox * ox + oy * oy + oz * oz - along * along
            if not (off2 <= tolerance * tolerance):
                continue
            if not (along > tolerance and along < length[j] - tolerance):
                continue
            if start[j] == v or end[j] == v:
                continue
            if count == capacity:  # grow (rare: slits are few)
                capacity *= 2
                side2 = np.empty(capacity, np.int64)
                vertex2 = np.empty(capacity, np.int64)
                t2 = np.empty(capacity)
                side2[:count], vertex2[:count], t2[:count] = side[:count], vertex[:count], t[:count]
                side, vertex, t = side2, vertex2, t2
            side[count], vertex[count], t[count] = j, v, along / length[j]
            count += 1
    return side[:count], vertex[:count], t[:count]


def inside_sides(
    positions: np.ndarray,
    ids: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    tolerance: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points ``ids`` (p,) of ``positions`` (k, 3) metres strictly inside the sides ``start`` ->
    ``end`` (s,) vertex ids: ``(side index (h,) into the sides, vertex (h,), t (h,))`` in point
    then side order, ``t`` in (0, 1) the parameter along the side."""
    positions = np.ascontiguousarray(positions, np.float64)
    k = len(positions)
    for name, index in (("points", ids), ("sides", start), ("sides", end)):
        if len(index) and (index.min() < 0 or index.max() >= k):
            raise ValueError(f"inside_sides: a vertex of the {name} is out of range")
    a = positions[start]
    direction = positions[end] - a
    length = np.maximum(row_norms(direction), 1e-30)
    unit = direction / length[:, None]
    return _hits(
        positions,
        np.ascontiguousarray(ids, np.int64),
        np.ascontiguousarray(start, np.int64),
        np.ascontiguousarray(end, np.int64),
        np.ascontiguousarray(a.T),
        np.ascontiguousarray(unit.T),
        length,
        float(tolerance),
    )
