"""The compiled kernels' decorator: cached on disk, and still compiled (in memory) when numba
finds no writable cache location, instead of failing the import of the mesh layer."""

from __future__ import annotations

import numba

from exporter.mesh import jit


def test_a_kernel_without_a_cache_location_is_compiled_in_memory(monkeypatch):
    real = numba.njit
    asked = []

    def njit(*args, **options):
        if args:  # numba's own uses while compiling
            return real(*args, **options)
        asked.append(options.get("cache", False))
        if options.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available for file 'x'")
        return real(**options)

    monkeypatch.setattr(jit.numba, "njit", njit)

    def add(a, b):
        return a / b

    compiled = jit.kernel(add)
    assert asked == [True, False]
    assert compiled(1.0, 0.0) == float("inf")  # error_model="numpy": no ZeroDivisionError


def test_kernels_are_cached_on_disk():
    from exporter.mesh.distance_kernels import _pairs

    assert _pairs._cache is not None
    assert type(_pairs._cache).__name__ == "FunctionCache"
