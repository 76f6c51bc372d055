"""Connected components of an undirected graph, labelled by their lowest node: the checks around
the compiled union-find (``exporter/mesh/c/component.c``; Tarjan 1975, path halving, the larger
root linked under the smaller)."""

from __future__ import annotations

import numpy as np

from ._component import lowest


def lowest_member(n: int, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """(n,) int64: the lowest node of every node's connected component in the undirected graph
    on nodes 0..n-1 with edges ``left[i] -- right[i]`` (int arrays of one length)."""
    left = np.ascontiguousarray(left, np.int64).reshape(-1)
    right = np.ascontiguousarray(right, np.int64).reshape(-1)
    if len(left) != len(right):
        raise ValueError("lowest_member: edge ends of different lengths")
    if len(left) and (min(left.min(), right.min()) < 0 or max(left.max(), right.max()) >= n):
        raise ValueError("lowest_member: a node index is out of range")
    return lowest(int(n), left, right)
