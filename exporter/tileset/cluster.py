"""Vertex clustering of a proxy's merged mesh, per building, with its Hausdorff bound by construction.

Source: J. Rossignac and P. Borrel, "Multi-resolution 3D approximations for rendering complex
scenes" (Modeling in Computer Graphics, 1993): vertices in one grid cell are replaced by one
representative; triangles whose corners fall into fewer than three cells vanish. Here the cells
are per building (a vertex's cell key is its building and its grid cell, so buildings never merge
and every vertex keeps its building) and a representative is its cell's mean (inside the cell).

Data form: the merged mesh of :mod:`.proxy` in one metric frame: positions (n, 3) float64 metres,
faces (m, 3) int64, uvs (n, 2) float (atlas units), owners (n,) int64 (building index,
non-decreasing in vertex order).

Why the bound holds (metres): every vertex moves by at most ``moved`` (measured exactly), so each
point of a kept triangle (a barycentric combination of its corners) moves by at most ``moved``,
both ways. A vanished triangle's points map to a segment [a, b] (or a point) between two
representatives within ``moved``; the distance to the kept surface is 1-Lipschitz, so it is at
most the largest distance (an upper bound of it: :meth:`SurfaceIndex.upper`) at points ``h``
apart along [a, b], plus ``h`` / 2 (0 without a query when [a, b] is an edge of a kept
triangle). So the
symmetric Hausdorff distance between the mesh and its clustering is at most ``moved`` + the
largest such value over vanished triangles. A vanished triangle whose segment reaches farther than
``keep_beyond`` from what is kept is kept as it was (a pole above a roof, an isolated small
building: never dropped at a cost above ``keep_beyond``).
The cost is a few numpy passes and one point-distance query: no surface-to-surface certification.

Uvs: vertices of one cell stay apart when their uvs lie in different bins of ``1 / uv_bins``
(texture seams survive, each side keeps its own uvs, averaged within the bin).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mesh.distance import SurfaceIndex


@dataclass
class Clustered:
    positions: np.ndarray  # (k, 3) float64 metres
    faces: np.ndarray  # (f, 3) int64
    uvs: np.ndarray  # (k, 2) float32
    owners: np.ndarray  # (k,) int64, non-decreasing
    source: np.ndarray  # (k,) int64: an input vertex of each output vertex (for per-vertex data)
    bound: float  # metres: symmetric Hausdorff bound between the input mesh and this one


def column_range(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(``rows.min(axis=0)``, ``rows.max(axis=0)``) of (n, k) int ``rows``, n > 0, a column at a
    time (numpy reduces a C-ordered array's axis 0 four times slower than a column)."""
    columns = [rows[:, c] for c in range(rows.shape[1])]
    return np.array([c.min() for c in columns]), np.array([c.max() for c in columns])


def unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(rows, axis=0, return_inverse=True)`` for (n, k) int64 ``rows``: the same
    (sorted rows, inverse (n,)), through one int64 key per row when the columns' ranges fit in 62
    bits (a 1-D sort instead of a row-wise one, several times faster)."""
    if len(rows) == 0:
        return rows, np.zeros(0, np.int64)
    low, high = column_range(rows)
    bits = [int(v).bit_length() for v in high - low]
    if sum(bits) > 62:
        found, inverse = np.unique(rows, axis=0, return_inverse=True)
        return found, inverse.reshape(-1)
    key = np.zeros(len(rows), np.int64)
    for column, width in enumerate(bits):  # most significant first: sorted keys = sorted rows
        key = (key << width) | (rows[:, column] - low[column])
    # Without return_index np.unique sorts unstably (quicksort): the same keys and inverse, and
    # any row of a key is that key's row (written in one scatter).
    keys, inverse = np.unique(key, return_inverse=True)
    inverse = inverse.reshape(-1)
    found = np.empty((len(keys), rows.shape[1]), rows.dtype)
    found[inverse] = rows
    return found, inverse


def members(indices: np.ndarray, size: int) -> np.ndarray:
    """``np.unique(indices)`` for int ``indices`` in [0, ``size``): one pass over a mask, no
    sort."""
    mask = np.zeros(size, bool)
    mask[indices.reshape(-1)] = True
    return np.flatnonzero(mask)


def contained(values: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """``np.isin(values, pool)`` for int64 arrays: the pool sorted once, the values found in it
    by binary search (no sort of both together)."""
    pool = np.sort(pool)
    if len(pool) == 0:
        return np.zeros(len(values), bool)
    at = np.minimum(np.searchsorted(pool, values), len(pool) - 1)
    return pool[at] == values


def _means(ids: np.ndarray, values: np.ndarray, count: int) -> np.ndarray:
    """(count, d) means of the rows of ``values`` (n, d) grouped by ``ids`` (n,)."""
    sums = np.column_stack(
        [np.bincount(ids, weights=values[:, d], minlength=count) for d in range(values.shape[1])]
    )
    return sums / np.bincount(ids, minlength=count)[:, None]


def spot_bins(spot: np.ndarray, uvs: np.ndarray, uv_bins: int) -> np.ndarray:
    """(n,) int64: one number per (cell ``spot``, u bin, v bin) of each vertex, in their
    lexicographic order (mixed radix), so that a row (building, 0, it) sorts as (building, 0,
    spot, u bin, v bin) would, in three columns whose bits fit one sort key."""
    uv_bin = np.floor(np.asarray(uvs, np.float64) * uv_bins).astype(np.int64)
    if len(uv_bin) == 0:
        return np.zeros(0, np.int64)
    low, high = column_range(uv_bin)
    uv_bin -= low
    span = high - low + 1
    return (spot * span[0] + uv_bin[:, 0]) * span[1] + uv_bin[:, 1]


def segment_reach(
    index: SurfaceIndex, centre: np.ndarray, corner: np.ndarray, spacing: float
) -> np.ndarray:
    """Per vanished triangle (``corner``: (v, 3) indices into ``centre`` (k, 3) metres, two of
    them equal), an upper bound in metres of the distance from its image segment to the surface
    of ``index``: upper bounds of the distance at points at most ``spacing`` apart along the
    segment, plus half that spacing (the distance is 1-Lipschitz)."""
    first = corner[:, 0]
    second = np.where(corner[:, 0] == corner[:, 1], corner[:, 2], corner[:, 1])
    # Many vanished triangles fold onto the same segment (ordered pair of cells: 8.9x on a
    # level-13 proxy of 16 x 1,248 buildings): each is measured once, with the same arithmetic.
    size = max(1, len(centre))
    pairs, inverse = np.unique(first * size + second, return_inverse=True)
    a = centre[pairs // size]
    b = centre[pairs % size]
    length = np.linalg.norm(b - a, axis=1)
    steps = np.maximum(1, np.ceil(length / spacing).astype(np.int64))
    owner = np.repeat(np.arange(len(a)), steps + 1)
    first = np.repeat(np.cumsum(steps + 1) - (steps + 1), steps + 1)
    t = (np.arange(len(owner)) - first) / steps[owner]
    points = a[owner] + t[:, None] * (b - a)[owner]
    # Upper bounds (exact distances to the triangles of the nearest probes): enough for a bound,
    # and a segment they overstate is only kept rather than dropped.
    distance = index.upper(points, memo=False)
    reach = np.full(len(a), -np.inf)
    np.maximum.at(reach, owner, distance)
    return (reach + length / steps / 2.0)[inverse.reshape(-1)]


def _reach(
    centre: np.ndarray, corner: np.ndarray, vanished: np.ndarray, spacing: float
) -> np.ndarray:
    """:func:`segment_reach` of the vanished triangles against the kept ones; a segment that is
    an edge of a kept triangle (most: a sliver folded onto its neighbour) reaches 0, measured
    without a query."""
    kept = corner[~vanished]
    gone = corner[vanished]
    ends = np.sort(
        np.column_stack([gone[:, 0], np.where(gone[:, 0] == gone[:, 1], gone[:, 2], gone[:, 1])]),
        axis=1,
    )
    edges = np.sort(np.concatenate([kept[:, [0, 1]], kept[:, [1, 2]], kept[:, [2, 0]]]), axis=1)
    width = max(1, int(len(centre)).bit_length())
    on_edge = contained((ends[:, 0] << width) | ends[:, 1], (edges[:, 0] << width) | edges[:, 1])
    on_edge &= ends[:, 0] != ends[:, 1]  # a point image is measured (its cell may be gone)
    reach = np.zeros(len(gone))
    open_ = ~on_edge
    if open_.any():
        # A sliding-midpoint tree, built in 0.4 of the time: any probes' triangles give upper
        # bounds (module doc), and the same ones on every machine.
        index = SurfaceIndex(centre, kept, samples_per_face=0, balanced=False)
        reach[open_] = segment_reach(index, centre, gone[open_], spacing)
    return reach


def cell_spots(positions: np.ndarray, owners: np.ndarray, cell: float) -> np.ndarray:
    """(n,) int64: each vertex's (building, grid cell of ``cell`` metres), numbered in sorted
    order."""
    grid = np.floor(positions / cell).astype(np.int64)
    return unique_rows(np.column_stack([owners, grid]))[1]


def vanishing(corner: np.ndarray) -> np.ndarray:
    """(m,) bool: the triangles whose corners' cells ``corner`` (m, 3) are not all different."""
    return (
        (corner[:, 0] == corner[:, 1])
        | (corner[:, 1] == corner[:, 2])
        | (corner[:, 0] == corner[:, 2])
    )


def clustered_faces(spot: np.ndarray, faces: np.ndarray) -> int:
    """The triangles ``faces`` (m, 3) that survive clustering on the cells ``spot``
    (:func:`cell_spots`) without being restored: a lower bound of :func:`cluster`'s faces, at a
    tenth of its cost (no reach is measured)."""
    return int(np.count_nonzero(~vanishing(spot[faces])))


def cluster(
    positions: np.ndarray,
    faces: np.ndarray,
    uvs: np.ndarray,
    owners: np.ndarray,
    cell: float,
    keep_beyond: float,
    uv_bins: int = 1024,
    spot: np.ndarray | None = None,
) -> Clustered:
    """The clustering of the mesh on a grid of ``cell`` metres (see the module doc); vanished
    triangles' segments are measured at points ``cell`` / 2 apart at most. ``spot``: its
    :func:`cell_spots` when the caller has them."""
    sample = cell / 2.0
    spot = cell_spots(positions, owners, cell) if spot is None else spot
    spots = int(spot.max()) + 1 if len(spot) else 0
    centre = _means(spot, positions, spots)
    corner = spot[faces]  # (m, 3) cell of each corner
    vanished = vanishing(corner)
    # Reach of every vanished triangle from the kept surface; one that reaches farther than
    # keep_beyond (a pole above a roof, an isolated small building) is kept as it was (restoring
    # only adds to the kept surface: the other values stay upper bounds).
    reach = np.zeros(len(faces))
    if vanished.any():
        reach[vanished] = np.inf
        if (~vanished).any():
            reach[vanished] = _reach(centre, corner, vanished, sample)
    restored = vanished & (reach > keep_beyond)
    clustered = ~vanished
    # Output vertices: one per (building, cell, uv bin) for the clustered triangles, and the
    # vertices of restored triangles as they were; sorted by building (owners stay grouped).
    n = len(positions)
    originals = members(faces[restored], n)
    rows = np.concatenate(
        [
            np.column_stack([owners, np.zeros(n, np.int64), spot_bins(spot, uvs, uv_bins)]),
            np.column_stack([owners[originals], np.ones(len(originals), np.int64), originals]),
        ]
    )
    kept_rows, vertex = unique_rows(rows)
    count = len(kept_rows)
    moved_to = np.concatenate([centre[spot], positions[originals]])
    uv_all = np.concatenate([np.asarray(uvs, np.float64), np.asarray(uvs, np.float64)[originals]])
    source = np.zeros(count, np.int64)
    source[vertex] = np.concatenate([np.arange(n), originals])
    out_faces = np.concatenate(
        [vertex[faces[clustered]], vertex[n + np.searchsorted(originals, faces[restored])]]
    )
    used = members(faces[~restored], n)  # every moved vertex: of kept and of dropped triangles
    moved = float(np.linalg.norm(positions[used] - centre[spot[used]], axis=1).max(initial=0.0))
    bound = moved + float(reach[vanished & ~restored].max(initial=0.0))
    return Clustered(
        _means(vertex, moved_to, count),
        out_faces,
        _means(vertex, uv_all, count).astype(np.float32),
        kept_rows[:, 0],
        source,
        bound,
    )
