"""A building's record file (``building.json``): bookkeeping that keeps outputs reproducible.

``{"tile", "record", "inputs", "files"}``: ``record`` is the building's manifest entry;
``inputs`` the input files' ``{path, size, mtime_ns, sha256}``; ``files`` the written files'
``{file, bytes, crc32}`` (name in the building folder, size in bytes, zlib CRC-32). Nothing in it
depends on when the run happened, so two runs over the same input write the same bytes.

When the inputs were hashed is kept as the record file's own modification time instead (set with
``os.utime``, a timestamp outside the file's bytes): git's "racy" rule needs it (a file modified
within ``RACY_NS`` of being hashed is hashed again on the next run, see
``exporter.pipeline.input_fingerprints``).

A re-run reuses a building only when every file the record lists is still there with its size and
CRC-32 (:func:`files_intact`): a truncated or damaged ``lod1.glb`` is rebuilt, not kept. Reading
the files back costs a re-run about as much I/O as the export wrote; CRC-32 runs at several GB/s.
"""

from __future__ import annotations

import json
import os
import zlib
from pathlib import Path

from .atomic import write_text_atomic

STAMP = "hashed_ns"  # in-memory only: when an input was hashed (ns since the epoch)


def file_entry(name: str, data: bytes) -> dict:
    """The ``files`` item of one written file: its name in the building folder, size, CRC-32."""
    return {"file": name, "bytes": len(data), "crc32": zlib.crc32(data)}


def files_intact(folder: Path, files: list[dict]) -> bool:
    """True when every file of ``files`` (``file_entry`` items) in ``folder`` has its recorded
    size and CRC-32 (only the size for items without one: records of 0.3.4 and older)."""
    for item in files:
        path = folder / str(item.get("file", ""))
        try:
            if path.stat().st_size != item.get("bytes"):
                return False
            if "crc32" in item and zlib.crc32(path.read_bytes()) != item["crc32"]:
                return False
        except OSError:
            return False
    return True


def write_record(path: Path, data: dict, inputs: list[dict]) -> None:
    """Write the record file ``path`` holding ``data`` plus ``inputs`` (fingerprints without their
    hash times), atomically, then set its modification time to the earliest hash time (module
    doc)."""
    stamps = [item[STAMP] for item in inputs if isinstance(item.get(STAMP), int)]
    stable = [{k: v for k, v in item.items() if k != STAMP} for item in inputs]
    write_text_atomic(path, json.dumps({**data, "inputs": stable}, allow_nan=False))
    if stamps:
        os.utime(path, ns=(min(stamps), min(stamps)))


def stamped(inputs: list, path: Path) -> list[dict]:
    """A record file's ``inputs`` with the record's modification time as their hash time."""
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        stamp = 0
    return [{**item, STAMP: stamp} for item in inputs if isinstance(item, dict) and "path" in item]
