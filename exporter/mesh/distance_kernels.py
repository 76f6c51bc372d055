"""Exact distance from points to triangles: the checks and shapes around the compiled kernel
(``exporter/mesh/c/distance.c``: Ericson, "Real-Time Collision Detection" (2005), 5.1.5, one
(point, triangle) pair at a time, the same bits as the former numpy form). Any one Cartesian
frame, metres.
"""

from __future__ import annotations

import numpy as np

from ._distance import pairs as _pairs


def point_triangle_distance(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance from points (..., 3) to triangles (..., 3, 3), broadcast against each other;
    (...) metres. Any one Cartesian frame."""
    if points.shape[-1:] != (3,) or tri.shape[-2:] != (3, 3):
        raise ValueError(f"point_triangle_distance: shapes {points.shape}, {tri.shape}")
    if points.shape[:-1] == tri.shape[:-2]:  # (point, triangle) pairs: no broadcasting
        shape = points.shape[:-1]
        p = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
        t = np.ascontiguousarray(tri, np.float64).reshape(-1, 3, 3)
    else:
        shape = np.broadcast_shapes(points.shape[:-1], tri.shape[:-2])
        p = np.ascontiguousarray(np.broadcast_to(points, (*shape, 3)), np.float64).reshape(-1, 3)
        t = np.ascontiguousarray(np.broadcast_to(tri, (*shape, 3, 3)), np.float64)
        t = t.reshape(-1, 3, 3)
    out = np.empty(len(p))
    if len(p):
        _pairs(p, t, out)
    return out.reshape(shape)
