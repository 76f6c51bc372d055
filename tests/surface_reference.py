"""The former numpy form of ``SurfaceIndex._upper`` (now ``exporter/mesh/c/surface.c``): the
reference tests/test_surface_kernels.py compares the C with, float for float (the nearest face's
reference is tests/test_perf_hausdorff.py's). Metres, any one Cartesian frame."""

from __future__ import annotations

import numpy as np

from exporter.mesh.distance import SurfaceIndex
from exporter.mesh.distance_kernels import point_triangle_distance


def reference_upper(
    index: SurfaceIndex, points: np.ndarray, probe_distance: np.ndarray, nearest: np.ndarray
) -> np.ndarray:
    """``SurfaceIndex._upper``: (p,) metres, 0 on a probe, else the least distance to the
    triangles owning the nearest probes (p, k)."""
    upper = np.zeros(len(points))
    off = np.flatnonzero(probe_distance[:, 0] > 0)
    if len(off) == 0:
        return upper
    owners = np.sort(index.owner[nearest[off]], axis=1)
    fresh = np.ones(owners.shape, dtype=bool)
    fresh[:, 1:] = owners[:, 1:] != owners[:, :-1]
    rows = np.repeat(np.arange(len(off)), fresh.sum(axis=1))
    distance = point_triangle_distance(points[off[rows]], index.tri[owners[fresh]])
    starts = np.concatenate([[0], np.cumsum(fresh.sum(axis=1))[:-1]])
    upper[off] = np.minimum.reduceat(distance, starts)
    return upper
