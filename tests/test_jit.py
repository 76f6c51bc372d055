"""The compiled kernels' decorator: numba only on first use, cached on disk, and still compiled
(in memory) when numba finds no writable cache location, instead of failing."""

from __future__ import annotations

import subprocess
import sys

import numba
import numpy as np

from exporter.mesh import jit


def test_a_kernel_without_a_cache_location_is_compiled_in_memory(monkeypatch):
    jit.compile_pending()  # the project's kernels keep their cache
    real = numba.njit
    asked = []

    def njit(*args, **options):
        if args:  # numba's own uses while compiling
            return real(*args, **options)
        asked.append(options.get("cache", False))
        if options.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available for file 'x'")
        return real(**options)

    monkeypatch.setattr(numba, "njit", njit)

    def divide(a, b):
        return a / b

    compiled = jit.kernel(divide)
    assert compiled(1.0, 0.0) == float("inf")  # error_model="numpy": no ZeroDivisionError
    assert asked == [True, False]


def test_kernels_are_cached_on_disk_and_rebound():
    from exporter.mesh import distance_kernels

    distance_kernels.point_triangle_distance(np.zeros((1, 3)), np.ones((1, 3, 3)))
    assert type(distance_kernels._pairs._cache).__name__ == "FunctionCache"
    # The module's names now hold the dispatchers (what kernels calling kernels resolve).
    assert isinstance(distance_kernels._pair_distance, numba.core.registry.CPUDispatcher)


def test_importing_the_mesh_layer_does_not_import_numba():
    code = "import sys, exporter.quality, exporter.mesh.hausdorff; print('numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
