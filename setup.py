"""Build of the compiled kernels: one CPython extension module per algorithm.

``exporter/mesh/c/<algorithm>.c`` becomes ``exporter.mesh._<algorithm>``. Plain C99 on numpy's C
API. Floating-point contraction (FMA) is off and no fast-math flag is given, so every kernel
rounds exactly as the numpy reference it is tested against (tests/test_*_kernels.py).
Everything else is in pyproject.toml.
"""

import sys
from pathlib import Path

import numpy
from setuptools import Extension, setup

if sys.platform == "win32":
    FLAGS = ["/O2", "/fp:precise"]  # MSVC contracts to FMA only under /fp:contract
else:
    # -fwrapv: int64 keys such as (region * k + v) * k + v wrap as numba's did instead of being
    # undefined behaviour should a mesh ever be large enough to overflow them.
    FLAGS = ["-O2", "-std=c99", "-ffp-contract=off", "-fno-fast-math", "-fwrapv", "-Wall"]

SOURCES = sorted(Path("exporter/mesh/c").glob("*.c"))

setup(
    ext_modules=[
        Extension(
            f"exporter.mesh._{source.stem}",
            [source.as_posix()],
            include_dirs=[numpy.get_include(), "exporter/mesh/c"],
            depends=[p.as_posix() for p in sorted(Path("exporter/mesh/c").glob("*.h"))],
            define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
            extra_compile_args=FLAGS,
        )
        for source in SOURCES
    ]
)
