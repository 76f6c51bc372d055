"""Bands of a chain difference, compiled: the cycles of each region's difference between the
boundary chains of two triangulations of one flat polygon, and each cycle's width when it is a
band (step 4 of :mod:`exporter.coverage`).

A cycle is walked edge after edge; where several edges leave a vertex the walk turns onto the
other side's edge (two bands meeting at a corner); an ambiguous turn, a walk that does not close
or one longer than ``max_edges`` makes the region's cycles unknown. A closed cycle is a band when,
split at its two farthest-apart vertices (the first such pair in (p, q) order), it is two runs each
monotone along that chord (within 1e-12 of its length), one of the level's boundary edges (side +1)
and the other of the source's (side -1); its width is the spread of the vertices across the chord.
Every float operation is the one the former numpy form did, in its order (the chord length is
``b ** 0.5`` with a run-time exponent, i.e. libm's ``pow`` as Python computes it: a constant 0.5
would become ``sqrt``, which differs in the last bit for ~1 in 1,000 values), so widths are the
same bits (checked in tests/test_band_kernels.py against a plain reference). In-plane metres.
"""

from __future__ import annotations

import numpy as np

from .jit import kernel
from .sorted_kernels import lower_bound, upper_bound


@kernel
def _walk(a, b, side, by_start, a_sorted, lo, hi, max_edges, cycle_of, order_in_cycle):
    # pragma: no cover - compiled
    """Cycles of rows lo..hi-1 (edge a -> b, side +1/-1/0; ``by_start`` the rows lo..hi-1 sorted
    by (a, row), so the rows leaving a vertex are a range in row order): fills ``cycle_of``
    (cycle number per row) and ``order_in_cycle``; returns the cycle count, or -1 when a walk
    fails."""
    n = hi - lo
    used = np.zeros(n, np.bool_)
    options = np.empty(n, np.int64)
    cycles = 0
    for first in range(n):
        if used[first]:
            continue
        i = first
        count = 0
        while True:
            used[i] = True
            cycle_of[lo + i] = cycles
            order_in_cycle[lo + i] = count
            count += 1
            if count > max_edges:
                return -1
            end = b[lo + i]
            s = lower_bound(a_sorted, lo, hi, end)
            e = upper_bound(a_sorted, lo, hi, end)
            if e - s == 1:
                j = by_start[s] - lo
                if j == first:
                    break
                if used[j]:
                    return -1
                i = j
                continue
            # Leaving rows in row order (the stable sort keeps it), not used or the first.
            found_first = False
            k = 0
            for t in range(s, e):
                j = by_start[t] - lo
                if j == first:
                    found_first = True
                if not used[j] or j == first:
                    options[k] = j
                    k += 1
            if found_first:
                break
            if k > 1:
                m = 0
                for t in range(k):
                    if side[lo + options[t]] != side[lo + i]:
                        options[m] = options[t]
                        m += 1
                k = m
            if k != 1:
                return -1
            i = options[0]
        cycles += 1
    return cycles


@kernel
def _band_width(x, y, side, half):  # pragma: no cover - compiled
    """Width across the chord of one cycle (vertex e at (x[e], y[e]), edge e from vertex e to
    e + 1 cyclically, ``side`` per edge), NaN when it is not a band."""
    n = x.shape[0]
    best, p, q = -1.0, 0, 0
    for i in range(n):
        for j in range(i + 1, n):
            dx = x[j] - x[i]
            dy = y[j] - y[i]
            d = dx * dx + dy * dy
            if d > best:
                best, p, q = d, i, j
    if not best > 0.0:
        return np.nan
    length = best**half
    xi, yi = x[p], y[p]
    ax = (x[q] - x[p]) / length
    ay = (y[q] - y[p]) / length
    slack = 1e-12 * length
    first_pos = first_neg = second_pos = second_neg = True
    high, low = -np.inf, np.inf
    for e in range(n):
        nxt = e + 1 if e + 1 < n else 0
        t = (x[e] - xi) * ax + (y[e] - yi) * ay
        t_next = (x[nxt] - xi) * ax + (y[nxt] - yi) * ay
        step = t_next - t
        h = (y[e] - yi) * ax - (x[e] - xi) * ay
        high = max(high, h)
        low = min(low, h)
        if p <= e < q:
            if step < -slack:
                return np.nan
            first_pos &= side[e] == 1
            first_neg &= side[e] == -1
        else:
            if -step < -slack:
                return np.nan
            second_pos &= side[e] == 1
            second_neg &= side[e] == -1
    if not ((first_pos and second_neg) or (first_neg and second_pos)):
        return np.nan
    return high - low


@kernel
def _region_bands(region, a, b, side, by_start, xy, good, width, max_edges, half):
    # pragma: no cover - compiled
    d = region.shape[0]
    a_sorted = np.empty(d, np.int64)
    for r in range(d):
        a_sorted[r] = a[by_start[r]]
    cycle_of = np.empty(d, np.int64)
    order_in_cycle = np.empty(d, np.int64)
    s = 0
    while s < d:
        g = region[s]
        e = s
        while e < d and region[e] == g:
            e += 1
        if good[g]:
            cycles = _walk(
                a, b, side, by_start, a_sorted, s, e, max_edges, cycle_of, order_in_cycle
            )
            zero = False
            for r in range(s, e):
                zero |= side[r] == 0
            if cycles < 0 or zero:
                good[g] = False
            else:
                for c in range(cycles):
                    size = 0
                    for r in range(s, e):
                        size += cycle_of[r] == c
                    x = np.empty(size)
                    y = np.empty(size)
                    sides = np.empty(size, np.int64)
                    for r in range(s, e):
                        if cycle_of[r] == c:
                            k = order_in_cycle[r]
                            x[k], y[k], sides[k] = xy[r, 0], xy[r, 1], side[r]
                    band = _band_width(x, y, sides, half)
                    if band != band:  # NaN: not a band
                        good[g] = False
                    elif band > width[g]:
                        width[g] = band
        s = e


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
    _region_bands(
        rows[:, 0].copy(),
        rows[:, 1].copy(),
        rows[:, 2].copy(),
        rows[:, 3].copy(),
        by_start,
        np.ascontiguousarray(xy, np.float64),
        good,
        width,
        max_edges,
        0.5,
    )
