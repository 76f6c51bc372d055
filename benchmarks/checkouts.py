"""Importing the ``exporter`` package of one checkout or another in the same process, so that a
benchmark times both on the same inputs, one after the other (the machines are shared and noisy:
only ratios measured in one run mean anything)."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

# The ``exporter`` modules of each checkout imported so far, by root (see use_checkout).
_MODULES: dict[str, dict] = {}
_ACTIVE: list[str] = []


def _exporter_modules() -> dict:
    return {n: m for n, m in sys.modules.items() if n == "exporter" or n.startswith("exporter.")}


def use_checkout(root: Path) -> None:
    """Make the checkout at ``root`` (imported by :func:`load_exporter`) the one whose modules
    ``sys.modules`` holds, before running its code: loading a compiled kernel from numba's cache
    imports the kernel's module by name, and a kernel new in one checkout is missing in the other.
    numba's environments are forgotten by name on each switch (they stay with their kernels): the
    kernels of two checkouts share names, and a cached kernel given the other checkout's
    environment fails ("NRT_adapt_ndarray_to_python: descr is NULL")."""
    key = str(root)
    if _ACTIVE and _ACTIVE[0] == key:
        return
    if _ACTIVE:
        _MODULES[_ACTIVE[0]] = _exporter_modules()
    for name in _exporter_modules():
        del sys.modules[name]
    sys.modules.update(_MODULES.get(key, {}))
    environment = sys.modules.get("numba.core.environment")
    if environment is not None:
        environment.Environment._memo.clear()
    _ACTIVE[:] = [key]


def load_exporter(root: Path, names: tuple[str, ...]) -> dict:
    """The modules ``exporter.<name>`` for each of ``names`` of the checkout at ``root``, freshly
    imported (every ``exporter`` module imported before is dropped first; it comes back with
    :func:`use_checkout` of its checkout)."""
    use_checkout(root)
    for name in _exporter_modules():
        del sys.modules[name]
    sys.path.insert(0, str(root))
    try:
        return {name: importlib.import_module(f"exporter.{name}") for name in names}
    finally:
        sys.path.remove(str(root))
