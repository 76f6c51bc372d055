"""Straight boundary runs merged into one segment (step 2 of :mod:`exporter.mesh.hausdorff`: a
region's projected outline): the keys and checks around the compiled walk
(``exporter/mesh/c/straight_run.c``: a run of boundary segments through vertices with one
oriented segment in and one out becomes its chord when its inner vertices lie within
``t_junction`` x the chord's length of it on the region's side, the largest offset going into the
region's ``gap``; the same bits as the former Python loop, tests/test_perf_hausdorff.py).
In-plane metres.
"""

from __future__ import annotations

import numpy as np

from ._straight_run import runs as _runs


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
    ``gap`` (r,) float64 metres raised in place by each merged run's largest offset."""
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
