"""Outline loops of many face regions at once (the walk of
:func:`exporter.simplify.planar._region_loops`): the compiled kernel ``exporter/mesh/c/outline.c``
(a region's outline is its half-edges whose reverse the region lacks, walked from its first
outline half-edge in face order, skipping dropped vertices; integers only, the former numpy and
Python form is matched exactly: ``tests/test_outline_kernels.py`` keeps it as the reference)."""

from __future__ import annotations

import numpy as np

from ._outline import loops as _loops


def outline_loops(
    half: np.ndarray, half_region: np.ndarray, region_count: int, k: int, droppable: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(bad (count,) bool, vertices (n,), bounds (l + 1,), loop_region (l,))`` for the directed
    half-edges ``half`` (h, 2) int64 (ids below ``k``) of regions ``half_region`` (h,) ascending:
    every loop's kept vertices are ``vertices[bounds[i]:bounds[i + 1]]``; ``bad``: pinched, open,
    without outline, or a loop under 3 kept vertices (such regions' loops are listed too, to be
    ignored); ``droppable`` (k,) bool the vertices left out of the loops."""
    bad, vertices, bounds, loop_region, count, loops = _loops(
        half, half_region, region_count, k, droppable
    )
    return bad, vertices[:count], bounds[: loops + 1], loop_region[:loops]
