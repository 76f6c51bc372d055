"""Small pure functions on triangle meshes in indexed form.

Data form: ``positions`` (n, 3) float metres in any one frame, ``triangles`` (m, 3) int indices
into it, wound so that ``(b - a) x (c - a)`` points outward (the model's convention). Results are
in the same frame as the input.
"""

from __future__ import annotations

import numpy as np

from ._area import cross_rows as _cross_rows
from ._weld import unique
from .edge_kernels import edge_key_order


def cross_rows(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise u x v of (m, 3) arrays (broadcast), (m, 3) float64: ``np.cross``'s arithmetic (same
    bits) without its per-call overhead (moveaxis, broadcasting checks), which dominates on the
    few hundred triangles of a building; compiled (``exporter/mesh/c/area.c``) for two (m, 3)
    float64 arrays."""
    if u.dtype == v.dtype == np.float64 and u.ndim == v.ndim == 2 and u.shape == v.shape:
        if u.shape[1] == 3:
            return _cross_rows(u, v)
    out = np.empty(np.broadcast_shapes(u.shape, v.shape))
    out[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    out[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    out[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return out


def row_norms(rows: np.ndarray) -> np.ndarray:
    """(n,) Euclidean norms of real (n, d) rows: ``np.linalg.norm(rows, axis=1)``'s own arithmetic
    (the square root of ``add.reduce`` of the squares) without its per-call dispatch."""
    return np.sqrt(np.add.reduce(rows * rows, axis=1))


def sorted_edge_keys(faces: np.ndarray, vertex_count: int) -> tuple[np.ndarray, np.ndarray]:
    """Every face side's undirected edge as one key ``low * vertex_count + high``, ascending
    (3m,) int64, and the stable permutation of the sides (side ``3 f + i`` runs from corner i of
    face f to the next) that sorts them: ``np.lexsort`` of the (low, high) pairs, with one key."""
    faces = np.ascontiguousarray(faces, np.int64).reshape(-1, 3)
    if len(faces) and (faces.min() < 0 or faces.max() >= vertex_count):
        raise ValueError("sorted_edge_keys: a face's vertex index is out of range")
    return edge_key_order(faces, int(vertex_count))  # compiled


def cross3(a, b) -> np.ndarray:
    """a x b of two 3-vectors (sequences or (3,) arrays), (3,) float64; ``np.cross`` costs ~20x
    more on single vectors."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def triangle_cross(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(m, 3) ``(b - a) x (c - a)`` per triangle: outward normal times twice the area (m²)."""
    positions = np.asarray(positions, dtype=np.float64)
    a, b, c = (positions[triangles[:, k]] for k in range(3))
    return cross_rows(b - a, c - a)


def longest_edges(tri: np.ndarray) -> np.ndarray:
    """(m,) metres: the longest edge of each triangle of a soup (m, 3, 3)."""
    return np.sqrt(((tri[:, [1, 2, 0]] - tri) ** 2).sum(-1)).max(axis=1)


def compact_vertices(faces: np.ndarray, vertex_count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(used (k',) int64, faces (m, 3) int64)``: the vertices ``faces`` (m, 3) use, ascending
    (``np.unique(faces)`` without its sort), and the faces renumbered onto them."""
    seen = np.zeros(vertex_count, dtype=bool)
    seen[faces.reshape(-1)] = True
    used = np.flatnonzero(seen)
    remap = np.full(vertex_count, -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return used, remap[faces]


def unique_float_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, axis=0, return_index=True, return_inverse=True)[1:]`` for (c, w) float64
    rows (w >= 1; other dtypes converted): ``first`` (k,) int64, the lowest index of each group of
    equal rows (every column ``==``, so -0.0 is 0.0 and a row holding a NaN is alone) in the rows'
    lexicographic order (``np.lexsort(keys.T[::-1])``, NaN last), and ``inverse`` (c,) int64, each
    row's group. A stable sort of row indices in ``exporter/mesh/c/weld.c``."""
    keys = np.ascontiguousarray(keys, dtype=np.float64)
    if keys.ndim != 2 or keys.shape[1] == 0:
        raise ValueError(f"unique_float_rows: keys must be (c, w >= 1) rows, not {keys.shape}")
    return unique(keys)


def isin_int(values: np.ndarray, of: np.ndarray) -> np.ndarray:
    """``np.isin(values, of)`` for integer arrays (1-D): (n,) bool, each value found in ``of``.
    One sort of ``of`` and a binary search per value (np.isin's general path costs ~5x this
    on the few hundred keys of a building)."""
    found = np.zeros(len(values), dtype=bool)
    if len(of) == 0 or len(values) == 0:
        return found
    ordered = np.sort(of)
    at = np.searchsorted(ordered, values)
    inside = at < len(ordered)
    found[inside] = ordered[at[inside]] == values[inside]
    return found


def unit_vectors(vectors: np.ndarray) -> np.ndarray:
    """(n, 3) float64 rows scaled to length 1; rows of zero (or non-finite) length become zero."""
    vectors = np.asarray(vectors, dtype=np.float64).reshape(-1, 3)
    length = np.linalg.norm(vectors, axis=1, keepdims=True)
    good = np.isfinite(length) & (length > 1e-12)
    return np.divide(vectors, length, out=np.zeros_like(vectors), where=good)


def vertex_normals(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(n, 3) area-weighted unit vertex normals (float64); zero for vertices with no area around
    them (callers that need a unit vector everywhere choose their own fallback)."""
    normals = np.zeros((len(positions), 3), dtype=np.float64)
    triangles = np.asarray(triangles).reshape(-1, 3)
    if len(triangles):
        face = triangle_cross(positions, triangles)  # length = 2 x area: area weighting for free
        # One bincount a coordinate over the corners in np.add.at's order (every first corner,
        # then every second, then every third): the same sums, bit for bit, in 0.6 of the time.
        corners = triangles.T.reshape(-1)
        for d in range(3):
            normals[:, d] = np.bincount(
                corners, weights=np.tile(face[:, d], 3), minlength=len(positions)
            )
    return unit_vectors(normals)
