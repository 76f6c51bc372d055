"""Topology of indexed triangle meshes: edges and how many faces use them, borders,
non-manifold vertices, planar regions and open-boundary loops.

Data form: a welded triangle mesh, ``faces`` (m, 3) int64 into ``positions`` (k, 3) float64
metres (any one frame); results are boolean masks over vertices (k,), per-face labels (m,) or
edge lists (e, 2) int64 of sorted vertex pairs.
"""

from __future__ import annotations

import numpy as np

from .boundary_kernels import border_loops
from .edge_kernels import edge_counts
from .geometry import sorted_edge_keys
from .planar_region_kernels import region_labels

# Two faces sharing an edge are one planar region when their unit normals differ by less than
# this angle (cosine) and the second lies on the first's plane within PLANE_M metres.
COPLANAR_COS = float(np.cos(np.radians(1.0)))
PLANE_M = 1e-3


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
    corners = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(corners) and corners.min() < 0:
        raise ValueError("edge_use: a face's vertex index is negative")
    # Compiled: sides sorted by (low, high) vertex, equal neighbours counted.
    unique, counts = edge_counts(corners, int(corners.max()) + 1 if len(corners) else 1)
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
    faces = np.ascontiguousarray(faces, np.int64)
    if faces.min() < 0 or faces.max() >= len(positions):
        raise ValueError("planar_regions: a face's vertex index is out of range")
    if groups is not None and len(groups) != m:
        raise ValueError("planar_regions: groups and faces differ in length")
    keys, order = edge_keys if edge_keys is not None else sorted_edge_keys(faces, len(positions))
    use_groups = groups is not None
    return region_labels(
        np.ascontiguousarray(positions, np.float64),
        faces,
        np.ascontiguousarray(groups if use_groups else np.zeros(0), np.int64),
        use_groups,
        np.ascontiguousarray(keys, np.int64),
        np.ascontiguousarray(order, np.int64),
        COPLANAR_COS,
        PLANE_M,
    )


def boundary_loops(faces: np.ndarray, vertex_count: int) -> tuple[np.ndarray, int]:
    """Open-boundary edges (e, 2) int64 (used by one face, (low, high) vertex, sorted) and the
    number of loops they form (connected components of those edges), compiled."""
    faces = np.ascontiguousarray(faces, np.int64).reshape(-1, 3)
    if len(faces) and (faces.min() < 0 or faces.max() > vertex_count):
        raise ValueError("boundary_loops: a face's vertex index is out of range")
    border, loops = border_loops(faces, int(vertex_count))
    return border, int(loops)
