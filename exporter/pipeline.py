"""The export pipeline: tile folders in, per-tile glTF LoD chains and manifests out.

Per building: :func:`exporter.job.process_entry`, run in worker processes (the local pool here,
or a Dask cluster's workers with ``scheduler``, see ``exporter.distributed``). Its
``input_hash`` (input files' sha256 + effective config + generator version) lets a re-run skip
unchanged buildings, and an interrupted run resume where it stopped.

Per tile (``export_tiles``): collect the records, remove what a previous run left that this run no
longer produces, and write ``lod_manifest.json`` last. Every file is written atomically
(``exporter.atomic``). One broken building never stops a tile: it is listed in ``skipped``.

Output layout: ``OUT/<level>_<idx>_<idy>/lod_manifest.json`` and
``OUT/<level>_<idx>_<idy>/<building folder>/lod<k>.glb`` + ``building.json``.
"""

from __future__ import annotations

import dataclasses
import gc
import hashlib
import itertools
import json
import multiprocessing
import os
import shutil
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .atomic import end_writing, start_writing, write_bytes_atomic
from .completion import Overlap, tile_skips
from .config import Config, ReaderOptions, check_optional_features
from .distributed import (
    ClusterOptions,
    ProxyWorkers,
    batch_size_for,
    cluster_options,
    cluster_results,
    cluster_session,
)
from .errors import InputError
from .job import RECORD_NAME, STAGES, EntryResult, process_entry
from .json_members import top_level_values
from .manifest import MANIFEST_NAME, build_manifest, dumps, record_line
from .model import Skipped, TileId
from .names import printable, unique_ids
from .placement import tile_placement
from .readers import Entry, Scan, check_crs_option, scan_folder
from .readers.folder import FORMAT as INDEX_FORMAT
from .records import (
    STAMP,
    Summary,
    file_entry,
    files_intact,
    hash_time,
    read_summary,
    stable_inputs,
    stamped,
    summary_entry,
    write_record,
    write_summary,
)
from .tile_index import fresh_facts, tile_from_name, write_tile_index
from .tiles import tile_bounds, tile_center
from .tileset import TILESET_NAME, TilesetResult, write_tileset
from .tileset.external import write_tile_tileset
from .workers import start_worker

# --------------------------------------------------------------------------- small pure helpers


def config_fingerprint(config: Config) -> str:
    """Hash of everything in the config that changes a building's output."""
    data = config.to_dict()
    data.pop("tileset")  # the tileset is made after the buildings, from their files
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode("utf-8")).hexdigest()


# A file modified this close (ns) to when it was hashed may change again within one mtime tick
# without its (size, mtime) changing: its recorded stat is not trusted (git's "racy" rule).
RACY_NS = 2_000_000_000


def _sha256_file(name: str) -> str | None:
    digest = hashlib.sha256()
    try:
        with open(name, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


def input_fingerprints(names: list[str], known: dict[str, dict]) -> list[dict]:
    """``[{"path", "size", "mtime_ns", "sha256", "hashed_ns"}]`` of every input file.

    A file whose size and mtime equal what ``known`` (a previous run's fingerprints by path)
    recorded, and that was not modified within ``RACY_NS`` of being hashed then, keeps its recorded
    sha256 without being read again (as make, rsync and git trust stat data); any other file is
    hashed. A missing file has ``sha256`` None."""
    out: list[dict] = []
    for name in names:
        try:
            stat = os.stat(name)
        except OSError:
            out.append({"path": name, "sha256": None})
            continue
        previous = known.get(name)
        if (
            previous
            and previous.get("sha256")
            and previous.get("size") == stat.st_size
            and previous.get("mtime_ns") == stat.st_mtime_ns
            and stat.st_mtime_ns < previous.get("hashed_ns", 0) - RACY_NS
        ):
            out.append(previous)
            continue
        sha256, hashed_ns = _sha256_once(name, stat.st_size, stat.st_mtime_ns)
        out.append(
            {
                "path": name,
                "size": stat.st_size,
                "mtime_ns": stat.st_mtime_ns,
                "sha256": sha256,
                "hashed_ns": hashed_ns,
            }
        )
    return out


_hashed: dict[tuple, tuple] = {}  # (path, size, mtime_ns) -> (sha256, hashed_ns), this process


def _sha256_once(name: str, size: int, mtime_ns: int) -> tuple[str | None, int]:
    """(sha256, when hashed) of a file whose stat is (size, mtime_ns). A file many buildings share
    (CityGML, CityJSON) is hashed once, not once per building, under the same trust rule as a
    previous run's record (not modified within RACY_NS of that hashing)."""
    key = (name, size, mtime_ns)
    known = _hashed.get(key)
    if known is not None and mtime_ns < known[1] - RACY_NS:
        return known
    hashed_ns = time.time_ns()
    if len(_hashed) >= 64:
        _hashed.clear()
    _hashed[key] = (_sha256_file(name), hashed_ns)
    return _hashed[key]


# The release whose building outputs this version writes byte for byte (.glb files; records may
# gain optional fields, as 0.4.2's gltf_bounds, which readers of older records do without): part
# of every input_hash, so a release that changes no .glb byte (0.4.1: the kernels in C; 0.4.2)
# redoes nothing of an earlier run, and one that changes any must set this to its own version.
OUTPUT_VERSION = "0.6.0"  # 0.6.0: partly used (shared) atlases cropped (exporter/crop.py)


def input_hash(entry: Entry, config_hash: str, fingerprints: list[dict]) -> str:
    """Content hash of a building's inputs (the sha256 of every input file's bytes, from
    :func:`input_fingerprints`), the effective config and :data:`OUTPUT_VERSION`; missing input
    files hash as missing (the load reports them)."""
    digest = hashlib.sha256()
    digest.update(
        f"vworld-lod {OUTPUT_VERSION}\n{config_hash}\n{entry.format}\n{entry.id}\n{entry.key_text}\n".encode()
    )
    for fingerprint in fingerprints:
        digest.update(
            f"\n{os.path.basename(fingerprint['path'])}\n{fingerprint['sha256'] or '<missing>'}".encode()
        )
    return digest.hexdigest()


def has_level_errors(record: dict) -> bool:
    """True when every level of ``record`` states its ``error_m`` (records since 0.5.0). An older
    record is redone rather than patched: its texel sizes need the meshes' UVs, and the redo
    writes the same ``.glb`` bytes (files left untouched, ``write_bytes_if_changed``)."""
    lods = record.get("lods")
    return isinstance(lods, list) and all(
        isinstance(lod, dict) and "error_m" in lod for lod in lods
    )


def reusable_record(previous: dict | None, digest: str, out_dir: Path) -> dict | None:
    """A previous run's record when its input hash matches and all its files are still there,
    intact (size and CRC-32, ``exporter.records``)."""
    if previous is None or previous["record"].get("input_hash") != digest:
        return None
    if not has_level_errors(previous["record"]):
        return None  # written before 0.5.0: redone for its levels' errors (same .glb bytes)
    tile_dir = out_dir / previous["tile"].name
    if (tile_dir / previous["record"]["folder"]).is_symlink():  # redone: the job replaces the link
        return None
    files = previous["files"] or [  # a record of 0.3.4 or older: sizes only
        {"file": Path(lod["file"]).name, "bytes": lod.get("file_bytes")}
        for lod in previous["record"]["lods"]
    ]
    return previous if files_intact(tile_dir / previous["record"]["folder"], files) else None


# --------------------------------------------------------------------------- previous runs


def read_record(path: Path) -> dict | None:
    """A building's record file: ``{"tile", "record", "inputs", "files"}`` (inputs: the input
    fingerprints of the run that wrote it; files: its written files, ``exporter.records``), or None
    when it cannot be read (such leftovers are simply redone)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        files = [item for item in data.get("files", []) if isinstance(item, dict)]
        return {
            "tile": TileId(**data["tile"]),
            "record": data["record"],
            "inputs": stamped(data.get("inputs", []), path),
            "files": files,
        }
    except (OSError, ValueError, KeyError, TypeError):
        return None


@dataclass
class TileRecord:
    """A building's record file as its tile's manifest and summary take it."""

    record: dict  # its manifest entry
    line: str | None  # its manifest line when its text can be copied (manifest.record_line)
    summary: dict  # its item of the tile's summary (exporter.records.summary_entry)
    inputs: list[dict]  # its input fingerprints with their hash times (records.stamped)


def manifest_record(path: str) -> TileRecord | None:
    """A record file of the tile being written (:class:`TileRecord`; its inputs stamped with the
    file's time as hashed in this run, which only makes the summary's time earlier), or None
    when it cannot be read."""
    try:
        with open(path, "rb") as handle:
            data = handle.read()
            stamp = os.fstat(handle.fileno()).st_mtime_ns
        members = top_level_values(data.decode("utf-8"))
        record, text = members["record"]
        inputs = members.get("inputs", ([], ""))[0]
        files = members.get("files", ([], ""))[0]
        if not (isinstance(record, dict) and isinstance(inputs, list) and isinstance(files, list)):
            return None
        inputs = [item for item in inputs if isinstance(item, dict) and "path" in item]
        files = [item for item in files if isinstance(item, dict)]
        entry = summary_entry(record, inputs, files + [file_entry(RECORD_NAME, data)])
        fresh = [{**item, STAMP: stamp} for item in inputs] or [{STAMP: stamp}]
        return TileRecord(record, record_line(text), entry, fresh)
    except (OSError, ValueError, KeyError, TypeError):
        return None


def manifest_buildings(text: str) -> dict[str, tuple[dict, str]]:
    """The building entries of a manifest as :func:`exporter.manifest.dumps` wrote it (one line
    each), by folder, with their line; empty when it is not laid out so."""
    start = text.find('\n "buildings": [\n')
    if start < 0:
        return {}
    out = {}
    for line in text[start:].split("\n")[2:]:
        if line in (" ]", " ],"):
            break
        item = line[2:-1] if line.endswith(",") else line[2:]
        record = json.loads(item)
        out[str(record["folder"])] = (record, item)
    return out


def manifest_member(text: str, key: str) -> Any:
    """The value of the top-level ``key`` of a manifest's text as
    :func:`exporter.manifest.dumps` wrote it (each key at the start of a line), decoded alone:
    the buildings are not parsed. Raises ValueError/KeyError when it is not there."""
    start = text.find(f'\n "{key}": ')
    if start < 0:
        raise KeyError(key)
    return _DECODER.raw_decode(text, start + len(key) + 6)[0]


_DECODER = json.JSONDecoder()


def manifest_head(tile: TileId, config: Config, skipped: list[Skipped]) -> str:
    """sha256 of what a manifest holds besides its buildings (the tile, config, generator and
    ``skipped``): with the same buildings, the same head makes the same manifest bytes."""
    text = dumps(build_manifest(tile, tile_bounds(tile), {}, {}, config, [], skipped))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def previous_records(
    out_dir: Path, keep: Iterable[tuple[str, str]] = ()
) -> tuple[dict[tuple[str, str], str], dict[str, str], dict[tuple[str, str], dict]]:
    """Record files a previous run left in ``out_dir``: their paths (text: a ``Path`` is made
    when one comes up, not for every building at a re-run's start) keyed by (source, id), each
    building folder's source (to say which building of another input a run replaces), and the
    summary items of the buildings ``keep`` names (by (source, id)). A tile whose summary
    matches its manifest (:func:`exporter.records.read_summary`) names its buildings from there;
    a record file is read only for a folder it does not list. Only the paths are kept: a
    building's summary item or record is read again when it comes up (memory stays flat over a
    city)."""
    found, sources, kept = {}, {}, {}
    keep = set(keep)
    with os.scandir(out_dir) as tiles:
        tile_dirs = sorted(Path(e.path) for e in tiles if e.is_dir())
    for tile_dir in tile_dirs:
        summary = read_summary(tile_dir)
        items = summary.items if summary is not None else {}
        with os.scandir(tile_dir) as names:
            folders = sorted(e.name for e in names if e.is_dir())
        tile_text = str(tile_dir)
        for name in folders:
            folder = os.path.join(tile_text, name)
            path = os.path.join(folder, RECORD_NAME)
            record = items.get(name) or (read_record(Path(path)) or {}).get("record")
            if isinstance(record, dict) and "source" in record and "id" in record:
                key = (record["source"], record["id"])
                found[key] = path
                sources[folder] = str(record["source"])
                item = summary.item(name) if summary is not None and key in keep else None
                if item is not None:
                    kept[key] = item
    return found, sources, kept


@dataclass(frozen=True)
class SummaryFacts:
    """What a tile's summary says of the whole tile: enough for :func:`write_tile_output` to
    see that the tile is unchanged without reading the summary again."""

    manifest_sha256: str
    head: str
    folders: frozenset[str]


class TileSummaries:
    """Tile summaries (:func:`exporter.records.read_summary`) read as their buildings come up,
    a few tiles kept (a folder's buildings come one after the other); of every tile read, its
    :class:`SummaryFacts` (``facts``, by tile folder name)."""

    KEEP = 4

    def __init__(self) -> None:
        self._read: dict[Path, Summary | None] = {}
        self.facts: dict[str, SummaryFacts] = {}

    def item(self, record_path: Path) -> dict | None:
        """The summary item of the building whose record file is ``record_path``, or None."""
        tile_dir = record_path.parent.parent
        if tile_dir not in self._read:
            if len(self._read) >= self.KEEP:
                del self._read[next(iter(self._read))]
            self._read[tile_dir] = read_summary(tile_dir)
            found = self._read[tile_dir]
            if found is not None:
                folders = frozenset(found.items)
                self.facts[tile_dir.name] = SummaryFacts(found.manifest_sha256, found.head, folders)
        summary = self._read[tile_dir]
        return summary.item(record_path.parent.name) if summary is not None else None

    def written_ns(self, record_path: Path) -> int | None:
        """When the summary holding ``record_path``'s building was written (its ctime, ns;
        :func:`exporter.records.files_intact`), None when unknown."""
        summary = self._read.get(record_path.parent.parent)
        return summary.written_ns if summary is not None else None


def summary_matches(item: dict, digest: str, folder: Path, fingerprints: list[dict]) -> bool:
    """True when a building's summary item lets this run reuse it without reading its record
    file, once its files are found intact (:func:`exporter.records.files_intact`): same input
    hash, same input fingerprints (else its record gets the new ones), its folder not a link."""
    return (
        item.get("input_hash") == digest
        and fingerprints == item["inputs"]
        and not folder.is_symlink()
    )


Owns = Callable[[Iterable[str]], bool]


def input_owner(scans: Iterable[Scan]) -> Owns:
    """Whether a building came from this run's inputs (the command line's folders and files, as
    ``scans``): ``owns(paths)`` is true when one of ``paths`` (a record's source and input files)
    is one of the input files or lies in one of the input folders, after symlinks. An OBJ/glTF
    index file owns its folder (its models are named relative to it). A building of another
    input in the same ``OUT`` is never this run's to remove (issue 36: exporting districts one by
    one into one ``OUT``)."""
    files, folders = set(), []
    for scan in scans:
        real = os.path.realpath(scan.folder)
        if os.path.isdir(real):
            folders.append(os.path.join(real, ""))
        else:
            files.add(real)
            if scan.format == INDEX_FORMAT:
                folders.append(os.path.join(os.path.dirname(real), ""))

    def owns(paths: Iterable[str]) -> bool:
        for path in paths:
            real = os.path.realpath(path)
            inside = os.path.join(real, "")  # an input folder itself (a folder-wide skip)
            if real in files or any(inside.startswith(folder) for folder in folders):
                return True
        return False

    return owns


def scan_folders(folders: list[str | Path], options: ReaderOptions, jobs: int) -> list[Scan]:
    """:func:`exporter.readers.scan_folder` of each folder, in order: several folders in up to
    ``jobs`` forked processes (a scan parses every model's header or every document, a re-run's
    fixed cost). The first folder in order that cannot be used raises, as when they are scanned
    one after the other."""
    if jobs <= 1 or len(folders) <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [scan_folder(folder, options) for folder in folders]
    with ProcessPoolExecutor(
        max_workers=min(jobs, len(folders)),
        mp_context=multiprocessing.get_context("fork"),  # no re-import: starts in milliseconds
        initializer=start_worker,
        initargs=(os.getpid(),),
    ) as pool:
        return list(pool.map(scan_folder, folders, itertools.repeat(options)))


def entry_groups(scans: list[Scan]) -> list[list[Entry]]:
    """The scans' entries (in order) in runs of one scan and one tile: a folder's tile, the unit
    a re-run finds changed or not (:func:`export_tiles` checks each run's first entry first)."""
    groups: list[list[Entry]] = []
    for scan in scans:
        for index, entry in enumerate(scan.entries):
            if index == 0 or entry.tile != scan.entries[index - 1].tile:
                groups.append([])
            groups[-1].append(entry)
    return groups


def _refresh_fingerprints(out_dir: Path, previous: dict, fingerprints: list[dict]) -> None:
    """Rewrite a reused building's record file with its inputs' current fingerprints, so the next
    run trusts their stat instead of hashing them again."""
    path = out_dir / previous["tile"].name / previous["record"]["folder"] / RECORD_NAME
    data = {
        "tile": dataclasses.asdict(previous["tile"]),
        "record": previous["record"],
        "files": previous["files"],
    }
    write_record(path, data, fingerprints)


# --------------------------------------------------------------------------- the run


@dataclass
class TileResult:
    tile: TileId
    manifest_path: Path
    buildings: int
    skipped: int
    reused: int


@dataclass
class RunStats:
    """What a run did: counts and seconds summed over buildings per stage."""

    buildings: int = 0
    skipped: int = 0
    reused: int = 0
    seconds: dict = field(default_factory=lambda: {stage: 0.0 for stage in STAGES})
    wall_seconds: float = 0.0
    tiles: list[TileResult] = field(default_factory=list)
    tileset: TilesetResult | None = None  # OUT/tileset.json (exporter.tileset), when enabled
    # Buildings of other inputs whose folder a building of this run took (same folder name).
    replaced: list[str] = field(default_factory=list)


Progress = Callable[[int, int], None]


# Buildings per pool task at most: a task's round trip through the pool (pickling, the pool's
# threads and pipes) costs about as much CPU as a tenth of a building's export.
LOCAL_BATCH = 8


def _process_batch(items: list[tuple]) -> list[EntryResult]:
    """Run in a pool worker: :func:`exporter.job.process_entry` for each task tuple of ``items``."""
    return [process_entry(*item) for item in items]


def _results(
    work: Iterable[tuple | EntryResult],
    jobs: int,
    total: int = 0,
    idle: Iterable[tuple | EntryResult] = (),
    after_work: Callable[[], None] | None = None,
) -> Iterable[EntryResult]:
    """Run ``process_entry`` over ``work`` then ``idle`` (task tuples, or finished results passed
    through as they come), in this process for one job, else in a process pool, in batches of up
    to ``LOCAL_BATCH`` tasks, smaller when what is left of the ``total`` items would not give
    every worker four more (so the workers finish together), with a bounded number of batches in
    flight (memory stays bounded by the work in flight). ``work`` is consumed lazily, so the
    caller's per-entry checks (input hashing) overlap the workers; ``idle`` (a re-run's unchanged
    buildings: checks that mostly end in finished results) is also taken while every worker is
    busy, its results passed through at once, its tasks kept for when ``work`` is done. With
    ``after_work``, ``idle`` waits instead until every result of ``work`` is back, then
    ``after_work()`` is called (it starts the proxies built ahead: the idle checks then run
    beside them rather than beside the buildings)."""
    idle = iter(idle)
    if jobs <= 1:
        for item in work:
            yield item if isinstance(item, EntryResult) else process_entry(*item)
        if after_work is not None:
            after_work()
        for item in idle:
            yield item if isinstance(item, EntryResult) else process_entry(*item)
        return
    # Workers end with this process even when it is killed outright (exporter.workers).
    with ProcessPoolExecutor(
        max_workers=jobs, initializer=start_worker, initargs=(os.getpid(),)
    ) as pool:
        pending: set = set()
        batch: list[tuple] = []
        deferred: list[tuple] = []  # idle tasks met while the workers were busy
        size = taken = 0

        def while_busy() -> Iterator[EntryResult]:
            while not any(future.done() for future in pending):
                item = next(idle, None)
                if item is None:
                    return
                if isinstance(item, EntryResult):
                    yield item
                else:
                    deferred.append(item)

        def feed(items: Iterable[tuple | EntryResult], fill: bool) -> Iterator[EntryResult]:
            nonlocal batch, size, taken, pending
            for item in items:
                taken += 1
                if isinstance(item, EntryResult):
                    yield item
                    continue
                if not batch:  # sized on what is left: batches shrink to one near the end
                    size = batch_size_for(total - taken + 1, jobs, LOCAL_BATCH)
                batch.append(item)
                if len(batch) < size:
                    continue
                pending.add(pool.submit(_process_batch, batch))
                batch = []
                if len(pending) >= jobs * 2:
                    if fill:
                        yield from while_busy()
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for future in done:
                        yield from future.result()

        def drain() -> Iterator[EntryResult]:
            """The last batch out, then every result still pending."""
            nonlocal batch, pending
            if batch:
                pending.add(pool.submit(_process_batch, batch))
                batch = []
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield from future.result()

        try:
            yield from feed(work, after_work is None)
            if after_work is not None:
                yield from drain()
                after_work()
            yield from feed(itertools.chain(deferred, idle), False)
            yield from drain()
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


@contextmanager
def _result_stream(
    work: Iterable[tuple | EntryResult],
    jobs: int,
    total: int,
    folders: list[str | Path],
    out_dir: Path,
    scheduler: str | ClusterOptions | None,
    notify: Callable[[str], None] | None,
    workers: ProxyWorkers | None = None,
    idle: Iterable[tuple | EntryResult] = (),
    after_work: Callable[[], None] | None = None,
) -> Iterator[Iterable[EntryResult]]:
    """The results of ``work`` and ``idle`` (:func:`_results`): from the local pool, or, with
    ``scheduler`` (an address, ``"local"`` or :class:`exporter.distributed.ClusterOptions`), from
    a Dask cluster checked before any work starts (``exporter.distributed``; ``idle`` after
    ``work``), whose session the proxies' ``workers`` share meanwhile."""
    if scheduler is None:
        yield _results(work, min(jobs, max(1, total)), total, idle, after_work)
        return
    options = cluster_options(scheduler, jobs)
    assert options is not None
    with cluster_session(options, [str(f) for f in folders], str(out_dir), notify) as client:
        if workers is not None:
            workers.share(client)
        yield cluster_results(client, itertools.chain(work, idle), total, options)


@contextmanager
def without_gc() -> Iterator[None]:
    """No cyclic garbage collection inside: the manifests and the tileset allocate about a million
    short-lived, acyclic objects (parsed records, tree nodes) that reference counting frees, and
    each collection they trigger would scan the whole heap again (the 1,248-building tile's tail:
    ~0.1 s of ~0.8 s CPU). Collection resumes as it was after, also on an error."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def export_tiles(
    folders: list[str | Path],
    out: str | Path,
    config: Config,
    jobs: int | None = None,
    force: bool = False,
    progress: Progress | None = None,
    scheduler: str | ClusterOptions | None = None,
    notify: Callable[[str], None] | None = None,
) -> RunStats:
    """Export every building of ``folders`` into ``out``; returns what was done.

    ``scheduler``: run the per-building work on a Dask cluster (a ``tcp://host:port`` address,
    ``"local"``, or :class:`exporter.distributed.ClusterOptions`) instead of the local process
    pool; the output is the same. ``notify(text)`` gets notices such as the dashboard address.

    Raises InputError for a folder that cannot be used at all (before writing anything), and
    ``exporter.distributed.ClusterError`` for a cluster that cannot run the work."""
    started = time.perf_counter()
    out_dir = Path(out)
    check_optional_features(config)  # a Config made in code skipped load_config's check
    jobs = max(1, jobs or os.cpu_count() or 1)
    scans = scan_folders(folders, config.readers, jobs)  # all folders checked first
    check_crs_option(scans, config.readers)
    out_dir.mkdir(parents=True, exist_ok=True)
    start_writing(out_dir)
    summaries = TileSummaries()
    # Per tile, the buildings reused from its summary: their manifest entry is the old manifest's.
    from_summary: dict[TileId, set[str]] = {}
    owns = input_owner(scans)
    config_hash = config_fingerprint(config)

    entries = [entry for scan in scans for entry in scan.entries]
    # Ids must be unique in a run (also their folders, ignoring case): they name the output folders.
    for entry, unique in zip(entries, unique_ids(entry.id for entry in entries)):
        entry.id = unique
    groups = entry_groups(scans)
    previous, folder_sources, first_items = previous_records(
        out_dir, [(group[0].source, group[0].id) for group in groups]
    )
    if force:
        previous = {}

    # Unchanged buildings are recognised here, in the main process, entry by entry as the pool
    # takes work: hashing is cheap I/O (and skipped for files whose stat is unchanged), and a
    # re-run that changes nothing starts no worker at all.
    def by_record(
        entry: Entry, before: dict | None, fingerprints: list[dict], digest: str
    ) -> tuple | EntryResult:
        """The entry's earlier result when its record file (``before``) lets it be reused, else
        its task for the workers."""
        previous_run = reusable_record(before, digest, out_dir)
        if previous_run is not None and before is not None:
            if fingerprints != before["inputs"]:  # e.g. touched, same bytes: record the new stat
                _refresh_fingerprints(out_dir, previous_run, fingerprints)
            return EntryResult(
                tile=previous_run["tile"], record=previous_run["record"], reused=True
            )
        return (entry, config, str(out_dir), digest, tuple(fingerprints))

    def against(entry: Entry, known: dict | None) -> tuple[list[dict], str]:
        """(input fingerprints, input hash) of ``entry``, its files' stat trusted against a
        previous run's record or summary item ``known`` (:func:`input_fingerprints`)."""
        fingerprints = input_fingerprints(
            entry.inputs, {f["path"]: f for f in known["inputs"]} if known else {}
        )
        return fingerprints, input_hash(entry, config_hash, fingerprints)

    Confirm = tuple[Entry, Path, dict, TileId, list[dict], str, int | None]

    def checked(entry: Entry) -> tuple[tuple | EntryResult | None, Confirm | None]:
        """(its task or earlier result, None), or (None, what :func:`files_intact` confirms) for
        a building its tile's summary can reuse once its files are found intact."""
        known = previous.get((entry.source, entry.id))
        before_path = Path(known) if known is not None else None
        item = summaries.item(before_path) if before_path is not None else None
        before = read_record(before_path) if before_path and item is None else None
        fingerprints, digest = against(entry, item or before)
        if item is not None and before_path is not None:
            tile = tile_from_name(before_path.parent.parent.name)
            if tile and summary_matches(item, digest, before_path.parent, fingerprints):
                written = summaries.written_ns(before_path)
                return None, (entry, before_path, item, tile, fingerprints, digest, written)
            before = read_record(before_path)  # the record decides (e.g. new fingerprints)
        return by_record(entry, before, fingerprints, digest), None

    def probably_reused(entry: Entry) -> bool:
        """Whether a group's first building (``entry``) looks unchanged from its summary item
        (read with the record paths): its files are confirmed when its group's turn comes."""
        item = first_items.get((entry.source, entry.id))
        if item is None or (entry.source, entry.id) not in previous:
            return False
        fingerprints, digest = against(entry, item)
        folder = Path(previous[(entry.source, entry.id)]).parent
        return summary_matches(item, digest, folder, fingerprints)

    # Re-runs: the groups (a folder's tile) whose first building looks changed are the work; the
    # others are idle work, checked while the workers are busy with the first (so one changed
    # tile of many starts the workers after one look a tile, and the unchanged tiles' checks
    # overlap its buildings). A first export is all work, in entry order.
    reused_groups = [probably_reused(group[0]) for group in groups]

    def run(reused: bool) -> Iterable[tuple | EntryResult]:
        for group, probe in zip(groups, reused_groups):
            if probe != reused:
                continue
            for entry in group:
                now, confirm = checked(entry)
                if confirm is None:
                    assert now is not None
                    yield now
                    continue
                entry, before_path, item, tile, fingerprints, digest, written = confirm
                if files_intact(before_path.parent, item["files"], written):
                    from_summary.setdefault(tile, set()).add(item["folder"])
                    record = {key: item[key] for key in ("id", "folder", "source")}
                    yield EntryResult(tile=tile, record=record, reused=True)
                else:  # damaged since: its record decides, as without a summary
                    yield by_record(entry, read_record(before_path), fingerprints, digest)

    # Only each building's folder is kept: its record is on disk (written before its result came
    # back) and read again when the tile's manifest is made, so memory does not grow with records.
    folders_of: dict[TileId, list[str]] = {}
    reused: dict[TileId, int] = {}
    skipped: dict[TileId | None, list[Skipped]] = {}
    for scan in scans:
        for item in scan.skipped:
            skipped.setdefault(item.tile, []).append(item)
    # Buildings that fail are listed after the scan's skips in entry order, not in the order
    # results come back, so that every scheduler writes the same manifest.
    failed: list[Skipped] = []
    order = {entry.id: index for index, entry in enumerate(entries)}
    stats = RunStats()
    done = 0
    total = len(entries)
    # The tileset's proxies are built on the same kind of workers as the buildings (a pool or the
    # cluster, started at the first proxy to build): a tile whose buildings are all done gets its
    # manifest and leaf proxy while the others' buildings are made (docs/running-at-scale.md).
    workers = ProxyWorkers(
        jobs, cluster_options(scheduler, jobs), [str(f) for f in folders], notify
    )
    early = Overlap(entries, out_dir, config, force, jobs, scheduler, workers)
    written: dict[TileId, TileResult] = {}

    # The leaf proxy task a tile written early made for its summary, handed to its start at once
    # (its buildings not read again); popped there, so none is kept.
    leaf_tasks: dict = {}

    def write_tile(tile: TileId, skips: list[Skipped], tasks: dict | None = None) -> TileResult:
        # One call for a tile made early and one made at the end: the same manifest either way.
        return write_tile_output(
            out_dir,
            tile,
            config,
            folders_of.get(tile, []),
            skips,
            reused.get(tile, 0),
            owns,
            from_summary.get(tile, set()),
            summaries.facts.get(tile.name),
            tasks,
        )

    # A re-run of a few changed tiles among unchanged ones: once the changed buildings are done,
    # their tiles' ancestor proxies are built ahead while the unchanged ones are confirmed (they
    # would otherwise slow the buildings and then wait for them: docs/running-at-scale.md).
    ahead = early.can_build_ahead and any(reused_groups) and not all(reused_groups)

    def build_ahead() -> None:
        early.build_ahead(fresh_facts(list(written.values()), config.globe))

    # Built ahead, the work's batches are sized on the work alone (they shrink as it ends, so the
    # workers finish it together), not on every building of the run.
    sized = sum(len(g) for g, r in zip(groups, reused_groups) if not r) if ahead else total
    stream = _result_stream(
        run(False),
        jobs,
        sized,
        folders,
        out_dir,
        scheduler,
        notify,
        workers,
        run(True),
        build_ahead if ahead else None,
    )
    with stream as results, early:
        for result in results:
            done += 1
            for stage, value in result.seconds.items():
                stats.seconds[stage] += value
            if result.record is not None:
                assert result.tile is not None  # a building written is filed in a tile
                replaced = folder_sources.get(
                    os.path.join(out_dir, result.tile.name, result.record["folder"])
                )
                # The building's own earlier output is not another input's (no realpath needed).
                if (
                    replaced is not None
                    and replaced != result.record["source"]
                    and not owns([replaced])
                ):
                    stats.replaced.append(replaced_notice(out_dir, result, replaced))
                folders_of.setdefault(result.tile, []).append(result.record["folder"])
                stats.buildings += 1
                stats.reused += int(result.reused)
                reused[result.tile] = reused.get(result.tile, 0) + int(result.reused)
            elif result.skipped is not None:
                failed.append(result.skipped)
                stats.skipped += 1
            for tile in early.completed(result, written):
                skips = tile_skips(tile, skipped, failed, order)
                written[tile] = write_tile(tile, skips, leaf_tasks if early.leaves else None)
                early.start_proxy(tile, leaf_tasks.pop(tile, None))
            if progress:
                progress(done, total)
    for item in sorted(failed, key=lambda item: order.get(item.id or "", len(order))):
        skipped.setdefault(item.tile, []).append(item)

    # Skips without a known tile go to every tile of this run (or a tile of their own when none).
    unplaced = skipped.pop(None, [])
    tiles = set(folders_of) | {tile for tile in skipped if tile is not None}

    if unplaced and not tiles:
        raise InputError(
            f"{', '.join(map(str, folders))}: no building could be read; first problem: {unplaced[0].source}: {unplaced[0].reason}"
        )
    with without_gc():
        for tile in sorted(tiles, key=lambda t: (t.level, t.idx, t.idy)):
            stats.tiles.append(
                written.get(tile) or write_tile(tile, skipped.get(tile, []) + unplaced)
            )
        # After the manifests (the tileset and tiles.json reference only complete files);
        # tiles.json once, after the tileset, listing its proxies for the streamer, and also when
        # the tileset fails. The proxies of one quadtree level are built in parallel.
        try:
            if config.tileset.enabled:
                stats.tileset = write_tileset(
                    out_dir,
                    config.tileset,
                    config.textures.jpeg_quality,
                    fresh_facts(stats.tiles, config.globe),
                    force,
                    workers,
                    early.proxy_records(),
                )
        finally:
            workers.close()
            proxies = stats.tileset.proxies_index if stats.tileset is not None else []
            write_tile_index(out_dir, stats.tiles, config.globe, proxies)
    end_writing(out_dir)
    stats.wall_seconds = time.perf_counter() - started
    return stats


def replaced_notice(out_dir: Path, result: EntryResult, source: str) -> str:
    """The line saying that a building of this run took the folder of another input's."""
    assert result.tile is not None and result.record is not None
    return (
        f"{printable(str(out_dir / result.tile.name / result.record['folder']))}: replaced the "
        f"building of {printable(source)} by {printable(str(result.record['id']))} of "
        f"{printable(str(result.record['source']))} (same folder name)"
    )


def other_inputs_record(path: str) -> tuple[TileRecord, list[str]] | None:
    """A record file an earlier run left (:class:`TileRecord`) and its source and input paths,
    or None when it cannot be read (a damaged leftover is not listed)."""
    found = manifest_record(path)
    if found is None:
        return None
    paths = [str(found.record.get("source", ""))]
    paths += [str(i["path"]) for i in found.summary["inputs"]]
    return found, paths


def _skip_key(item: Skipped) -> tuple:
    """A skipped entry as the manifest writes it (printable text), for comparing."""
    return tuple(printable([item.source, item.reason, item.id]))


def previous_skipped(
    tile_dir: Path, owns: Owns, current: list[Skipped], text: str | None = None
) -> list[Skipped]:
    """The skipped buildings of the tile's previous manifest (``text``, when already read) that
    came from other inputs than this run's (kept beside their buildings), less those this run
    skips again (``current``): a source that cannot be matched (a non-UTF-8 name in its printable
    form) is never listed twice."""
    seen = {_skip_key(item) for item in current}
    try:
        if text is None:
            text = (tile_dir / MANIFEST_NAME).read_text(encoding="utf-8")
        manifest = {"skipped": manifest_member(text, "skipped")}
        kept = [
            Skipped(str(s["source"]), str(s["reason"]), s.get("id"), None)
            for s in manifest["skipped"]
            if isinstance(s, dict) and not owns([str(s["source"])])
        ]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    return [item for item in kept if _skip_key(item) not in seen]


def _previous_manifest(tile_dir: Path) -> bytes | None:
    try:
        return (tile_dir / MANIFEST_NAME).read_bytes()
    except OSError:
        return None


def write_tile_output(
    out_dir: Path,
    tile: TileId,
    config: Config,
    folders: list[str],
    skipped: list[Skipped],
    reused: int = 0,
    owns: Owns | None = None,
    from_summary: set[str] | frozenset[str] = frozenset(),
    facts: SummaryFacts | None = None,
    leaf_tasks: dict | None = None,
) -> TileResult:
    """Read the records of the tile's buildings (``folders``, in result order), remove building
    folders of earlier runs that this run did not produce but that came from its inputs
    (``owns``, :func:`input_owner`; without it every earlier folder is this run's), keep those of
    other inputs in the manifest, then write the manifest (last of the buildings' files,
    atomically; left as it is when its bytes are the same), the tile's summary
    (:func:`exporter.records.write_summary`) after it and, with the tileset on, the tile's own
    tileset and its summary (:func:`exporter.tileset.external.write_tile_tileset`; from the
    records in hand: the end of the run reads no building).

    ``from_summary``: folders reused from the tile's summary: their manifest entry is taken
    from the previous manifest that summary was written with (their record files are not read);
    when they are all of the tile's buildings (``facts``: what the summary said of the tile when
    this run read it) and the manifest's head is the same, the manifest and the summary are left
    as they are."""
    tile_dir = out_dir / tile.name
    tile_dir.mkdir(parents=True, exist_ok=True)
    old_bytes = _previous_manifest(tile_dir)
    old_text = old_bytes.decode("utf-8", "replace") if old_bytes is not None else None
    keep = set(folders)
    with os.scandir(tile_dir) as found_names:  # a listing: no stat of the folders kept
        others = [
            e.path
            for e in found_names
            if e.name not in keep
            and e.name not in (MANIFEST_NAME, TILESET_NAME)
            and not e.name.startswith(".")
        ]
    kept_skips = previous_skipped(tile_dir, owns, skipped, old_text) if owns is not None else []
    if (
        facts is not None
        and old_bytes is not None
        and not others
        and len(folders) == len(from_summary) == len(facts.folders)
        and keep == from_summary == facts.folders
        and facts.head == manifest_head(tile, config, skipped + kept_skips)
        and facts.manifest_sha256 == hashlib.sha256(old_bytes).hexdigest()
    ):  # the same buildings and head: the same manifest
        return TileResult(
            tile, tile_dir / MANIFEST_NAME, len(folders), len(skipped) + len(kept_skips), reused
        )
    summary = read_summary(tile_dir, old_bytes) if from_summary and old_bytes else None
    old = manifest_buildings(old_text) if summary is not None and old_text else {}
    records = []
    lines_of: dict[int, str] = {}  # records' manifest lines copied from their files, by id()
    items_of: dict[int, dict] = {}  # records' summary items, by id()
    stamps: list[dict] = []  # their inputs' hash times (exporter.records.hash_time)

    def add(found: TileRecord) -> None:
        records.append(found.record)
        if found.line is not None:
            lines_of[id(found.record)] = found.line
        if has_level_errors(found.record):  # else redone next time: read from its record file
            items_of[id(found.record)] = found.summary
        stamps.extend(found.inputs)

    for folder in folders:
        item = summary.item(folder) if summary is not None and folder in from_summary else None
        entry = old.get(folder) if item is not None else None
        if item and entry and entry[0].get("input_hash") == item["input_hash"]:
            stable = {**item, "inputs": stable_inputs(item["inputs"])}
            add(TileRecord(entry[0], entry[1], stable, item["inputs"]))
            continue
        found = manifest_record(os.path.join(tile_dir, folder, RECORD_NAME))
        if found is None:  # removed or damaged since this run wrote it: reported, not invented
            skipped = skipped + [
                Skipped(
                    str(tile_dir / folder),
                    f"{RECORD_NAME} vanished or became unreadable during the run",
                    folder,
                    tile,
                )
            ]
        else:
            add(found)
    skipped = skipped + kept_skips
    for folder_path in sorted(others):  # only folders this tool made (as glob's "*" sees them)
        if os.path.islink(folder_path):  # never made by this tool: neither removed nor listed
            continue
        record_path = os.path.join(folder_path, RECORD_NAME)
        if not os.path.isfile(record_path):
            continue
        kept = other_inputs_record(record_path) if owns is not None else None
        if owns is not None and kept is not None and not owns(kept[1]):  # another input's: kept
            add(kept[0])
            continue
        shutil.rmtree(folder_path, ignore_errors=True)
    lon, lat = tile_center(tile)
    manifest = build_manifest(
        tile,
        tile_bounds(tile),
        {"lon": lon, "lat": lat, "elev": 0.0},
        tile_placement(tile, config.globe),
        config,
        records,
        skipped,
    )
    text = dumps(manifest, lines_of).encode("utf-8")
    path = tile_dir / MANIFEST_NAME
    if text != old_bytes:  # an unchanged manifest keeps its time (and costs no fsync)
        write_bytes_atomic(path, text, durable=True)
    # In the manifest's order; a building without an item (an older record) is read next time.
    items = [items_of[id(r)] for r in manifest["buildings"] if id(r) in items_of]
    head = manifest_head(tile, config, skipped)
    write_summary(tile_dir, text, head, items, hash_time(stamps))
    if config.tileset.enabled:  # the tile's own tileset, with it (exporter.tileset.external)
        write_tile_tileset(
            out_dir,
            tile,
            manifest["buildings"],
            text,
            config.tileset,
            config.textures.jpeg_quality,
            leaf_tasks=leaf_tasks,
        )
    return TileResult(tile, path, len(records), len(skipped), reused)
