"""The in-plane bound of the certified Hausdorff distance (step 2 of
:mod:`exporter.mesh.hausdorff`, which holds the argument): the checks and shapes around the
compiled kernel (``exporter/mesh/c/planar_bound.c``, which holds the arithmetic: each
(triangle, region) pair whose centroid projects into a candidate face, the triangle shrunk about
its incentre and tested against the region's boundary segments by separating axes; the same bits
as the former numpy form, tests/test_perf_hausdorff.py). In-plane metres.
"""

from __future__ import annotations

import numpy as np

from ._planar_bound import bound as _bound


def _check_regions(regions, m: int) -> None:
    """Raise ValueError unless ``regions`` (a ``hausdorff._Regions`` of m faces) is consistent:
    the kernel follows its indices (it checks them again, with a less telling message)."""
    r = len(regions.normal)
    start = np.asarray(regions.seg_start)
    fields = (regions.slack, regions.offset, regions.gap, regions.u, regions.v)
    if (
        len(regions.tri2) != m
        or (m and (regions.region.min() < 0 or regions.region.max() >= r))
        or any(len(x) != r for x in fields)
        or len(start) != r + 1
        or (r and (start[0] < 0 or np.any(np.diff(start) < 0)))
        or start[-1]
        > min(map(len, (regions.seg_x0, regions.seg_y0, regions.seg_x1, regions.seg_y1)))
    ):
        raise ValueError(
            "planar_bound: the planar regions are inconsistent (an index out of range)"
        )


_FIELDS = ("region", "seg_start", "slack", "offset", "gap", "u", "v", "normal", "tri2")
_SEGMENTS = ("seg_x0", "seg_y0", "seg_x1", "seg_y1")


def _packed(regions, m: int) -> tuple[np.ndarray, np.ndarray]:
    """``regions`` checked (:func:`_check_regions`) and packed as the kernel reads them: the
    planes (12, r) (slack, offset, gap, u, v, normal) and the segments (4, s), both float64.
    Kept on ``regions`` with the arrays they were made of, and remade when any field is another
    array (the hot loop calls this for every batch of triangles against one prepared target; a
    field changed in place is caught by the kernel's own index checks)."""
    fields = tuple(getattr(regions, name) for name in _FIELDS + _SEGMENTS)
    cached = getattr(regions, "_planar_bound_packed", None)
    if cached is not None and cached[0] == m and all(a is b for a, b in zip(cached[1], fields)):
        return cached[2], cached[3]
    _check_regions(regions, m)
    planes = np.ascontiguousarray(
        np.vstack(
            [
                regions.slack[None],
                regions.offset[None],
                regions.gap[None],
                regions.u.T,
                regions.v.T,
                regions.normal.T,
            ]
        ),
        np.float64,
    )
    seg = np.ascontiguousarray(
        np.vstack([regions.seg_x0, regions.seg_y0, regions.seg_x1, regions.seg_y1]), np.float64
    )
    regions._planar_bound_packed = (m, fields, planes, seg)
    return planes, seg


def planar_bound(tri, row, face, regions, cap, constants) -> np.ndarray:
    """(n,) metres: the in-plane bound of each triangle ``tri`` (n, 3, 3) metres over the
    planar regions of its candidate faces (``row``, ``face`` (p,) int64 pairs), inf where none
    holds; ``regions`` a prepared ``hausdorff._Regions`` of the target, ``cap`` (n,) metres or
    None, ``constants`` = (shrink, largest region slack, loose shares (3,))."""
    shrink, plane_slack_max, loose = constants
    if cap is not None and len(cap) != len(tri):
        raise ValueError("planar_bound: one cap per triangle")
    n = len(tri)
    bound = np.full(n, np.inf)
    row = np.ascontiguousarray(row, np.int64)
    face = np.ascontiguousarray(face, np.int64)
    m = len(regions.region)
    if len(row) == 0:
        return bound
    if row.min() < 0 or row.max() >= n or face.min() < 0 or face.max() >= m:
        raise ValueError("planar_bound: a triangle or face index is out of range")
    if len(row) != len(face) or np.shape(tri)[1:] != (3, 3):
        raise ValueError("planar_bound: pairs or triangles of the wrong shape")
    planes, seg = _packed(regions, m)
    _bound(
        np.ascontiguousarray(tri, np.float64),
        row,
        face,
        np.ascontiguousarray(regions.region, np.int64),
        planes,
        np.ascontiguousarray(regions.tri2, np.float64),
        np.ascontiguousarray(regions.seg_start, np.int64),
        seg,
        None if cap is None else np.ascontiguousarray(cap, np.float64),
        np.asarray(loose, np.float64),
        float(regions.scale),
        float(shrink),
        float(plane_slack_max),
        bound,
    )
    return bound
