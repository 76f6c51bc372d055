"""The region certificate's counting and slivers, compiled (steps 2-4 and 6 of
:mod:`exporter.mesh.coverage`, which holds the argument; this is its arithmetic).

Given both meshes welded onto shared vertex ids (``points`` (k, 3) metres, ``level`` and
``source`` faces (m, 3) int64 into it), the faces not shared, and the planar regions of the
source's other faces: each level face joins the first region (lowest id) holding its three
corners whose normal is within ``same_normal_cos`` of its own; a region is refused when a face of
either side flips along its normal, when its chain difference has an edge of multiplicity > 1 or
a cycle that is not a band (:mod:`.band_kernels`), or when its bound (spread of heights + widest
band + 1e-12 x the largest coordinate) plus twice the weld offset exceeds ``max_bound``. Then up
to ``sliver_rounds`` rings of slivers along settled edges are settled, each ring's width added.

Every float operation is the former numpy form's, in its order: sums over three coordinates
left to right (``.sum(1)``), except the heights, which ``np.einsum("mkj,mj->mk")`` added as
(x + z) + y; region normals accumulated face by face (``np.add.at``). So the bounds and decisions
are the same bits (tests/test_region_kernels.py checks them against the former code).
"""

from __future__ import annotations

import math

import numpy as np

from .band_kernels import _region_bands
from .jit import kernel
from .sorted_kernels import lower_bound, stable_order


@kernel
def _any(flags):  # pragma: no cover - compiled
    for flag in flags:
        if flag:
            return True
    return False


@kernel
def _rows(table, pick):  # pragma: no cover - compiled
    """``table[pick]`` for a (n, 3) table (a loop: numba's fancy indexing compiles slowly)."""
    out = np.empty((pick.shape[0], 3), table.dtype)
    for i in range(pick.shape[0]):
        for j in range(3):
            out[i, j] = table[pick[i], j]
    return out


@kernel
def _cross(points, f):  # pragma: no cover - compiled
    """(b - a) x (c - a) of face ``f`` (3,) of ``points``, as ``cross_rows``."""
    a, b, c = points[f[0]], points[f[1]], points[f[2]]
    u0, u1, u2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    v0, v1, v2 = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    return u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0


@kernel
def _orientation(points, faces, cross, reg, normals, oriented_eps, good):  # pragma: no cover
    """Step 3: regions of faces that do not keep their orientation along the region's normal
    (projected doubled area <= ``oriented_eps`` x the squared longest edge) are not ``good``."""
    for i in range(faces.shape[0]):
        longest = -np.inf
        for j in range(3):
            p, q = points[faces[i, j]], points[faces[i, (j + 1) % 3]]
            e0, e1, e2 = p[0] - q[0], p[1] - q[1], p[2] - q[2]
            longest = max(longest, e0 * e0 + e1 * e1 + e2 * e2)
        g = reg[i]
        along = cross[i, 0] * normals[g, 0] + cross[i, 1] * normals[g, 1]
        along = along + cross[i, 2] * normals[g, 2]
        if along <= oriented_eps * longest:
            good[g] = False


@kernel
def _heights(points, faces, reg, normals, low, high):  # pragma: no cover - compiled
    """Each region's lowest and highest corner height along its normal (einsum's order)."""
    for i in range(faces.shape[0]):
        g = reg[i]
        for j in range(3):
            p = points[faces[i, j]]
            h = (p[0] * normals[g, 0] + p[2] * normals[g, 2]) + p[1] * normals[g, 1]
            low[g] = min(low[g], h)
            high[g] = max(high[g], h)


@kernel
def _assign(level, normal_l, source, region, normals, k, same_normal_cos):  # pragma: no cover
    """(m_level,) the first region (lowest id) whose source faces use all three corners of the
    level face and whose normal its unit normal is within ``same_normal_cos`` of; -1 if none."""
    m = source.shape[0]
    member = np.empty(3 * m, np.int64)
    for i in range(m):
        for j in range(3):
            member[3 * i + j] = region[i] * k + source[i, j]
    ordered = member[stable_order(member)]
    count = 0
    for t in range(len(ordered)):  # distinct keys, ascending (np.unique)
        if t == 0 or ordered[t] != ordered[t - 1]:
            ordered[count] = ordered[t]
            count += 1
    member = ordered[:count]
    # Regions of each vertex, ascending: a counting sort of the members by vertex.
    start = np.zeros(k + 1, np.int64)
    for key in member:
        start[key % k + 1] += 1
    for v in range(k):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    regions_of = np.empty(len(member), np.int64)
    for key in member:
        v = key % k
        regions_of[fill[v]] = key // k
        fill[v] += 1
    out = np.full(level.shape[0], -1, np.int64)
    n = len(member)
    for f in range(level.shape[0]):
        v0 = level[f, 0]
        for t in range(start[v0], start[v0 + 1]):
            g = regions_of[t]
            dot = normal_l[f, 0] * normals[g, 0] + normal_l[f, 1] * normals[g, 1]
            if dot + normal_l[f, 2] * normals[g, 2] < same_normal_cos:
                continue
            ok = True
            for c in (1, 2):
                key = g * k + level[f, c]
                at = lower_bound(member, 0, n, key)
                ok &= at < n and member[at] == key
            if ok:
                out[f] = g
                break
    return out


@kernel
def _chain_difference(level, reg_l, source, reg_s, k, good):  # pragma: no cover - compiled
    """Step 3-4: the nonzero edges of boundary(level faces) - boundary(source faces) per region,
    as columns region, a, b, side in (region, low, high) order (a -> b the edge's direction in the
    difference, side +1 / -1 / 0: only the level's, only the source's, both); regions with an
    edge of multiplicity above 1 are marked not ``good``."""
    count = 3 * (level.shape[0] + source.shape[0])
    keys = np.empty(count, np.int64)
    sign = np.empty(count, np.int64)
    from_level = np.empty(count, np.bool_)
    h = 0
    for side_faces, side_reg, is_level in ((level, reg_l, True), (source, reg_s, False)):
        for i in range(side_faces.shape[0]):
            for j in range(3):
                a, b = side_faces[i, j], side_faces[i, (j + 1) % 3]
                keys[h] = (side_reg[i] * k + min(a, b)) * k + max(a, b)
                sign[h] = 1 if a < b else -1
                from_level[h] = is_level
                h += 1
    order = stable_order(keys)
    rg = np.empty(count, np.int64)
    ra = np.empty(count, np.int64)
    rb = np.empty(count, np.int64)
    rs = np.empty(count, np.int64)
    d = 0
    i = 0
    while i < count:
        key = keys[order[i]]
        net_l, net_s = 0, 0
        while i < count and keys[order[i]] == key:
            if from_level[order[i]]:
                net_l += sign[order[i]]
            else:
                net_s += sign[order[i]]
            i += 1
        total = net_l - net_s
        if total == 0:
            continue
        g, low, high = key // (k * k), (key // k) % k, key % k
        if abs(total) > 1:
            good[g] = False
        rg[d] = g
        ra[d], rb[d] = (low, high) if total > 0 else (high, low)
        rs[d] = 1 if net_s == 0 else (-1 if net_l == 0 else 0)
        d += 1
    return rg[:d], ra[:d], rb[:d], rs[:d]


@kernel
def _in_plane(region, start, points, normals):  # pragma: no cover - compiled
    """(d, 2) metres: each start vertex in its region's plane axes (u = n x helper, v =
    n x u, helper x unless n is nearly x)."""
    xy = np.empty((region.shape[0], 2))
    for r in range(region.shape[0]):
        n0, n1, n2 = normals[region[r], 0], normals[region[r], 1], normals[region[r], 2]
        h0, h1, h2 = (1.0, 0.0, 0.0) if abs(n0) < 0.9 else (0.0, 1.0, 0.0)
        u0, u1, u2 = n1 * h2 - n2 * h1, n2 * h0 - n0 * h2, n0 * h1 - n1 * h0
        length = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        u0, u1, u2 = u0 / length, u1 / length, u2 / length
        v0, v1, v2 = n1 * u2 - n2 * u1, n2 * u0 - n0 * u2, n0 * u1 - n1 * u0
        s = points[start[r]]
        xy[r, 0] = s[0] * u0 + s[1] * u1 + s[2] * u2
        xy[r, 1] = s[0] * v0 + s[1] * v1 + s[2] * v2
    return xy


@kernel
def _regions(points, la, lb, rest_a, rest_b, region, done_a, done_b, limits, steps):
    # pragma: no cover - compiled
    """Steps 2-4: marks the faces of regions that settle in ``done_a`` / ``done_b``; returns the
    largest settled region bound (metres, 0 if none). ``limits`` = (weld offset, max bound,
    largest coordinate) metres, ``steps`` = (same-normal cosine, orientation share, longest
    band, 0.5 as a run-time exponent)."""
    offset, max_bound, scale = limits
    same_normal_cos, oriented_eps, max_band_edges, half = steps
    k = points.shape[0]
    fs = _rows(lb, rest_b)
    fl = _rows(la, rest_a)
    ms, ml = fs.shape[0], fl.shape[0]
    r = region.max() + 1
    cross_s = np.empty((ms, 3))
    normals = np.zeros((r, 3))
    for i in range(ms):
        c = _cross(points, fs[i])
        for j in range(3):
            cross_s[i, j] = c[j]
            normals[region[i], j] += c[j]
    good = np.zeros(r, np.bool_)
    for g in range(r):
        n0, n1, n2 = normals[g, 0], normals[g, 1], normals[g, 2]
        length = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if length > 0:
            good[g] = True
            normals[g, 0], normals[g, 1], normals[g, 2] = n0 / length, n1 / length, n2 / length
        else:  # a region whose faces' normals cancel has no plane
            normals[g, 0], normals[g, 1], normals[g, 2] = 0.0, 0.0, 1.0
    cross_l = np.empty((ml, 3))
    normal_l = np.empty((ml, 3))
    for i in range(ml):
        c = _cross(points, fl[i])
        length = max(math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), 1e-300)
        for j in range(3):
            cross_l[i, j] = c[j]
            normal_l[i, j] = c[j] / length
    reg_l = _assign(fl, normal_l, fs, region, normals, k, same_normal_cos)
    placed = np.empty(ml, np.int64)
    count = 0
    for i in range(ml):
        if reg_l[i] >= 0:
            placed[count] = i
            count += 1
    placed = placed[:count]
    fp, cp = _rows(fl, placed), _rows(cross_l, placed)
    rp = np.empty(count, np.int64)
    for i in range(count):
        rp[i] = reg_l[placed[i]]
    _orientation(points, fs, cross_s, region, normals, oriented_eps, good)
    _orientation(points, fp, cp, rp, normals, oriented_eps, good)
    dg, da, db, ds = _chain_difference(fp, rp, fs, region, k, good)
    width = np.zeros(r)
    if dg.shape[0]:
        keys = np.empty(dg.shape[0], np.int64)
        for i in range(dg.shape[0]):
            keys[i] = dg[i] * k + da[i]
        xy = _in_plane(dg, da, points, normals)
        _region_bands(dg, da, db, ds, stable_order(keys), xy, good, width, max_band_edges, half)
    low = np.full(r, np.inf)
    high = np.full(r, -np.inf)
    _heights(points, fs, region, normals, low, high)
    _heights(points, fp, rp, normals, low, high)
    settled = 0.0
    found = False
    for g in range(r):
        value = (high[g] - low[g]) + width[g] + 1e-12 * scale
        good[g] &= value + 2 * offset <= max_bound
        if good[g]:
            settled = value if not found else max(settled, value)
            found = True
    for i in range(ms):
        if good[region[i]]:
            done_b[rest_b[i]] = True
    for i in range(placed.shape[0]):
        if good[rp[i]]:
            done_a[rest_a[placed[i]]] = True
    return settled


@kernel
def _slivers(points, faces, done, budget, sliver, settled):  # pragma: no cover - compiled
    """Step 6 on one side: marks in ``settled`` the open faces that are slivers (twice the least
    altitude <= ``budget`` and <= ``sliver`` x the longest edge) whose longest edge, or both other
    edges, are edges of ``done`` faces; returns the widest one's width (metres, 0 if none)."""
    m = faces.shape[0]
    if budget <= 0:
        return 0.0
    e = np.empty((3, 3))
    on = np.zeros(3, np.bool_)
    thin = np.zeros(m, np.bool_)
    width = np.zeros(m)
    longest = np.zeros(m, np.int64)
    any_thin = False
    for i in range(m):
        if done[i]:
            continue
        top, at = -np.inf, 0
        for j in range(3):
            p, q = points[faces[i, j]], points[faces[i, (j + 1) % 3]]
            for c in range(3):
                e[j, c] = q[c] - p[c]
            length = math.sqrt(e[j, 0] * e[j, 0] + e[j, 1] * e[j, 1] + e[j, 2] * e[j, 2])
            if length > top:
                top, at = length, j
        v0, v1, v2 = -e[2, 0], -e[2, 1], -e[2, 2]
        c0 = e[0, 1] * v2 - e[0, 2] * v1
        c1 = e[0, 2] * v0 - e[0, 0] * v2
        c2 = e[0, 0] * v1 - e[0, 1] * v0
        w = 2 * math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) / max(top, 1e-300)
        if w <= budget and w <= sliver * top and top > 0:
            thin[i], width[i], longest[i] = True, w, at
            any_thin = True
    if not any_thin:
        return 0.0
    k = faces.max() + 1
    known_count = 0
    for i in range(m):
        known_count += done[i]
    known = np.empty(3 * known_count, np.int64)
    h = 0
    for i in range(m):
        if done[i]:
            for j in range(3):
                a, b = faces[i, j], faces[i, (j + 1) % 3]
                known[h] = min(a, b) * k + max(a, b)
                h += 1
    known = known[stable_order(known)]
    n = len(known)
    widest = 0.0
    found = False
    for i in range(m):
        if not thin[i]:
            continue
        for j in range(3):
            a, b = faces[i, j], faces[i, (j + 1) % 3]
            key = min(a, b) * k + max(a, b)
            at = lower_bound(known, 0, n, key)
            on[j] = at < n and known[at] == key
        j = longest[i]
        if on[j] or (on[(j + 1) % 3] and on[(j + 2) % 3]):
            settled[i] = True
            widest = width[i] if not found else max(widest, width[i])
            found = True
    return widest


@kernel
def _settle(points, la, lb, rest_a, rest_b, region, done_a, done_b, limits, steps, slivers):
    # pragma: no cover - compiled
    offset, max_bound, _ = limits
    sliver, sliver_rounds = slivers
    settled = 0.0
    if rest_a.shape[0] and rest_b.shape[0]:
        settled = _regions(points, la, lb, rest_a, rest_b, region, done_a, done_b, limits, steps)
    for _ in range(sliver_rounds):
        if not (_any(done_a) or _any(done_b)):
            break
        budget = max_bound - 2 * offset - settled
        slivers_a = np.zeros(la.shape[0], np.bool_)
        slivers_b = np.zeros(lb.shape[0], np.bool_)
        width_a = _slivers(points, la, done_a, budget, sliver, slivers_a)
        width_b = _slivers(points, lb, done_b, budget, sliver, slivers_b)
        if not (_any(slivers_a) or _any(slivers_b)):
            break
        settled += max(width_a, width_b)
        for i in range(la.shape[0]):
            done_a[i] = done_a[i] or slivers_a[i]
        for i in range(lb.shape[0]):
            done_b[i] = done_b[i] or slivers_b[i]
    return settled


def settle_regions(
    points: np.ndarray,
    level: np.ndarray,
    source: np.ndarray,
    rest_level: np.ndarray,
    rest_source: np.ndarray,
    region: np.ndarray,
    done_level: np.ndarray,
    done_source: np.ndarray,
    offset: float,
    max_bound: float,
    constants: tuple[float, float, int, float, int],
) -> float:
    """Steps 2-4 and 6 of the certificate: ``points`` (k, 3) metres, ``level`` / ``source`` (m, 3)
    int64 welded ids, ``rest_*`` the faces not shared (indices), ``region`` (len(rest_source),)
    the source's planar regions of those faces, ``done_*`` (m,) bool the faces settled so far
    (updated in place), ``offset`` metres the largest weld move, ``max_bound`` metres;
    ``constants`` = (same-normal cosine, orientation share, longest band, sliver share, sliver
    rounds). Returns the settled bound without the weld allowance (metres)."""
    k = len(points)
    for faces in (level, source):
        if len(faces) and (faces.min() < 0 or faces.max() >= k):
            raise ValueError("settle_regions: a vertex index is out of range")
    if len(rest_source) and (region.min() < 0 or len(region) != len(rest_source)):
        raise ValueError("settle_regions: regions do not match the source faces")
    for faces, rest, done in ((level, rest_level, done_level), (source, rest_source, done_source)):
        if len(done) != len(faces) or (len(rest) and (rest.min() < 0 or rest.max() >= len(faces))):
            raise ValueError("settle_regions: a face index is out of range")
    same_normal_cos, oriented_eps, max_band_edges, sliver, sliver_rounds = constants
    scale = float(np.abs(points).max()) if k else 0.0
    return float(
        _settle(
            np.ascontiguousarray(points, np.float64),
            np.ascontiguousarray(level, np.int64),
            np.ascontiguousarray(source, np.int64),
            np.ascontiguousarray(rest_level, np.int64),
            np.ascontiguousarray(rest_source, np.int64),
            np.ascontiguousarray(region, np.int64),
            done_level,
            done_source,
            (float(offset), float(max_bound), scale),
            (float(same_normal_cos), float(oriented_eps), int(max_band_edges), 0.5),
            (float(sliver), int(sliver_rounds)),
        )
    )
