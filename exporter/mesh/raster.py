"""Conservative rasterisation of triangles, and the silhouettes it gives.

Data form: ``positions`` (n, 3) float64 metres in the building-local East/Up/North frame (y = Up),
``faces`` (m, 3) int64; rasters are bool arrays, pixel (row, col) covering
[row - 0.5, row + 0.5] x [col - 0.5, col + 0.5] of the pixel coordinates. Used by the quality
metrics (``silhouette_iou``) and the simplifier's silhouette floor, which must agree pixel for
pixel.

The guard and the quality metrics rasterise the same triangles (LOD0 and the accepted level,
on vertex arrays numbered differently): :func:`silhouettes` keeps its last few results keyed by
the triangles' corner coordinates in face order and the box, which is all the raster reads.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

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
    on the box [low, high] (metres, local East/Up/North). Read-only: the same array may be
    returned for the same triangles again."""
    key = _silhouette_key(positions, faces, low, high)
    if key is not None:
        with _SILHOUETTES_LOCK:  # a Dask worker runs buildings in several threads
            kept = _SILHOUETTES.get(key)
            if kept is not None:
                _SILHOUETTES.move_to_end(key)
                return kept
    span = np.maximum(high - low, 1e-9)
    pixels = (positions - low) / span * (RESOLUTION - 1)
    views = rasterise_views(pixels[:, VIEWS].transpose(1, 0, 2), faces, RESOLUTION)
    if key is not None:
        views.setflags(write=False)
        with _SILHOUETTES_LOCK:
            _SILHOUETTES[key] = views
            if len(_SILHOUETTES) > _KEPT:
                _SILHOUETTES.popitem(last=False)
    return views


_KEPT = 16  # silhouette stacks kept (a building's guard trials and levels)
_SILHOUETTES: OrderedDict[bytes, np.ndarray] = OrderedDict()
_SILHOUETTES_LOCK = threading.Lock()


def _silhouette_key(
    positions: np.ndarray, faces: np.ndarray, low: np.ndarray, high: np.ndarray
) -> bytes | None:
    """Digest of what :func:`silhouettes` reads: each face's corners (m, 3, 3) metres in face
    order and the box (low, high), with their dtypes; None (not cached) for anything but numpy
    arrays of shapes (n, 3), (m, 3) integer in range, (3,), which the raster reports itself."""
    arrays = (positions, faces, low, high)
    if (
        not all(isinstance(a, np.ndarray) for a in arrays)
        or positions.ndim != 2
        or positions.shape[1] != 3
        or faces.ndim != 2
        or faces.shape[1] != 3
        or low.shape != (3,)
        or high.shape != (3,)
        or faces.dtype.kind not in "iu"
        or (len(faces) and (faces.min() < 0 or faces.max() >= len(positions)))
    ):
        return None
    digest = hashlib.blake2b(digest_size=32)
    digest.update(" ".join(a.dtype.str for a in (positions, low, high)).encode())
    digest.update(np.ascontiguousarray(positions[faces]).tobytes())
    digest.update(low.tobytes())
    digest.update(high.tobytes())
    return digest.digest()


def min_iou(source: np.ndarray, level: np.ndarray) -> float:
    """The smallest intersection over union of two stacks of views (v, n, n) bool (1 for two
    empty views)."""
    counts = overlaps(source, level)  # compiled: (v, 2) intersection and union pixels
    return min(float(o / u) if u else 1.0 for o, u in counts.tolist())
