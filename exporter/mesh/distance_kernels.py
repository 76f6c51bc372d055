"""Exact distance from points to triangles, compiled: one (point, triangle) pair at a time.

Source: Ericson, "Real-Time Collision Detection" (2005), 5.1.5 (closest point on a triangle by its
Voronoi regions). The regions are tested in the order the former vectorised form applied them
(vertex A, B, C, then edges AB, AC, BC, then the interior), and every float operation is the one
it did, in the same order, so the results are the same bits (checked against a numpy reference in
tests/test_distance_kernels.py). A degenerate (zero-area) triangle whose formula gives NaN takes
its nearest corner's distance. Frame-free: any one Cartesian frame, metres.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import kernel


@kernel
def _pair_distance(px, py, pz, t):  # pragma: no cover - compiled
    """Distance (metres) from point (px, py, pz) to the triangle ``t`` (3, 3) (row = corner)."""
    ax, ay, az = t[0, 0], t[0, 1], t[0, 2]
    bx, by, bz = t[1, 0], t[1, 1], t[1, 2]
    cx, cy, cz = t[2, 0], t[2, 1], t[2, 2]
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    if d1 <= 0 and d2 <= 0:
        qx, qy, qz = ax, ay, az
    elif d3 >= 0 and d4 <= d3:
        qx, qy, qz = bx, by, bz
    elif d6 >= 0 and d5 <= d6:
        qx, qy, qz = cx, cy, cz
    elif vc <= 0 and d1 >= 0 and d3 <= 0:
        s = d1 / (d1 - d3)
        s = 0.0 if s < 0 else (1.0 if s > 1 else s)  # a NaN stays NaN (as np.clip)
        qx, qy, qz = ax + s * abx, ay + s * aby, az + s * abz
    elif vb <= 0 and d2 >= 0 and d6 <= 0:
        s = d2 / (d2 - d6)
        s = 0.0 if s < 0 else (1.0 if s > 1 else s)
        qx, qy, qz = ax + s * acx, ay + s * acy, az + s * acz
    elif va <= 0 and d4 - d3 >= 0 and d5 - d6 >= 0:
        s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        s = 0.0 if s < 0 else (1.0 if s > 1 else s)
        qx, qy, qz = bx + s * (cx - bx), by + s * (cy - by), bz + s * (cz - bz)
    else:
        denom = va + vb + vc
        v = vb / denom if denom != 0 else 0.0
        w = vc / denom if denom != 0 else 0.0
        qx, qy, qz = ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w
    ox, oy, oz = px - qx, py - qy, pz - qz
    distance = math.sqrt(ox * ox + oy * oy + oz * oz)
    if math.isnan(distance):
        da = math.sqrt(apx * apx + apy * apy + apz * apz)
        db = math.sqrt(bpx * bpx + bpy * bpy + bpz * bpz)
        dc = math.sqrt(cpx * cpx + cpy * cpy + cpz * cpz)
        distance = min(min(da, db), dc)
    return distance


@kernel
def _pairs(points, tri, out):  # pragma: no cover - compiled
    for i in range(points.shape[0]):
        out[i] = _pair_distance(points[i, 0], points[i, 1], points[i, 2], tri[i])


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
