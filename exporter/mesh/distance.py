"""Exact distance from points to a triangle mesh.

Data form: ``positions`` (k, 3) float64 metres and ``faces`` (m, 3) int64 in any one frame (the
stages use the building-local East/Up/North frame); points (p, 3) in the same frame; distances in
metres. :func:`point_triangle_distance` is Ericson's closest-point test (compiled:
:mod:`.distance_kernels`);
:class:`SurfaceIndex` prepares a mesh once (a k-d tree of probes on it) so that many points are
answered by a few candidate triangles first, then every triangle that could still be closer; a
large one keeps each distinct point's answers (:class:`PointMemo`), asked again by the certified
bound's rounds and calls.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from . import _point_memo, _surface
from .distance_kernels import point_triangle_distance
from .geometry import cross_rows

SEED = 20240521  # probe samples (and the quality metrics' wall samples) are the same on every run
PROBE_MARGIN_M = 1e-9  # metres (+ the same share of the distance): rounding of a probe's distance


def face_normals(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unnormalised (b - a) x (c - a), (m, 3) square metres (length = twice the area).

    ``np.cross``'s arithmetic written out (its per-call overhead dominates on building meshes)."""
    a, b, c = (positions[faces[:, i]] for i in range(3))
    return cross_rows(b - a, c - a)


def row_lengths(vectors: np.ndarray) -> np.ndarray:
    """(m,) lengths of (m, 3) rows: ``np.linalg.norm(vectors, axis=1)``'s sum in its order."""
    return np.sqrt(
        vectors[:, 0] * vectors[:, 0]
        + vectors[:, 1] * vectors[:, 1]
        + vectors[:, 2] * vectors[:, 2]
    )


def sample_surface(
    positions: np.ndarray,
    faces: np.ndarray,
    count: int,
    rng: np.random.Generator,
    with_faces: bool = False,
):
    """``count`` area-weighted random points on the triangles, (count, 3) metres (and, with
    ``with_faces``, the (count,) index of the triangle each lies on)."""
    areas = row_lengths(face_normals(positions, faces))
    if len(faces) == 0 or areas.sum() <= 0:
        empty = np.zeros((0, 3))
        return (empty, np.zeros(0, np.int64)) if with_faces else empty
    chosen = rng.choice(len(faces), size=count, p=areas / areas.sum())
    r1, r2 = rng.random(count), rng.random(count)
    flip = r1 + r2 > 1.0
    r1[flip], r2[flip] = 1.0 - r1[flip], 1.0 - r2[flip]
    a, b, c = (positions[faces[chosen, i]] for i in range(3))
    points = a + r1[:, None] * (b - a) + r2[:, None] * (c - a)
    return (points, chosen) if with_faces else points


class PointMemo:
    """Per-point answers kept for each distinct point (bit for bit, ``c/point_memo.c``): a
    prepared surface is asked the same questions about the same points many times (the corners
    triangles share, those a split hands to its children, those the refinement's rounds and the
    calls of one building meet again). Each answer depends on the point alone, so it is computed
    once, for the points first met, in their order: the same values as asking every time."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled  # else every question is computed (a small surface's are cheap)
        self._memo = _point_memo.memo()
        self._columns: dict[object, tuple[np.ndarray, list[np.ndarray]]] = {}
        self._lock = threading.RLock()  # a Dask worker's threads may share a surface

    def get(
        self,
        name: object,
        points: np.ndarray,
        compute: Callable[[np.ndarray], tuple[np.ndarray, ...]],
    ) -> tuple[np.ndarray, ...]:
        """``compute(points)``'s arrays (each (p, ...)) for points (p, 3), from what was kept under
        ``name``; ``compute`` runs only on the points not met before under it (first of each)."""
        points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        if len(points) == 0 or not self.enabled:
            return compute(points)
        with self._lock:
            column = self._columns.get(name)
            done, values = column if column is not None else (np.zeros(0, bool), [])
            need = _point_memo.count(self._memo) + len(points)
            if len(done) < need:
                size = max(need, 2 * len(done), 64)
                done = np.concatenate([done, np.zeros(size - len(done), bool)])
                values = [_grown(v, size) for v in values]
                self._columns[name] = done, values
            rows, first = _point_memo.lookup(self._memo, points, done)
            if len(first):
                fresh_rows = rows.take(first)
                try:
                    fresh = compute(points.take(first, axis=0))
                except BaseException:
                    done[fresh_rows] = False
                    raise
                if not values:
                    values = [np.empty((len(done),) + f.shape[1:], f.dtype) for f in fresh]
                    self._columns[name] = done, values
                for value, f in zip(values, fresh):
                    value[fresh_rows] = f
            return tuple([v.take(rows, axis=0) for v in values])


def _grown(values: np.ndarray, size: int) -> np.ndarray:
    grown = np.empty((size,) + values.shape[1:], values.dtype)
    grown[: len(values)] = values
    return grown


class SurfaceIndex:
    """A triangle mesh prepared for exact point-to-surface distances (see :func:`distance_to_surface`).

    Holds the triangles (m, 3, 3) metres, their centres and bounding radii, and a
    ``scipy.spatial.cKDTree`` of probes (corners, centroids and ``samples_per_face`` x m
    area-weighted samples, fixed seed) labelled with their triangle.
    """

    def __init__(
        self,
        positions: np.ndarray,
        faces: np.ndarray,
        samples_per_face: int = 2,
        tri: np.ndarray | None = None,
        balanced: bool = True,
    ) -> None:
        """``tri``: ``positions[faces]`` (m, 3, 3) when the caller has it. ``balanced``: the
        probes' tree split at medians (scipy's default), else at sliding midpoints and not
        compacted: built in ~0.4 of the time for about the same queries, but probes at equal
        distance (a corner shared by several triangles) may come in another order, so an upper
        bound may take another of those triangles."""
        self.tri = positions[faces] if tri is None else tri
        m = len(faces)
        if samples_per_face * m:
            samples, sample_faces = sample_surface(
                positions, faces, samples_per_face * m, np.random.default_rng(SEED), with_faces=True
            )
        else:  # what sample_surface gives for no samples, without its generator and area sums
            samples, sample_faces = np.zeros((0, 3)), np.zeros(0, np.int64)
        # tri.mean(axis=1) and each corner's largest distance to it (compiled: c/surface.c).
        self.centres, self.radii = _surface.centres_radii(self.tri)
        probes = np.concatenate([self.tri.reshape(-1, 3), self.centres, samples])
        self.owner = np.concatenate([np.repeat(np.arange(m), 3), np.arange(m), sample_faces])
        options = {} if balanced else {"balanced_tree": False, "compact_nodes": False}
        self.tree = cKDTree(probes, **options) if m else None
        self._centre_tree: cKDTree | None = None  # of the centres, made when first needed
        # Per-point answers (probes, upper bounds, nearest faces), kept for a surface whose
        # queries cost more than the keeping.
        self.memo = PointMemo(m >= self.MEMO_FACES)

    CANDIDATES = 6  # nearest probes whose triangles give the upper bound
    MEMO_FACES = 200  # surfaces of this many triangles keep their per-point answers
    DENSE_PAIRS = 20_000  # point x triangle tests below which all pairs are tested at once
    TREE_SHARE = 8  # the tree's lists are used when they hold under 1/8 of all pairs
    BLOCK_PAIRS = 1 << 20  # candidate pairs held at once (an 8 MiB float64 block)

    @staticmethod
    def _near(point: list, centre: list, radius, limit, strict: bool) -> np.ndarray:
        """Bool (broadcast): the sphere of ``centre`` and ``radius`` comes within ``limit`` of
        ``point`` (``< limit`` when ``strict``); points and centres as their three coordinate
        arrays, so no (p, m, 3) temporary: dx^2 + dy^2 + dz^2 is the same sum, in the same order,
        as ((p - c) ** 2).sum(-1)."""
        squared = (point[0] - centre[0]) ** 2
        squared += (point[1] - centre[1]) ** 2
        squared += (point[2] - centre[2]) ** 2
        gap = np.sqrt(squared) - radius
        return gap < limit if strict else gap <= limit

    def _dense_pairs(
        self, points: np.ndarray, limit: np.ndarray, strict: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """Every point x triangle pair tested, in blocks of at most ``BLOCK_PAIRS`` pairs (a
        (p, m) block of a merged tile's points and triangles is gigabytes)."""
        step = max(1, self.BLOCK_PAIRS // max(len(self.centres), 1))
        rows_out, cols_out = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        for start in range(0, len(points), step):
            block = points[start : start + step]
            near = self._near(
                [block[:, i, None] for i in range(3)],
                [self.centres[None, :, i] for i in range(3)],
                self.radii[None],
                limit[start : start + step, None],
                strict,
            )
            rows, cols = np.nonzero(near)
            rows_out.append(rows + start)
            cols_out.append(cols)
        return np.concatenate(rows_out), np.concatenate(cols_out)

    def _tree_pairs(
        self, points: np.ndarray, limit: np.ndarray, reach: np.ndarray, strict: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """The pairs of points (p, 3) with the centres within ``reach`` (p,) metres of them, then
        the exact sphere test; the tree's lists made for a few points at a time."""
        assert self._centre_tree is not None
        found = self._centre_tree.query_ball_point(points, reach, return_sorted=True)
        counts = np.fromiter(map(len, found), np.int64, len(found))  # the lists' own lengths
        rows = np.repeat(np.arange(len(points)), counts)
        cols = np.fromiter(itertools.chain.from_iterable(found), np.int64, int(counts.sum()))
        keep = self._near(
            [points[rows, i] for i in range(3)],
            [self.centres[cols, i] for i in range(3)],
            self.radii[cols],
            limit[rows],
            strict,
        )
        return rows[keep], cols[keep]

    def sphere_pairs(
        self, points: np.ndarray, limit: np.ndarray, strict: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) int64, row-major sorted: every point i (p, 3) metres and triangle j whose
        bounding sphere comes within ``limit[i]`` (metres; ``< limit`` when ``strict``) of it.

        Small problems test all p x m pairs; larger ones only the centres a ``cKDTree`` finds
        within ``limit + largest radius`` (widened by 1e-9 for the tree's own rounding), then
        apply the same test to those: the same pairs either way (an O(p m) step was the certified
        bound's cost on buildings of thousands of triangles). The tree's lists are Python lists:
        when they would hold more than 1/``TREE_SHARE`` of all pairs (counted first, in C), the
        dense test is cheaper and is used. Either way at most ``BLOCK_PAIRS`` candidate pairs are
        held at once (points taken a block at a time), besides the pairs found."""
        m = len(self.centres)
        if len(points) * m <= self.DENSE_PAIRS or not np.all(np.isfinite(limit)):
            return self._dense_pairs(points, limit, strict)
        if self._centre_tree is None:
            self._centre_tree = cKDTree(self.centres)
        reach = (limit + self.radii.max()) * (1 + 1e-9) + 1e-12
        counts = self._centre_tree.query_ball_point(points, reach, return_length=True)
        if counts.sum() * self.TREE_SHARE > len(points) * m:
            # Most pairs are near (large limits, one big face): the lists would cost more.
            return self._dense_pairs(points, limit, strict)
        # Blocks of points whose lists hold at most BLOCK_PAIRS entries (one point at least).
        total = np.cumsum(counts)
        rows_out, cols_out = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        start = 0
        while start < len(points):
            base = total[start] - counts[start]
            stop = max(
                int(np.searchsorted(total, base + self.BLOCK_PAIRS, side="right")), start + 1
            )
            rows, cols = self._tree_pairs(
                points[start:stop], limit[start:stop], reach[start:stop], strict
            )
            rows_out.append(rows + start)
            cols_out.append(cols)
            start = stop
        return np.concatenate(rows_out), np.concatenate(cols_out)

    def probes(
        self, points: np.ndarray, candidates: int, memo: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """Distances (p, k) metres and indices (p, k) of each point's (p, 3) k nearest probes,
        k = min(candidates, probes): the tree's answer (with ``memo``, each distinct point's kept
        from an earlier query: the tree answers each point on its own, so the same)."""
        assert self.tree is not None  # callers check for an empty surface first
        k = min(candidates, self.tree.n)
        if not memo:
            return self._query(points, k)
        probe_distance, nearest = self.memo.get(("probes", k), points, lambda x: self._query(x, k))
        return probe_distance, nearest

    def _query(self, points: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        assert self.tree is not None
        probe_distance, nearest = self.tree.query(points, k=k)
        return probe_distance.reshape(len(points), k), nearest.reshape(len(points), k)

    def upper(
        self, points: np.ndarray, candidates: int = CANDIDATES, memo: bool = True
    ) -> np.ndarray:
        """Upper bound of each point's distance (p,) metres: exact distances to the triangles
        owning the ``candidates`` nearest probes (inf if the surface is empty; with ``memo``,
        kept per distinct point)."""
        if self.tree is None:
            return np.full(len(points), np.inf)
        if not memo:
            return self._upper(points, *self.probes(points, candidates, memo=False))
        return self.memo.get(
            ("upper", candidates),
            points,
            lambda x: (self._upper(x, *self.probes(x, candidates, memo=False)),),
        )[0]

    def _upper(
        self, points: np.ndarray, probe_distance: np.ndarray, nearest: np.ndarray
    ) -> np.ndarray:
        # A point on a probe (a shared vertex: most of them when a level keeps input vertices) is
        # on the surface: 0, which is also what its triangles would give; else the least exact
        # distance to the triangles owning its probes (compiled: c/surface.c).
        return _surface.upper(points, probe_distance, nearest, self.owner, self.tri)

    def refine(self, points: np.ndarray, upper: np.ndarray) -> np.ndarray:
        """Exact distances (p,) metres given upper bounds: every triangle whose bounding sphere
        comes closer than the bound is checked."""
        exact = upper.copy()
        open_points = np.flatnonzero(upper > 1e-9)  # points on the surface need no second look
        if len(open_points) == 0 or self.tree is None:
            return exact
        near = points[open_points]
        rows, cols = self.sphere_pairs(near, upper[open_points] - 1e-12, strict=True)
        if len(rows):
            # rows come sorted (row-major nonzero): one minimum per point over its triangles.
            distance = point_triangle_distance(near[rows], self.tri[cols])
            starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
            which = open_points[rows[starts]]
            exact[which] = np.minimum(exact[which], np.minimum.reduceat(distance, starts))
        return exact

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Exact distance from each point (p, 3) to the surface, (p,) metres (inf if empty)."""
        return self.refine(points, self.upper(points))

    def max_distance(self, points: np.ndarray, chunk: int = 32, floor: float = 0.0) -> float:
        """Exact maximum distance of the points (metres), or ``floor`` (metres) when that is
        larger: refines the largest upper bounds first and stops once no remaining bound can
        beat the best exact value (a known floor, e.g. the other direction of a Hausdorff
        distance, stops it sooner; the result is still max(floor, exact maximum))."""
        best = max(0.0, floor)
        if len(points) == 0:
            return best
        if self.tree is None:
            return float("inf")  # no surface: every point is infinitely far
        probe_distance, nearest = self.probes(points, self.CANDIDATES)
        # A point whose nearest probe (a point of the surface, up to rounding: the margin, metres)
        # is closer than the floor cannot raise the maximum: no triangle distances for it.
        rest = np.flatnonzero(
            probe_distance[:, 0] + PROBE_MARGIN_M * (1.0 + probe_distance[:, 0]) >= best
        )
        points = points[rest]
        upper = self._upper(points, probe_distance[rest], nearest[rest])
        order = np.argsort(-upper)
        for start in range(0, len(order), chunk):
            if upper[order[start]] <= best:
                break
            take = order[start : start + chunk]
            best = max(best, float(self.refine(points[take], upper[take]).max()))
        return best

    def within(self, points: np.ndarray, tolerance: float) -> np.ndarray:
        """(p,) bool: exact distance <= ``tolerance`` metres (only bounds above it are refined)."""
        if self.tree is None or len(points) == 0:
            return np.zeros(len(points), dtype=bool)
        # A probe lies on the surface, so the nearest probe's distance is a first upper bound;
        # the same query's nearest probes give the others their upper bound (one query, not two).
        probe_distance, nearest = self.probes(points, self.CANDIDATES, memo=False)
        inside = probe_distance[:, 0] <= tolerance
        if (~inside).any():
            rest = points[~inside]
            upper = self._upper(rest, probe_distance[~inside], nearest[~inside])
            near = upper <= tolerance
            if (~near).any():
                near[~near] = self.refine(rest[~near], upper[~near]) <= tolerance
            inside[~inside] = near
        return inside


def distance_to_surface(points: np.ndarray, positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Exact distance from each point (p, 3) to the triangle mesh, (p,) metres (inf if empty)."""
    return SurfaceIndex(positions, faces).distance(points)
