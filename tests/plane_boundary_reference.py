"""The former numpy form of the planar regions' boundary edges (``_Regions._boundary``, now
``exporter/mesh/c/plane_boundary.c``): the reference tests/test_plane_boundary_kernels.py compares
the C with, bit for bit. Projected coordinates in metres on each region's plane."""

from __future__ import annotations

import numpy as np

from exporter.mesh.hausdorff import T_JUNCTION, _ranges


def reference_matched(region, a, b, ok, k) -> np.ndarray:
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


def reference_boundary(faces: np.ndarray, k: int, face_region: np.ndarray, r: int, tri2):
    """``_Regions._boundary`` before straightening: (seg_region, seg, ends, oriented, gap) of
    the faces (m, 3) (vertex ids below ``k``) in regions ``face_region`` (m,) below ``r``,
    projected ``tri2`` (m, 3, 2) metres. Each region's boundary edges: every half-edge without
    exactly one opposite half-edge in its region, both on faces that keep their orientation when projected (conservative:
    an edge wrongly called boundary only costs a subdivision). Half-edges are first split at
    the region's T-junctions (a vertex of the region on an unmatched edge, within
    ``T_JUNCTION`` x the edge's length of its line); ``gap`` (r,) metres is the largest such
    offset of each region (a point in the sliver between is that close to the region)."""
    m = len(faces)
    t = tri2
    area2 = (t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1]) - (t[:, 1, 1] - t[:, 0, 1]) * (
        t[:, 2, 0] - t[:, 0, 0]
    )
    a = faces[:, [0, 1, 2]].reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    face = np.repeat(np.arange(m), 3)
    region = face_region[face]
    upright = (area2 > 0)[face]
    start2 = t.reshape(-1, 2)  # 2-D start of each half-edge, its end is the next corner
    end2 = t[:, [1, 2, 0]].reshape(-1, 2)
    gap = np.zeros(r)
    interior = reference_matched(region, a, b, upright, k)
    loose = np.flatnonzero(~interior & upright)
    if len(loose):
        # Split the unmatched half-edges at unmatched ends of the same region lying on them.
        ends, pick = np.unique(
            np.concatenate([region[loose] * k + a[loose], region[loose] * k + b[loose]]),
            return_index=True,
        )
        end_region, end_vertex = ends // k, ends % k
        end_point = np.concatenate([start2[loose], end2[loose]])[pick]
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
            np.maximum.at(gap, region[h[on]], off[on])
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
            sub_ok = reference_matched(region[sub_h], sub_a, sub_b, np.ones(len(sub_h), bool), k)
            keep = ~interior & ~np.isin(np.arange(len(a)), loose)
            seg_region = np.concatenate([region[keep], region[sub_h[~sub_ok]]])
            seg = np.concatenate(
                [
                    np.stack([start2[keep], end2[keep]], axis=1),
                    np.stack([sub_p[~sub_ok], sub_q[~sub_ok]], axis=1),
                ]
            )
            ends = np.concatenate(
                [np.column_stack([a[keep], b[keep]]), np.column_stack([sub_a, sub_b])[~sub_ok]]
            )
            oriented = np.concatenate([upright[keep], np.ones((~sub_ok).sum(), bool)])
            return seg_region, seg, ends, oriented, gap
    boundary = np.flatnonzero(~interior)
    seg = np.stack([start2[boundary], end2[boundary]], axis=1)
    ends = np.column_stack([a[boundary], b[boundary]])
    return region[boundary], seg, ends, upright[boundary], gap
