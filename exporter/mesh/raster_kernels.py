"""Conservative rasterisation of triangles: the checks around the compiled kernel
(``exporter/mesh/c/raster.c``: one triangle, one pixel row at a time; pixel (row r, column c)
is the unit square centred on (c, r), and a triangle covers every pixel its edges or interior
meet). Pixel coordinates, any view.
"""

from __future__ import annotations

import numpy as np

from ._raster import rasterise as _rasterise


def rasterise_views(xy: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """Conservative coverage of the triangles ``faces`` (m, 3) int64 in each view: ``xy`` (v, n, 2)
    pixel coordinates (column, row), one (n, 2) set per view; (v, size, size) bool."""
    xy = np.ascontiguousarray(xy, np.float64)
    if xy.ndim != 3 or xy.shape[2] != 2:
        raise ValueError(f"rasterise_views: xy must be (views, n, 2), not {xy.shape}")
    faces = np.ascontiguousarray(faces, np.int64).reshape(-1, 3)
    out = np.zeros((len(xy), size, size), dtype=bool)
    if len(faces) and size > 0:
        if faces.min() < 0 or faces.max() >= xy.shape[1]:
            raise ValueError("rasterise_views: a face index is out of range")
        _rasterise(xy, faces, size, out)
    return out
