"""Conservative rasterisation of triangles, and the silhouettes it gives.

Data form: ``positions`` (n, 3) float64 metres in the building-local East/Up/North frame (y = Up),
``faces`` (m, 3) int64; rasters are bool arrays, pixel (row, col) covering
[row - 0.5, row + 0.5] x [col - 0.5, col + 0.5] of the pixel coordinates. Used by the quality
metrics (``silhouette_iou``) and the simplifier's silhouette floor, which must agree pixel for
pixel.
"""

from __future__ import annotations

import numpy as np

RESOLUTION = 128  # silhouette raster side, pixels


def rasterise(xy: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """Conservative raster of 2-D triangles: (size, size) bool, pixel (row, col) covers
    [row - 0.5, row + 0.5] x [col - 0.5, col + 0.5] of ``xy`` (n, 2) pixel coordinates (x = col).

    Every pixel a triangle touches is set, so edge-on faces still draw a line. A row's span of a
    triangle is the x-extent of its edges clipped to the row's strip (the x at both clipped ends
    of each edge). See :func:`rasterise_views` (this is its one-view case).
    """
    return rasterise_views(xy[None], faces, size)[0]


def rasterise_views(xy: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """:func:`rasterise` of the same triangles in several views at once: ``xy`` (v, n, 2) pixel
    coordinates, one (n, 2) set per view; (v, size, size) bool.

    Vectorised over (view, edge, triangle, strip line): every edge is evaluated once at each
    line ``k - 0.5`` of its triangle's rows, clipped to the edge's y-range, and row k reads its
    two lines as neighbours in one flat array (no gathers per row; rows straddling two triangles
    are dropped). One pass for all views and edges: a few dozen numpy calls on (3, lines) arrays
    rather than many per view (on building-sized meshes the calls, not the arithmetic, cost).
    The arithmetic is that of the plain (triangle, row) form (an edge's x at a line is
    ``px + (clip(y, py, qy) - py) * slope``, a flat edge gives its two end x; the minimum and
    maximum over the edges meeting the strip), so the pixels are the same bit for bit
    (tests/test_perf_quality.py holds that form as the reference).
    """
    views = len(xy)
    if len(faces) == 0:
        return np.zeros((views, size, size), dtype=bool)
    top = size - 1
    x = xy[:, faces.T, 0]  # (v, 3, m): corner k of every triangle; edge k runs to corner k + 1
    y = xy[:, faces.T, 1]
    r0 = np.minimum(np.maximum(np.ceil(y.min(axis=1) - 0.5), 0), top).astype(np.int64).ravel()
    r1 = np.minimum(np.maximum(np.floor(y.max(axis=1) + 0.5), 0), top).astype(np.int64).ravel()
    lines = r1 - r0 + 2  # rows r0..r1 have lines r0..r1 + 1 (view-major, then triangle)
    ends = np.cumsum(lines)
    starts = ends - lines
    total = int(ends[-1])
    line = np.repeat(r0 - starts, lines) + np.arange(total)
    y_line = line - 0.5  # exact: the strips' bottoms and tops
    next_x, next_y = x[:, [1, 2, 0]], y[:, [1, 2, 0]]
    down = y > next_y
    px, qx = np.where(down, next_x, x), np.where(down, x, next_x)
    py, qy = np.where(down, next_y, y), np.where(down, y, next_y)
    dy = qy - py
    slope = np.divide(qx - px, dy, out=np.zeros_like(dy), where=dy > 0)
    edges = np.stack([px, py, qx, qy, slope, dy > 0]).transpose(0, 2, 1, 3).reshape(6, 3, -1)
    px, py, qx, qy, slope, rising = np.repeat(edges, lines, axis=2)  # (3, lines) each
    # x where the line meets the edge, the line clipped to the edge's y-range: a flat edge
    # (slope 0) gives px at a strip's bottom and qx at its top, as its two ends.
    at = px + (np.clip(y_line, py, qy) - py) * slope
    at_top = np.where(rising > 0, at, qx)
    # Row k (strip [y_k, y_k+1]): the edge meets it when py <= y_k+1 and qy >= y_k.
    valid = (py[:, :-1] <= y_line[1:]) & (qy[:, :-1] >= y_line[:-1])
    lo = np.where(valid, np.minimum(at[:, :-1], at_top[:, 1:]), np.inf).min(axis=0)
    hi = np.where(valid, np.maximum(at[:, :-1], at_top[:, 1:]), -np.inf).max(axis=0)
    keep = lo <= hi
    keep[ends[:-1] - 1] = False  # a triangle's last line starts no row
    width = size + 1
    view_rows = np.repeat(np.arange(views) * size, len(faces))  # the views' rows one after another
    base = (np.repeat(view_rows + r0 - starts, lines) + np.arange(total))[:-1][keep] * width
    c0 = np.minimum(np.maximum(np.ceil(lo[keep] - 0.5), 0), top).astype(np.int64)
    c1 = np.minimum(np.maximum(np.floor(hi[keep] + 0.5), 0), top).astype(np.int64)
    cells = views * size * width
    spans = np.bincount(base + c0, minlength=cells) - np.bincount(base + c1 + 1, minlength=cells)
    return np.cumsum(spans[:cells].reshape(views, size, width)[:, :, :size], axis=2) > 0


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
    unions = (source | level).sum(axis=(1, 2))
    overlaps = (source & level).sum(axis=(1, 2))
    return min(float(o / u) if u else 1.0 for o, u in zip(overlaps.tolist(), unions.tolist()))
