"""The in-plane bound of the certified Hausdorff distance, compiled (step 2 of
:mod:`exporter.mesh.hausdorff`, which holds the argument; this is its arithmetic).

For each (triangle, candidate face) pair: the face's planar region (flat within
``plane_slack_max``), the triangle's corners in the region's plane axes and their largest height
over its plane; the pair counts when the centroid's projection lies in the face (1e-9 relative
margin) and, with a cap, the plane bound stays under it; each (triangle, region) is bounded once.
A triangle shrunk about its incentre by ``shrink`` that no boundary segment of the region crosses
(separating axes) lies in the region: bound ``sqrt(h^2 + rho^2) + slack``, rho = 2 x ratio x
its reach + the region's gap. When segments cross it, each side is moved in just past the
segments charged to it (the side they enter least) and the moved triangle tested against every
segment of the region; then shrinks by shares ``loose`` of the target's diagonal, tested against
the segments that crossed the first copy. Every float operation is the former numpy form's, in
its order (``np.hypot`` is libm's ``hypot`` in both), so the bounds are the same bits
(tests/test_perf_hausdorff.py). In-plane metres.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import kernel
from .sorted_kernels import stable_order


@kernel
def _crosses(px, py, x0, y0, x1, y1):  # pragma: no cover - compiled
    """The segment (x0, y0)-(x1, y1) meets the open triangle (px, py) (3,): bounding boxes,
    then separating axes (the triangle's edge normals, then the segment's)."""
    low_x, high_x = min(min(px[0], px[1]), px[2]), max(max(px[0], px[1]), px[2])
    low_y, high_y = min(min(py[0], py[1]), py[2]), max(max(py[0], py[1]), py[2])
    if not (max(x0, x1) > low_x and min(x0, x1) < high_x):
        return False
    if not (max(y0, y1) > low_y and min(y0, y1) < high_y):
        return False
    for a in range(4):
        if a < 3:
            nx, ny = py[a] - py[(a + 1) % 3], px[(a + 1) % 3] - px[a]
        else:
            nx, ny = y0 - y1, x1 - x0
        t0 = px[0] * nx + py[0] * ny
        t1 = px[1] * nx + py[1] * ny
        t2 = px[2] * nx + py[2] * ny
        s0, s1 = x0 * nx + y0 * ny, x1 * nx + y1 * ny
        if max(s0, s1) <= min(min(t0, t1), t2) or min(s0, s1) >= max(max(t0, t1), t2):
            return False
    return True


@kernel
def _inside_face(x, y, tri2):  # pragma: no cover - compiled
    """(x, y) lies in the closed 2-D triangle ``tri2`` (3, 2), with a 1e-9 relative margin."""
    pos = neg = True
    for i in range(3):
        j = (i + 1) % 3
        ex, ey = tri2[j, 0] - tri2[i, 0], tri2[j, 1] - tri2[i, 1]
        wx, wy = x - tri2[i, 0], y - tri2[i, 1]
        side = ex * wy - ey * wx
        margin = 1e-9 * (abs(ex) + abs(ey)) * (abs(wx) + abs(wy) + abs(ex) + abs(ey))
        pos &= side >= -margin
        neg &= side <= margin
    return pos or neg


@kernel
def _sides_in(tx, ty, inradius, crossing, count, seg, shrink, mx, my):  # pragma: no cover
    """Each side moved in past the ``count`` crossing segments charged to it; the moved corners
    in ``mx``, ``my``; returns the largest corner move (metres), or -1 when a move reaches a
    quarter of the inradius or is not finite."""
    nx = np.empty(3)
    ny = np.empty(3)
    orient = np.sign((tx[1] - tx[0]) * (ty[2] - ty[0]) - (ty[1] - ty[0]) * (tx[2] - tx[0]))
    for i in range(3):
        ex, ey = tx[(i + 1) % 3] - tx[i], ty[(i + 1) % 3] - ty[i]
        length = np.hypot(ex, ey)
        nx[i], ny[i] = -ey / length * orient, ex / length * orient
    need = np.zeros(3)
    depth = np.empty(3)
    for c in range(count):
        s = crossing[c]
        x0, y0, x1, y1 = seg[0, s], seg[1, s], seg[2, s], seg[3, s]
        for i in range(3):
            depth[i] = max(
                (x0 - tx[i]) * nx[i] + (y0 - ty[i]) * ny[i],
                (x1 - tx[i]) * nx[i] + (y1 - ty[i]) * ny[i],
            )
        side = 0
        for i in (1, 2):
            if depth[i] < depth[side]:
                side = i
        need[side] = max(need[side], depth[side])
    size = max(max(abs(tx[0]), abs(tx[1])), abs(tx[2])) + max(
        max(abs(ty[0]), abs(ty[1])), abs(ty[2])
    )
    delta = np.empty(3)
    for i in range(3):
        delta[i] = max(need[i] * (1 + 1e-6) + 1e-12 * size, shrink * inradius)
        if not delta[i] < 0.25 * inradius:
            return -1.0
    shift = -np.inf
    for i in range(3):
        b = (i + 2) % 3  # corner i lies on sides i - 1 and i
        c1 = nx[b] * tx[b] + ny[b] * ty[b] + delta[b]
        c2 = nx[i] * tx[i] + ny[i] * ty[i] + delta[i]
        det = nx[b] * ny[i] - ny[b] * nx[i]
        mx[i] = (c1 * ny[i] - ny[b] * c2) / det
        my[i] = (nx[b] * c2 - c1 * nx[i]) / det
        d = math.sqrt((mx[i] - tx[i]) ** 2 + (my[i] - ty[i]) ** 2)
        if not np.isfinite(d):  # NaN or inf (parallel sides): no move
            return -1.0
        shift = max(shift, d)
    return shift


@kernel
def _value(tx, ty, height, slack, gap, seg, lo, hi, scale, shrink, loose):  # pragma: no cover
    """The in-plane bound (metres) of one triangle (tx, ty) (3,) in one region whose boundary
    segments are ``seg[:, lo:hi]`` (rows x0, y0, x1, y1), inf where none holds."""
    la = np.hypot(tx[2] - tx[1], ty[2] - ty[1])  # side opposite each corner
    lb = np.hypot(tx[0] - tx[2], ty[0] - ty[2])
    lc = np.hypot(tx[1] - tx[0], ty[1] - ty[0])
    perimeter = la + lb + lc
    area2 = abs((tx[1] - tx[0]) * (ty[2] - ty[0]) - (ty[1] - ty[0]) * (tx[2] - tx[0]))
    ix = (la * tx[0] + lb * tx[1] + lc * tx[2]) / perimeter
    iy = (la * ty[0] + lb * ty[1] + lc * ty[2]) / perimeter
    inradius = area2 / perimeter
    reach2 = -np.inf
    for k in range(3):
        reach2 = max(reach2, (tx[k] - ix) ** 2 + (ty[k] - iy) ** 2)
    reach = math.sqrt(reach2)
    size = max(max(abs(tx[0]), abs(tx[1])), abs(tx[2]))
    size = size + max(max(abs(ty[0]), abs(ty[1])), abs(ty[2])) + reach
    if not (np.isfinite(inradius) and inradius > 1e-9 * size):
        return np.inf  # too thin to shrink safely against rounding
    sx = np.empty(3)
    sy = np.empty(3)
    for k in range(3):
        sx[k] = ix + (tx[k] - ix) * (1.0 - shrink)
        sy[k] = iy + (ty[k] - iy) * (1.0 - shrink)
    crossing = np.empty(hi - lo, np.int64)
    count = 0
    for s in range(lo, hi):
        if _crosses(sx, sy, seg[0, s], seg[1, s], seg[2, s], seg[3, s]):
            crossing[count] = s
            count += 1
    if count == 0:
        rho = 2.0 * shrink * reach + gap
        return math.sqrt(height**2 + rho**2) + slack
    shift = _sides_in(tx, ty, inradius, crossing, count, seg, shrink, sx, sy)
    if shift >= 0:
        crossed = False
        for s in range(lo, hi):
            if _crosses(sx, sy, seg[0, s], seg[1, s], seg[2, s], seg[3, s]):
                crossed = True
                break
        if not crossed:
            rho = 2.0 * shift + gap
            return math.sqrt(height**2 + rho**2) + slack
    for level in range(loose.shape[0]):
        delta = max(shrink * inradius, loose[level] * scale)
        if not delta < 0.5 * inradius:
            continue
        ratio = delta / inradius
        for k in range(3):
            sx[k] = ix + (tx[k] - ix) * (1.0 - ratio)
            sy[k] = iy + (ty[k] - iy) * (1.0 - ratio)
        inside = True
        for c in range(count):
            s = crossing[c]
            if _crosses(sx, sy, seg[0, s], seg[1, s], seg[2, s], seg[3, s]):
                inside = False
                break
        if inside:
            rho = 2.0 * ratio * reach + gap
            return math.sqrt(height**2 + rho**2) + slack
    return np.inf


@kernel
def _planar(tri, row, face, regions, planes, tri2, seg_start, seg, cap, numbers, loose, bound):
    # pragma: no cover - compiled
    (region_of,) = regions
    slack, offset, gap = planes[0], planes[1], planes[2]
    u, v, normal = planes[3:6], planes[6:9], planes[9:12]
    scale, shrink, plane_slack_max, has_cap = numbers
    r = slack.shape[0]
    p = row.shape[0]
    keys = np.empty(p, np.int64)
    kept = np.empty(p, np.int64)
    tx = np.empty((p, 3))
    ty = np.empty((p, 3))
    height = np.empty(p)
    count = 0
    for i in range(p):
        g = region_of[face[i]]
        if not slack[g] <= plane_slack_max:
            continue
        t = tri[row[i]]
        h = -np.inf
        for k in range(3):
            tx[i, k] = t[k, 0] * u[0, g] + t[k, 1] * u[1, g] + t[k, 2] * u[2, g]
            ty[i, k] = t[k, 0] * v[0, g] + t[k, 1] * v[1, g] + t[k, 2] * v[2, g]
            along = t[k, 0] * normal[0, g] + t[k, 1] * normal[1, g] + t[k, 2] * normal[2, g]
            h = max(h, abs(along - offset[g]))
        height[i] = h
        cx = (tx[i, 0] + tx[i, 1] + tx[i, 2]) / 3.0
        cy = (ty[i, 0] + ty[i, 1] + ty[i, 2]) / 3.0
        keep = _inside_face(cx, cy, tri2[face[i]])
        if has_cap > 0:
            keep &= h + slack[g] < cap[row[i]]
        if keep:
            keys[count] = row[i] * (r + 1) + g
            kept[count] = i
            count += 1
    keys, kept = keys[:count], kept[:count]
    order = stable_order(keys)
    for n in range(count):
        if n > 0 and keys[order[n]] == keys[order[n - 1]]:
            continue  # one test per (triangle, region): its first pair
        i = kept[order[n]]
        g = region_of[face[i]]
        value = _value(
            tx[i],
            ty[i],
            height[i],
            slack[g],
            gap[g],
            seg,
            seg_start[g],
            seg_start[g + 1],
            scale,
            shrink,
            loose,
        )
        bound[row[i]] = min(bound[row[i]], value)


def _check_regions(regions, m: int) -> None:
    """Raise ValueError unless ``regions`` (a ``hausdorff._Regions`` of m faces) is consistent:
    the kernel follows its indices without bounds checks."""
    r = len(regions.normal)
    start = np.asarray(regions.seg_start)
    fields = (regions.slack, regions.offset, regions.gap, regions.u, regions.v)
    if (
        len(regions.tri2) != m
        or (m and (regions.region.min() < 0 or regions.region.max() >= r))
        or any(len(x) != r for x in fields)
        or len(start) != r + 1
        or (r and (start[0] < 0 or np.any(np.diff(start) < 0)))
        or start[-1]
        > min(map(len, (regions.seg_x0, regions.seg_y0, regions.seg_x1, regions.seg_y1)))
    ):
        raise ValueError(
            "planar_bound: the planar regions are inconsistent (an index out of range)"
        )


def planar_bound(tri, row, face, regions, cap, constants) -> np.ndarray:
    """(n,) metres: the in-plane bound of each triangle ``tri`` (n, 3, 3) metres over the
    planar regions of its candidate faces (``row``, ``face`` (p,) int64 pairs), inf where none
    holds; ``regions`` a prepared ``hausdorff._Regions`` of the target, ``cap`` (n,) metres or
    None, ``constants`` = (shrink, largest region slack, loose shares (3,))."""
    shrink, plane_slack_max, loose = constants
    if cap is not None and len(cap) != len(tri):
        raise ValueError("planar_bound: one cap per triangle")
    n = len(tri)
    bound = np.full(n, np.inf)
    row = np.ascontiguousarray(row, np.int64)
    face = np.ascontiguousarray(face, np.int64)
    m = len(regions.region)
    if len(row) == 0:
        return bound
    if row.min() < 0 or row.max() >= n or face.min() < 0 or face.max() >= m:
        raise ValueError("planar_bound: a triangle or face index is out of range")
    if len(row) != len(face) or np.shape(tri)[1:] != (3, 3):
        raise ValueError("planar_bound: pairs or triangles of the wrong shape")
    _check_regions(regions, m)
    planes = np.ascontiguousarray(
        np.vstack(
            [
                regions.slack[None],
                regions.offset[None],
                regions.gap[None],
                regions.u.T,
                regions.v.T,
                regions.normal.T,
            ]
        ),
        np.float64,
    )
    seg = np.ascontiguousarray(
        np.vstack([regions.seg_x0, regions.seg_y0, regions.seg_x1, regions.seg_y1]), np.float64
    )
    _planar(
        np.ascontiguousarray(tri, np.float64),
        row,
        face,
        (np.ascontiguousarray(regions.region, np.int64),),
        planes,
        np.ascontiguousarray(regions.tri2, np.float64),
        np.ascontiguousarray(regions.seg_start, np.int64),
        seg,
        np.zeros(n) if cap is None else np.ascontiguousarray(cap, np.float64),
        (float(regions.scale), float(shrink), float(plane_slack_max), 0.0 if cap is None else 1.0),
        np.asarray(loose, np.float64),
        bound,
    )
    return bound
