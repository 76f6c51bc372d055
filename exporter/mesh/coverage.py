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
   settled with that width added (a fan of them ring by ring, the widths summed), which leaves
   far fewer faces to the general method.

A region that fails a test (a flipped face, a chain that differs otherwise) and every face not
placed in a region are returned as *open*: the caller bounds them with the general method
(:mod:`exporter.mesh.hausdorff`), which they then cost alone.

Steps 2-4 and 6 run compiled (:mod:`exporter.mesh.region_kernels`, bands in
:mod:`exporter.mesh.band_kernels`); welding and the planar regions are the shared numpy ones.

Sources: the winding-number argument is the one of polygon coverage tests (e.g. Hormann &
Agathos, "The point in polygon problem for arbitrary polygons", 2001); welding as
:mod:`exporter.mesh.weld`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .geometry import isin_int
from .region_kernels import settle_regions
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
    shared_a, shared_b = isin_int(ka, kb), isin_int(kb, ka)
    # Degenerate faces (two corners welded together) are never settled here.
    degenerate_a = (la[:, 0] == la[:, 1]) | (la[:, 1] == la[:, 2]) | (la[:, 0] == la[:, 2])
    degenerate_b = (lb[:, 0] == lb[:, 1]) | (lb[:, 1] == lb[:, 2]) | (lb[:, 0] == lb[:, 2])
    # 2. regions of b's other faces (b is the side whose regions are used: the source)
    rest_b = np.flatnonzero(~shared_b & ~degenerate_b)
    rest_a = np.flatnonzero(~shared_a & ~degenerate_a)
    done_a, done_b = shared_a & ~degenerate_a, shared_b & ~degenerate_b
    both = len(rest_b) and len(rest_a)
    region = planar_regions(points, lb[rest_b]) if both else np.zeros(0, np.int64)
    # 2-4 (regions: placement, orientation, chains, bands, heights) and 6 (slivers), compiled.
    settled = settle_regions(
        points,
        la,
        lb,
        rest_a if both else rest_a[:0],
        rest_b if both else rest_b[:0],
        region,
        done_a,
        done_b,
        offset,
        max_bound,
        (SAME_NORMAL_COS, ORIENTED, MAX_BAND_EDGES, SLIVER, SLIVER_ROUNDS),
    )
    bound = settled + 2 * offset if (done_a.any() or done_b.any()) else 0.0
    return Certificate(bound, ~done_a, ~done_b)
