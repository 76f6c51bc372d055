"""The former numpy forms of ``SurfaceIndex._upper`` and ``hausdorff._pair_bound`` (now
``exporter/mesh/c/surface.c``): the references tests/test_surface_kernels.py compares the C with,
float for float (the nearest face's, single-face and chain bounds' references are
tests/test_perf_hausdorff.py's). Metres, any one Cartesian frame."""

from __future__ import annotations

import numpy as np

from exporter.mesh.distance import SurfaceIndex
from exporter.mesh.distance_kernels import point_triangle_distance
from exporter.mesh.hausdorff import Surface, _dot3


def reference_upper(
    index: SurfaceIndex, points: np.ndarray, probe_distance: np.ndarray, nearest: np.ndarray
) -> np.ndarray:
    """``SurfaceIndex._upper``: (p,) metres, 0 on a probe, else the least distance to the
    triangles owning the nearest probes (p, k)."""
    upper = np.zeros(len(points))
    off = np.flatnonzero(probe_distance[:, 0] > 0)
    if len(off) == 0:
        return upper
    owners = np.sort(index.owner[nearest[off]], axis=1)
    fresh = np.ones(owners.shape, dtype=bool)
    fresh[:, 1:] = owners[:, 1:] != owners[:, :-1]
    rows = np.repeat(np.arange(len(off)), fresh.sum(axis=1))
    distance = point_triangle_distance(points[off[rows]], index.tri[owners[fresh]])
    starts = np.concatenate([[0], np.cumsum(fresh.sum(axis=1))[:-1]])
    upper[off] = np.minimum.reduceat(distance, starts)
    return upper


def max3(x: np.ndarray) -> np.ndarray:
    """``x.max(-1)`` of (..., 3) arrays, NaN winning (hausdorff's former ``_max3``)."""
    return np.maximum(np.maximum(x[..., 0], x[..., 1]), x[..., 2])


def reference_pair_bound(
    tri: np.ndarray, target: Surface, nearest: np.ndarray, other: np.ndarray
) -> np.ndarray:
    """``hausdorff._pair_bound`` once each corner's nearest face ``other`` (n, 3) is known: (n,)
    metres, the least two-cell bound over the pairs (nearest, other) of distinct trusted faces."""
    n = len(tri)
    trusted = target.trusted
    ok = (other != nearest[:, None]) & trusted[other] & trusted[nearest][:, None]
    # One pair per distinct other face of a row.
    ok[:, 1] &= other[:, 1] != other[:, 0]
    ok[:, 2] &= (other[:, 2] != other[:, 0]) & (other[:, 2] != other[:, 1])
    row, col = np.nonzero(ok)
    fi, fj = nearest[row], other[row, col]
    bound = np.full(n, np.inf)
    if len(row) == 0:
        return bound
    normal, offset, _ = target.face_planes
    t = tri[row]  # (q, 3, 3)
    s = (_dot3(t, normal[fi][:, None]) - offset[fi][:, None]) - (
        _dot3(t, normal[fj][:, None]) - offset[fj][:, None]
    )  # (q, 3) at the corners: where the two planes are equally far (signed)
    after = [1, 2, 0]
    s_next = s[:, after]
    crosses = s * s_next < 0  # edge k -> k + 1 crosses the cut
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(crosses, s / (s - s_next), 0.0)
    cut = t + share[..., None] * (t[:, after] - t)  # (q, 3, 3) crossing points
    tri_i, tri_j = target.tri[fi][:, None], target.tri[fj][:, None]
    corner_i = point_triangle_distance(t, tri_i)
    corner_j = point_triangle_distance(t, tri_j)
    on_cut = max3(
        np.where(
            crosses,
            np.maximum(
                point_triangle_distance(cut, tri_i),
                point_triangle_distance(cut, tri_j),
            ),
            0.0,
        )
    )
    below, above = s <= 0, s >= 0
    # Either face may take either cell (the nearer face lies on the larger signed distance at
    # a convex edge, on the smaller at a concave one): both assignments are bounds.
    value = np.minimum(
        np.maximum(max3(np.where(below, corner_i, 0.0)), max3(np.where(above, corner_j, 0.0))),
        np.maximum(max3(np.where(above, corner_i, 0.0)), max3(np.where(below, corner_j, 0.0))),
    )
    value = np.maximum(value, on_cut)
    value += 1e-12 * np.abs(t).reshape(len(t), -1).max(axis=1)
    np.minimum.at(bound, row, value)
    return bound
