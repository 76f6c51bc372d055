"""Every face side's undirected edge key in ascending order, and the distinct edges with their
use counts: the compiled kernel ``exporter/mesh/c/edge.c`` (sides bucketed by their lower vertex,
each bucket sorted stably by the higher one: exactly ``np.argsort(keys, kind="stable")``'s order;
``tests/test_edge_kernels.py`` keeps the numpy form as the reference)."""

from __future__ import annotations

import numpy as np

from ._edge import counts as _counts
from ._edge import key_order as _key_order


def edge_key_order(faces: np.ndarray, vertex_count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(keys (3m,) int64 ascending, order (3m,) int64)`` of ``faces`` (m, 3) int64 (ids below
    ``vertex_count``): side ``3 f + i`` runs from corner i of face f to the next, its key is
    ``low * vertex_count + high``; ``order`` the stable permutation that sorts the keys."""
    return _key_order(faces, vertex_count)


def edge_counts(faces: np.ndarray, vertex_count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(edges (e, 2) int64, uses (e,) int64)``: the undirected edges of ``faces`` (m, 3) int64
    (ids below ``vertex_count``) as ascending (low, high) pairs and how many sides use each."""
    return _counts(faces, vertex_count)
