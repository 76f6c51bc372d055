"""Weld vertices of a triangle soup: one index per position cluster.

Data form: ``positions`` (n, 3) float64 metres in the building-local East/Up/North frame;
the result maps every input vertex to a cluster (``welded``, (n,) int64) whose position is the
position of its lowest-index member, so welding never invents a coordinate.

Exact duplicates (equal by ``==``: -0.0 is 0.0, a row holding a NaN stays alone) are found by a
hash of the rows; ``distance == 0`` merges them only. Otherwise the clusters are the connected
components of the graph joining distinct positions whose squared distance
``(dx*dx + dy*dy) + dz*dz`` is at most ``distance**2`` (the test and result of
``scipy.spatial.cKDTree.query_pairs``, which still handles non-finite input), found by a sweep
along one direction. Both loops are in ``exporter/mesh/c/weld.c``. :func:`join_meshes` joins
meshes into one :class:`WeldedMesh` by exact position (rounded to ``WELD_M``), as the quality
metrics see them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from ._weld import exact, near
from .component_kernels import lowest_member
from .geometry import unique_float_rows

WELD_M = 1e-6  # metres: positions equal to this are one vertex in a joined mesh


class WeldedMesh(NamedTuple):
    """One triangle mesh whose equal positions are one vertex: ``positions`` (k, 3) float64
    metres, ``faces`` (m, 3) int64 into them. Unpacks as ``(positions, faces)``, the pair every
    mesh function takes."""

    positions: np.ndarray
    faces: np.ndarray


def join_meshes(meshes: list[tuple[np.ndarray, np.ndarray]], weld: float = WELD_M) -> WeldedMesh:
    """Meshes ``(positions (n_i, 3) metres, triangles (m_i, 3))`` in one frame as one
    :class:`WeldedMesh`: positions equal on a ``weld`` metre grid (rounded) become one vertex,
    the first one met keeping its coordinates, so texture seams and part junctions are no
    open boundary."""
    if not meshes:
        return WeldedMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    offsets = np.cumsum([0] + [len(positions) for positions, _ in meshes])
    positions = np.concatenate([positions for positions, _ in meshes])
    faces = np.concatenate([triangles + offsets[i] for i, (_, triangles) in enumerate(meshes)])
    first, inverse = unique_float_rows(np.round(positions / weld))
    return WeldedMesh(positions[first], inverse[faces])


def weld_positions(positions: np.ndarray, distance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Cluster vertices closer than ``distance`` (metres).

    Returns ``(welded, welded_positions)``: ``welded`` (n,) int64 cluster index per vertex,
    ``welded_positions`` (k, 3) float64 metres, the lowest-index member's position per cluster.
    """
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    if len(positions) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    # Exact duplicates are one cluster at any distance (first member wins): numbered by their
    # lowest member, so the order follows the input.
    cluster, first = exact(np.ascontiguousarray(positions))
    distinct = positions[first]
    if distance <= 0.0:
        return cluster, distinct
    # Components over distinct positions: a component's lowest distinct position is its lowest
    # member (duplicates are at distance 0, so in the component of their first member).
    lowest = near(distinct, float(distance))
    if lowest is None:  # a coordinate or the distance not finite: the tree decides, as before
        pairs = cKDTree(distinct).query_pairs(r=float(distance), output_type="ndarray")
        lowest = lowest_member(len(distinct), pairs[:, 0], pairs[:, 1])
    root = lowest == np.arange(len(distinct))
    return (np.cumsum(root) - 1)[lowest][cluster], distinct[root]
