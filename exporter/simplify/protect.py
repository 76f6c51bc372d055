"""Which faces and vertices the simplifier must not touch (the paper's geometric filter and locks).

Data form: a welded triangle mesh, ``faces`` (m, 3) int64 into ``positions`` (k, 3) float64
metres (building-local East/Up/North, y = Up), ``face_part`` (m,) int64 the part of every face,
``corner_uvs`` (m, 3, 2) float32 (glTF UV convention) or None. Every function returns a boolean
mask over faces (m,) or over vertices (k,).

Sources: the paper's geometric filter (sort faces by area, exclude the largest 30 % from
simplification); Table II's border / UV-seam options as defined by Whinarn's UnityMeshSimplifier
(border edge = used by one triangle, seam = one position with two UVs).
"""

from __future__ import annotations

import numpy as np

from ..mesh._area import face_areas as _face_areas
from ..mesh.geometry import cross_rows, row_norms


def face_areas(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area of every face, (m,) float64 square metres: ``0.5 |(b - a) x (c - a)|`` with
    :func:`~exporter.mesh.geometry.cross_rows` and :func:`~exporter.mesh.geometry.row_norms`'
    arithmetic, compiled (``exporter/mesh/c/area.c``) for float64 positions."""
    if positions.dtype != np.float64:  # numpy's arithmetic in the positions' own precision
        a, b, c = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
        return 0.5 * row_norms(cross_rows(b - a, c - a))
    return _face_areas(positions, np.ascontiguousarray(faces, np.int64).reshape(-1, 3))


def largest_faces(areas: np.ndarray, share: float) -> np.ndarray:
    """(m,) bool: the ``round(share * m)`` largest faces by area (ties: lower index first)."""
    count = int(round(share * len(areas)))
    mask = np.zeros(len(areas), dtype=bool)
    mask[np.argsort(-areas, kind="stable")[:count]] = True
    return mask


def part_border_vertices(faces: np.ndarray, face_part: np.ndarray, vertex_count: int) -> np.ndarray:
    """(k,) bool: vertices used by faces of two or more parts; locking them means no cracks."""
    if len(face_part) == 0 or face_part.min() == face_part.max():
        return np.zeros(vertex_count, dtype=bool)  # one part (most buildings): no part border
    corner_part = np.repeat(face_part, 3)
    low = np.full(vertex_count, np.iinfo(np.int64).max)
    high = np.full(vertex_count, np.iinfo(np.int64).min)
    np.minimum.at(low, faces.reshape(-1), corner_part)
    np.maximum.at(high, faces.reshape(-1), corner_part)
    return (high > low) & (high >= 0)


def footprint_wall_faces(
    positions: np.ndarray, faces: np.ndarray, border: np.ndarray, max_normal_up: float = 0.2
) -> np.ndarray:
    """(m,) bool: near-vertical faces (|unit normal . Up| <= ``max_normal_up``) that stand on the
    open bottom border: a border vertex at the building's lowest level (within 1 % of its height).

    These are the walls on the footprint outline of a floorless building; keeping them keeps the
    outline and the side silhouettes.
    """
    a, b, c = (positions[faces[:, i]] for i in range(3))
    normal = cross_rows(b - a, c - a)
    length = np.linalg.norm(normal, axis=1)
    up = np.abs(normal[:, 1]) / np.maximum(length, 1e-30)
    y = positions[:, 1]
    low = y <= y.min() + 0.01 * max(float(np.ptp(y)), 1e-9)
    on_ground = (border & low)[faces].any(axis=1)
    return (up <= max_normal_up) & on_ground & (length > 0)
