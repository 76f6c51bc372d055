"""Readers: a tile folder (or one index or CityJSON file) in, buildings
(:class:`exporter.model.Building`) out.

Two steps, so the pipeline can plan, skip unchanged work and load in parallel:

1. ``scan_folder(folder, options)`` is cheap: it detects the format, lists one :class:`Entry` per
   building (id, source file, the tile it belongs to, the files its content depends on) and the
   :class:`~exporter.model.Skipped` items found while listing. It raises
   :class:`~exporter.errors.InputError` naming the folder when the folder is unusable.
2. ``load_entry(entry, options)`` reads one building fully; it raises only
   :class:`~exporter.errors.ReadError` (naming the file and the problem), so one broken building
   never stops a tile.

Each format module (``vworld``, ``cityjson``, ``citygml``, ``folder``) provides
``detect(folder) -> bool``, ``scan(path, options) -> Scan`` (``path`` a folder, or one file of the
format: a VWorld ``.dat``, a CityJSON or CityGML file, an OBJ/glTF index file) and
``load(entry, options) -> Building``. Entries are plain picklable data (they cross process
boundaries). ``input_paths(paths)`` turns a command line's inputs (shell globs expanded: folders
and files mixed) into the list to scan.
"""

from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..config import ReaderOptions
from ..errors import InputError, ReadError, error_text
from ..model import Building, Skipped, TileId
from ..names import MAX_TEXT_CHARS, bounded_text


# Readers check every number they use (non-finite vertices, far vertices: a problem or a skip
# naming the building), so numpy's floating-point warnings on hostile input ("overflow encountered
# in multiply") would only break the one-line stderr rule. np.errstate is thread-local (Dask); a
# new one each time, as one keeps the state it replaced.
def _quiet_numbers() -> np.errstate:
    return np.errstate(all="ignore")


# Format modules in detection order; each is imported lazily so a broken optional dependency of
# one reader does not stop the others.
FORMATS = ("vworld", "cityjson", "citygml", "folder")
LABELS = {"vworld": "VWorld", "cityjson": "CityJSON", "citygml": "CityGML", "folder": "OBJ/glTF"}


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

    @functools.cached_property
    def key_text(self) -> str:
        """``repr(key)`` (part of the building's input hash): made once, in the scan's process
        (:func:`scan_folder`), so a re-run's main process does not make it for every building.
        A reader sets ``key`` during its scan only."""
        return repr(self.key)


@dataclass
class Scan:
    """What a folder holds: its format, the buildings to load and what could not even be listed."""

    folder: str
    format: str
    entries: list[Entry] = field(default_factory=list)
    skipped: list[Skipped] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    # ReaderOptions.crs: whether a file declaring no CRS was read in it, and the files declaring
    # another one (read in theirs; see check_crs_option).
    crs_option_used: bool = False
    crs_conflicts: list[str] = field(default_factory=list)

    def add(self, other: Any) -> None:
        """Take in the entries, skipped items, notes and CRS findings of ``other`` (a Scan or a
        reader's per-file scan with the same fields)."""
        self.entries += other.entries
        self.skipped += other.skipped
        self.notes += other.notes
        self.crs_option_used |= other.crs_option_used
        self.crs_conflicts += other.crs_conflicts


def _module(name: str):
    return importlib.import_module(f"{__name__}.{name}")


EXPECTED = (
    "expected a VWorld .dat index with .xdo files, CityJSON *.city.json / *.json / *.city.jsonl "
    "files, CityGML *.gml / *.gml.gz / *.xml files, or OBJ/glTF/GLB files with an index file "
    "buildings.csv/.yaml/.json; see README 'Input'"
)
# Files a folder's index refers to: given on their own (e.g. by a shell glob over a tile folder)
# they are read through their index, never alone.
COMPANIONS = {
    ".xdo": "a VWorld model: give its .dat index or its folder",
    ".obj": "a model: give its index file (buildings.csv/.yaml/.json) or its folder",
    ".gltf": "a model: give its index file (buildings.csv/.yaml/.json) or its folder",
    ".glb": "a model: give its index file (buildings.csv/.yaml/.json) or its folder",
    ".mtl": "an OBJ material file: give the models' index file or their folder",
    ".bin": "a glTF buffer: give the models' index file or their folder",
    ".jpg": "an image: give the index file or the folder that uses it",
    ".jpeg": "an image: give the index file or the folder that uses it",
    ".png": "an image: give the index file or the folder that uses it",
}


def _missing(path: Path) -> InputError:
    pattern = any(c in str(path) for c in "*?[")
    hint = " (a shell pattern that matched nothing?)" if pattern else ""
    return InputError(f"{path}: no such file or folder{hint}")


def file_format(path: Path) -> str:
    """The format of a single input file, by name (and the first 64 KiB of a ``*.json``);
    InputError naming the file when it is none of them."""
    name = path.name.lower()
    try:
        empty = path.stat().st_size == 0
    except OSError as error:
        raise InputError(f"{path}: cannot be read ({error.strerror or error})") from None
    if empty:
        raise InputError(f"{path}: empty file; {EXPECTED}")
    if name.endswith(".dat"):
        return "vworld"
    if _module("cityjson").is_cityjson_file(path):
        return "cityjson"
    if _module("citygml").is_citygml_file(path):
        return "citygml"
    if name.endswith((".csv", ".yaml", ".yml")) or name == "buildings.json":
        return "folder"
    if name.endswith(".json") and _mentions(path, b'"file"'):  # an index under another name
        return "folder"

    suffix = path.suffix.lower()
    if suffix in COMPANIONS:
        raise InputError(f"{path}: {COMPANIONS[suffix]}")
    raise InputError(f"{path}: not an input file; {EXPECTED}")


def detect_formats(folder: str | Path) -> list[str]:
    """Names of the formats a folder holds (each whose ``detect`` accepts it, in detection order),
    or the one format of a file (:func:`file_format`); InputError naming the path when none fits
    or it cannot be read."""
    folder = Path(folder)
    if folder.is_file():
        return [file_format(folder)]
    if not folder.is_dir():
        raise (
            _missing(folder)
            if not folder.exists()
            else InputError(f"{folder}: not a file or folder")
        )
    try:
        found = [name for name in FORMATS if _module(name).detect(folder)]
    except OSError as error:
        raise InputError(f"{folder}: cannot be read ({error.strerror or error})") from None
    if not found:
        raise InputError(f"{folder}: no building data found ({EXPECTED})")
    return found


def detect_format(folder: str | Path) -> str:
    """The first of :func:`detect_formats` (a folder holding several is read in each)."""
    return detect_formats(folder)[0]


def scan_folder(folder: str | Path, options: ReaderOptions | None = None) -> Scan:
    """List the buildings of a tile folder or of one input file (see module doc). A folder
    holding several formats (e.g. a ``.dat`` tile and CityJSON files) is read in each, noted:
    ``Scan.format`` then names them all, joined by ``+``."""
    options = options or ReaderOptions()
    names = detect_formats(folder)
    scans = []
    for name in names:
        try:
            with _quiet_numbers():
                scans.append(_bounded_scan(_module(name).scan(Path(folder), options)))
        except OSError as error:  # e.g. a file in it that cannot be opened
            where = error.filename or folder
            raise InputError(f"{where}: cannot be read ({error.strerror or error})") from None
    for scan in scans:
        for entry in scan.entries:
            entry.key_text  # noqa: B018 (made here: scans may run in other processes)
    if len(scans) == 1:
        return scans[0]
    merged = Scan(folder=str(folder), format="+".join(names))
    merged.notes.append(
        f"{Path(folder).name}: holds {' and '.join(LABELS[n] for n in names)} data; read each"
    )
    for scan in scans:
        merged.add(scan)
    return merged


def check_crs_option(scans: list[Scan], options: ReaderOptions) -> None:
    """Refuse ``options.crs`` (``--crs``) when it contradicts what files declare and no file of
    the run lacks a CRS: it then could only have been meant to override, which it never does
    silently (``override_crs`` does, noted). With a file lacking one, the option is for that file
    and the declaring files keep their own CRS (noted)."""
    conflicts = [text for scan in scans for text in scan.crs_conflicts]
    if conflicts and not any(scan.crs_option_used for scan in scans):
        raise InputError(
            f"{conflicts[0]}, and no input lacks a CRS (--crs / readers.crs applies only to files "
            "that declare none); drop --crs, or replace the declared CRS with --override-crs "
            "EPSG:<code> or readers.override_crs"
        )


def input_paths(paths: list[str | Path]) -> list[Path]:
    """The inputs of one command line (shell globs expanded: folders and files mixed), each once.

    A file inside a folder also given is left to that folder when the folder reads it (same
    format); a companion file (``.xdo``, image, model) is left out when its folder or another file
    of its folder is given (``vworld-lod export tile/*``), else refused naming the file. A folder
    holding only such files beside a given file (CityGML's appearance folder) is left out too.
    Raises InputError for a path that does not exist.
    """
    given = [Path(p) for p in paths]
    for path in given:
        if not path.exists():
            raise _missing(path)
    folders = {p.resolve() for p in given if p.is_dir()}
    parents = {
        p.resolve().parent for p in given if p.is_file() and p.suffix.lower() not in COMPANIONS
    }
    beside = {p.absolute().parent for p in given if p.is_file()}  # as given: links not followed
    kept: list[Path] = []
    seen: set[Path] = set()
    for path in given:
        resolved = path.resolve()
        if resolved in seen:
            continue
        seen.add(resolved)
        if path.is_file():
            parent = resolved.parent
            if path.suffix.lower() in COMPANIONS and (parent in folders or parent in parents):
                continue
            if parent in folders and _read_by_folder(path, parent):
                continue
        elif path.absolute().parent in beside and _images_only(path):
            continue  # e.g. a CityGML file's <name>_appearance/ folder matched by tile/*
        kept.append(path)
    return kept


def _images_only(folder: Path) -> bool:
    """True when every file directly in ``folder`` is a companion (image, model part), so the
    folder is a sibling file's appearance store, not an input."""
    try:
        files = [p for p in folder.iterdir() if p.is_file()]
    except OSError:
        return False
    return bool(files) and all(p.suffix.lower() in COMPANIONS for p in files)


def _read_by_folder(path: Path, folder: Path) -> bool:
    """True when scanning ``folder`` already lists the buildings of ``path`` (a format it reads)."""
    try:
        return file_format(path) in detect_formats(folder)
    except InputError:
        return False


def _bounded_scan(scan: Scan) -> Scan:
    """``scan`` with every text taken from input (ids, reasons, notes) bounded (docs/input.md)."""
    for entry in scan.entries:
        entry.id = bounded_text(entry.id)
    for item in scan.skipped:
        item.reason = bounded_text(item.reason)
        item.id = None if item.id is None else bounded_text(item.id)
    scan.notes = [bounded_text(note) for note in scan.notes]
    return scan


def _bounded_building(building: Building) -> Building:
    """``building`` with its id, problems and part/texture names bounded, a
    problem saying what was cut (docs/input.md "Texts from input are bounded")."""
    cut = []
    if len(building.id) > MAX_TEXT_CHARS:
        cut.append(f"id cut to {MAX_TEXT_CHARS} of {len(building.id)} characters")
        building.id = bounded_text(building.id)
    # attribute texts are bounded where every reader makes them (exporter/attributes.py)
    building.problems = [bounded_text(problem) for problem in building.problems] + cut
    for part in building.parts:  # names of materials and images in the glTF files
        part.name = bounded_text(part.name)
        if part.texture is not None:
            part.texture.name = bounded_text(part.texture.name)
    return building


def load_entry(entry: Entry, options: ReaderOptions | None = None) -> Building:
    """Read one listed building; raises only ReadError."""
    options = options or ReaderOptions()
    try:
        with _quiet_numbers():
            return _bounded_building(_module(entry.format).load(entry, options))
    except ReadError as error:
        error.problem = bounded_text(error.problem)
        error.args = (f"{error.path}: {error.problem}",)
        raise
    except MemoryError:
        raise ReadError(entry.source, "too large to read into memory") from None
    except Exception as error:  # a reader bug must not stop the tile; report it as this building's
        raise ReadError(entry.source, f"unexpected {error_text(error)}") from error


def _mentions(path: Path, text: bytes) -> bool:
    try:
        with path.open("rb") as handle:
            return text in handle.read(65536)
    except OSError:
        return False
