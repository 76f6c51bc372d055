"""Certified Hausdorff distance between two triangle meshes: a lower and an upper bound.

Data form: triangle meshes ``(positions (k, 3) float64 metres, faces (m, 3) int64)`` in the
building-local East/Up/North frame (any one frame works: nothing here depends on which axis is
up); a soup is a mesh whose faces share no vertex. Results are metres.

Entry points: :func:`hausdorff_bounds` (symmetric: ``(lower, upper)`` with ``lower <= true <=
upper`` and ``upper - lower`` small), :func:`exceeds` (the decision ``true > tolerance``, never
``False`` when it is), both on a prepared :class:`Surface` (the reference side, prepared once).

Why not sampling: distances from samples are lower bounds; the worst point of a triangle that
bridges a notch lies between the samples (a real Munich building: 0.03 m sampled, 0.52 m true).
Why not libigl / pymeshlab / trimesh: ``igl::hausdorff`` on meshes and pymeshlab's
``get_hausdorff_distance`` sample vertices and surface points (lower bounds); trimesh has no
Hausdorff distance. libigl's single-triangle ``hausdorff(V, dist_to_B, l, u)`` bounds one
triangle by subdivision (Lipschitz); the bound here is the same idea made tight for buildings.

The bound (one direction, triangle T of A against surface B):

1. ``d(., t)`` to one triangle t (a convex set) is convex, so over T its maximum is at a vertex:
   ``U(T) = min_t max_v d(v, t)`` is an upper bound of ``max_{p in T} d(p, B)`` and
   ``L(T) = max_v d(v, B)`` a lower bound. A triangle of A equal to one of B has U = 0.
1b. A triangle bridging two faces t_i, t_j (a chord across a dome's facets, a facet piece over
   a ridge) is cut by the plane where their planes are equally far; each cell is convex, so the
   bound ``max(max_{cell_i corners} d(., t_i), max_{cell_j corners} d(., t_j))`` is again taken
   at corners (:func:`_pair_bound`).
2. Coplanar source triangles (a wall of 50 becomes 2 at a coarser level): B's faces are grouped
   in planar regions (:func:`~exporter.mesh.topology.planar_regions`); the region R of plane
   P (its vertices within ``slack`` of P) projected on P is a polygon ``R_P``. If T projected on
   P lies inside ``R_P``, every p in T is within ``sqrt(h^2 + rho^2) + slack`` of R, h the largest
   distance of T's vertices to P (affine, so at a vertex), rho the in-plane margin below. The
   containment is decided without polygon clipping: T's incentre lies in ``R_P`` and no boundary
   edge of ``R_P`` meets the open triangle ``T_delta`` (T shrunk about its incentre by the ratio
   1 - ``SHRINK``): the open, connected ``T_delta`` then lies in ``R_P`` and every point of T is
   within rho = ``2 SHRINK max|v - incentre|`` of it (2x covers rounding in the tests).
3. A triangle whose bound is still too large (above the tolerance for :func:`exceeds`, above the
   lower bound by more than the requested gap for :func:`hausdorff_bounds`) is split in four at
   its edge midpoints and its children bounded again, up to ``MAX_DEPTH`` times; a triangle still
   open at the last depth keeps its (valid) bound. Lower bounds are exact point-to-surface
   distances of the vertices met (:class:`~exporter.mesh.distance.SurfaceIndex`); :func:`exceeds`
   stops at the first vertex certainly above the tolerance.

The symmetric distance is the larger of the two directions (A to B, B to A); an empty side
against a non-empty one is infinitely far. The per-triangle loops run compiled
(``c/surface.c``: nearest face, single-face, chain and pair bounds; ``c/plane_boundary.c``: the
regions' boundary edges); the orchestration here stays numpy.
"""

from __future__ import annotations

import numpy as np

from . import _chains, _plane_boundary, _surface, coverage
from .component_kernels import lowest_member
from .distance import SurfaceIndex
from .geometry import cross_rows, isin_int, longest_edges, unique_float_rows
from .planar_bound_kernels import planar_bound
from .straight_run_kernels import straight_runs
from .topology import planar_regions

MAX_DEPTH = 7  # 4-splits per triangle at most (edges down to 1/128 of the triangle's)
MAX_OPEN = 4096  # sub-triangles bounded per round at most (the worst split first)
MAX_ROUNDS = 12  # refinement rounds at most (the bounds left are still valid)
SHRINK = 1e-7  # relative shrink of a triangle before the containment test (see module doc)
CANDIDATES = 4  # nearest probes of each point whose triangles give the single-triangle bound
CENTRE_PROBES = 3  # nearest probes of a triangle's centroid whose regions are tried first
LOWER_POINTS = 16  # open corners measured exactly per round of exceeds (the farthest first)
RTOL = 0.02  # default relative gap upper - lower of hausdorff_bounds
ATOL = 1e-6  # default absolute gap of hausdorff_bounds, share of the bounding-box diagonal
PLANE_SLACK_MAX = 1e-3  # metres: regions flatter than this give the in-plane bound
SAME_PLANE_COS = 1.0 - 1e-10  # regions this parallel (cosine of their normals) ...
SAME_PLANE = 1e-6  # ... and this close (x the mesh's diagonal, slack included) are merged
STRAIGHT = 1.0 - 1e-10  # edges whose directions have a cosine below -this continue each other
# Last containment tries: the triangle shrunk about its incentre by these x the target's diagonal.
LOOSE = (3e-7, 3e-6, 1e-5)
TRUSTED = 1e-6  # faces flatter than this (altitude / longest edge) give no single-face bound
T_JUNCTION = 1e-6  # a vertex this close to an edge (share of its length) splits it
PAIR_CHUNK = 1 << 20  # region pairs compared at once when merging regions on one plane
NEAREST_DENSE = 1 << 18  # point x face tests below which every face is tried (no tree lists)

__all__ = ["Surface", "bounds_within", "hausdorff_bounds", "directed_bounds", "exceeds", "split4"]


class Surface:
    """One side prepared for bounds: welded positions (k, 3) metres, faces (m, 3), its exact
    point-distance index, its planar regions (planes, slack, projected triangles and boundary
    edges) and straight edge chains, each made when first needed. ``reference``: prepared once
    and used often (the thorough preparation) rather than per call."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray, reference: bool = True) -> None:
        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        self.positions, self.faces = positions, faces
        # A reference (prepared once, used many times) gets the thorough preparation: straight
        # outline runs merged, 2 probe samples per face; a level (prepared per call) the quick one.
        self.reference = reference
        self.tri = positions[faces]  # (m, 3, 3) metres
        self._index: SurfaceIndex | None = None
        self._regions: _Regions | None = None
        self._chains: _Chains | None = None
        self._trusted: np.ndarray | None = None
        self._face_planes: tuple[np.ndarray, np.ndarray, float] | None = None
        self._cross: np.ndarray | None = None

    @property
    def cross(self) -> np.ndarray:
        """(m, 3) square metres: each face's (b - a) x (c - a), made once for all the pieces."""
        if self._cross is None:
            t = self.tri
            self._cross = cross_rows(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        return self._cross

    @property
    def empty(self) -> bool:
        return len(self.faces) == 0

    @property
    def index(self) -> SurfaceIndex:
        if self._index is None:
            self._index = SurfaceIndex(
                self.positions, self.faces, 2 if self.reference else 0, tri=self.tri
            )
        return self._index

    @property
    def trusted(self) -> np.ndarray:
        """(m,) bool: faces whose point distances keep their digits (smallest altitude at least
        ``TRUSTED`` x the longest edge)."""
        if self._trusted is None:
            t, cross = self.tri, self.cross
            area2 = np.sqrt((cross**2).sum(1))
            self._trusted = area2 >= TRUSTED * longest_edges(t) ** 2
        return self._trusted

    @property
    def face_planes(self) -> tuple[np.ndarray, np.ndarray, float]:
        """Each face's plane ``normal . x = offset``: unit normals (m, 3), offsets (m,) metres
        (both 0 for untrusted faces: no plane) and the rounding margin (metres) of a point's
        distance to a plane (normals of trusted faces keep ~1e-10 of their direction)."""
        if self._face_planes is None:
            t, cross = self.tri, self.cross
            length = np.sqrt((cross**2).sum(1))
            ok = self.trusted & (length > 0)
            normal = np.zeros_like(cross)
            normal[ok] = cross[ok] / length[ok, None]
            offset = _dot3(t[:, 0], normal)
            scale = float(np.abs(self.positions).max()) if len(self.positions) else 0.0
            self._face_planes = (normal, offset, 1e-6 * scale + 1e-12)
        return self._face_planes

    @property
    def chains(self) -> _Chains:
        if self._chains is None:
            self._chains = _Chains(self.positions, self.faces)
        return self._chains

    @property
    def regions(self) -> _Regions:
        if self._regions is None:
            self._regions = _Regions(
                self.positions, self.faces, self.reference, (self.tri, self.cross)
            )
        return self._regions


class _Regions:
    """Planar regions of a mesh (see the module doc, step 2), all arrays per region r or per face.

    ``region`` (m,) the region of each face; ``normal`` (r, 3) unit, ``offset`` (r,) metres and
    ``slack`` (r,) metres: the plane ``normal . x = offset`` and the largest distance of the
    region's vertices to it; ``u``, ``v`` (r, 3) the plane's in-plane axes; ``tri2`` (m, 3, 2)
    metres each face projected on its region's plane; ``seg_start`` (r + 1,) and ``seg`` (s, 2, 2)
    metres the boundary edges of each region projected (CSR); ``face_start`` (r + 1,) and
    ``face_order`` (m,) the faces of each region (CSR)."""

    def __init__(
        self,
        positions: np.ndarray,
        faces: np.ndarray,
        straighten: bool = True,
        made: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """``made``: ``(positions[faces], their cross products)`` when the caller has them."""
        self.straighten = straighten
        m = len(faces)
        region = planar_regions(positions, faces) if m else np.zeros(0, np.int64)
        if made is None:
            tri = positions[faces]
            cross = cross_rows(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        else:
            tri, cross = made
        self.scale = (
            float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0))) if m else 0.0
        )
        normal, offset, slack = _planes(tri, cross, region)
        # Regions on one plane that only meet at T-junctions (or not at all) are one region.
        if len(normal) > 1:
            r = len(normal)
            tolerance = SAME_PLANE * max(self.scale, 1e-9)
            if r * r <= PAIR_CHUNK:  # a building's few regions: all pairs at once
                same = (normal @ normal.T > SAME_PLANE_COS) & (
                    np.abs(offset[:, None] - offset[None, :]) + slack[:, None] + slack[None, :]
                    <= tolerance
                )
                merge = same.sum() > r
                if merge:
                    rows, cols = np.nonzero(same)
            else:  # a merged tile's thousands: an (r, r) block would be gigabytes
                rows, cols, pairs, alone = _same_plane_pairs(normal, offset, slack, tolerance)
                merge = r - alone + 2 * pairs > r  # the count of the same r x r relation
            if merge:
                region = _components(r, rows, cols)[1][region]
                normal, offset, slack = _planes(tri, cross, region)
        r = len(normal)
        self.offset, self.slack = offset, slack
        self.normal, self.region = normal, region
        helper = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        u = cross_rows(normal, helper)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        self.u, self.v = u, cross_rows(normal, u)
        # Each corner on its region's (u, v) axes (compiled: c/surface.c).
        self.tri2 = _surface.project(tri, self.u, self.v, region)
        self.face_order = np.argsort(region, kind="stable")
        self.face_start = np.searchsorted(region[self.face_order], np.arange(r + 1))
        self._boundary(faces, len(positions))

    def _boundary(self, faces: np.ndarray, k: int) -> None:
        """Each region's boundary edges: every half-edge without exactly one opposite half-edge
        in its region, both on faces that keep their orientation when projected (conservative:
        an edge wrongly called boundary only costs a subdivision). Half-edges are first split at
        the region's T-junctions (a vertex of the region on an unmatched edge, within
        ``T_JUNCTION`` x the edge's length of its line); ``gap`` (r,) metres is the largest such
        offset of each region (a point in the sliver between is that close to the region)."""
        seg_region, seg, ends, oriented, self.gap = _plane_boundary.boundary(
            faces, k, self.region, len(self.normal), self.tri2, T_JUNCTION
        )  # compiled: c/plane_boundary.c
        self._store(*self._straighten(seg_region, seg, ends, oriented), len(self.normal))

    def _straighten(
        self, seg_region: np.ndarray, seg: np.ndarray, ends: np.ndarray, oriented: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        if not self.straighten:
            return seg_region, seg
        return self._straight_runs(seg_region, seg, ends, oriented)

    def _straight_runs(
        self, seg_region: np.ndarray, seg: np.ndarray, ends: np.ndarray, oriented: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Boundary runs a -> b -> ... -> c whose inner vertices lie within ``T_JUNCTION`` x |ac|
        of the chord ac, on the region's side of it (left of a -> c), become the one segment ac
        (the planar stage drops such straight outline vertices, and a level's edge ac would
        otherwise be crossed by a -> b -> c through float noise). The region grows by slivers
        whose height goes into its ``gap`` (every point of the new region is that close to the
        old one). A vertex off to the outside is never crossed by a triangle inside the region,
        so it is left (1e-9 x |ac| of rounding allowed, counted in ``gap`` too). Only runs
        through vertices with one boundary edge in and one out, on faces that keep their
        orientation."""
        if len(seg) < 2:
            return seg_region, seg
        return straight_runs(seg_region, seg, ends, oriented, self.gap, T_JUNCTION)

    def _store(self, seg_region: np.ndarray, seg: np.ndarray, r: int) -> None:
        order = np.argsort(seg_region, kind="stable")
        seg = seg[order]
        self.seg_x0, self.seg_y0 = seg[:, 0, 0].copy(), seg[:, 0, 1].copy()
        self.seg_x1, self.seg_y1 = seg[:, 1, 0].copy(), seg[:, 1, 1].copy()
        self.seg_start = np.searchsorted(seg_region[order], np.arange(r + 1))


class _Chains:
    """Straight chains of edges (see the module doc, step 2b): ``face_chain`` (m, 3) the chain of
    each face's edges; ``start``, ``end`` (c, 3) metres each chain's segment and ``slack`` (c,)
    metres the largest distance of its vertices to the segment's line. Edges meeting at a vertex
    in opposite directions (within ``STRAIGHT``) chain; a chain's edges cover its segment up to
    ``slack`` (they are connected and lie within ``slack`` of the line)."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        # Compiled (c/chains.c): the edges, their directions, the chains (union-find over the
        # opposite pairs at each vertex) and each chain's segment and slack.
        self.face_chain, self.start, self.end, self.slack = _chains.chains(
            np.ascontiguousarray(positions, np.float64).reshape(-1, 3),
            np.ascontiguousarray(faces, np.int64).reshape(-1, 3),
            STRAIGHT,
        )


def _chain_bound(tri: np.ndarray, target: Surface, faces: np.ndarray) -> np.ndarray:
    """(n,) metres: ``min_chain max_v d(v, chain segment) + slack`` over the chains of the edges
    of each triangle's candidate ``faces`` (n, c) of ``target`` (compiled: c/surface.c)."""
    chains = target.chains
    cand = chains.face_chain[faces].reshape(len(tri), -1)  # (n, 3c)
    return _surface.chain_bound(tri, cand, chains.start, chains.end, chains.slack)


def _same_plane_pairs(
    normal: np.ndarray, offset: np.ndarray, slack: np.ndarray, tolerance: float
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Pairs ``i < j`` of regions on one plane: normals (r, 3) with a cosine above
    ``SAME_PLANE_COS`` and ``|offset_i - offset_j| + slack_i + slack_j <= tolerance`` (metres), as
    edges (rows, cols) int64 joining the same regions as those pairs (at most r), the number of
    pairs and the number of regions that fail the test against themselves (slack above half the
    tolerance). Only pairs within ``tolerance`` in offset are compared
    (sorted by offset, in chunks of at most ``PAIR_CHUNK`` pairs): memory grows with the pairs
    compared, not with r x r (a merged 1,248-building tile has 31,424 regions: 7.4 GiB a block)."""
    r = len(normal)
    order = np.argsort(offset, kind="stable")
    sorted_offset = offset[order]
    # A window a little wider than the tolerance (plus the rounding of the sum, a few ulps of
    # large offsets): the exact test below decides.
    margin = tolerance * (1 + 1e-9) + 4 * np.spacing(np.abs(sorted_offset) + tolerance)
    reach = np.searchsorted(sorted_offset, sorted_offset + margin, side="right")
    counts = np.maximum(reach - np.arange(r) - 1, 0)
    ends = np.cumsum(counts)
    rows_out: list[np.ndarray] = []
    cols_out: list[np.ndarray] = []
    first = pairs = 0
    while first < r:
        base = ends[first] - counts[first]
        last = max(int(np.searchsorted(ends, base + PAIR_CHUNK, side="right")), first + 1)
        owner, item = _ranges(np.arange(first, min(last, r)) + 1, counts[first:last])
        i, j = order[owner + first], order[item]
        same = ((normal[i] * normal[j]).sum(1) > SAME_PLANE_COS) & (
            np.abs(offset[i] - offset[j]) + slack[i] + slack[j] <= tolerance
        )
        rows_out.append(np.minimum(i, j)[same])
        cols_out.append(np.maximum(i, j)[same])
        pairs += int(same.sum())
        if sum(len(x) for x in rows_out) > 2 * r:  # many on one plane: keep a spanning set
            rows_out, cols_out = list(
                _spanning(np.concatenate(rows_out), np.concatenate(cols_out), r)
            )
        first = last
    alone = int(
        np.count_nonzero(~((normal * normal).sum(1) > SAME_PLANE_COS) | (2 * slack > tolerance))
    )
    rows, cols = _spanning(np.concatenate(rows_out), np.concatenate(cols_out), r)
    return rows[0], cols[0], pairs, alone


def _components(n: int, rows: np.ndarray, cols: np.ndarray) -> tuple[int, np.ndarray]:
    """``(count, label (n,) int64)`` of the undirected graph on n nodes with edges ``rows[i] --
    cols[i]``: scipy's ``connected_components(directed=False)`` numbering (components in the
    order of their lowest node), from the compiled union-find without building a sparse graph."""
    lowest = lowest_member(n, rows, cols)
    root = lowest == np.arange(n)
    rank = np.cumsum(root) - 1
    return int(root.sum()), rank[lowest]


def _spanning(rows: np.ndarray, cols: np.ndarray, r: int):
    """Edges ``(rows (q,), cols (q,))`` among r nodes replaced by as few with the same connected
    components (each node of a component joined to its lowest member), each wrapped in a list."""
    if len(rows) == 0:
        return [rows], [cols]
    lowest = lowest_member(r, rows, cols)
    node = np.flatnonzero(lowest != np.arange(r))
    return [lowest[node]], [node]


def _planes(tri: np.ndarray, cross: np.ndarray, region: np.ndarray):
    """Each region's plane: unit ``normal`` (r, 3) (area-weighted), ``offset`` (r,) metres
    halfway between the extreme corners (the smallest slack for that normal) and ``slack`` (r,)
    metres, the largest distance of the region's corners to the plane (compiled: c/surface.c;
    the numpy form is tests/test_surface_prep.py's reference)."""
    r = int(region.max()) + 1 if len(region) else 0
    return _surface.planes(tri, cross, region, r)


def split4(tri: np.ndarray) -> np.ndarray:
    """(4n, 3, 3): each triangle (n, 3, 3) split at its edge midpoints (children of triangle i
    are rows 4i..4i+3; compiled: c/surface.c, its numpy form in tests/test_surface_prep.py)."""
    return _surface.split4(tri)


def _single_triangle_bound(tri: np.ndarray, target: Surface, nearest: np.ndarray) -> np.ndarray:
    """Step 1: (n,) metres ``min_t max_v d(v, t)`` over candidate triangles t of ``target`` (the
    owners of the nearest probes of the vertices and centroid, and the face ``nearest`` (n,) to
    the centroid)."""
    index = target.index
    assert index.tree is not None  # callers check for an empty surface first
    n = len(tri)
    points = np.concatenate([tri, _centroid(tri)[:, None]], axis=1)  # (n, 4, 3)
    _, probes = index.probes(points.reshape(-1, 3), CANDIDATES)
    # Each corner's distance to each distinct candidate (compiled: c/surface.c); slivers, whose
    # distances lose digits (Ericson's barycentric products cancel), are no candidates (inf).
    cand = np.column_stack([index.owner[probes.reshape(n, -1)], nearest])  # (n, 4k + 1)
    return _surface.single_bound(tri, cand, target.trusted, index.tri)


def _planar_bound(tri: np.ndarray, target: Surface, row: np.ndarray, face: np.ndarray, cap):
    """Step 2: (n,) metres the in-plane bound of each triangle (n, 3, 3) over the regions of its
    candidate faces of ``target`` (``row``, ``face`` pairs: faces near its centroid), inf where
    none holds. A pair counts only if the centroid projected on the region's plane lies in the
    face (a point of the shrunk triangle in the region, see the module doc) and, with ``cap``
    (metres), the plane bound stays below it."""
    return planar_bound(tri, row, face, target.regions, cap, (SHRINK, PLANE_SLACK_MAX, LOOSE))


def _centroid(tri: np.ndarray) -> np.ndarray:
    """(n, 3) metres: ``tri.mean(axis=1)`` of triangles (n, 3, 3), written out (the same sum,
    in the same order, divided by 3)."""
    return (tri[:, 0] + tri[:, 1] + tri[:, 2]) / 3.0


def _dot3(points: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """``(points * axis).sum(-1)`` for (..., 3) arrays, written out."""
    return (
        points[..., 0] * axis[..., 0]
        + points[..., 1] * axis[..., 1]
        + points[..., 2] * axis[..., 2]
    )


def _ranges(starts: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(owner, item) pairs for owners with item ranges [starts, starts + counts)."""
    owner = np.repeat(np.arange(len(counts)), counts)
    item = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return owner, starts[owner] + item


def _identical(tri: np.ndarray, target: Surface) -> np.ndarray:
    """(n,) bool: the triangle (n, 3, 3) has the same three corners (bit for bit, any order) as a
    face of ``target``."""
    if target.empty or len(tri) == 0:
        return np.zeros(len(tri), bool)
    rows = np.concatenate([tri.reshape(-1, 3), target.tri.reshape(-1, 3)])
    _, inverse = unique_float_rows(rows)
    ids = np.sort(inverse.reshape(-1, 3), axis=1)
    k = int(inverse.max()) + 1
    keys = (ids[:, 0] * k + ids[:, 1]) * k + ids[:, 2]
    return isin_int(keys[: len(tri)], keys[len(tri) :])


def directed_bounds(
    tri: np.ndarray,
    target: Surface,
    tolerance: float | None = None,
    rtol: float = RTOL,
    atol: float = 0.0,
    floor: float = 0.0,
    max_depth: int = MAX_DEPTH,
    give_up: float = np.inf,
) -> tuple[float, float]:
    """Bounds ``(lower, upper)`` metres of ``max_{p in tri} d(p, target)``, ``tri`` (n, 3, 3) metres.

    With ``tolerance`` (metres) only the decision is certified: returns as soon as ``lower >
    tolerance`` or every triangle's bound is <= tolerance (then ``upper <= tolerance``; the
    returned lower bound is what was met on the way). Without it the triangles are refined until
    ``upper <= max(lower, floor) * (1 + rtol) + atol`` or ``max_depth``. ``floor`` (metres): a
    value the caller already has (the other direction), below which nothing is refined.
    ``give_up`` (metres): refining stops as soon as the lower bound is above it (the upper bound
    returned is then inf), and goes on while the upper bound is above it (within ``max_depth``)."""
    if len(tri) == 0:
        return 0.0, 0.0
    if target.empty:
        return float("inf"), float("inf")
    tri = tri[~_identical(tri, target)]
    index = target.index
    lower, upper_done = 0.0, 0.0
    if tolerance is None and len(tri):
        # A first lower bound from the corners, so that refining aims at a known value.
        # Distinct corners (np.unique's rows, in its order: compiled, without its void sort).
        corners = tri.reshape(-1, 3)
        corners = corners[unique_float_rows(corners)[0]]
        lower = float(index.max_distance(corners))
        if lower > give_up:
            return lower, float("inf")  # a corner is already too far: no triangle bounded

    def goal() -> float:
        if tolerance is not None:
            return tolerance
        # Never stop above give_up while the bound may still come under it.
        return min(max(lower, floor) * (1 + rtol) + atol, give_up)

    # Best-first refinement: the pending triangles with the largest bounds are split first.
    depth = np.zeros(len(tri), np.int64)
    bound = _bound(tri, target, goal()) if len(tri) else np.zeros(0)
    for _ in range(MAX_ROUNDS):
        open_ = bound > goal()
        if (~open_).any():
            upper_done = max(upper_done, float(bound[~open_].max()))
            tri, bound, depth = tri[open_], bound[open_], depth[open_]
        if len(tri) == 0:
            break
        # Lower bound: exact distances of the corners of the worst open triangles.
        worst = np.argsort(-bound, kind="stable")[:LOWER_POINTS]
        corners = tri[worst].reshape(-1, 3)
        upper = index.upper(corners)
        far = upper > max(lower, floor if tolerance is None else tolerance)
        if far.any():
            lower = max(lower, float(index.refine(corners[far], upper[far]).max()))
        if tolerance is not None and lower > tolerance:
            return lower, float(bound.max())
        if lower > give_up:
            return lower, float("inf")
        if bound.max() <= goal():
            continue
        deep = depth >= max_depth
        if tolerance is not None and deep.any():
            return lower, float(bound.max())  # cannot be certified within the depth
        order = np.flatnonzero(~deep)[np.argsort(-bound[~deep], kind="stable")]
        split, wait = order[: MAX_OPEN // 4], order[MAX_OPEN // 4 :]
        if len(split) == 0:
            break
        children = split4(tri[split])
        child_depth = np.repeat(depth[split] + 1, 4)
        keep = np.concatenate([wait, np.flatnonzero(deep)])
        tri = np.concatenate([tri[keep], children])
        depth = np.concatenate([depth[keep], child_depth])
        bound = np.concatenate([bound[keep], _bound(children, target, goal())])
    if len(tri):
        open_ = bound > goal()
        if open_.any():
            upper_done = max(upper_done, float(bound[open_].max()))
        elif len(bound):
            upper_done = max(upper_done, float(bound.max()))
    return lower, max(lower, upper_done)


def _bound(tri: np.ndarray, target: Surface, goal: float) -> np.ndarray:
    """(n,) metres: an upper bound of each triangle's (n, 3, 3) largest distance to ``target``,
    trying the cheap bounds first and the next only for triangles still above ``goal``."""
    index = target.index
    assert index.tree is not None  # callers check for an empty surface first
    n = len(tri)
    # Planar regions of the faces nearest the centroid (probes, then exact for the rest).
    centre = _centroid(tri)
    _, near = index.probes(centre, CENTRE_PROBES, memo=False)  # few centres come again
    k = near.shape[1]
    faces = index.owner[near]
    bound = _planar_bound(tri, target, np.repeat(np.arange(n), k), faces.reshape(-1), cap=None)
    open_ = np.flatnonzero(bound > goal)
    extra = None
    if len(open_):
        nearest = _nearest_face(target, centre[open_])
        extra = np.full(n, -1)
        extra[open_] = nearest
        fresh = ~(faces[open_] == nearest[:, None]).any(axis=1)
        if fresh.any():
            bound[open_[fresh]] = np.minimum(
                bound[open_[fresh]],
                _planar_bound(
                    tri[open_[fresh]], target, np.arange(fresh.sum()), nearest[fresh], cap=None
                ),
            )
        still = bound[open_] > goal
        if still.any():
            # Straight chains of the nearest faces' edges (triangles along an edge of target).
            cand = np.column_stack([faces[open_], nearest])[still]
            open_ = open_[still]
            bound[open_] = np.minimum(bound[open_], _chain_bound(tri[open_], target, cand))
            open_ = open_[bound[open_] > goal]
        else:
            open_ = open_[still]
    if len(open_):
        assert extra is not None  # set whenever a triangle stayed open
        bound[open_] = np.minimum(
            bound[open_], _single_triangle_bound(tri[open_], target, extra[open_])
        )
        open_ = open_[bound[open_] > goal]
    if len(open_):
        assert extra is not None
        bound[open_] = np.minimum(bound[open_], _pair_bound(tri[open_], target, extra[open_]))
    return bound


def _pair_bound(tri: np.ndarray, target: Surface, nearest: np.ndarray) -> np.ndarray:
    """Step 1b: (n,) metres, the single-triangle bound over a split of each triangle (n, 3, 3)
    in two cells, for a triangle bridging two faces of ``target`` (a chord across the facets of
    a dome or a curved roof: no one face is near all of it).

    For faces t_i, t_j and any plane s = 0 cutting the triangle T, ``d(p, target) <= d(p, t_i)``
    on ``T ∩ {s <= 0}`` and ``<= d(p, t_j)`` on ``T ∩ {s >= 0}``; both cells are convex
    polygons and each distance is convex, so each maximum is at a cell corner: T's corners on
    that side and the points where T's edges cross s = 0. The cut is where the two faces'
    planes are equally far (signed, with the faces' own normals); either face may take either
    cell (the nearer face has the larger signed distance at a convex edge, the smaller at a
    concave one), the lesser of both bounds is kept. Pairs: the face ``nearest`` (n,) to the
    centroid with the face nearest each corner; the least bound is kept (inf where no pair of
    distinct trusted faces exists). The crossing points carry rounding of about 1e-16 of the
    coordinates: 1e-12 x the largest coordinate is added (distances are 1-Lipschitz). Compiled:
    c/surface.c."""
    other = _nearest_face(target, tri.reshape(-1, 3)).reshape(len(tri), 3)
    normal, offset, _ = target.face_planes
    return _surface.pair_bound(tri, nearest, other, target.trusted, normal, offset, target.tri)


def _nearest_face(target: Surface, points: np.ndarray) -> np.ndarray:
    """(p,) int64: a face of ``target`` at the least distance from each point (p, 3) metres (the
    faces whose bounding sphere and plane both come within the probes' upper bound are all
    checked; the first in face order of the least distance, compiled: c/surface.c). Each
    distinct point's face is kept on the index (:class:`~exporter.mesh.distance.PointMemo`)."""
    return target.index.memo.get("nearest_face", points, lambda x: (_nearest_faces(target, x),))[0]


def _nearest_faces(target: Surface, points: np.ndarray) -> np.ndarray:
    """:func:`_nearest_face` computed (each point's face depends on that point alone: the same
    faces are tried in the same order whether the tree's lists or the dense test find them)."""
    index = target.index
    upper = index.upper(points, memo=False)
    reach = upper * (1 + 1e-9) + 1e-12
    # A face's plane is no farther than the face: faces whose plane is beyond the bound cannot
    # be nearest (the margin covers the rounding of both distances; untrusted slivers, whose
    # normals are noise, have no plane and are always kept).
    normal, offset, margin = target.face_planes
    start = cols = None
    if len(points) * len(index.tri) > NEAREST_DENSE and np.all(np.isfinite(reach)):
        # A merged tile's many faces: only those the tree finds near (the same candidates).
        rows, cols = index.sphere_pairs(points, reach)
        start = np.searchsorted(rows, np.arange(len(points) + 1))
    return _surface.nearest_face(
        points, reach, index.centres, index.radii, normal, offset, margin, index.tri, start, cols
    )


def _prepare(side) -> Surface:
    return side if isinstance(side, Surface) else Surface(side[0], side[1], reference=False)


def hausdorff_bounds(
    a, b, rtol: float = RTOL, atol: float | None = None, max_depth: int = MAX_DEPTH
) -> tuple[float, float]:
    """Symmetric Hausdorff distance between meshes ``a`` and ``b`` (each a :class:`Surface` or a
    ``(positions, faces)`` pair, metres) as ``(lower, upper)`` metres: ``lower <= true <=
    upper``, refined until ``upper <= lower * (1 + rtol) + atol`` or ``max_depth``; ``atol``
    (metres) defaults to ``ATOL`` x the diagonal of both sides' bounding box. (inf, inf) when
    exactly one side is empty, (0, 0) when both are."""
    a, b = _prepare(a), _prepare(b)
    if a.empty and b.empty:
        return 0.0, 0.0
    if a.empty or b.empty:
        return float("inf"), float("inf")
    if atol is None:
        both = np.concatenate([a.tri.reshape(-1, 3), b.tri.reshape(-1, 3)])
        atol = ATOL * float(np.linalg.norm(both.max(axis=0) - both.min(axis=0)))
    # Step 0: re-triangulated flat regions settled by counting, within atol (so the gap holds).
    settled = coverage.region_certificate(
        (b.positions, b.faces), (a.positions, a.faces), max_bound=atol
    )
    low_ab, up_ab = directed_bounds(
        a.tri[settled.open_source], b, rtol=rtol, atol=atol, max_depth=max_depth
    )
    low_ba, up_ba = directed_bounds(
        b.tri[settled.open_level], a, rtol=rtol, atol=atol, floor=low_ab, max_depth=max_depth
    )
    return max(low_ab, low_ba), max(up_ab, up_ba, settled.bound)


def bounds_within(
    a, b, tolerance: float, rtol: float = RTOL, atol: float | None = None
) -> tuple[float, float] | None:
    """:func:`hausdorff_bounds` of ``a`` and ``b`` when its upper bound is at most ``tolerance``
    (metres), else None; stops early once a lower bound is above ``tolerance``. What the error
    guard runs on a candidate level: the bounds it keeps are the manifest's, computed once."""
    a, b = _prepare(a), _prepare(b)
    if a.empty and b.empty:
        return 0.0, 0.0
    if a.empty or b.empty:
        return None
    if atol is None:
        both = np.concatenate([a.tri.reshape(-1, 3), b.tri.reshape(-1, 3)])
        atol = ATOL * float(np.linalg.norm(both.max(axis=0) - both.min(axis=0)))
    settled = coverage.region_certificate(
        (b.positions, b.faces), (a.positions, a.faces), max_bound=min(atol, tolerance)
    )
    if settled.bound > tolerance:
        return None
    low_ab, up_ab = directed_bounds(
        a.tri[settled.open_source], b, rtol=rtol, atol=atol, give_up=tolerance
    )
    if up_ab > tolerance:
        return None
    low_ba, up_ba = directed_bounds(
        b.tri[settled.open_level], a, rtol=rtol, atol=atol, floor=low_ab, give_up=tolerance
    )
    upper = max(up_ab, up_ba, settled.bound)
    return (max(low_ab, low_ba), upper) if upper <= tolerance else None


def exceeds(a, b, tolerance: float, max_depth: int = MAX_DEPTH) -> bool:
    """Whether the symmetric Hausdorff distance between ``a`` and ``b`` (as in
    :func:`hausdorff_bounds`) may exceed ``tolerance`` (metres): False only when it certainly does
    not (a level whose bound cannot be brought below the tolerance within ``max_depth`` counts as
    exceeding)."""
    a, b = _prepare(a), _prepare(b)
    if a.empty or b.empty:
        return not (a.empty and b.empty)
    settled = coverage.region_certificate(
        (b.positions, b.faces), (a.positions, a.faces), max_bound=tolerance
    )
    for source, open_, target in ((b, settled.open_level, a), (a, settled.open_source, b)):
        low, up = directed_bounds(
            source.tri[open_], target, tolerance=tolerance, max_depth=max_depth
        )
        if up > tolerance or low > tolerance:
            return True
    return False
