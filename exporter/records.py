"""A building's record file (``building.json``): bookkeeping that keeps outputs reproducible.

``{"tile", "record", "inputs", "files"}``: ``record`` is the building's manifest entry;
``inputs`` the input files' ``{path, size, mtime_ns, sha256}``; ``files`` the written files'
``{file, bytes, crc32}`` (name in the building folder, size in bytes, zlib's CRC-32). Nothing in it
depends on when the run happened, so two runs over the same input write the same bytes.

When the inputs were hashed is kept as the record file's own modification time instead (set with
``os.utime``, a timestamp outside the file's bytes): git's "racy" rule needs it (a file modified
within ``RACY_NS`` of being hashed is hashed again on the next run, see
``exporter.pipeline.input_fingerprints``).

A re-run reuses a building only when every file the record lists is still there with its size and
CRC-32 (:func:`files_intact`): a truncated or damaged ``lod1.glb`` is rebuilt, not kept. Reading
the files back costs an unchanged re-run 1.25x the time of checking sizes only (200 buildings,
20.9 MB of ``.glb``, files in the page cache: 0.30 s against 0.24 s; first run 21.9 s), and far
more when they are not cached (16 tiles x 300 buildings, 570 MB: ~2.3 s of a 9 s re-run with one
changed tile). So a building reused from its tile's summary has only the files read back whose
inode changed since that summary was written (their ctime; every change to a file sets it).

A tile's summary (``.tile_records.json`` beside its manifest, :func:`write_summary`) gathers what
a re-run checks of each of the tile's buildings (input hash, input fingerprints, files' size and
CRC-32, the record file's own among them) with the sha256 of the manifest it goes with, so that
an unchanged tile is recognised without parsing its buildings' record files (issue 37). It is
written after the manifest and trusted only while that manifest is the one it was written
with; its modification time is its inputs' hash time, as a record's (:func:`hash_time`).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

# zlib's CRC-32 (same polynomial and values as zlib.crc32), ~10x faster than zlib 1.2's: 9 against
# 97 us for 300 KB here, the size of a building's lod0.glb.
from isal.isal_zlib import crc32

from .atomic import write_bytes_if_changed, write_text_atomic
from .manifest import MANIFEST_NAME

STAMP = "hashed_ns"  # in-memory only: when an input was hashed (ns since the epoch)
FROM_RECORD = "stamp_from_record"  # in-memory only: STAMP is a previous record's time


def file_entry(name: str, data: bytes) -> dict:
    """The ``files`` item of one written file: its name in the building folder, size, CRC-32."""
    return {"file": name, "bytes": len(data), "crc32": crc32(data)}


def files_intact(folder: Path, files: list[dict], unchanged_before: int | None = None) -> bool:
    """True when every file of ``files`` (``file_entry`` items) in ``folder`` has its recorded
    size and CRC-32 (only the size for items without one: records of 0.3.4 and older).

    ``unchanged_before``: a status-change time (ns, ``st_ctime_ns``) the files were all written
    before (their tile summary's, :attr:`Summary.written_ns`); a file whose inode has not changed
    since (its ctime earlier) is trusted on its size without being read back. Any write,
    truncation, rename onto it or ``utime`` sets a file's ctime to the present, which no call
    sets back, so only such a file is read (git's index trusts stat data the same way)."""
    where = os.fspath(folder)
    for item in files:
        path = os.path.join(where, str(item.get("file", "")))  # os, not pathlib: 3 a building
        try:
            # one stat for a trusted file (no open: most of a re-run's files)
            status = os.stat(path)
            if status.st_size != item.get("bytes"):
                return False
            if unchanged_before is not None and status.st_ctime_ns < unchanged_before:
                continue
            if "crc32" in item:
                with open(path, "rb") as handle:
                    data = handle.read()
                if len(data) != item.get("bytes") or crc32(data) != item["crc32"]:
                    return False
        except OSError:
            return False
    return True


def hash_time(inputs: list[dict]) -> int | None:
    """The hash time a file recording ``inputs`` (fingerprints with their STAMP) may carry: the
    earliest time an input was hashed in this run, else the earliest previous record's time
    (None without any). Inputs trusted from a previous record were last modified well before
    that record's time (``input_fingerprints`` trusts no other), so a later time is as safe for
    them."""
    fresh = [item[STAMP] for item in inputs if STAMP in item and FROM_RECORD not in item]
    stamps = fresh or [item[STAMP] for item in inputs if STAMP in item]
    return min(stamps) if stamps else None


def stable_inputs(inputs: list[dict]) -> list[dict]:
    """``inputs`` without their in-memory hash times (what a file records)."""
    return [{k: v for k, v in item.items() if k not in (STAMP, FROM_RECORD)} for item in inputs]


def write_record(path: str | Path, data: dict, inputs: list[dict]) -> None:
    """Write the record file ``path`` holding ``data`` plus ``inputs`` (fingerprints without their
    hash times), atomically, then set its modification time to :func:`hash_time` (module doc)."""
    stamp = hash_time(inputs)
    write_text_atomic(
        os.fspath(path), json.dumps({**data, "inputs": stable_inputs(inputs)}, allow_nan=False)
    )
    if stamp is not None:
        os.utime(path, ns=(stamp, stamp))


def stamped(inputs: list, path: Path) -> list[dict]:
    """A record file's ``inputs`` with the record's modification time as their hash time."""
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        stamp = 0
    return [
        {**item, STAMP: stamp, FROM_RECORD: True}
        for item in inputs
        if isinstance(item, dict) and "path" in item
    ]


# --------------------------------------------------------------------------- a tile's summary

SUMMARY_NAME = ".tile_records.json"  # beside the manifest; hidden: never taken for a building
SUMMARY_FORMAT = "vworld-lod-tile-records"
SUMMARY_VERSION = 1


def summary_entry(record: dict, inputs: list[dict], files: list[dict]) -> dict:
    """A building's item in its tile's summary: what a re-run checks to reuse it without reading
    its record file (``record``: its manifest entry; ``inputs``: its input fingerprints;
    ``files``: ``file_entry`` items of its level files and of its record file)."""
    return {
        "folder": record["folder"],
        "source": record["source"],
        "id": record["id"],
        "input_hash": record.get("input_hash"),
        "inputs": stable_inputs(inputs),
        "files": files,
    }


@dataclass
class Summary:
    """A tile's summary as read (:func:`read_summary`)."""

    items: dict[str, dict]  # by building folder, as written (:meth:`item` stamps their inputs)
    head: str  # :func:`write_summary`'s ``head``
    manifest_sha256: str  # of the manifest it goes with
    # Its file's status-change time (ns): when it was last written (its utime, after its tile's
    # building files; :func:`files_intact`'s ``unchanged_before``).
    written_ns: int
    stamp: int  # its modification time (ns): its inputs' hash time (:func:`stamped`)

    def item(self, folder: str) -> dict | None:
        """The item of the building in ``folder``, its ``inputs`` stamped with the summary's
        time as :func:`stamped` does (on demand: a summary is read for a few of its items)."""
        item = self.items.get(folder)
        if item is None:
            return None
        try:
            inputs = [{**i, STAMP: self.stamp, FROM_RECORD: True} for i in item["inputs"]]
        except (KeyError, TypeError):  # damaged: its record file decides
            return None
        return {**item, "inputs": inputs}


def write_summary(
    tile_dir: str | Path, manifest: bytes, head: str, entries: list[dict], stamp: int | None
) -> None:
    """Write ``tile_dir``'s summary: ``entries`` (:func:`summary_entry`, in the manifest's order),
    the sha256 of the manifest text they were written with (``manifest``) and ``head`` (what
    the manifest holds besides its buildings, as a hash: a re-run whose head and buildings are
    the same leaves the manifest as it is without making it again), atomically,
    unless it holds these bytes already; then its modification time is ``stamp`` (the hash time
    its inputs were fingerprinted at, :func:`hash_time`; the same racy rule as a record's).
    No time is in its bytes: two runs over the same input write the same summary."""
    path = os.path.join(tile_dir, SUMMARY_NAME)
    data = {
        "format": SUMMARY_FORMAT,
        "version": SUMMARY_VERSION,
        "manifest_sha256": hashlib.sha256(manifest).hexdigest(),
        "head_sha256": head,
        "buildings": entries,
    }
    write_bytes_if_changed(path, json.dumps(data, allow_nan=False).encode("utf-8"))
    if stamp is not None:
        os.utime(path, ns=(stamp, stamp))


def read_summary(tile_dir: str | Path, manifest: bytes | None = None) -> Summary | None:
    """``tile_dir``'s summary (items by building folder), or None when there is none, it cannot
    be read, or the tile's manifest (``manifest``, its bytes when already read) is not the one it
    was written with (an interrupted run, a manifest edited or replaced): then every record file
    is read."""
    path = Path(tile_dir) / SUMMARY_NAME
    try:
        data = json.loads(path.read_bytes())
        if manifest is None:
            manifest = (Path(tile_dir) / MANIFEST_NAME).read_bytes()
        if (
            data["format"] != SUMMARY_FORMAT
            or data["version"] != SUMMARY_VERSION
            or data["manifest_sha256"] != hashlib.sha256(manifest).hexdigest()
        ):
            return None
        status = path.stat()
        out = {}
        for item in data["buildings"]:
            out[str(item["folder"])] = item
        return Summary(
            out,
            str(data["head_sha256"]),
            str(data["manifest_sha256"]),
            status.st_ctime_ns,
            status.st_mtime_ns,
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
