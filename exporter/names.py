"""Names the exporter makes from what the input gives: building folder names and printable text.

Any name a file system allows must give a working export:

- :func:`safe_folder_name`: a building id as a folder name that is safe (ASCII letters, digits,
  ``.``, ``_``, ``-``), bounded (at most 89 characters) and not reserved (Windows device names
  such as ``CON`` or ``nul.txt``, and the names the tile folder's own files use); a name that had
  to change gets 8 hex digits of the id's SHA-1, so distinct ids keep distinct folders. The
  Unity package's ``LodPlan.SafeName`` is the same rule.
- :func:`unique_ids`: ids made unique within a run, also when two folder names differ only in
  case (one folder on macOS and Windows), by ``~1``, ``~2``, ... (as duplicate ids always were).
- :func:`printable`: text that is not valid UTF-8 (file names decoded with surrogate escapes)
  with each undecodable byte written ``\\xNN``, so manifests stay UTF-8 JSON and keep the original.
- :func:`bounded_text`: a text taken from input (id, name, a problem quoting it) cut to
  ``MAX_TEXT_CHARS`` (1000) characters + ``…`` + 8 hex digits of its SHA-1 (distinct long texts
  stay distinct), so a 300 MB building name does not become 300 MB of JSON.
- :func:`terminal_text`: text made safe to print on a terminal: control characters (escape
  sequences, carriage returns, ...) and bidirectional overrides written ``\\xNN`` / ``\\uNNNN``.
- :func:`name_error`: an OSError that concerns one building's file names only (too long, invalid
  on this file system): it costs that building, while a full disk or a read-only output stops the
  run.
"""

from __future__ import annotations

import errno
import hashlib
import re
from collections.abc import Iterable
from typing import Any

MAX_KEPT = 80  # characters of the readable part of a folder name; + "_" + 8 hex digits at most
# Names Windows refuses for any file (any case, with or without an extension), and the names of
# what the exporter writes beside the building folders in a tile folder.
_DEVICE = re.compile(r"^(con|prn|aux|nul|com[0-9]|lpt[0-9])(\..*)?$", re.IGNORECASE)
TILE_FILES = frozenset({"lod_manifest.json", "report.html", "report", "tiles.json", "index.html"})
# errno values that come from one path's name, not from the output's storage.
NAME_ERRNOS = frozenset(
    code
    for code in (errno.ENAMETOOLONG, errno.EINVAL, getattr(errno, "EILSEQ", None))
    if code is not None
)


MAX_TEXT_CHARS = 1000  # characters kept of a text taken from input (bounded_text)
# C0/C1 controls and DEL, and the bidirectional embeddings/overrides/isolates (they reorder what
# follows on a terminal): written escaped by terminal_text.
_UNPRINTABLE = re.compile("[\x00-\x08\x0a-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def bounded_text(text: str, limit: int = MAX_TEXT_CHARS) -> str:
    """``text`` when at most ``limit`` characters, else its first ``limit`` characters, ``…`` and
    8 hex digits of its SHA-1 (module doc)."""
    if len(text) <= limit:
        return text
    digest = hashlib.sha1(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    return f"{text[:limit]}…{digest}"


def terminal_text(text: str) -> str:
    """``text`` with control characters (but tab) and bidirectional controls written
    ``\\xNN`` / ``\\uNNNN``, so a name from input cannot move the cursor, recolour or rewrite
    the terminal it is printed on."""
    return _UNPRINTABLE.sub(
        lambda m: (
            f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100 else f"\\u{ord(m.group()):04x}"
        ),
        text,
    )


def slug(text: str) -> str:
    """``text`` with every run of characters other than ASCII letters, digits, ``.``, ``_``, ``-``
    replaced by ``_``, leading and trailing ``.``/``_`` removed (never empty)."""
    return re.sub(r"[^0-9A-Za-z._-]+", "_", text).strip("._") or "building"


def reserved(name: str) -> bool:
    """True for a folder name a file system or the tile folder's own files forbid."""
    return bool(_DEVICE.match(name)) or name.casefold() in TILE_FILES


def safe_folder_name(building_id: str) -> str:
    """A file-system-safe, bounded, still readable folder name for a building id (stable across
    runs; module doc)."""
    name = slug(building_id)
    if name != building_id or len(name) > MAX_KEPT or reserved(name):
        digest = hashlib.sha1(building_id.encode("utf-8", "surrogatepass")).hexdigest()[:8]
        name = f"{name[:MAX_KEPT]}_{digest}"
    return name


def unique_ids(ids: Iterable[str]) -> list[str]:
    """``ids`` made printable and unique in order (module doc): the first keeps its id, a later
    one whose id or folder name (ignoring case) is taken gets ``~1``, ``~2``, ..."""
    out: list[str] = []
    taken: set[str] = set()
    for raw in ids:
        base = candidate = printable(raw)
        count = 0
        folder = safe_folder_name(candidate).casefold()  # once a candidate (a re-run's start)
        while candidate in taken or folder in taken:
            count += 1
            candidate = f"{base}~{count}"
            folder = safe_folder_name(candidate).casefold()
        taken.add(candidate)
        taken.add(folder)
        out.append(candidate)
    return out


def printable(value: Any) -> Any:
    """``value`` (a string, or lists and dicts of them) with undecodable bytes of surrogate-escaped
    text written ``\\xNN`` (module doc); other values unchanged."""
    if isinstance(value, str):
        try:
            value.encode("utf-8")
            return value
        except UnicodeEncodeError:
            try:
                raw = value.encode("utf-8", "surrogateescape")
            except UnicodeEncodeError:  # a lone surrogate that no byte decoded to
                raw = value.encode("utf-8", "backslashreplace")
            return raw.decode("utf-8", "backslashreplace")
    if isinstance(value, list):
        return [printable(item) for item in value]
    if isinstance(value, dict):
        return {printable(key): printable(item) for key, item in value.items()}
    return value


def name_error(error: OSError) -> bool:
    """True when ``error`` concerns one path's name (module doc)."""
    return error.errno in NAME_ERRNOS
