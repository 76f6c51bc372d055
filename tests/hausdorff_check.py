"""An independent dense check of the symmetric Hausdorff distance (a sampled lower bound).

Data form: meshes ``(positions (k, 3) metres, faces (m, 3))``. Every triangle of each side is
sampled on a barycentric grid of ``steps`` intervals per edge (corners, edge points and inner
points; ``(steps + 1)(steps + 2)/2`` points per triangle whatever its size), and each point's exact
distance to the other side is taken (:class:`exporter.mesh.distance.SurfaceIndex`), so the result never
exceeds the true distance and approaches it as ``steps`` grows.
"""

from __future__ import annotations

import numpy as np

from exporter.mesh.distance import SurfaceIndex


def grid_points(positions: np.ndarray, faces: np.ndarray, steps: int) -> np.ndarray:
    """(m * (steps + 1)(steps + 2)/2, 3) metres: the barycentric grid of every triangle."""
    i, j = np.meshgrid(np.arange(steps + 1), np.arange(steps + 1), indexing="ij")
    keep = i + j <= steps
    u, v = i[keep] / steps, j[keep] / steps
    tri = positions[faces]
    a, b, c = tri[:, 0, None], tri[:, 1, None], tri[:, 2, None]
    return (a + u[:, None] * (b - a) + v[:, None] * (c - a)).reshape(-1, 3)


def directed_dense(a, b, steps: int) -> float:
    """max over ``a``'s grid points of the exact distance to ``b`` (metres; inf if b is empty)."""
    points = grid_points(*a, steps)
    if len(points) == 0:
        return 0.0
    if len(b[1]) == 0:
        return float("inf")
    return float(SurfaceIndex(*b).max_distance(points))


def dense_hausdorff(a, b, steps: int = 8) -> float:
    """Symmetric sampled Hausdorff distance (metres) between meshes ``a`` and ``b``."""
    return max(directed_dense(a, b, steps), directed_dense(b, a, steps))


def count_rounds(monkeypatch) -> list[int]:
    """Record every call of the certified bound's per-round step (``exporter.mesh.hausdorff._bound``)
    from now on: the returned list gets each call's number of triangles (one entry a round)."""
    from exporter.mesh import hausdorff

    calls: list[int] = []
    real = hausdorff._bound

    def counted(*args):
        calls.append(len(args[0]))
        return real(*args)

    monkeypatch.setattr(hausdorff, "_bound", counted)
    return calls
