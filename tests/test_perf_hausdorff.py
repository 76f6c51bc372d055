"""The error guard's fast paths give exactly what their former formulations gave.

The certified Hausdorff bound (``exporter.mesh.hausdorff``) and the region certificate
(``exporter.mesh.coverage``) were made faster (branch speed-hausdorff): the nearest face skips faces
whose plane is beyond the bound, the last containment tries of the in-plane bound run in one test
on the segments that crossed the first, band widths are measured for all cycles at once, sliver
edges are looked up in one sorted search, sums and extremes over three corners are written out. The former functions are copied here from commit
6f9f0a9 as ``reference_*``; each test runs both and asserts equality bit for bit (the same lower
and upper floats), so a later change that moves a bound fails here. Coordinates are metres
(building-local East/Up/North for the generated buildings, arbitrary for random cycles).
"""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh import coverage, hausdorff
from exporter.mesh.band_kernels import _band_width, _walk
from exporter.mesh.coverage import SLIVER
from exporter.mesh.distance import SurfaceIndex, point_triangle_distance
from exporter.mesh.geometry import cross_rows, isin_int
from exporter.mesh.hausdorff import (
    CANDIDATES,
    LOOSE,
    PLANE_SLACK_MAX,
    SHRINK,
    Surface,
    _dot3,
    _ranges,
    _Regions,
)
from tests.region_reference import reference_region_certificate

# --------------------------------------------------------------------------- reference formulations


def reference_nearest_face(index: SurfaceIndex, points: np.ndarray) -> np.ndarray:
    """(p,) int64: a face of ``index`` at the least distance from each point (p, 3) metres (the
    faces whose bounding sphere comes within the probes' upper bound are all checked)."""
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


def reference_planar_bound(
    tri: np.ndarray, target: Surface, row: np.ndarray, face: np.ndarray, cap
):
    """Step 2: (n,) metres the in-plane bound of each triangle (n, 3, 3) over the regions of its
    candidate faces of ``target`` (``row``, ``face`` pairs: faces near its centroid), inf where
    none holds. A pair counts only if the centroid projected on the region's plane lies in the
    face (a point of the shrunk triangle in the region, see the module doc) and, with ``cap``
    (metres), the plane bound stays below it."""
    reg = target.regions
    n = len(tri)
    bound = np.full(n, np.inf)
    region = reg.region[face]
    keep = reg.slack[region] <= PLANE_SLACK_MAX
    row, face, region = row[keep], face[keep], region[keep]
    if len(row) == 0:
        return bound
    u, v, normal = reg.u[region], reg.v[region], reg.normal[region]
    t = tri[row]
    # (p, 3) in-plane coordinates and heights of the corners, metres
    tx = _dot3(t, u[:, None])
    ty = _dot3(t, v[:, None])
    height = np.abs(_dot3(t, normal[:, None]) - reg.offset[region, None])
    height = np.maximum(np.maximum(height[:, 0], height[:, 1]), height[:, 2])
    cx, cy = tx.sum(1) / 3.0, ty.sum(1) / 3.0
    keep = reference_inside_face(cx, cy, reg.tri2[face])
    if cap is not None:
        keep &= height + reg.slack[region] < cap[row]
    if not keep.any():
        return bound
    # One test per (triangle, region).
    key = row[keep] * (len(reg.normal) + 1) + region[keep]
    _, first = np.unique(key, return_index=True)
    pick = np.flatnonzero(keep)[first]
    row, region, height, tx, ty = row[pick], region[pick], height[pick], tx[pick], ty[pick]
    la = np.hypot(tx[:, 2] - tx[:, 1], ty[:, 2] - ty[:, 1])  # side opposite each corner
    lb = np.hypot(tx[:, 0] - tx[:, 2], ty[:, 0] - ty[:, 2])
    lc = np.hypot(tx[:, 1] - tx[:, 0], ty[:, 1] - ty[:, 0])
    perimeter = la + lb + lc
    area2 = np.abs(
        (tx[:, 1] - tx[:, 0]) * (ty[:, 2] - ty[:, 0])
        - (ty[:, 1] - ty[:, 0]) * (tx[:, 2] - tx[:, 0])
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        ix = (la * tx[:, 0] + lb * tx[:, 1] + lc * tx[:, 2]) / perimeter
        iy = (la * ty[:, 0] + lb * ty[:, 1] + lc * ty[:, 2]) / perimeter
        inradius = area2 / perimeter
    reach = np.sqrt(np.max((tx - ix[:, None]) ** 2 + (ty - iy[:, None]) ** 2, axis=1))
    size = np.max(np.abs(tx), axis=1) + np.max(np.abs(ty), axis=1) + reach
    # Too thin to shrink safely against rounding: left to the other bounds.
    fine = np.isfinite(inradius) & (inradius > 1e-9 * size)
    inradius = np.where(fine, inradius, 1.0)
    value = np.full(len(row), np.inf)
    # First shrunk about the incentre by rounding only; then, for triangles crossed by boundary
    # edges (float noise: a level edge along a region's outline), each side moved in by what
    # the crossing edges need of it.
    todo = np.flatnonzero(fine)
    ratio = np.full(len(todo), SHRINK)
    sx = ix[todo, None] + (tx[todo] - ix[todo, None]) * (1.0 - SHRINK)
    sy = iy[todo, None] + (ty[todo] - iy[todo, None]) * (1.0 - SHRINK)
    owner, seg = reference_boundary_crosses(sx, sy, region[todo], reg, pairs=True)
    inside = np.ones(len(todo), bool)
    inside[owner] = False
    rho = 2.0 * ratio * reach[todo] + reg.gap[region[todo]]
    value[todo[inside]] = (np.sqrt(height[todo] ** 2 + rho**2) + reg.slack[region[todo]])[inside]
    if len(owner):
        retry = np.unique(owner)
        moved = reference_sides_in(tx[todo], ty[todo], inradius[todo], owner, seg, reg, retry)
        if moved is not None:
            pick, mx, my, shift = moved
            crossed = reference_boundary_crosses(mx, my, region[todo[pick]], reg)
            ok = ~crossed
            which = todo[pick[ok]]
            rho = 2.0 * shift[ok] + reg.gap[region[which]]
            value[which] = np.sqrt(height[which] ** 2 + rho**2) + reg.slack[region[which]]
    # Last tries: shrunk about the incentre by a share of the target's diagonal.
    for loose in LOOSE:
        delta = np.maximum(SHRINK * inradius, loose * reg.scale)
        todo = np.flatnonzero(fine & ~np.isfinite(value) & (delta < 0.5 * inradius))
        if len(todo) == 0:
            break
        ratio = delta[todo] / inradius[todo]
        sx = ix[todo, None] + (tx[todo] - ix[todo, None]) * (1.0 - ratio[:, None])
        sy = iy[todo, None] + (ty[todo] - iy[todo, None]) * (1.0 - ratio[:, None])
        inside = ~reference_boundary_crosses(sx, sy, region[todo], reg)
        rho = 2.0 * ratio * reach[todo] + reg.gap[region[todo]]
        value[todo[inside]] = (np.sqrt(height[todo] ** 2 + rho**2) + reg.slack[region[todo]])[
            inside
        ]
    np.minimum.at(bound, row, value)
    return bound


def reference_inside_face(x: np.ndarray, y: np.ndarray, tri2: np.ndarray) -> np.ndarray:
    """(p,) bool: the point (x, y) lies in the 2-D triangle (p, 3, 2) (closed, with a 1e-9
    relative margin: a point wrongly inside lies that close to an edge of the face; if that edge
    bounds the region, the boundary test sees it cross the shrunk triangle)."""
    pos = np.ones(len(x), bool)
    neg = np.ones(len(x), bool)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        ex, ey = tri2[:, j, 0] - tri2[:, i, 0], tri2[:, j, 1] - tri2[:, i, 1]
        wx, wy = x - tri2[:, i, 0], y - tri2[:, i, 1]
        side = ex * wy - ey * wx
        margin = (
            1e-9 * (np.abs(ex) + np.abs(ey)) * (np.abs(wx) + np.abs(wy) + np.abs(ex) + np.abs(ey))
        )
        pos &= side >= -margin
        neg &= side <= margin
    return pos | neg


def reference_sides_in(tx, ty, inradius, owner, seg, reg, retry):
    """Triangles (p, 3) metres with each side moved inwards just past the boundary edges that
    cross them (``owner``, ``seg`` pairs): every crossing edge is charged to the side it enters
    least; a side moves by the largest charge (at least ``SHRINK`` x the inradius). Returns the
    rows ``retry`` kept (the moves stay below a quarter of the inradius), their new corners (q, 3)
    and each one's largest corner displacement (metres; d(., moved triangle) is convex, so every
    point of the triangle is that close to it), or None."""
    # Inward unit normals of the sides i -> i+1 (side i is opposite corner i+2).
    ex = tx[:, [1, 2, 0]] - tx  # np.roll(tx, -1, axis=1), without its Python overhead
    ey = ty[:, [1, 2, 0]] - ty
    length = np.hypot(ex, ey)
    orient = np.sign(
        (tx[:, 1] - tx[:, 0]) * (ty[:, 2] - ty[:, 0])
        - (ty[:, 1] - ty[:, 0]) * (tx[:, 2] - tx[:, 0])
    )
    nx, ny = -ey / length * orient[:, None], ex / length * orient[:, None]
    x0, y0 = reg.seg_x0[seg], reg.seg_y0[seg]
    x1, y1 = reg.seg_x1[seg], reg.seg_y1[seg]
    depth = np.maximum(
        (x0[:, None] - tx[owner]) * nx[owner] + (y0[:, None] - ty[owner]) * ny[owner],
        (x1[:, None] - tx[owner]) * nx[owner] + (y1[:, None] - ty[owner]) * ny[owner],
    )  # (q, 3): how far each crossing edge enters past each side
    side = np.argmin(depth, axis=1)
    need = np.zeros(tx.shape)
    np.maximum.at(need, (owner, side), depth[np.arange(len(owner)), side])
    need = need[retry]
    r = inradius[retry]
    size = np.abs(tx[retry]).max(axis=-1) + np.abs(ty[retry]).max(axis=-1)
    delta = np.maximum(need * (1 + 1e-6) + 1e-12 * size[:, None], SHRINK * r[:, None])
    keep = (delta < 0.25 * r[:, None]).all(axis=1)
    if not keep.any():
        return None
    retry, delta = retry[keep], delta[keep]
    px, py = tx[retry], ty[retry]
    nxr, nyr = nx[retry], ny[retry]
    # Corner i lies on sides i-1 and i: solve n . x = n . p + delta for both moved sides.
    back = [2, 0, 1]  # np.roll(., 1, axis=1)
    a1x, a1y = nxr[:, back], nyr[:, back]
    c1 = a1x * px[:, back] + a1y * py[:, back] + delta[:, back]
    c2 = nxr * px + nyr * py + delta
    det = a1x * nyr - a1y * nxr
    mx = (c1 * nyr - a1y * c2) / det
    my = (a1x * c2 - c1 * nxr) / det
    shift = np.sqrt((mx - px) ** 2 + (my - py) ** 2).max(axis=-1)
    good = np.isfinite(shift)
    return retry[good], mx[good], my[good], shift[good]


def reference_boundary_crosses(
    tx: np.ndarray, ty: np.ndarray, region: np.ndarray, reg: _Regions, pairs: bool = False
):
    """(p,) bool: a boundary edge of the region meets the open triangle with corners (tx, ty)
    (p, 3) metres (bounding boxes first, then separating axes: the triangle's three edge
    normals and the segment's normal)."""
    counts = reg.seg_start[region + 1] - reg.seg_start[region]
    owner, item = _ranges(reg.seg_start[region], counts)
    low_x, high_x = np.min(tx, axis=1), np.max(tx, axis=1)
    low_y, high_y = np.min(ty, axis=1), np.max(ty, axis=1)
    x0, y0, x1, y1 = reg.seg_x0[item], reg.seg_y0[item], reg.seg_x1[item], reg.seg_y1[item]
    near = (
        (np.maximum(x0, x1) > low_x[owner])
        & (np.minimum(x0, x1) < high_x[owner])
        & (np.maximum(y0, y1) > low_y[owner])
        & (np.minimum(y0, y1) < high_y[owner])
    )
    owner, item = owner[near], item[near]
    x0, y0, x1, y1 = x0[near], y0[near], x1[near], y1[near]
    px, py = tx[owner], ty[owner]  # (q, 3)
    separated = np.zeros(len(owner), bool)
    for i, j in ((0, 1), (1, 2), (2, 0), (-1, -1)):
        if i < 0:
            nx, ny = y0 - y1, x1 - x0
        else:
            nx, ny = py[:, i] - py[:, j], px[:, j] - px[:, i]
        t0 = px[:, 0] * nx + py[:, 0] * ny
        t1 = px[:, 1] * nx + py[:, 1] * ny
        t2 = px[:, 2] * nx + py[:, 2] * ny
        s0, s1 = x0 * nx + y0 * ny, x1 * nx + y1 * ny
        separated |= (np.maximum(s0, s1) <= np.minimum(np.minimum(t0, t1), t2)) | (
            np.minimum(s0, s1) >= np.maximum(np.maximum(t0, t1), t2)
        )
    if pairs:
        return owner[~separated], item[~separated]
    result = np.zeros(len(tx), bool)
    result[owner[~separated]] = True
    return result


def reference_band_width(xy: list, sides: list) -> float | None:
    """Width (metres) across the chord of a cycle of the chain difference that is a band: the
    cycle (its vertices ``xy``, 2-D in-plane metres, edge i from vertex i to i + 1) splits at its
    two farthest-apart vertices into two runs, each monotone along the chord, one of the level's
    boundary edges and the other of the source's (``sides`` +1 / -1 per edge); None otherwise.
    Plain floats: cycles have a handful of edges."""
    n = len(xy)
    best, i, j = -1.0, 0, 0
    for p in range(n):
        xp, yp = xy[p]
        for q in range(p + 1, n):
            d = (xy[q][0] - xp) ** 2 + (xy[q][1] - yp) ** 2
            if d > best:
                best, i, j = d, p, q
    if best <= 0.0:
        return None
    length = best**0.5
    ax, ay = (xy[j][0] - xy[i][0]) / length, (xy[j][1] - xy[i][1]) / length
    t = [(x - xy[i][0]) * ax + (y - xy[i][1]) * ay for x, y in xy]
    h = [(y - xy[i][1]) * ax - (x - xy[i][0]) * ay for x, y in xy]
    first = [(i + m) % n for m in range((j - i) % n)]  # edges i -> ... -> j
    second = [(j + m) % n for m in range((i - j) % n)]  # edges j -> ... -> i
    slack = 1e-12 * length
    if any(t[(e + 1) % n] - t[e] < -slack for e in first):
        return None
    if any(t[e] - t[(e + 1) % n] < -slack for e in second):
        return None
    kinds = {sides[e] for e in first}, {sides[e] for e in second}
    if kinds not in (({1}, {-1}), ({-1}, {1})):
        return None
    return max(h) - min(h)


def reference_bands(diff: np.ndarray, points: np.ndarray, normals: np.ndarray, good, width) -> None:
    """Step 4: the cycles of the chain difference ``diff`` (:func:`_chain_difference` rows) per
    region; a region whose cycles are not all bands is marked not ``good``; ``width`` (r,) gets
    each region's widest band (metres)."""
    order = np.argsort(diff[:, 0], kind="stable")
    diff = diff[order]
    # In-plane coordinates of every edge's start on its region's plane.
    n = normals[diff[:, 0]]
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = cross_rows(n, helper)
    u /= np.sqrt((u**2).sum(1))[:, None]
    v = cross_rows(n, u)
    start = points[diff[:, 1]]
    xy = np.column_stack([(start * u).sum(1), (start * v).sum(1)]).tolist()
    starts = np.flatnonzero(np.r_[True, diff[1:, 0] != diff[:-1, 0]])
    ends = np.r_[starts[1:], len(diff)]
    for s, e in zip(starts.tolist(), ends.tolist()):
        g = int(diff[s, 0])
        if not good[g]:
            continue
        rows = diff[s:e].tolist()
        cycles = reference_cycles(rows)
        if cycles is None or any(row[3] == 0 for row in rows):
            good[g] = False
            continue
        for cycle in cycles:
            band = reference_band_width([xy[s + i] for i in cycle], [rows[i][3] for i in cycle])
            if band is None:
                good[g] = False
                break
            width[g] = max(width[g], band)


def reference_slivers(points: np.ndarray, faces: np.ndarray, done: np.ndarray, budget: float):
    """Step 6: ``(width, settled)``: the open faces of one side (welded ids ``faces`` (m, 3),
    ``done`` (m,) bool) that are slivers lying along settled faces' edges, and the metres they add.

    A collapse onto a line leaves collinear triangles that fill a T-junction (corners a, m, b with
    m on the segment ab). Every point of a triangle lies within its least altitude h of its
    longest edge ab, and the polyline a-m-b lies within h of ab. So when ab is an edge of a
    settled face, or both other edges are, every point of the sliver is within 2h of a point of a
    settled face, hence within 2h + the settled bound of the other mesh. Slivers whose 2h exceeds
    ``budget`` (metres) or ``SLIVER`` x their longest edge stay open."""
    settled = np.zeros(len(faces), bool)
    open_ = np.flatnonzero(~done)
    if len(open_) == 0 or budget <= 0:
        return 0.0, settled
    t = points[faces[open_]]
    edges = t[:, [1, 2, 0]] - t  # edge i runs from corner i to corner i + 1
    lengths = np.sqrt((edges**2).sum(-1))
    longest = lengths.argmax(axis=1)
    top = lengths[np.arange(len(open_)), longest]
    area2 = np.sqrt((cross_rows(edges[:, 0], -edges[:, 2]) ** 2).sum(1))
    width = 2 * area2 / np.maximum(top, 1e-300)  # twice the least altitude
    thin = (width <= budget) & (width <= SLIVER * top) & (top > 0)
    if not thin.any():
        return 0.0, settled
    k = int(faces.max()) + 1
    kept = faces[done]
    pairs = np.sort(kept[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    known = np.unique(pairs[:, 0] * k + pairs[:, 1])
    f = faces[open_]
    rows = np.arange(len(open_))

    def on_settled(i: np.ndarray) -> np.ndarray:
        a, b = f[rows, i], f[rows, (i + 1) % 3]
        return np.isin(np.minimum(a, b) * k + np.maximum(a, b), known)

    along = on_settled(longest) | (on_settled((longest + 1) % 3) & on_settled((longest + 2) % 3))
    ok = thin & along
    settled[open_[ok]] = True
    return (float(width[ok].max()) if ok.any() else 0.0), settled


def reference_segment_distance(
    points: np.ndarray, start: np.ndarray, end: np.ndarray
) -> np.ndarray:
    """Distance (...) metres from points (..., 3) to segments start-end (..., 3) (broadcast)."""
    d = end - start
    w = points - start
    d = np.broadcast_to(d, w.shape)
    length2 = (d * d).sum(-1)
    t = np.clip(
        np.divide((w * d).sum(-1), length2, out=np.zeros_like(length2), where=length2 > 0), 0.0, 1.0
    )
    return np.sqrt(((w - t[..., None] * d) ** 2).sum(-1))


def reference_chain_bound(tri: np.ndarray, target: Surface, faces: np.ndarray) -> np.ndarray:
    """(n,) metres: ``min_chain max_v d(v, chain segment) + slack`` over the chains of the edges
    of each triangle's candidate ``faces`` (n, c) of ``target``."""
    chains = target.chains
    n = len(tri)
    cand = chains.face_chain[faces].reshape(n, -1)  # (n, 3c)
    d = (
        reference_segment_distance(
            tri[:, None, :, :], chains.start[cand][:, :, None], chains.end[cand][:, :, None]
        ).max(axis=2)
        + chains.slack[cand]
    )
    return d.min(axis=1)


def reference_single_triangle_bound(
    tri: np.ndarray, target: Surface, nearest: np.ndarray
) -> np.ndarray:
    """Step 1: (n,) metres ``min_t max_v d(v, t)`` over candidate triangles t of ``target`` (the
    owners of the nearest probes of the vertices and centroid, and the face ``nearest`` (n,) to
    the centroid)."""
    index = target.index
    assert index.tree is not None  # callers check for an empty surface first
    n = len(tri)
    points = np.concatenate([tri, tri.mean(axis=1, keepdims=True)], axis=1)  # (n, 4, 3)
    k = min(CANDIDATES, index.tree.n)
    _, probes = index.tree.query(points.reshape(-1, 3), k=k)
    owners = np.sort(
        np.column_stack([index.owner[probes.reshape(n, -1)], nearest]), axis=1
    )  # (n, 4k + 1)
    fresh = np.ones(owners.shape, dtype=bool)
    fresh[:, 1:] = owners[:, 1:] != owners[:, :-1]
    row = np.repeat(np.arange(n), fresh.sum(axis=1))
    cand = owners[fresh]
    # (pairs, 3): each vertex's distance to the candidate triangle; slivers, whose distances
    # lose digits (Ericson's barycentric products cancel), are no candidates.
    d = point_triangle_distance(tri[row], index.tri[cand][:, None])
    d[~target.trusted[cand]] = np.inf
    starts = np.concatenate([[0], np.cumsum(fresh.sum(axis=1))[:-1]])
    return np.minimum.reduceat(d.max(axis=1), starts)


def reference_cycles(rows: list) -> list | None:
    """The cycles of one region's chain difference (``(region, a, b, side)`` rows), walked so
    that at a vertex where several edges leave, the walk turns onto the other side's edge (two
    bands meeting at a corner); None when that is ambiguous or a walk does not close."""
    leaving: dict[int, list[int]] = {}
    for i, (_, va, _vb, _side) in enumerate(rows):
        leaving.setdefault(va, []).append(i)
    used = [False] * len(rows)
    cycles = []
    for first in range(len(rows)):
        if used[first]:
            continue
        cycle, i = [], first
        while True:
            used[i] = True
            cycle.append(i)
            if len(cycle) > coverage.MAX_BAND_EDGES:
                return None
            at, side = rows[i][2], rows[i][3]
            options = [j for j in leaving.get(at, ()) if not used[j] or j == first]
            if first in options:
                break
            if len(options) > 1:
                options = [j for j in options if rows[j][3] != side]
            if len(options) != 1:
                return None
            i = options[0]
        cycles.append(cycle)
    return cycles


def reference_straight_runs(
    self, seg_region: np.ndarray, seg: np.ndarray, ends: np.ndarray, oriented: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Boundary runs a -> b -> ... -> c whose inner vertices lie within ``hausdorff.T_JUNCTION`` x |ac|
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
    outgoing: dict[tuple[int, int], list[int]] = {}
    incoming: dict[tuple[int, int], list[int]] = {}
    for i, (g, (va, vb), ok) in enumerate(
        zip(seg_region.tolist(), ends.tolist(), oriented.tolist())
    ):
        if ok:
            outgoing.setdefault((g, va), []).append(i)
            incoming.setdefault((g, vb), []).append(i)

    def through(g, v):
        out, into = outgoing.get((g, v), ()), incoming.get((g, v), ())
        return out[0] if len(out) == 1 and len(into) == 1 else None

    points = seg.tolist()
    used = np.zeros(len(seg), bool)
    merged_region, merged = [], []
    order = sorted(range(len(seg)), key=lambda i: through(seg_region[i], ends[i, 0]) is not None)
    for i in order:
        if used[i]:
            continue
        used[i] = True
        g = int(seg_region[i])
        if not oriented[i]:
            merged_region.append(g)
            merged.append(points[i])
            continue
        start, end = points[i][0], points[i][1]
        inner: list[list[float]] = []
        j = i
        while True:
            nxt = through(g, int(ends[j, 1]))
            if nxt is None or used[nxt]:
                break
            candidate = points[nxt][1]
            cx, cy = candidate[0] - start[0], candidate[1] - start[1]
            length = (cx * cx + cy * cy) ** 0.5
            offsets = [
                (cx * (q[1] - start[1]) - cy * (q[0] - start[0])) / length if length > 0 else 1e300
                for q in inner + [end]
            ]
            # Inward (left, the region's side) only: the new region then contains the old
            # one, and is within the largest offset of it.
            if max(offsets) > hausdorff.T_JUNCTION * length or min(offsets) < -1e-9 * length:
                break
            inner.append(end)
            end = candidate
            used[nxt] = True
            j = nxt
        if inner:
            cx, cy = end[0] - start[0], end[1] - start[1]
            length = (cx * cx + cy * cy) ** 0.5
            offset = max(
                abs(cx * (q[1] - start[1]) - cy * (q[0] - start[0])) / length for q in inner
            )
            self.gap[g] = max(self.gap[g], offset)
        merged_region.append(g)
        merged.append([start, end])
    return np.array(merged_region, np.int64), np.array(merged, np.float64).reshape(-1, 2, 2)


# --------------------------------------------------------------------------- tests


def _cycle(rng, n, band):
    """A random cycle of n vertices (2-D metres) and its sides: a thin band along a random chord
    (a run of +1 edges out, -1 edges back) or, with ``band`` False, random points and sides."""
    if not band or n < 3:
        return rng.normal(size=(n, 2)) * 10, rng.choice([-1, 1], size=n)
    out = rng.integers(1, n)
    t = np.concatenate([np.sort(rng.random(out + 1)), np.sort(rng.random(n - out - 1))[::-1]])
    t[0], t[out] = 0.0, 1.0
    h = rng.normal(size=n) * rng.choice([1e-9, 1e-4, 0.1])
    angle = rng.random() * 2 * np.pi
    axis = np.array([np.cos(angle), np.sin(angle)])
    normal = np.array([-axis[1], axis[0]])
    xy = rng.normal(size=2) * 50 + 20 * t[:, None] * axis + h[:, None] * normal
    sides = np.where(np.arange(n) < out, 1, -1) * rng.choice([-1, 1])
    if rng.random() < 0.2:
        sides[rng.integers(n)] *= -1
    if rng.random() < 0.1:
        xy[rng.integers(n)] = xy[rng.integers(n)]  # repeated vertices: ties in the farthest pair
    return xy, sides


@pytest.mark.parametrize("seed", range(4))
def test_band_widths_of_many_cycles_equal_the_loop(seed):
    rng = np.random.default_rng(seed)
    cycles = [_cycle(rng, int(rng.integers(1, 40)), rng.random() < 0.8) for _ in range(300)]
    cycles.append((np.zeros((4, 2)), np.array([1, 1, -1, -1])))  # all vertices at one point
    fast = [_band_width(xy[:, 0].copy(), xy[:, 1].copy(), sides, 0.5) for xy, sides in cycles]
    accepted = 0
    for (points, side), value in zip(cycles, fast):
        expected = reference_band_width(points.tolist(), side.tolist())
        if expected is None:
            assert np.isnan(value)
        else:
            assert value == expected
            accepted += 1
    assert accepted > 100  # the bands were bands


def _former(monkeypatch):
    """Swap the former formulations into the modules (undone by ``monkeypatch``)."""
    monkeypatch.setattr(
        hausdorff,
        "_nearest_face",
        lambda target, points: reference_nearest_face(target.index, points),
    )
    monkeypatch.setattr(hausdorff, "_planar_bound", reference_planar_bound)
    monkeypatch.setattr(hausdorff._Regions, "_straight_runs", reference_straight_runs)
    monkeypatch.setattr(hausdorff, "_chain_bound", reference_chain_bound)
    monkeypatch.setattr(hausdorff, "_single_triangle_bound", reference_single_triangle_bound)
    monkeypatch.setattr(
        coverage,
        "region_certificate",
        lambda level, source, weld=coverage.WELD_M, max_bound=np.inf: reference_region_certificate(
            level, source, reference_bands, reference_slivers, weld, max_bound
        ),
    )


def test_the_guard_gives_the_former_bounds_on_a_generated_tile(tmp_path, monkeypatch):
    # Every level the guard certifies (and the manifest's bounds of the kept levels) on
    # VWorld-like buildings: the same (lower, upper) floats, or the same refusal.
    import exporter.simplify as simplify
    from exporter import samplegen
    from exporter.config import Config
    from exporter.readers import load_entry, scan_folder
    from exporter.simplify.guard import Reference, certify

    samplegen.generate_tile(tmp_path, count=24, seed=3, atlas_size=16)
    config = Config()
    calls = []

    def spy(reference, positions, faces, tolerance):
        calls.append((reference.positions, reference.faces, positions, faces, tolerance))
        return certify(reference, positions, faces, tolerance)

    with monkeypatch.context() as patch:
        patch.setattr(simplify, "certify", spy)
        for entry in scan_folder(tmp_path, config.readers).entries:
            building = load_entry(entry, config.readers)
            simplify.build_mesh_chain(building.parts, config.lods, config.simplify)
    assert len(calls) >= 8

    def run():
        out = []
        for ref_positions, ref_faces, positions, faces, tolerance in calls:
            reference = Reference(ref_positions, ref_faces)
            out.append(certify(reference, positions, faces, tolerance))
            out.append(hausdorff.hausdorff_bounds(reference.surface, (positions, faces)))
        return out

    fast = run()
    with monkeypatch.context() as patch:
        _former(patch)
        former = run()
    assert fast == former
    assert any(value is not None for value in fast[::2])


def test_the_former_bounds_on_random_soups(monkeypatch):
    # Unstructured input (no planar regions to speak of, slivers, open edges) both ways.
    rng = np.random.default_rng(11)
    for _ in range(6):
        a = (rng.random((60, 3)), rng.integers(0, 60, size=(40, 3)))
        b = (a[0] + rng.normal(size=(60, 3)) * 0.02, a[1])
        fast = hausdorff.hausdorff_bounds(Surface(*a), b)
        with monkeypatch.context() as patch:
            _former(patch)
            former = hausdorff.hausdorff_bounds(Surface(*a), b)
        assert fast == former


def compiled_cycles(rows: list) -> list | None:
    """The compiled walk's cycles as lists of row numbers in walk order (None: refused)."""
    table = np.array(rows, np.int64).reshape(-1, 4)
    cycle_of = np.empty(len(rows), np.int64)
    order = np.empty(len(rows), np.int64)
    by_start = np.argsort(table[:, 1], kind="stable")
    count = _walk(
        table[:, 1].copy(),
        table[:, 2].copy(),
        table[:, 3].copy(),
        by_start,
        table[by_start, 1].copy(),
        0,
        len(rows),
        coverage.MAX_BAND_EDGES,
        cycle_of,
        order,
    )
    if count < 0:
        return None
    cycles: list[list[int]] = [[] for _ in range(count)]
    for row in np.lexsort((order, cycle_of)).tolist():
        cycles[cycle_of[row]].append(row)
    return cycles


@pytest.mark.parametrize("seed", range(3))
def test_cycles_equal_the_former_walk(seed):
    # Random chain differences: closed loops (one edge leaving each vertex), loops meeting at a
    # corner (two leaving), dangling and branching walks; long loops past MAX_BAND_EDGES.
    rng = np.random.default_rng(seed)
    closed = 0
    for _ in range(400):
        rows = []
        for _loop in range(int(rng.integers(1, 4))):
            n = int(rng.integers(2, 80 if rng.random() < 0.1 else 12))
            ring = rng.choice(100, size=n, replace=False).tolist()
            side = int(rng.choice([-1, 1]))
            rows += [[0, ring[i], ring[(i + 1) % n], side] for i in range(n)]
        for _extra in range(int(rng.integers(0, 3)) if rng.random() < 0.5 else 0):
            rows.append(
                [0, int(rng.integers(100)), int(rng.integers(100)), int(rng.choice([-1, 1]))]
            )
        rng.shuffle(rows)
        expected = reference_cycles(rows)
        assert compiled_cycles(rows) == expected
        closed += expected is not None
    assert closed > 100


@pytest.mark.parametrize("seed", range(4))
def test_isin_int_is_numpys_isin(seed):
    """The face-key membership of region_certificate and _identical: np.isin's answer, with
    repeats, negative and extreme keys, and empty sides."""
    rng = np.random.default_rng(seed)
    extremes = np.array([np.iinfo(np.int64).min, -1, 0, np.iinfo(np.int64).max])
    for n, m in ((0, 5), (5, 0), (1, 1), (40, 7), (300, 300)):
        values = np.concatenate([rng.integers(-50, 50, n), extremes[: min(n, 4)]])
        of = np.concatenate([rng.integers(-50, 50, m), extremes[rng.integers(0, 4, min(m, 2))]])
        assert np.array_equal(isin_int(values, of), np.isin(values, of))
        assert isin_int(values, of).dtype == bool and len(isin_int(values, of)) == len(values)


@pytest.mark.parametrize("seed", range(4))
def test_components_are_scipys_connected_components(seed):
    """_Regions' plane merge, _Chains and _spanning label components by the union-find: scipy's
    count and numbering (components in the order of their lowest node), self-loops and repeated
    edges included; _spanning's edges join the same components."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rng = np.random.default_rng(seed)
    for n, edges in ((0, 0), (1, 0), (5, 0), (30, 12), (200, 150), (200, 400)):
        rows, cols = rng.integers(0, max(n, 1), (2, edges))
        graph = coo_matrix((np.ones(edges, bool), (rows, cols)), shape=(n, n))
        count, label = connected_components(graph, directed=False)
        got_count, got = hausdorff._components(n, rows, cols)
        assert got_count == count and np.array_equal(got, label) and got.dtype == np.int64
        if n:
            (left,), (right,) = hausdorff._spanning(rows, cols, n)
            spanned = coo_matrix((np.ones(len(left), bool), (left, right)), shape=(n, n))
            assert np.array_equal(connected_components(spanned, directed=False)[1], label)
