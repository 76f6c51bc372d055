"""Straight boundary runs merged into one segment, compiled (step 2 of :mod:`exporter.hausdorff`:
a region's projected outline).

A run a -> b -> ... -> c of a region's boundary segments, through vertices with exactly one
oriented boundary segment in and one out, becomes the one segment ac when its inner vertices lie
within ``t_junction`` x |ac| of the chord ac on the region's side (left of a -> c; 1e-9 x |ac|
the other way for rounding); the largest offset goes into the region's ``gap``. Runs start at
segments whose first vertex no run passes through, then the rest in order; segments of faces
that flip when projected stay as they are. The order of the walk and every float operation are
those of the former Python loop (tests/test_perf_hausdorff.py keeps it as the reference; the
chord length is ``pow(., half)`` with a run-time 0.5, as Python's ``** 0.5``), so the segments
and gaps are the same bits. In-plane metres.
"""

from __future__ import annotations

import numpy as np

from .jit import kernel
from .sorted_kernels import lower_bound, upper_bound


@kernel
def _through(keys_out, order_out, keys_in, key):  # pragma: no cover - compiled
    """The one oriented segment leaving ``key`` = (region, vertex) when exactly one leaves and
    one enters it, else -1."""
    s = lower_bound(keys_out, 0, len(keys_out), key)
    if upper_bound(keys_out, s, len(keys_out), key) - s != 1:
        return -1
    t = lower_bound(keys_in, 0, len(keys_in), key)
    if upper_bound(keys_in, t, len(keys_in), key) - t != 1:
        return -1
    return order_out[s]


@kernel
def _runs(
    region,
    seg,
    start_key,
    end_key,
    order_out,
    keys_in,
    oriented,
    t_junction,
    half,
    gap,
    out_region,
    out_seg,
):
    # pragma: no cover - compiled
    n = region.shape[0]
    keys_out = start_key[order_out]
    # Run starts first (no run passes through their first vertex), then the rest, in order.
    order = np.empty(n, np.int64)
    later = np.empty(n, np.int64)
    first, rest = 0, 0
    for i in range(n):
        if _through(keys_out, order_out, keys_in, start_key[i]) >= 0:
            later[rest] = i
            rest += 1
        else:
            order[first] = i
            first += 1
    for m in range(rest):
        order[first + m] = later[m]
    used = np.zeros(n, np.bool_)
    inner_x = np.empty(n)
    inner_y = np.empty(n)
    count = 0
    for i in order:
        if used[i]:
            continue
        used[i] = True
        g = region[i]
        if not oriented[i]:
            out_region[count] = g
            for c in range(2):
                out_seg[count, c, 0], out_seg[count, c, 1] = seg[i, c, 0], seg[i, c, 1]
            count += 1
            continue
        sx, sy = seg[i, 0, 0], seg[i, 0, 1]
        ex, ey = seg[i, 1, 0], seg[i, 1, 1]
        inner = 0
        j = i
        while True:
            nxt = _through(keys_out, order_out, keys_in, end_key[j])
            if nxt < 0 or used[nxt]:
                break
            cx, cy = seg[nxt, 1, 0] - sx, seg[nxt, 1, 1] - sy
            length = (cx * cx + cy * cy) ** half
            high, low = -np.inf, np.inf
            for m in range(inner + 1):
                qx, qy = ex, ey
                if m < inner:
                    qx, qy = inner_x[m], inner_y[m]
                offset = (cx * (qy - sy) - cy * (qx - sx)) / length if length > 0 else 1e300
                high = max(high, offset)
                low = min(low, offset)
            if high > t_junction * length or low < -1e-9 * length:
                break
            inner_x[inner], inner_y[inner] = ex, ey
            inner += 1
            ex, ey = seg[nxt, 1, 0], seg[nxt, 1, 1]
            used[nxt] = True
            j = nxt
        if inner:
            cx, cy = ex - sx, ey - sy
            length = (cx * cx + cy * cy) ** half
            widest = -np.inf
            for m in range(inner):
                widest = max(widest, abs(cx * (inner_y[m] - sy) - cy * (inner_x[m] - sx)) / length)
            gap[g] = max(gap[g], widest)
        out_region[count] = g
        out_seg[count, 0, 0], out_seg[count, 0, 1] = sx, sy
        out_seg[count, 1, 0], out_seg[count, 1, 1] = ex, ey
        count += 1
    return count


def straight_runs(
    seg_region: np.ndarray,
    seg: np.ndarray,
    ends: np.ndarray,
    oriented: np.ndarray,
    gap: np.ndarray,
    t_junction: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Boundary segments ``seg`` (s, 2, 2) in-plane metres of regions ``seg_region`` (s,) int64,
    with vertex ids ``ends`` (s, 2) int64 and ``oriented`` (s,) bool (their face keeps its
    orientation when projected), straight runs merged: ``(region (s',), segments (s', 2, 2))``;
    ``gap`` (r,) metres raised in place by each merged run's largest offset."""
    s = len(seg)
    region = np.ascontiguousarray(seg_region, np.int64)
    ends = np.ascontiguousarray(ends, np.int64).reshape(-1, 2)
    if len(region) != s or len(ends) != s or len(oriented) != s or np.shape(seg)[1:] != (2, 2):
        raise ValueError("straight_runs: segments, regions, ends and orientations differ in shape")
    if s and (region.min() < 0 or region.max() >= len(gap) or ends.min() < 0):
        raise ValueError("straight_runs: a region or vertex index is out of range")
    out_region = np.empty(s, np.int64)
    out_seg = np.empty((s, 2, 2))
    if s == 0:
        return out_region, out_seg
    k = int(ends.max()) + 1
    start_key, end_key = region * k + ends[:, 0], region * k + ends[:, 1]
    oriented = np.ascontiguousarray(oriented, np.bool_)
    which = np.flatnonzero(oriented)
    count = _runs(
        region,
        np.ascontiguousarray(seg, np.float64),
        start_key,
        end_key,
        which[np.argsort(start_key[which], kind="stable")],  # oriented rows by start, in order
        np.sort(end_key[which]),
        oriented,
        t_junction,
        0.5,
        gap,
        out_region,
        out_seg,
    )
    return out_region[:count], out_seg[:count]
