"""Importing the ``exporter`` package of one checkout or another in the same process, so that a
benchmark times both on the same inputs, one after the other (the machines are shared and noisy:
only ratios measured in one run mean anything)."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path


def load_exporter(root: Path, names: tuple[str, ...]) -> dict:
    """The modules ``exporter.<name>`` for each of ``names`` of the checkout at ``root``, freshly
    imported (every ``exporter`` module imported before is dropped first)."""
    for name in [m for m in sys.modules if m == "exporter" or m.startswith("exporter.")]:
        del sys.modules[name]
    sys.path.insert(0, str(root))
    try:
        return {name: importlib.import_module(f"exporter.{name}") for name in names}
    finally:
        sys.path.remove(str(root))
