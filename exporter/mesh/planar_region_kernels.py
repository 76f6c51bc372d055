"""Planar regions of a triangle mesh: the compiled kernel ``exporter/mesh/c/planar_region.c``
(faces joined across every shared edge where their unit normals agree and the second face's
centroid lies on the first's plane, numbered by their lowest face; the floats of the numpy form:
``tests/test_planar_region_kernels.py`` keeps it as the reference and checks labels equal)."""

from __future__ import annotations

import numpy as np

from ._planar_region import labels as _labels


def region_labels(
    positions: np.ndarray,
    faces: np.ndarray,
    groups: np.ndarray,
    use_groups: bool,
    keys: np.ndarray,
    order: np.ndarray,
    cos_limit: float,
    plane_m: float,
) -> np.ndarray:
    """(m,) int64 region of every face of ``faces`` (m, 3) int64 into ``positions`` (k, 3) float64
    metres; ``keys`` / ``order``: the faces' sorted edge keys and their side permutation
    (:func:`~exporter.mesh.geometry.sorted_edge_keys`); with ``use_groups`` only faces of one
    ``groups`` (m,) int64 value join. Two faces join when their unit normals' cosine is above
    ``cos_limit`` and the second's centroid is within ``plane_m`` metres of the first's plane."""
    return _labels(positions, faces, groups, use_groups, keys, order, cos_limit, plane_m)
