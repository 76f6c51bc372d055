"""How the compiled kernels of :mod:`exporter.mesh` are compiled: numba's ``njit``, cached on disk.

``cache=True`` keeps the machine code next to the module (``__pycache__``) or, when that is not
writable, in numba's user cache (``NUMBA_CACHE_DIR`` when set): a process pays the compile once per
machine, later ones load it (measured in docs/performance.md, "Compiled kernels"). When no cache
location is writable at all the kernel is compiled in memory on first use instead of failing.
``error_model="numpy"``: a float division by zero gives inf/NaN as numpy does (the numpy code the
kernels replaced relied on it), never an exception.

numba (and LLVM, ~115 MiB of a process's memory) is imported on the first call of a kernel, not
when the mesh layer is imported: a process that never runs one (the export's main process, the
command line's ``--help``) does not pay for it. On that first call every kernel defined so far
becomes a numba dispatcher and the module names bound to a kernel are rebound to it (kernels call
each other by global name, which numba resolves when it compiles the caller).
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Any

_PENDING: list[_Lazy] = []
_LOCK = threading.Lock()  # a Dask worker may run several threads


class _Lazy:
    """A kernel not yet handed to numba; calling it hands every pending kernel over."""

    def __init__(self, function: Callable[..., Any]) -> None:
        functools.update_wrapper(self, function)
        self.function = function
        self.dispatcher: Any = None
        _PENDING.append(self)

    def __call__(self, *args: Any) -> Any:
        if self.dispatcher is None:
            compile_pending()
        return self.dispatcher(*args)


def _njit(function: Callable[..., Any]) -> Any:
    import numba

    try:
        return numba.njit(cache=True, error_model="numpy", nogil=True)(function)
    except RuntimeError:  # numba: "cannot cache function ...: no locator available"
        return numba.njit(error_model="numpy", nogil=True)(function)


def compile_pending() -> None:
    """Every kernel defined so far as a numba dispatcher (compiled on its first call), and the
    names of the kernel modules that hold one rebound to it."""
    with _LOCK:
        _compile_pending()


def _compile_pending() -> None:
    for lazy in _PENDING:
        if lazy.dispatcher is None:
            lazy.dispatcher = _njit(lazy.function)
    # Each kernel module's namespace (its functions' globals: what numba resolves names in).
    namespaces = {id(lazy.function.__globals__): lazy.function.__globals__ for lazy in _PENDING}
    for namespace in namespaces.values():
        for name, value in list(namespace.items()):
            if isinstance(value, _Lazy):
                namespace[name] = value.dispatcher


def kernel(function: Callable[..., Any]) -> Any:
    """``function`` compiled with numba (nopython, disk-cached when a cache dir is writable) on
    its first call."""
    return _Lazy(function)
