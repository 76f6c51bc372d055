"""Planar regions of a triangle mesh, compiled: faces joined across every shared edge where their
unit normals agree (cosine above ``cos_limit``) and the second face's centroid lies on the first's
plane (within ``plane_m`` metres), then numbered by their lowest face (union-find with path
halving, the larger root linked under the smaller). The floats are those of the numpy form
(``tests/test_planar_region_kernels.py`` keeps it as the reference and checks labels equal)."""

from __future__ import annotations

import numpy as np

from .component_kernels import root
from .jit import kernel


@kernel
def region_labels(
    positions, faces, groups, use_groups, keys, order, cos_limit, plane_m
):  # pragma: no cover - compiled
    """(m,) int64 region of every face of ``faces`` (m, 3) int64 into ``positions`` (k, 3) float64
    metres; ``keys`` / ``order``: the faces' sorted edge keys and their side permutation
    (:func:`~exporter.mesh.geometry.sorted_edge_keys`); with ``use_groups`` only faces of one
    ``groups`` (m,) int64 value join."""
    m = faces.shape[0]
    normal = np.empty((m, 3))
    centroid = np.empty((m, 3))
    for f in range(m):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        ux = positions[b, 0] - positions[a, 0]
        uy = positions[b, 1] - positions[a, 1]
        uz = positions[b, 2] - positions[a, 2]
        vx = positions[c, 0] - positions[a, 0]
        vy = positions[c, 1] - positions[a, 1]
        vz = positions[c, 2] - positions[a, 2]
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        length = max(np.sqrt(nx * nx + ny * ny + nz * nz), 1e-30)
        normal[f, 0], normal[f, 1], normal[f, 2] = nx / length, ny / length, nz / length
        for i in range(3):
            centroid[f, i] = (0.0 + positions[a, i] + positions[b, i] + positions[c, i]) / 3
    parent = np.arange(m)
    for s in range(keys.shape[0] - 1):
        if keys[s] != keys[s + 1]:
            continue
        f, g = order[s] // 3, order[s + 1] // 3
        if use_groups and groups[f] != groups[g]:
            continue
        cos = (
            normal[f, 0] * normal[g, 0] + normal[f, 1] * normal[g, 1] + normal[f, 2] * normal[g, 2]
        )
        a = faces[f, 0]
        height = (
            (centroid[g, 0] - positions[a, 0]) * normal[f, 0]
            + (centroid[g, 1] - positions[a, 1]) * normal[f, 1]
            + (centroid[g, 2] - positions[a, 2]) * normal[f, 2]
        )
        if not (cos > cos_limit and abs(height) < plane_m):
            continue
        rf, rg = root(parent, f), root(parent, g)
        if rf < rg:
            parent[rg] = rf
        elif rg < rf:
            parent[rf] = rg
    labels = np.empty(m, np.int64)
    count = 0
    for f in range(m):  # parents are lower than their children: one pass in order settles all
        parent[f] = parent[parent[f]]
        if parent[f] == f:
            labels[f] = count
            count += 1
        else:
            labels[f] = labels[parent[f]]
    return labels
