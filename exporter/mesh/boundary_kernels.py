"""The open boundary of a triangle mesh: the compiled kernel ``exporter/mesh/c/boundary.c`` (the
edges used by exactly one face side as (low, high) vertex pairs, ascending, the number of loops
they form, and the sides on it; integers only, the former numpy form is matched exactly:
``tests/test_boundary_kernels.py`` keeps it as the reference)."""

from __future__ import annotations

import numpy as np

from ._boundary import border_loops as _border_loops
from ._boundary import once_sides as _once_sides


def once_sides(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """(s,) int64 ascending: the sides ``3 f + i`` (corner i of face f to corner i + 1) of
    ``faces`` (m, 3) int64 (ids in 0..vertex_count) whose undirected edge no other side uses."""
    return _once_sides(faces, vertex_count)


def border_loops(faces: np.ndarray, vertex_count: int) -> tuple[np.ndarray, int]:
    """``(edges (e, 2) int64, loops)`` of ``faces`` (m, 3) int64 with ids in 0..vertex_count:
    the border edges as ascending (low, high) pairs and the number of their connected
    components."""
    return _border_loops(faces, vertex_count)
