"""How the compiled kernels of :mod:`exporter.mesh` are compiled: numba's ``njit``, cached on disk.

``cache=True`` keeps the machine code next to the module (``__pycache__``) or, when that is not
writable, in numba's user cache (``NUMBA_CACHE_DIR`` when set): a process pays the compile once per
machine, later ones load it (measured in docs/performance.md, "Compiled kernels"). When no cache
location is writable at all the kernel is compiled in memory on first use instead of failing.
``error_model="numpy"``: a float division by zero gives inf/NaN as numpy does (the numpy code the
kernels replaced relied on it), never an exception.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba


def kernel(function: Callable[..., Any]) -> Any:
    """``function`` compiled with numba (nopython, disk-cached when a cache dir is writable)."""
    try:
        return numba.njit(cache=True, error_model="numpy", nogil=True)(function)
    except RuntimeError:  # numba: "cannot cache function ...: no locator available"
        return numba.njit(error_model="numpy", nogil=True)(function)
