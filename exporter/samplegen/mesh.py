"""Mesh primitives for the sample-building generator: wall grids, roof caps, fans, rings.

Data form: every position is in the building's **local East/Up/North frame, metres**
(x = East, y = Up, z = North); a 2-D footprint point is ``(x, z)`` in the same frame (metres), and
a footprint ring is an ``(k, 2)`` array listed counter-clockwise in ``(x, z)`` (positive shoelace
area), not closed (the last point is not repeated). UVs are glTF's (origin top-left, v down), in
``[0, 1]``; a UV rectangle is ``(u0, v0, u1, v1)`` with ``v0`` the top.

Each primitive is a pure function returning ``(positions (n, 3) float64, uvs (n, 2) float64,
triangles (m, 3) int64)``. Triangles are put outward by :func:`orient`: a triangle whose
numerical ``(b - a) x (c - a)`` points against the primitive's outward direction is reversed
(the model's winding, see ``exporter/model.py``). Vertices are never shared between primitives,
so every roof/wall junction is a UV seam, as in VWorld's textured models.
"""

from __future__ import annotations

from functools import lru_cache

import mapbox_earcut
import numpy as np

from ..mesh.geometry import cross_rows

UP = np.array([0.0, 1.0, 0.0])


@lru_cache(maxsize=1024)
def steps(n: int) -> np.ndarray:
    """``n + 1`` evenly spaced fractions 0..1 (read-only, cached: called for every grid line)."""
    out = np.arange(n + 1) / max(n, 1)
    out.flags.writeable = False
    return out


def triangle_normals(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Unnormalised ``(b - a) x (c - a)`` per triangle, shape (m, 3), metres squared."""
    a, b, c = (positions[triangles[:, i]] for i in range(3))
    return cross_rows(b - a, c - a)


def orient(positions: np.ndarray, triangles: np.ndarray, outward: np.ndarray) -> np.ndarray:
    """Reverse triangles whose normal points against ``outward`` ((3,) or (m, 3)); returns (m, 3)."""
    facing = np.einsum(
        "ij,ij->i",
        triangle_normals(positions, triangles),
        np.broadcast_to(outward, (len(triangles), 3)),
    )
    if np.all(facing >= 0):
        return triangles
    return np.where((facing < 0)[:, None], triangles[:, ::-1], triangles)


@lru_cache(maxsize=4096)
def grid_triangles(rows: int, cols: int) -> np.ndarray:
    """Two triangles per cell of a ``(rows + 1) x (cols + 1)`` vertex grid stored row-major; (2*rows*cols, 3), read-only."""
    a = (np.arange(rows)[:, None] * (cols + 1) + np.arange(cols)[None, :]).ravel()
    b, d = a + 1, a + cols + 1
    triangles = np.concatenate([np.stack([a, b, d + 1], 1), np.stack([a, d + 1, d], 1)]).astype(
        np.int64
    )
    triangles.flags.writeable = False
    return triangles


def patch(points: np.ndarray, uv_rect: tuple, outward) -> tuple:
    """A grid patch through ``points`` (R, C, 3) metres; row 0 maps to the bottom of ``uv_rect``.

    ``outward`` is a (3,) direction or a callable ``f(centroids (m, 3)) -> (m, 3)``.
    """
    rows, cols = points.shape[0] - 1, points.shape[1] - 1
    u0, v0, u1, v1 = uv_rect
    uvs = np.empty((rows + 1, cols + 1, 2))
    uvs[:, :, 0] = u0 + steps(cols)[None, :] * (u1 - u0)
    uvs[:, :, 1] = v1 - steps(rows)[:, None] * (v1 - v0)
    uvs = uvs.reshape(-1, 2)
    positions = points.reshape(-1, 3)
    triangles = grid_triangles(rows, cols)
    if callable(outward):
        outward = outward(positions[triangles].mean(axis=1))
    return positions, uvs, orient(positions, triangles, outward)


def fan(apex, base: np.ndarray, uv_rect: tuple, outward) -> tuple:
    """Triangles from ``apex`` (3,) to each segment of the polyline ``base`` (k, 3): gable ends, hip ends, spire tips."""
    base = np.asarray(base, float)
    k = len(base)
    positions = np.vstack([base, np.asarray(apex, float)[None]])
    u0, v0, u1, v1 = uv_rect
    s = steps(k - 1)
    uvs = np.vstack([np.stack([u0 + s * (u1 - u0), np.full(k, v1)], 1), [[(u0 + u1) / 2, v0]]])
    i = np.arange(k - 1)
    triangles = np.stack([i, i + 1, np.full(k - 1, k)], 1).astype(np.int64)
    if callable(outward):
        outward = outward(positions[triangles].mean(axis=1))
    return positions, uvs, orient(positions, triangles, outward)


def cap(ring: np.ndarray, y: float, uv_rect: tuple, up: bool = True) -> tuple:
    """A flat horizontal polygon at height ``y`` (metres) over ``ring`` (k, 2), triangulated with earcut.

    UVs project ``(x, z)`` onto ``uv_rect`` over the ring's bounding box (north at the top).
    """
    ring = np.asarray(ring, float)
    triangles = np.asarray(
        mapbox_earcut.triangulate_float64(ring, np.array([len(ring)], dtype=np.uint32)), np.int64
    ).reshape(-1, 3)
    positions = np.column_stack([ring[:, 0], np.full(len(ring), y), ring[:, 1]])
    low, high = ring.min(0), ring.max(0)
    st = (ring - low) / np.maximum(high - low, 1e-9)
    u0, v0, u1, v1 = uv_rect
    uvs = np.stack([u0 + st[:, 0] * (u1 - u0), v1 - st[:, 1] * (v1 - v0)], 1)
    return positions, uvs, orient(positions, triangles, UP if up else -UP)


def edge_normals(ring: np.ndarray) -> np.ndarray:
    """Outward unit normals (k, 2) in ``(x, z)`` of the edges ``ring[i] -> ring[i+1]`` of a CCW ring."""
    edges = np.roll(ring, -1, axis=0) - ring
    normals = np.stack([edges[:, 1], -edges[:, 0]], 1)
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def inset(ring: np.ndarray, distance: float) -> np.ndarray:
    """The CCW ring moved ``distance`` metres inward, mitred at corners (k, 2); points on straight runs move straight in."""
    outward = edge_normals(ring)
    before, after = np.roll(outward, 1, axis=0), outward
    mitre = (before + after) / (1.0 + np.einsum("ij,ij->i", before, after))[:, None]
    return ring - distance * mitre


def subdivide(ring: np.ndarray, cuts: list[int]) -> np.ndarray:
    """The ring with edge ``i`` cut into ``cuts[i]`` equal pieces (k', 2); corners kept."""
    nxt = np.roll(ring, -1, axis=0)
    pieces = [ring[i] + np.outer(np.arange(n) / n, nxt[i] - ring[i]) for i, n in enumerate(cuts)]
    return np.vstack(pieces)


def ring_points(ring: np.ndarray, heights: np.ndarray) -> np.ndarray:
    """(len(heights), k, 3) points of the 2-D ring lifted to each height (metres)."""
    k = len(ring)
    out = np.empty((len(heights), k, 3))
    out[:, :, 0] = ring[:, 0]
    out[:, :, 1] = np.asarray(heights, float)[:, None]
    out[:, :, 2] = ring[:, 1]
    return out


def shares(total: int, weights: np.ndarray, minimum: int = 1) -> list[int]:
    """Split ``total`` into integers proportional to ``weights`` (largest remainder), each >= ``minimum``."""
    weights = np.asarray(weights, float)
    total = max(int(total), minimum * len(weights))
    raw = weights / weights.sum() * (total - minimum * len(weights))
    base = np.floor(raw).astype(int)
    order = np.argsort(-(raw - base), kind="stable")
    base[order[: total - minimum * len(weights) - base.sum()]] += 1
    return [int(n) + minimum for n in base]


class MeshBuilder:
    """Collects primitives per ``group`` ("wall", "roof", "detail") into one triangle list."""

    def __init__(self) -> None:
        self.positions: list[np.ndarray] = []
        self.uvs: list[np.ndarray] = []
        self.triangles: list[np.ndarray] = []
        self.groups: list[str] = []

    def add(self, primitive: tuple, group: str) -> None:
        positions, uvs, triangles = primitive
        self.positions.append(positions)
        self.uvs.append(uvs)
        self.triangles.append(triangles)
        self.groups.append(group)

    @property
    def triangle_count(self) -> int:
        return int(sum(len(t) for t in self.triangles))

    def arrays(self, groups=None) -> tuple:
        """``(positions (n, 3), uvs (n, 2), triangles (m, 3))`` of the primitives in ``groups`` (all when None)."""
        keep = [i for i, g in enumerate(self.groups) if groups is None or g in groups]
        sizes = [len(self.positions[i]) for i in keep]
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        return (
            np.vstack([self.positions[i] for i in keep]),
            np.vstack([self.uvs[i] for i in keep]),
            np.vstack([self.triangles[i] + o for i, o in zip(keep, offsets)]),
        )
