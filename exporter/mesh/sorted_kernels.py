"""Binary search in a sorted int64 array, compiled (the kernels' own, instead of numba's
``np.searchsorted``, whose generic implementation costs seconds of compile time per caller)."""

from __future__ import annotations

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
