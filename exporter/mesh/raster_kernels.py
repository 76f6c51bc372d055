"""Conservative rasterisation of triangles, compiled: one triangle, one pixel row at a time.

Pixel (row r, column c) is the unit square centred on (c, r); a triangle covers every pixel of
every row r whose strip [r - 0.5, r + 0.5] it meets, from the column of the leftmost to that of
the rightmost point where its edges cross the strip (clipped to the raster). An edge's x on a
line y is ``px + (clip(y, py, qy) - py) * slope`` (p its lower end, q its upper end); a flat edge
gives its two end x. This is the arithmetic of the former vectorised form (of commit af57811
before it), so the pixels are the same bit for bit (tests/test_perf_quality.py checks it against
a plain reference). Pixel coordinates, any view.
"""

from __future__ import annotations

import numpy as np

from .jit import kernel


@kernel
def _rasterise(xy, faces, size, out):  # pragma: no cover - compiled
    top = size - 1
    # Row spans as differences (+1 at a span's first column, -1 past its last), summed per row
    # at the end: each triangle costs its rows, not its pixels.
    spans = np.zeros((size, size + 1), np.int32)
    px = np.empty(3)
    py = np.empty(3)
    qx = np.empty(3)
    qy = np.empty(3)
    slope = np.empty(3)
    for view in range(xy.shape[0]):
        spans[:] = 0
        for f in range(faces.shape[0]):
            y_min, y_max = np.inf, -np.inf
            for k in range(3):
                x0, y0 = xy[view, faces[f, k], 0], xy[view, faces[f, k], 1]
                x1, y1 = xy[view, faces[f, (k + 1) % 3], 0], xy[view, faces[f, (k + 1) % 3], 1]
                y_min = min(y_min, y0)
                y_max = max(y_max, y0)
                if y0 > y1:  # p the lower end, q the upper end
                    px[k], py[k], qx[k], qy[k] = x1, y1, x0, y0
                else:
                    px[k], py[k], qx[k], qy[k] = x0, y0, x1, y1
                dy = qy[k] - py[k]
                slope[k] = (qx[k] - px[k]) / dy if dy > 0 else 0.0
            r0 = int(min(max(np.ceil(y_min - 0.5), 0.0), top))
            r1 = int(min(max(np.floor(y_max + 0.5), 0.0), top))
            for r in range(r0, r1 + 1):
                bottom, upper = r - 0.5, r + 0.5
                lo, hi = np.inf, -np.inf
                for k in range(3):
                    if not (py[k] <= upper and qy[k] >= bottom):
                        continue
                    at = px[k] + (min(max(bottom, py[k]), qy[k]) - py[k]) * slope[k]
                    if qy[k] - py[k] > 0:
                        at_top = px[k] + (min(max(upper, py[k]), qy[k]) - py[k]) * slope[k]
                    else:
                        at_top = qx[k]
                    lo = min(lo, min(at, at_top))
                    hi = max(hi, max(at, at_top))
                if lo <= hi:
                    c0 = int(min(max(np.ceil(lo - 0.5), 0.0), top))
                    c1 = int(min(max(np.floor(hi + 0.5), 0.0), top))
                    spans[r, c0] += 1
                    spans[r, c1 + 1] -= 1
        for r in range(size):
            total = 0
            for c in range(size):
                total += spans[r, c]
                out[view, r, c] = total > 0


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
