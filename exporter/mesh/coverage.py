"""Certified distance between two triangulations of the same flat polygons, without sampling.

Data form: two triangle meshes ``(positions (k, 3) float64 metres, faces (m, 3) int64)`` in one
frame (the building-local East/Up/North frame here; nothing depends on which axis is up), e.g. a
level of detail and its source. Results are metres.

Entry point: :func:`region_certificate`. Most of a level is its source re-triangulated: the
lossless planar stage rebuilds each flat polygon from its outline, and the collapse leaves most
faces as they were. For those parts the Hausdorff distance follows from counting, with no
distance computed at all:

1. Faces that appear in both meshes (the same three corners) are at distance 0 both ways; they
   are set aside.
2. The other source faces are grouped in planar regions (plane of normal n); each other level
   face joins the region whose vertices hold its three corners and whose normal it shares.
3. Within a region R, project along n. If every face of both sides keeps its orientation (the
   projected signed area is positive) and the boundary 1-chains (half-edges, interior ones
   cancelling) agree, the projected faces cover the same points the same number of times: the
   winding number of a boundary chain is the sum of its faces' indicator functions, and it only
   depends on the chain. Two points with the same projection differ only along n, by at most the
   spread of the heights of R's vertices (heights are affine on a face).
4. Straight outline vertices that one side dropped make the chains differ by thin cycles: a run
   of one side's edges and a run of the other's between the same two vertices, both monotone
   along their chord and within ``width`` of each other across it. Inside such a band the two
   sides may disagree, but every point of the band is within ``width`` of both runs (and a run's
   points belong to its side), so the region's bound becomes spread + width.
5. Vertices are identified across the meshes after welding within ``weld`` metres; moving every
   vertex by at most d moves every point of a face by at most d, so twice the largest weld offset
   is added.

6. Slivers: a collapse onto a line leaves collinear triangles filling a T-junction (no region
   takes them: their normal is noise). One whose longest edge, or both other edges, are edges of
   settled faces of its side lies within twice its least altitude of those faces, so it is
   settled with that width added (a fan of them ring by ring, the widths summed). On generated
   buildings this left 163 level faces open where there were 633 over the guard's 71 candidate
   certifications of a 100-building tile, and the certification ran 0.83-0.89x its time
   (``bench_stages.py``, quality and simplify columns, same run).

A region that fails a test (a flipped face, a chain that differs otherwise) and every face not
placed in a region are returned as *open*: the caller bounds them with the general method
(:mod:`exporter.mesh.hausdorff`), which they then cost alone.

Sources: the winding-number argument is the one of polygon coverage tests (e.g. Hormann &
Agathos, "The point in polygon problem for arbitrary polygons", 2001); welding as
:mod:`exporter.mesh.weld`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .band_kernels import region_bands
from .geometry import cross_rows
from .topology import planar_regions
from .weld import weld_positions

WELD_M = 1e-6  # metres: vertices this close are one (the pipeline's noise welding)
ORIENTED = 1e-9  # projected doubled area below this x the squared longest edge: not trusted
SAME_NORMAL_COS = float(np.cos(np.radians(1.0)))  # a level face's normal vs its region's
MAX_BAND_EDGES = 64  # longest straight run followed through one cycle of the chain difference
SLIVER = 1e-6  # a face this thin (twice its least altitude / longest edge) may lie along edges
SLIVER_ROUNDS = 4  # rings of a sliver fan settled at most


@dataclasses.dataclass(frozen=True)
class Certificate:
    """What :func:`region_certificate` settled: ``bound`` (metres) holds both ways for every face
    not marked open (each point of such a face is within ``bound`` of the other mesh);
    ``open_level`` (m_level,) and ``open_source`` (m_source,) bool are the faces left to the
    general method (each against the whole other mesh)."""

    bound: float
    open_level: np.ndarray
    open_source: np.ndarray


def _weld(pa: np.ndarray, pb: np.ndarray, weld: float):
    """Shared vertex ids of both meshes' positions and the largest weld offset (metres)."""
    both = np.concatenate([pa, pb])
    ids, points = weld_positions(both, weld)
    offset = float(np.sqrt(((both - points[ids]) ** 2).sum(1)).max()) if len(both) else 0.0
    return ids[: len(pa)], ids[len(pa) :], points, offset


def _face_keys(faces: np.ndarray, k: int) -> np.ndarray:
    s = np.sort(faces, axis=1)
    return (s[:, 0] * k + s[:, 1]) * k + s[:, 2]


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


def region_certificate(
    level, source, weld: float = WELD_M, max_bound: float = np.inf
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
            _bands(diff, points, normals, good, width)
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
        width_a, slivers_a = _slivers(points, la, done_a, max_bound - 2 * offset - settled)
        width_b, slivers_b = _slivers(points, lb, done_b, max_bound - 2 * offset - settled)
        if not (slivers_a.any() or slivers_b.any()):
            break
        settled += max(width_a, width_b)
        done_a |= slivers_a
        done_b |= slivers_b
    bound = settled + 2 * offset if (done_a.any() or done_b.any()) else 0.0
    return Certificate(bound, ~done_a, ~done_b)


def _slivers(points: np.ndarray, faces: np.ndarray, done: np.ndarray, budget: float):
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
    # Only the thin faces' edges are looked up (one sorted search for all three edges of each).
    thin_rows = np.flatnonzero(thin)
    f = faces[open_[thin_rows]]
    g = f[:, [1, 2, 0]]
    keys = np.minimum(f, g) * k + np.maximum(f, g)  # (t, 3): edge i from corner i to i + 1
    at = np.minimum(np.searchsorted(known, keys), len(known) - 1)
    on = (known[at] == keys) if len(known) else np.zeros(keys.shape, bool)
    rows = np.arange(len(thin_rows))
    i = longest[thin_rows]
    along = np.zeros(len(open_), bool)
    along[thin_rows] = on[rows, i] | (on[rows, (i + 1) % 3] & on[rows, (i + 2) % 3])
    ok = thin & along
    settled[open_[ok]] = True
    return (float(width[ok].max()) if ok.any() else 0.0), settled


def _bands(diff: np.ndarray, points: np.ndarray, normals: np.ndarray, good, width) -> None:
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
    xy = np.column_stack([(start * u).sum(1), (start * v).sum(1)])
    region_bands(diff, xy, good, width, MAX_BAND_EDGES)
