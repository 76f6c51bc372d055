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

from ..mesh.geometry import cross_rows, row_norms, sorted_edge_keys
from ..mesh.weld import lowest_member

# Two faces sharing an edge are one planar region when their unit normals differ by less than
# this angle (cosine) and the second lies on the first's plane within PLANE_M metres.
COPLANAR_COS = float(np.cos(np.radians(1.0)))
PLANE_M = 1e-3


def face_areas(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area of every face, (m,) float64 square metres."""
    a, b, c = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
    return 0.5 * row_norms(cross_rows(b - a, c - a))


def largest_faces(areas: np.ndarray, share: float) -> np.ndarray:
    """(m,) bool: the ``round(share * m)`` largest faces by area (ties: lower index first)."""
    count = int(round(share * len(areas)))
    mask = np.zeros(len(areas), dtype=bool)
    mask[np.argsort(-areas, kind="stable")[:count]] = True
    return mask


def unique_rows(pairs: np.ndarray, **options):
    """``np.unique(pairs, axis=0, **options)`` for (e, 2) non-negative int64 rows, through one
    int64 key per row (the same rows in the same order, several times faster than ``axis=0``)."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    base = int(pairs.max()) + 1 if len(pairs) else 1
    result = np.unique(pairs[:, 0] * base + pairs[:, 1], **options)
    if not options:
        return np.column_stack(np.divmod(result, base))
    keys, *rest = result
    return (np.column_stack(np.divmod(keys, base)), *(r.reshape(-1) for r in rest))


# The last face array edge_use saw and its result: one level asks for the border, the
# non-manifold edges and the boundary of the same faces several times. The array is held, so its
# identity cannot pass to another; callers never modify face arrays in place.
_last_edge_use: tuple = (None, None)


def edge_use(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges (e, 2) int64 (sorted pairs) and how many faces use each (e,)."""
    global _last_edge_use
    seen, result = _last_edge_use
    if seen is faces:
        return result
    if len(faces) == 0:
        unique, counts = np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    else:
        # One int64 key per side (low * base + high) sorted once; groups of equal keys are the
        # edges (the rows and counts of np.unique(axis=0) on the sorted pairs).
        corners = np.asarray(faces, dtype=np.int64)
        ahead = corners[:, [1, 2, 0]]
        low, high = np.minimum(corners, ahead).reshape(-1), np.maximum(corners, ahead).reshape(-1)
        base = int(high.max()) + 1
        keys = np.sort(low * base + high)
        start = np.flatnonzero(np.concatenate([[True], keys[1:] != keys[:-1]]))
        counts = np.concatenate([start[1:], [len(keys)]]) - start
        unique = np.empty((len(start), 2), np.int64)
        unique[:, 0], unique[:, 1] = np.divmod(keys[start], base)
    unique.flags.writeable = counts.flags.writeable = False
    _last_edge_use = (faces, (unique, counts))
    return unique, counts


def border_vertices(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """(k,) bool: vertices on an edge used by exactly one face (the open boundary)."""
    edges, counts = edge_use(faces)
    mask = np.zeros(vertex_count, dtype=bool)
    mask[edges[counts == 1].reshape(-1)] = True
    return mask


def nonmanifold_vertices(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """(k,) bool: vertices on an edge used by more than two faces (locked so collapses stay sane)."""
    edges, counts = edge_use(faces)
    mask = np.zeros(vertex_count, dtype=bool)
    mask[edges[counts > 2].reshape(-1)] = True
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


def planar_regions(
    positions: np.ndarray,
    faces: np.ndarray,
    groups: np.ndarray | None = None,
    edge_keys: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """(m,) int64 region of every face: edge-connected faces on one plane (the polygons of the
    building's polygonal model, whatever their triangulation); with ``groups`` (m,) int64 only
    faces of one group (e.g. one UV chart) join. ``edge_keys``: :func:`sorted_edge_keys` of
    ``faces`` and ``len(positions)`` when the caller has them."""
    m = len(faces)
    if m == 0:
        return np.zeros(0, np.int64)
    a, b, c = (positions[faces[:, i]] for i in range(3))
    normal = cross_rows(b - a, c - a)
    normal /= np.maximum(row_norms(normal)[:, None], 1e-30)
    keys, order = edge_keys if edge_keys is not None else sorted_edge_keys(faces, len(positions))
    owner = order // 3
    same = keys[1:] == keys[:-1]
    f, g = owner[:-1][same], owner[1:][same]
    if groups is not None:
        keep = groups[f] == groups[g]
        f, g = f[keep], g[keep]
    # Every face's centroid with the arithmetic of positions[faces].mean(axis=1) (its sum starts
    # at 0.0), for all faces at once.
    centroid = (0.0 + a + b + c) / 3
    coplanar = ((normal[f] * normal[g]).sum(1) > COPLANAR_COS) & (
        np.abs(((centroid[g] - a[f]) * normal[f]).sum(1)) < PLANE_M
    )
    # Components numbered by their lowest face, as scipy's connected_components numbers them.
    lowest = lowest_member(m, f[coplanar], g[coplanar])
    root = lowest == np.arange(m)
    return (np.cumsum(root) - 1)[lowest]
