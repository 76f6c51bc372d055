"""The region certificate's counting and slivers (steps 2-4 and 6 of
:mod:`exporter.mesh.coverage`, which holds the argument): the checks and shapes around the compiled
kernel ``exporter/mesh/c/region.c`` (bands in ``exporter/mesh/c/bands.h``).

Given both meshes welded onto shared vertex ids, the faces not shared and the planar regions of
the source's other faces, level faces join regions, regions whose faces flip, whose chain
difference is not made of bands or whose bound exceeds ``max_bound`` are refused, then rings of
slivers along settled edges are settled. Every float operation is the former numpy form's, in its
order, so the bounds and decisions are the same bits (tests/test_region_kernels.py). Metres.
"""

from __future__ import annotations

import numpy as np

from ._region import settle as _settle


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
    return _settle(
        np.ascontiguousarray(points, np.float64),
        np.ascontiguousarray(level, np.int64),
        np.ascontiguousarray(source, np.int64),
        np.ascontiguousarray(rest_level, np.int64),
        np.ascontiguousarray(rest_source, np.int64),
        np.ascontiguousarray(region, np.int64),
        done_level,
        done_source,
        float(offset),
        float(max_bound),
        scale,
        float(same_normal_cos),
        float(oriented_eps),
        int(max_band_edges),
        0.5,  # the chord length's exponent, at run time: pow, as Python's b ** 0.5
        float(sliver),
        int(sliver_rounds),
    )
