"""Vertices lying inside border sides: every border point against every border side, in the
compiled kernel ``exporter/mesh/c/slit.c``.

A point is inside a side (start a, unit direction u, length L) when its offset o = p - a has
``along = o . u`` in (tolerance, L - tolerance) and ``|o|^2 - along^2 <= tolerance^2``, and it is
neither end of the side. The arithmetic and the order of the hits (point by point, sides in
order) are those of the former numpy blocks (sums over x, y, z left to right), so the same
pairs and parameters come out (tests/test_slits.py, tests/test_slit_kernels.py). Metres.
"""

from __future__ import annotations

import numpy as np

from ._slit import inside as _inside


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
    return _inside(positions, ids, start, end, float(tolerance))
