"""Binary search in a sorted int64 array, compiled (the kernels' own, instead of numba's
``np.searchsorted``, whose generic implementation costs seconds of compile time per caller)."""

from __future__ import annotations

import numpy as np

from .jit import kernel


@kernel
def lower_bound(keys, lo, hi, key):  # pragma: no cover - compiled
    """First index in ``keys[lo:hi]`` (sorted ascending) whose value is >= ``key`` (hi if none)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo


@kernel
def upper_bound(keys, lo, hi, key):  # pragma: no cover - compiled
    """First index in ``keys[lo:hi]`` (sorted ascending) whose value is > ``key`` (hi if none)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if keys[mid] <= key:
            lo = mid + 1
        else:
            hi = mid
    return lo


@kernel
def stable_order(keys):  # pragma: no cover - compiled
    """(n,) int64: the stable ascending order of ``keys`` (n,) int64 (``np.argsort(keys,
    kind="stable")``), a bottom-up merge sort (numba's own sorts cost seconds of compile time)."""
    n = keys.shape[0]
    order = np.arange(n)
    spare = np.empty(n, np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid, hi = min(lo + width, n), min(lo + 2 * width, n)
            i, j = lo, mid
            for t in range(lo, hi):
                # Ties take the left run first: stable.
                if i < mid and (j >= hi or keys[order[i]] <= keys[order[j]]):
                    spare[t] = order[i]
                    i += 1
                else:
                    spare[t] = order[j]
                    j += 1
        order, spare = spare, order
        width *= 2
    return order


@kernel
def run_end(keys, lo):  # pragma: no cover - compiled
    """The end of the run of equal values in ``keys`` starting at ``lo`` (first index after it
    holding another value, or ``len(keys)``)."""
    hi = lo
    while hi < keys.shape[0] and keys[hi] == keys[lo]:
        hi += 1
    return hi
