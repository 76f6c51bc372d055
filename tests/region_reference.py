"""The region certificate as numpy computed it before its arithmetic was compiled
(exporter/mesh/region_kernels.py), kept as the plain reference the kernels are checked against
(tests/test_region_kernels.py, tests/test_perf_hausdorff.py). ``bands`` and ``slivers`` are the
step 4 and step 6 functions to use (tests/test_perf_hausdorff.py's references). Metres."""

from __future__ import annotations

import numpy as np

from exporter.mesh.coverage import (
    ORIENTED,
    SAME_NORMAL_COS,
    SLIVER_ROUNDS,
    WELD_M,
    Certificate,
    _face_keys,
    _weld,
)
from exporter.mesh.geometry import cross_rows
from exporter.mesh.topology import planar_regions


def _assign(
    level: np.ndarray, normal_l: np.ndarray, source: np.ndarray, region: np.ndarray, normals, k
) -> np.ndarray:
    """(m_level,) region of each level face (-1: none): a region whose source faces use all three
    of its corners and whose normal its own is within ``SAME_NORMAL_COS`` of."""
    r = len(normals)
    # (region, vertex) memberships, sorted, for lookups.
    member = np.unique(np.repeat(region, 3) * k + source.reshape(-1))
    out = np.full(len(level), -1, np.int64)
    if len(level) == 0 or len(member) == 0:
        return out
    # Candidates: every region holding the face's first corner.
    mv = member % k
    order = np.argsort(mv, kind="stable")
    first = np.searchsorted(mv[order], level[:, 0], side="left")
    last = np.searchsorted(mv[order], level[:, 0], side="right")
    counts = last - first
    owner = np.repeat(np.arange(len(level)), counts)
    item = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    cand = member[order[first[owner] + item]] // k
    ok = (normal_l[owner] * normals[cand]).sum(1) >= SAME_NORMAL_COS
    for c in (1, 2):
        key = cand * k + level[owner, c]
        at = np.minimum(np.searchsorted(member, key), len(member) - 1)
        ok &= member[at] == key
    owner, cand = owner[ok], cand[ok]
    # First fitting region per face (several fit only for regions on one plane).
    out[owner[::-1]] = cand[::-1]
    del r
    return out


def _unit_normals(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = points[faces]
    cross = cross_rows(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    length = np.sqrt((cross**2).sum(1))
    return cross / np.maximum(length, 1e-300)[:, None], cross


def _chain_difference(
    faces_l: np.ndarray, reg_l: np.ndarray, faces_s: np.ndarray, reg_s: np.ndarray, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """The nonzero edges of boundary(level faces of region) - boundary(source faces of region):
    (d, 4) rows ``(region, a, b, side)``, a -> b the edge's direction in the difference, side +1
    when it is the level's boundary edge a -> b (the source has none there), -1 when it is the
    source's boundary edge b -> a reversed (the level has none), 0 otherwise; and the regions
    where an edge of the difference has a multiplicity above 1."""
    half = np.concatenate([faces_l[:, [0, 1, 1, 2, 2, 0]], faces_s[:, [0, 1, 1, 2, 2, 0]]])
    half = half.reshape(-1, 2)
    from_level = np.concatenate([np.ones(3 * len(faces_l), bool), np.zeros(3 * len(faces_s), bool)])
    region = np.repeat(np.concatenate([reg_l, reg_s]), 3)
    lo, hi = np.minimum(half[:, 0], half[:, 1]), np.maximum(half[:, 0], half[:, 1])
    sign = np.where(half[:, 0] < half[:, 1], 1.0, -1.0)
    keys = (region * k + lo) * k + hi
    uniq, inverse = np.unique(keys, return_inverse=True)
    # Net boundary of each side along lo -> hi.
    net_l = np.bincount(inverse, weights=sign * from_level, minlength=len(uniq))
    net_s = np.bincount(inverse, weights=sign * ~from_level, minlength=len(uniq))
    total = net_l - net_s
    nonzero = np.flatnonzero(np.abs(total) > 0.5)
    key = uniq[nonzero]
    reg = key // (k * k)
    lo, hi = (key // k) % k, key % k
    forward = total[nonzero] > 0
    side = np.where(np.abs(net_s[nonzero]) < 0.5, 1, np.where(np.abs(net_l[nonzero]) < 0.5, -1, 0))
    rows = np.column_stack(
        [reg, np.where(forward, lo, hi), np.where(forward, hi, lo), side]
    ).astype(np.int64)
    return rows, np.unique(reg[np.abs(total[nonzero]) > 1.5])


def reference_region_certificate(
    level, source, bands, slivers, weld: float = WELD_M, max_bound: float = np.inf
) -> Certificate:
    """Certified Hausdorff bound between meshes ``level`` and ``source`` (``(positions, faces)``
    pairs, metres) for every face a planar region of ``source`` settles (see the module doc);
    regions whose bound would exceed ``max_bound`` (metres) are left open too. ``bound`` is 0
    when nothing was settled."""
    pa = np.asarray(level[0], np.float64).reshape(-1, 3)
    fa = np.asarray(level[1], np.int64).reshape(-1, 3)
    pb = np.asarray(source[0], np.float64).reshape(-1, 3)
    fb = np.asarray(source[1], np.int64).reshape(-1, 3)
    open_a, open_b = np.ones(len(fa), bool), np.ones(len(fb), bool)
    if len(fa) == 0 or len(fb) == 0:
        return Certificate(0.0, open_a, open_b)
    ida, idb, points, offset = _weld(pa, pb, weld)
    k = len(points)
    la, lb = ida[fa], idb[fb]
    # 1. faces on both sides
    ka, kb = _face_keys(la, k), _face_keys(lb, k)
    shared_a, shared_b = np.isin(ka, kb), np.isin(kb, ka)
    # Degenerate faces (two corners welded together) are never settled here.
    degenerate_a = (la[:, 0] == la[:, 1]) | (la[:, 1] == la[:, 2]) | (la[:, 0] == la[:, 2])
    degenerate_b = (lb[:, 0] == lb[:, 1]) | (lb[:, 1] == lb[:, 2]) | (lb[:, 0] == lb[:, 2])
    # 2. regions of b's other faces (b is the side whose regions are used: the source)
    rest_b = np.flatnonzero(~shared_b & ~degenerate_b)
    rest_a = np.flatnonzero(~shared_a & ~degenerate_a)
    settled = 0.0
    done_a, done_b = shared_a & ~degenerate_a, shared_b & ~degenerate_b
    if len(rest_b) and len(rest_a):
        fs = lb[rest_b]
        region = planar_regions(points, fs)
        ns, cross_s = _unit_normals(points, fs)
        r = int(region.max()) + 1
        normals = np.zeros((r, 3))
        np.add.at(normals, region, cross_s)
        length = np.sqrt((normals**2).sum(1))
        good = length > 0  # a region whose faces' normals cancel has no plane
        normals[~good] = (0.0, 0.0, 1.0)
        normals[good] /= length[good, None]
        fl = la[rest_a]
        nl, cross_l = _unit_normals(points, fl)
        reg_l = _assign(fl, nl, fs, region, normals, k)
        # Faces of a not placed: their candidate regions are unknown, so nothing is lost by
        # leaving them open alone.
        placed = reg_l >= 0
        # 3. orientation along the region's normal, both sides
        for faces_x, cross_x, reg_x in (
            (fs, cross_s, region),
            (fl[placed], cross_l[placed], reg_l[placed]),
        ):
            t = points[faces_x]
            e = t - t[:, [1, 2, 0]]
            e2 = e[..., 0] * e[..., 0] + e[..., 1] * e[..., 1] + e[..., 2] * e[..., 2]
            longest = np.maximum(np.maximum(e2[:, 0], e2[:, 1]), e2[:, 2])
            along = (cross_x * normals[reg_x]).sum(1)
            bad = along <= ORIENTED * longest
            good[reg_x[bad]] = False
        # 3-4. chains
        diff, multiple = _chain_difference(fl[placed], reg_l[placed], fs, region, k)
        good[multiple] = False
        width = np.zeros(r)
        if len(diff):
            bands(diff, points, normals, good, width)
        # heights
        heights_lo = np.full(r, np.inf)
        heights_hi = np.full(r, -np.inf)
        for faces_x, reg_x in ((fs, region), (fl[placed], reg_l[placed])):
            h = np.einsum("mkj,mj->mk", points[faces_x], normals[reg_x])
            np.minimum.at(heights_lo, reg_x, np.minimum(np.minimum(h[:, 0], h[:, 1]), h[:, 2]))
            np.maximum.at(heights_hi, reg_x, np.maximum(np.maximum(h[:, 0], h[:, 1]), h[:, 2]))
        spread = heights_hi - heights_lo
        # Rounding of the heights themselves: a relative margin.
        scale = float(np.abs(points).max()) if len(points) else 0.0
        value = spread + width + 1e-12 * scale
        good &= value + 2 * offset <= max_bound
        if good.any():
            settled = float(value[good].max())
        done_b[rest_b[good[region]]] = True
        done_a[rest_a[placed][good[reg_l[placed]]]] = True
    # 6. slivers along settled edges, both sides; a fan of slivers is settled one ring a round,
    # each round's width added to the bound (its faces lie along the faces settled before it).
    for _ in range(SLIVER_ROUNDS):
        if not (done_a.any() or done_b.any()):
            break
        width_a, slivers_a = slivers(points, la, done_a, max_bound - 2 * offset - settled)
        width_b, slivers_b = slivers(points, lb, done_b, max_bound - 2 * offset - settled)
        if not (slivers_a.any() or slivers_b.any()):
            break
        settled += max(width_a, width_b)
        done_a |= slivers_a
        done_b |= slivers_b
    bound = settled + 2 * offset if (done_a.any() or done_b.any()) else 0.0
    return Certificate(bound, ~done_a, ~done_b)
