"""Readers: a tile folder in, buildings (:class:`exporter.model.Building`) out.

Two steps, so the pipeline can plan, skip unchanged work and load in parallel:

1. ``scan_folder(folder, options)`` is cheap: it detects the format, lists one :class:`Entry` per
   building (id, source file, the tile it belongs to, the files its content depends on) and the
   :class:`~exporter.model.Skipped` items found while listing. It raises
   :class:`~exporter.errors.InputError` naming the folder when the folder is unusable.
2. ``load_entry(entry, options)`` reads one building fully; it raises only
   :class:`~exporter.errors.ReadError` (naming the file and the problem), so one broken building
   never stops a tile.

Each format module (``vworld``, ``cityjson``, ``folder``) provides ``detect(folder) -> bool``,
``scan(folder, options) -> Scan`` and ``load(entry, options) -> Building``. Entries are plain
picklable data (they cross process boundaries).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..config import ReaderOptions
from ..errors import InputError, ReadError
from ..model import Building, Skipped, TileId

# Format modules in detection order; each is imported lazily so a broken optional dependency of
# one reader does not stop the others.
FORMATS = ("vworld", "cityjson", "folder")


@dataclass
class Entry:
    """One building to load. ``key`` is the reader's own handle (e.g. the object index in a
    ``.dat`` or the CityObject id in a CityJSON file); ``inputs`` are the files whose bytes decide
    the building's content (hashed for incremental runs)."""

    format: str
    id: str
    source: str
    tile: TileId | None
    inputs: list[str]
    key: Any = None


@dataclass
class Scan:
    """What a folder holds: its format, the buildings to load and what could not even be listed."""

    folder: str
    format: str
    entries: list[Entry] = field(default_factory=list)
    skipped: list[Skipped] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def _module(name: str):
    return importlib.import_module(f"{__name__}.{name}")


def detect_format(folder: str | Path) -> str:
    """Name of the first format whose ``detect`` accepts the folder; InputError when none does."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a readable folder")
    for name in FORMATS:
        if _module(name).detect(folder):
            return name
    raise InputError(
        f"{folder}: no building data found (expected a VWorld .dat index with .xdo files, CityJSON "
        "*.city.json / *.json files, or OBJ/glTF/GLB files with an index file; see README 'Input formats')"
    )


def scan_folder(folder: str | Path, options: ReaderOptions | None = None) -> Scan:
    """List the buildings of a tile folder (see module doc)."""
    options = options or ReaderOptions()
    name = detect_format(folder)
    return _module(name).scan(Path(folder), options)


def load_entry(entry: Entry, options: ReaderOptions | None = None) -> Building:
    """Read one listed building; raises only ReadError."""
    options = options or ReaderOptions()
    try:
        return _module(entry.format).load(entry, options)
    except ReadError:
        raise
    except MemoryError:
        raise ReadError(entry.source, "too large to read into memory") from None
    except Exception as error:  # a reader bug must not stop the tile; report it as this building's
        raise ReadError(entry.source, f"unexpected {type(error).__name__}: {error}") from error
