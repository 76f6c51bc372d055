"""Bands of a chain difference: the checks and shapes around the compiled kernel
(``exporter/mesh/c/band.c`` on ``exporter/mesh/c/bands.h``, which holds the algorithm): the
cycles of each region's difference between the boundary chains of two triangulations of one flat
polygon, and each cycle's width when it is a band (step 4 of :mod:`exporter.mesh.coverage`).

A cycle is walked edge after edge; a closed cycle is a band when, split at its two farthest-apart
vertices, it is two runs each monotone along that chord, one of the level's boundary edges and the
other of the source's; its width is the spread of the vertices across the chord. Widths are the
same bits as the former numpy form (tests/test_band_kernels.py). In-plane metres.
"""

from __future__ import annotations

import numpy as np

# The walk and the widths on their own (tests compare them with the former plain-Python ones):
# walk(a, b, side, by_start, a_sorted, lo, hi, max_edges, cycle_of, order_in_cycle) -> count or -1,
# band_width(x, y, side, half) -> metres, NaN when the cycle is not a band (c/bands.h).
from ._band import band_width as _band_width  # noqa: F401
from ._band import region_bands as _c_region_bands
from ._band import walk as _walk  # noqa: F401


def region_bands(
    diff: np.ndarray, xy: np.ndarray, good: np.ndarray, width: np.ndarray, max_edges: int
) -> None:
    """For chain-difference rows ``diff`` (d, 4) ``(region, a, b, side)`` sorted by region (stable)
    and each row's start vertex in its region's plane ``xy`` (d, 2) metres: marks not ``good``
    (r,) bool every region whose cycles are not all bands, and raises ``width`` (r,) metres to
    each region's widest band. In place."""
    if len(diff) == 0:
        return
    rows = np.ascontiguousarray(diff, np.int64)
    if rows[:, 0].min() < 0 or rows[:, 0].max() >= len(good) or len(width) != len(good):
        raise ValueError("region_bands: region index out of range")
    # Rows by (region, start vertex), stable: each region's rows leaving a vertex in row order.
    by_start = np.lexsort((rows[:, 1], rows[:, 0]))
    _c_region_bands(
        rows[:, 0].copy(),
        rows[:, 1].copy(),
        rows[:, 2].copy(),
        rows[:, 3].copy(),
        by_start,
        np.ascontiguousarray(xy, np.float64),
        good,
        width,
        int(max_edges),
        0.5,
    )
