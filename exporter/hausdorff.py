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
2. Coplanar source triangles (a wall of 50 becomes 2 at a coarser level): B's faces are grouped
   in planar regions (:func:`~exporter.simplify.protect.planar_regions`); the region R of plane
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
   distances of the vertices met (:class:`~exporter.quality.SurfaceIndex`); :func:`exceeds`
   stops at the first vertex certainly above the tolerance.

The symmetric distance is the larger of the two directions (A to B, B to A); an empty side
against a non-empty one is infinitely far.
"""

from __future__ import annotations

import numpy as np

from .geometry import cross_rows, unique_float_rows
from .quality import SurfaceIndex

MAX_DEPTH = 7  # 4-splits per triangle at most (edges down to 1/128 of the triangle's)
MAX_OPEN = 4096  # sub-triangles bounded per round at most (the work stops there, still valid)
SHRINK = 1e-7  # relative shrink of a triangle before the containment test (see module doc)
CANDIDATES = 4  # nearest probes of each point whose triangles give the single-triangle bound
CENTRE_PROBES = 3  # nearest probes of a triangle's centroid whose regions are tried first
LOWER_POINTS = 16  # open corners measured exactly per round of exceeds (the farthest first)
RTOL = 0.02  # default relative gap upper - lower of hausdorff_bounds
ATOL = 1e-6  # default absolute gap of hausdorff_bounds, share of the bounding-box diagonal
PLANE_SLACK_MAX = 1e-3  # metres: regions flatter than this give the in-plane bound
STRAIGHT = 1.0 - 1e-10  # edges whose directions have a cosine below -this continue each other
T_JUNCTION = 1e-6  # a vertex this close to an edge (share of its length) splits it
# Later containment tries: T shrunk by these x the target's diagonal (metres), for triangles that
# poke out of a region by float noise (float32 vertices: ~6e-8 of the coordinates).
LOOSE = (3e-7, 1e-5)

__all__ = ["Surface", "hausdorff_bounds", "directed_bounds", "exceeds", "split4"]


class Surface:
    """One side prepared for bounds: welded positions (k, 3) metres, faces (m, 3), its exact
    point-distance index, its planar regions (planes, slack, projected triangles and boundary
    edges) and its triangles' vertex keys (for "this triangle is one of mine")."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        self.positions, self.faces = positions, faces
        self.tri = positions[faces]  # (m, 3, 3) metres
        self._index: SurfaceIndex | None = None
        self._regions: _Regions | None = None
        self._chains: _Chains | None = None

    @property
    def empty(self) -> bool:
        return len(self.faces) == 0

    @property
    def index(self) -> SurfaceIndex:
        if self._index is None:
            self._index = SurfaceIndex(self.positions, self.faces)
        return self._index

    @property
    def chains(self) -> _Chains:
        if self._chains is None:
            self._chains = _Chains(self.positions, self.faces)
        return self._chains

    @property
    def regions(self) -> _Regions:
        if self._regions is None:
            self._regions = _Regions(self.positions, self.faces)
        return self._regions


class _Regions:
    """Planar regions of a mesh (see the module doc, step 2), all arrays per region r or per face.

    ``region`` (m,) the region of each face; ``normal`` (r, 3) unit, ``offset`` (r,) metres and
    ``slack`` (r,) metres: the plane ``normal . x = offset`` and the largest distance of the
    region's vertices to it; ``u``, ``v`` (r, 3) the plane's in-plane axes; ``tri2`` (m, 3, 2)
    metres each face projected on its region's plane; ``seg_start`` (r + 1,) and ``seg`` (s, 2, 2)
    metres the boundary edges of each region projected (CSR); ``face_start`` (r + 1,) and
    ``face_order`` (m,) the faces of each region (CSR)."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        from .simplify.protect import planar_regions

        m = len(faces)
        region = planar_regions(positions, faces) if m else np.zeros(0, np.int64)
        r = int(region.max()) + 1 if m else 0
        tri = positions[faces]
        cross = cross_rows(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal = np.zeros((r, 3))
        np.add.at(normal, region, cross)
        length = np.linalg.norm(normal, axis=1)
        good = length > 0
        normal[good] /= length[good, None]
        normal[~good] = (0.0, 0.0, 1.0)
        # Plane offset halfway between the extreme vertices: the smallest slack for this normal.
        heights = np.einsum("mkj,mj->mk", tri, normal[region])
        high = np.full(r, -np.inf)
        low = np.full(r, np.inf)
        np.maximum.at(high, region, heights.max(axis=1))
        np.minimum.at(low, region, heights.min(axis=1))
        self.offset = 0.5 * (high + low)
        self.slack = 0.5 * (high - low)
        self.normal, self.region = normal, region
        helper = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        u = cross_rows(normal, helper)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        self.u, self.v = u, cross_rows(normal, u)
        uf, vf = self.u[region], self.v[region]
        self.tri2 = np.stack(
            [np.einsum("mkj,mj->mk", tri, uf), np.einsum("mkj,mj->mk", tri, vf)], axis=-1
        )
        self.scale = (
            float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0))) if m else 0.0
        )
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
        m = len(faces)
        r = len(self.normal)
        t = self.tri2
        area2 = (t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1]) - (
            t[:, 1, 1] - t[:, 0, 1]
        ) * (t[:, 2, 0] - t[:, 0, 0])
        a = faces[:, [0, 1, 2]].reshape(-1)
        b = faces[:, [1, 2, 0]].reshape(-1)
        face = np.repeat(np.arange(m), 3)
        region = self.region[face]
        upright = (area2 > 0)[face]
        start2 = t.reshape(-1, 2)  # 2-D start of each half-edge, its end is the next corner
        end2 = t[:, [1, 2, 0]].reshape(-1, 2)
        self.gap = np.zeros(r)
        interior = _matched(region, a, b, upright, k)
        loose = np.flatnonzero(~interior & upright)
        if len(loose):
            # Split the unmatched half-edges at unmatched ends of the same region lying on them.
            ends = np.unique(
                np.concatenate([region[loose] * k + a[loose], region[loose] * k + b[loose]])
            )
            end_region, end_vertex = ends // k, ends % k
            where = np.concatenate([loose, loose])
            point_of = dict(
                zip(
                    np.concatenate(
                        [region[loose] * k + a[loose], region[loose] * k + b[loose]]
                    ).tolist(),
                    np.concatenate([start2[loose], end2[loose]]).tolist(),
                )
            )
            end_point = np.array([point_of[e] for e in ends.tolist()]).reshape(-1, 2)
            del where
            order = np.argsort(end_region, kind="stable")
            first = np.searchsorted(end_region[order], np.arange(r + 1))
            counts = first[region[loose] + 1] - first[region[loose]]
            owner, item = _ranges(first[region[loose]], counts)
            h = loose[owner]
            w = order[item]
            p, q, x = start2[h], end2[h], end_point[w]
            d = q - p
            length2 = (d * d).sum(1)
            with np.errstate(divide="ignore", invalid="ignore"):
                along = ((x - p) * d).sum(1) / length2
                off = np.abs(d[:, 0] * (x - p)[:, 1] - d[:, 1] * (x - p)[:, 0]) / np.sqrt(length2)
            on = (
                (end_vertex[w] != a[h])
                & (end_vertex[w] != b[h])
                & (along > 0)
                & (along < 1)
                & (off <= T_JUNCTION * np.sqrt(length2))
            )
            if on.any():
                np.maximum.at(self.gap, region[h[on]], off[on])
                # Sub-edges: each split half-edge's points in order along it.
                hs = np.concatenate([h[on], loose, loose])
                ts = np.concatenate([along[on], np.zeros(len(loose)), np.ones(len(loose))])
                vs = np.concatenate([end_vertex[w[on]], a[loose], b[loose]])
                ps = np.concatenate([end_point[w[on]], start2[loose], end2[loose]])
                o = np.lexsort((ts, hs))
                hs, vs, ps = hs[o], vs[o], ps[o]
                same = hs[1:] == hs[:-1]
                sub_a, sub_b = vs[:-1][same], vs[1:][same]
                sub_h = hs[:-1][same]
                sub_p, sub_q = ps[:-1][same], ps[1:][same]
                sub_ok = _matched(region[sub_h], sub_a, sub_b, np.ones(len(sub_h), bool), k)
                keep = ~interior & ~np.isin(np.arange(len(a)), loose)
                seg_region = np.concatenate([region[keep], region[sub_h[~sub_ok]]])
                seg = np.concatenate(
                    [
                        np.stack([start2[keep], end2[keep]], axis=1),
                        np.stack([sub_p[~sub_ok], sub_q[~sub_ok]], axis=1),
                    ]
                )
                self._store(seg_region, seg, r)
                return
        boundary = np.flatnonzero(~interior)
        self._store(region[boundary], np.stack([start2[boundary], end2[boundary]], axis=1), r)

    def _store(self, seg_region: np.ndarray, seg: np.ndarray, r: int) -> None:
        order = np.argsort(seg_region, kind="stable")
        self.seg = seg[order]
        self.seg_start = np.searchsorted(seg_region[order], np.arange(r + 1))


class _Chains:
    """Straight chains of edges (see the module doc, step 2b): ``face_chain`` (m, 3) the chain of
    each face's edges; ``start``, ``end`` (c, 3) metres each chain's segment and ``slack`` (c,)
    metres the largest distance of its vertices to the segment's line. Edges meeting at a vertex
    in opposite directions (within ``STRAIGHT``) chain; a chain's edges cover its segment up to
    ``slack`` (they are connected and lie within ``slack`` of the line)."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        m = len(faces)
        half = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        k = max(len(positions), 1)
        edges, edge_of = np.unique(half[:, 0] * k + half[:, 1], return_inverse=True)
        a, b = edges // k, edges % k
        self.face_chain = edge_of.reshape(m, 3)
        e = len(edges)
        direction = positions[b] - positions[a]
        length = np.sqrt((direction**2).sum(1))
        direction = np.divide(
            direction, length[:, None], out=np.zeros_like(direction), where=length[:, None] > 0
        )
        # Entries (vertex, edge, direction away from the vertex), grouped by vertex.
        vertex = np.concatenate([a, b])
        edge = np.concatenate([np.arange(e), np.arange(e)])
        away = np.concatenate([direction, -direction])
        order = np.argsort(vertex, kind="stable")
        vertex, edge, away = vertex[order], edge[order], away[order]
        first = np.searchsorted(vertex, vertex, side="left")
        last = np.searchsorted(vertex, vertex, side="right")
        # Pairs (i, j > i) within a vertex's entries.
        counts = last - np.arange(len(vertex)) - 1
        owner, item = _ranges(np.arange(len(vertex)) + 1, counts)
        del first
        straight = (away[owner] * away[item]).sum(1) < -STRAIGHT
        graph = coo_matrix(
            (np.ones(straight.sum()), (edge[owner[straight]], edge[item[straight]])), shape=(e, e)
        )
        count, chain = connected_components(graph, directed=False)
        self.face_chain = chain[self.face_chain]
        # Each chain's line: through its lowest edge's first end, along that edge.
        lead = np.full(count, e)
        np.minimum.at(lead, chain, np.arange(e))
        origin, axis = positions[a[lead]], direction[lead]
        ends = np.concatenate([a, b])
        owner_chain = np.concatenate([chain, chain])
        offset = positions[ends] - origin[owner_chain]
        along = (offset * axis[owner_chain]).sum(1)
        across = np.sqrt(np.maximum((offset**2).sum(1) - along**2, 0.0))
        low = np.full(count, np.inf)
        high = np.full(count, -np.inf)
        np.minimum.at(low, owner_chain, along)
        np.maximum.at(high, owner_chain, along)
        self.slack = np.zeros(count)
        np.maximum.at(self.slack, owner_chain, across)
        # Rounding of the perpendicular distance (sqrt of a difference): a relative margin.
        self.slack += 1e-7 * np.maximum(high - low, 0.0) + 1e-12
        self.start = origin + low[:, None] * axis
        self.end = origin + high[:, None] * axis


def _segment_distance(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance (...) metres from points (..., 3) to segments start-end (..., 3) (broadcast)."""
    d = end - start
    w = points - start
    d = np.broadcast_to(d, w.shape)
    length2 = (d * d).sum(-1)
    t = np.clip(
        np.divide((w * d).sum(-1), length2, out=np.zeros_like(length2), where=length2 > 0), 0.0, 1.0
    )
    return np.sqrt(((w - t[..., None] * d) ** 2).sum(-1))


def _chain_bound(tri: np.ndarray, target: Surface, faces: np.ndarray) -> np.ndarray:
    """(n,) metres: ``min_chain max_v d(v, chain segment) + slack`` over the chains of the edges
    of each triangle's candidate ``faces`` (n, c) of ``target``."""
    chains = target.chains
    n = len(tri)
    cand = chains.face_chain[faces].reshape(n, -1)  # (n, 3c)
    d = (
        _segment_distance(
            tri[:, None, :, :], chains.start[cand][:, :, None], chains.end[cand][:, :, None]
        ).max(axis=2)
        + chains.slack[cand]
    )
    return d.min(axis=1)


def _matched(region, a, b, ok, k) -> np.ndarray:
    """(h,) bool: the half-edge (a -> b) of ``region`` is ``ok`` and it and its opposite (b -> a)
    occur exactly once each among the ``ok`` half-edges of the region."""
    key = (region * k + a) * k + b
    rkey = (region * k + b) * k + a
    counted, counts = np.unique(key[ok], return_counts=True)
    if len(counted) == 0:
        return np.zeros(len(a), bool)

    def count(keys):
        at = np.minimum(np.searchsorted(counted, keys), len(counted) - 1)
        return np.where(counted[at] == keys, counts[at], 0)

    return ok & (count(key) == 1) & (count(rkey) == 1)


def split4(tri: np.ndarray) -> np.ndarray:
    """(4n, 3, 3): each triangle (n, 3, 3) split at its edge midpoints (children of triangle i
    are rows 4i..4i+3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, bc, ca = 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)
    return np.stack(
        [
            np.stack([a, ab, ca], 1),
            np.stack([ab, b, bc], 1),
            np.stack([ca, bc, c], 1),
            np.stack([ab, bc, ca], 1),
        ],
        1,
    ).reshape(-1, 3, 3)


def _single_triangle_bound(tri: np.ndarray, target: Surface) -> np.ndarray:
    """Step 1: (n,) metres ``min_t max_v d(v, t)`` over candidate triangles t of ``target`` (the
    owners of the nearest probes of the vertices and centroid)."""
    from .quality import point_triangle_distance

    index = target.index
    assert index.tree is not None  # callers check for an empty surface first
    n = len(tri)
    points = np.concatenate([tri, tri.mean(axis=1, keepdims=True)], axis=1)  # (n, 4, 3)
    k = min(CANDIDATES, index.tree.n)
    _, nearest = index.tree.query(points.reshape(-1, 3), k=k)
    owners = np.sort(index.owner[nearest.reshape(n, -1)], axis=1)  # (n, 4k)
    fresh = np.ones(owners.shape, dtype=bool)
    fresh[:, 1:] = owners[:, 1:] != owners[:, :-1]
    row = np.repeat(np.arange(n), fresh.sum(axis=1))
    cand = owners[fresh]
    # (pairs, 3): each vertex's distance to the candidate triangle
    d = point_triangle_distance(tri[row], index.tri[cand][:, None])
    starts = np.concatenate([[0], np.cumsum(fresh.sum(axis=1))[:-1]])
    return np.minimum.reduceat(d.max(axis=1), starts)


def _planar_bound(tri: np.ndarray, target: Surface, row: np.ndarray, cand: np.ndarray, cap):
    """Step 2: (n,) the in-plane bound of each triangle over the regions of its candidate
    triangles (``row``, ``cand`` pairs), inf where no region contains it; only pairs whose plane
    distance stays below ``cap`` (n,) metres are tested."""
    reg = target.regions
    n = len(tri)
    bound = np.full(n, np.inf)
    if len(row) == 0:
        return bound
    region = reg.region[cand]
    pair = np.unique(row * (len(reg.normal) + 1) + region)
    row, region = pair // (len(reg.normal) + 1), pair % (len(reg.normal) + 1)
    normal = reg.normal[region]
    height = np.abs(np.einsum("pkj,pj->pk", tri[row], normal) - reg.offset[region, None]).max(
        axis=1
    )
    keep = reg.slack[region] <= PLANE_SLACK_MAX
    if cap is not None:
        keep &= height + reg.slack[region] < cap[row]
    row, region, height = row[keep], region[keep], height[keep]
    if len(row) == 0:
        return bound
    t = tri[row]
    t2 = np.stack(
        [
            np.einsum("pkj,pj->pk", t, reg.u[region]),
            np.einsum("pkj,pj->pk", t, reg.v[region]),
        ],
        axis=-1,
    )  # (p, 3, 2) metres in the plane
    p0, p1, p2 = t2[:, 0], t2[:, 1], t2[:, 2]
    la = np.hypot(*(p2 - p1).T)  # side lengths opposite each vertex
    lb = np.hypot(*(p0 - p2).T)
    lc = np.hypot(*(p1 - p0).T)
    perimeter = la + lb + lc
    area2 = np.abs(
        (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1])
        - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0])
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        incentre = (la[:, None] * p0 + lb[:, None] * p1 + lc[:, None] * p2) / perimeter[:, None]
        inradius = area2 / perimeter
    reach = np.sqrt(((t2 - incentre[:, None]) ** 2).sum(-1)).max(axis=1)
    # Too thin to shrink safely against rounding (1e-12 of the reach): left to subdivision.
    fine = np.isfinite(inradius) & (inradius > 1e-9 * (reach + np.abs(t2).max(axis=(1, 2))))
    row, region, height, t2, incentre, reach = (
        x[fine] for x in (row, region, height, t2, incentre, reach)
    )
    if len(row) == 0:
        return bound
    inradius = inradius[fine]
    # First tight (rounding only), then loose for triangles poking out by float noise.
    value = np.full(len(row), np.inf)
    for loose in (0.0, *LOOSE):
        delta = np.maximum(SHRINK * inradius, loose * reg.scale)
        todo = np.flatnonzero(~np.isfinite(value) & (delta < 0.5 * inradius))
        if len(todo) == 0:
            break
        ratio = (delta / inradius)[todo]
        c = incentre[todo, None]
        inner = c + (t2[todo] - c) * (1.0 - ratio[:, None, None])
        inside = _incentre_inside(incentre[todo], region[todo], reg) & ~_boundary_crosses(
            inner, region[todo], reg
        )
        rho = 2.0 * ratio * reach[todo] + reg.gap[region[todo]]
        value[todo[inside]] = (np.sqrt(height[todo] ** 2 + rho**2) + reg.slack[region[todo]])[
            inside
        ]
    np.minimum.at(bound, row, value)
    return bound


def _ranges(starts: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(owner, item) pairs for owners with item ranges [starts, starts + counts)."""
    owner = np.repeat(np.arange(len(counts)), counts)
    item = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return owner, starts[owner] + item


def _incentre_inside(point: np.ndarray, region: np.ndarray, reg: _Regions) -> np.ndarray:
    """(p,) bool: the point (p, 2) lies in one of its region's projected faces (closed, with a
    1e-9 relative margin: a point wrongly inside is caught by the boundary test, see the doc)."""
    counts = reg.face_start[region + 1] - reg.face_start[region]
    owner, item = _ranges(reg.face_start[region], counts)
    t = reg.tri2[reg.face_order[item]]
    q = point[owner]
    pos = np.ones(len(owner), bool)
    neg = np.ones(len(owner), bool)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        e = t[:, j] - t[:, i]
        w = q - t[:, i]
        side = e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0]
        margin = 1e-9 * np.abs(e).sum(1) * (np.abs(w).sum(1) + np.abs(e).sum(1))
        pos &= side >= -margin
        neg &= side <= margin
    inside = pos | neg
    result = np.zeros(len(point), bool)
    result[owner[inside]] = True
    return result


def _boundary_crosses(tri2: np.ndarray, region: np.ndarray, reg: _Regions) -> np.ndarray:
    """(p,) bool: a boundary edge of the region meets the open triangle (p, 3, 2) (separating
    axes: the triangle's three edge normals and the segment's normal)."""
    counts = reg.seg_start[region + 1] - reg.seg_start[region]
    owner, item = _ranges(reg.seg_start[region], counts)
    s = reg.seg[item]  # (q, 2, 2)
    t = tri2[owner]  # (q, 3, 2)
    separated = np.zeros(len(owner), bool)
    axes = [t[:, 1] - t[:, 0], t[:, 2] - t[:, 1], t[:, 0] - t[:, 2], s[:, 1] - s[:, 0]]
    for axis in axes:
        normal = np.stack([-axis[:, 1], axis[:, 0]], axis=1)
        tp = np.einsum("qkj,qj->qk", t, normal)
        sp = np.einsum("qkj,qj->qk", s, normal)
        separated |= (sp.max(axis=1) <= tp.min(axis=1)) | (sp.min(axis=1) >= tp.max(axis=1))
    result = np.zeros(len(tri2), bool)
    result[owner[~separated]] = True
    return result


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
    return np.isin(keys[: len(tri)], keys[len(tri) :])


def directed_bounds(
    tri: np.ndarray,
    target: Surface,
    tolerance: float | None = None,
    rtol: float = RTOL,
    atol: float = 0.0,
    floor: float = 0.0,
    max_depth: int = MAX_DEPTH,
) -> tuple[float, float]:
    """Bounds ``(lower, upper)`` metres of ``max_{p in tri} d(p, target)``, ``tri`` (n, 3, 3) metres.

    With ``tolerance`` (metres) only the decision is certified: returns as soon as ``lower >
    tolerance`` or every triangle's bound is <= tolerance (then ``upper <= tolerance``; the
    returned lower bound is what was met on the way). Without it the triangles are refined until
    ``upper <= max(lower, floor) * (1 + rtol) + atol`` or ``max_depth``. ``floor`` (metres): a
    value the caller already has (the other direction), below which nothing is refined."""
    if len(tri) == 0:
        return 0.0, 0.0
    if target.empty:
        return float("inf"), float("inf")
    tri = tri[~_identical(tri, target)]
    index = target.index
    lower, upper_done = 0.0, 0.0
    if tolerance is None and len(tri):
        # A first lower bound from the corners, so that refining aims at a known value.
        corners = np.unique(tri.reshape(-1, 3), axis=0)
        lower = float(index.max_distance(corners))

    def goal() -> float:
        if tolerance is not None:
            return tolerance
        return max(lower, floor) * (1 + rtol) + atol

    for depth in range(max_depth + 1):
        if len(tri) == 0:
            break
        bound = _bound(tri, target, goal())
        open_ = np.flatnonzero(bound > goal())
        if len(open_) and tolerance is not None:
            # Lower bound: exact distances of the open triangles' corners (the farthest first).
            corners = tri[open_].reshape(-1, 3)
            upper = index.upper(corners)
            worst = np.argsort(-upper)[:LOWER_POINTS]
            worst = worst[upper[worst] > tolerance]
            if len(worst):
                lower = max(lower, float(index.refine(corners[worst], upper[worst]).max()))
            if lower > tolerance:
                return lower, float(bound.max())
        done = np.ones(len(tri), bool)
        done[open_] = False
        if done.any():
            upper_done = max(upper_done, float(bound[done].max()))
        if len(open_) == 0:
            break
        if depth == max_depth or 4 * len(open_) > MAX_OPEN:
            # Out of depth or work: the open triangles keep their (valid) bounds.
            upper_done = max(upper_done, float(bound[open_].max()))
            break
        tri = split4(tri[open_])
    return lower, max(lower, upper_done)


def _bound(tri: np.ndarray, target: Surface, goal: float) -> np.ndarray:
    """(n,) metres: an upper bound of each triangle's (n, 3, 3) largest distance to ``target``,
    trying the cheap bounds first and the next only for triangles still above ``goal``."""
    index = target.index
    assert index.tree is not None  # callers check for an empty surface first
    n = len(tri)
    # Planar regions of the faces nearest the centroid (probes, then exact for the rest).
    centre = tri.mean(axis=1)
    k = min(CENTRE_PROBES, index.tree.n)
    _, near = index.tree.query(centre, k=k)
    faces = index.owner[near.reshape(n, k)]
    bound = _planar_bound(tri, target, np.repeat(np.arange(n), k), faces.reshape(-1), cap=None)
    open_ = np.flatnonzero(bound > goal)
    if len(open_):
        nearest = _nearest_face(index, centre[open_])
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
        bound[open_] = np.minimum(bound[open_], _single_triangle_bound(tri[open_], target))
    return bound


def _nearest_face(index: SurfaceIndex, points: np.ndarray) -> np.ndarray:
    """(p,) int64: a face of ``index`` at the least distance from each point (p, 3) metres (the
    faces whose bounding sphere comes within the probes' upper bound are all checked)."""
    from .quality import point_triangle_distance

    upper = index.upper(points)
    squared = (points[:, 0, None] - index.centres[None, :, 0]) ** 2
    squared += (points[:, 1, None] - index.centres[None, :, 1]) ** 2
    squared += (points[:, 2, None] - index.centres[None, :, 2]) ** 2
    rows, cols = np.nonzero(
        np.sqrt(squared) - index.radii[None] <= upper[:, None] * (1 + 1e-9) + 1e-12
    )
    distance = point_triangle_distance(points[rows], index.tri[cols])
    order = np.lexsort((distance, rows))
    first = np.ones(len(order), bool)
    first[1:] = rows[order][1:] != rows[order][:-1]
    nearest = np.zeros(len(points), np.int64)
    nearest[rows[order][first]] = cols[order][first]
    return nearest


def _prepare(side) -> Surface:
    return side if isinstance(side, Surface) else Surface(*side)


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
    low_ab, up_ab = directed_bounds(a.tri, b, rtol=rtol, atol=atol, max_depth=max_depth)
    low_ba, up_ba = directed_bounds(
        b.tri, a, rtol=rtol, atol=atol, floor=low_ab, max_depth=max_depth
    )
    return max(low_ab, low_ba), max(up_ab, up_ba)


def exceeds(a, b, tolerance: float, max_depth: int = MAX_DEPTH) -> bool:
    """Whether the symmetric Hausdorff distance between ``a`` and ``b`` (as in
    :func:`hausdorff_bounds`) may exceed ``tolerance`` (metres): False only when it certainly does
    not (a level whose bound cannot be brought below the tolerance within ``max_depth`` counts as
    exceeding)."""
    a, b = _prepare(a), _prepare(b)
    if a.empty or b.empty:
        return not (a.empty and b.empty)
    for source, target in ((b, a), (a, b)):
        low, up = directed_bounds(source.tri, target, tolerance=tolerance, max_depth=max_depth)
        if up > tolerance or low > tolerance:
            return True
    return False
