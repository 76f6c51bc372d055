"""Conservative rasterisation of triangles, and the silhouettes it gives.

Data form: ``positions`` (n, 3) float64 metres in the building-local East/Up/North frame (y = Up),
``faces`` (m, 3) int64; rasters are bool arrays, pixel (row, col) covering
[row - 0.5, row + 0.5] x [col - 0.5, col + 0.5] of the pixel coordinates. Used by the quality
metrics (``silhouette_iou``) and the simplifier's silhouette floor, which must agree pixel for
pixel.
"""

from __future__ import annotations

import numpy as np

from ._raster import overlaps
from .raster_kernels import rasterise_views

RESOLUTION = 128  # silhouette raster side, pixels


def rasterise(xy: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """Conservative raster of 2-D triangles: (size, size) bool, pixel (row, col) covers
    [row - 0.5, row + 0.5] x [col - 0.5, col + 0.5] of ``xy`` (n, 2) pixel coordinates (x = col).

    Every pixel a triangle touches is set, so edge-on faces still draw a line. A row's span of a
    triangle is the x-extent of its edges clipped to the row's strip (the x at both clipped ends
    of each edge). See :func:`rasterise_views` (this is its one-view case).
    """
    return rasterise_views(xy[None], faces, size)[0]


VIEWS = ((0, 2), (0, 1), (2, 1))  # top (x, z), front (x, y), side (z, y): (column, row) axes


def silhouettes(
    positions: np.ndarray, faces: np.ndarray, low: np.ndarray, high: np.ndarray
) -> np.ndarray:
    """Top (x, z), front (x, y) and side (z, y) silhouettes, (3, RESOLUTION, RESOLUTION) bool,
    on the box [low, high] (metres, local East/Up/North)."""
    span = np.maximum(high - low, 1e-9)
    pixels = (positions - low) / span * (RESOLUTION - 1)
    return rasterise_views(pixels[:, VIEWS].transpose(1, 0, 2), faces, RESOLUTION)


def min_iou(source: np.ndarray, level: np.ndarray) -> float:
    """The smallest intersection over union of two stacks of views (v, n, n) bool (1 for two
    empty views)."""
    counts = overlaps(source, level)  # compiled: (v, 2) intersection and union pixels
    return min(float(o / u) if u else 1.0 for o, u in counts.tolist())
