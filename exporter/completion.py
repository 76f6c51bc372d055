"""When a tile's buildings are all done, while the pool still works on other tiles.

``export_tiles`` writes a tile's manifest and starts its leaf proxy as soon as nothing still
pending can land in that tile (docs/running-at-scale.md, "What runs when"). Results come back in
any order (pool and cluster batches); this module only counts.

Which tile a building lands in is known before it is read only when the reader keeps the data's
own tile: VWorld ``.dat`` files name theirs, the reader gives it to the building
(``exporter.readers.vworld.load_entry``) and ``exporter.job.building_tile`` keeps it. Other
formats file a building under the tile holding its centre once read (their entry's tile, when
set, is an estimate from the scan): such an entry is *unknown* here, and no tile completes before
every unknown entry is done (the last result then completes all tiles, as before this module).
"""

from __future__ import annotations

import os
import threading
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from .config import Config
from .distributed import ProxyWorkers
from .job import EntryResult
from .manifest import MANIFEST_NAME
from .model import Skipped, TileId
from .readers import Entry
from .tile_index import tile_from_name
from .tileset.external import read_tile_summary
from .tileset.proxy import ProxyTask
from .tileset.schedule import LeafProxies

# Readers whose building is filed under the entry's tile whatever its geometry (exporter.job).
FIXED_TILE_FORMATS = frozenset({"vworld"})


def known_tile(entry_format: str, tile: TileId | None) -> TileId | None:
    """The tile an entry's result certainly lands in, or None when only reading it tells."""
    return tile if entry_format in FIXED_TILE_FORMATS else None


class TileCompletion:
    """Counts the results of a run's entries by tile; :meth:`done` says which tiles it completes.

    ``entries``: ``(entry id, known tile or None)`` of every entry of the run (ids unique, as
    ``export_tiles`` makes them). A tile is complete when every entry known to land in it has
    returned and every unknown entry has returned (one could still land anywhere). A result that
    contradicts what was known (an id never seen, a known entry landing elsewhere) stops every
    further early completion: the rest complete at the end of the run, as without this tracker."""

    def __init__(self, entries: Iterable[tuple[str, TileId | None]]) -> None:
        self._tile_of: dict[str, TileId | None] = dict(entries)
        self._left = Counter(tile for tile in self._tile_of.values() if tile is not None)
        self._unknown = sum(1 for tile in self._tile_of.values() if tile is None)
        self._landed: set[TileId] = set()  # tiles unknown entries' results landed in
        self._completed: set[TileId] = set()
        self._broken = False

    def done(self, entry_id: str | None, landed: TileId | None) -> list[TileId]:
        """Take the result of entry ``entry_id``, which landed in tile ``landed`` (None: a skip
        without a tile); returns the tiles this result completes (sorted; each tile once)."""
        if self._broken:
            return []
        if entry_id not in self._tile_of:
            self._broken = True
            return []
        expected = self._tile_of.pop(entry_id)
        if expected is not None and landed != expected:
            self._broken = True
            return []
        candidates: set[TileId] = set()
        if expected is None:
            self._unknown -= 1
            if landed is not None:
                self._landed.add(landed)
            if self._unknown == 0:  # the last unknown entry: every tile may complete now
                candidates = set(self._left) | self._landed
        else:
            self._left[expected] -= 1
            if self._unknown == 0:
                candidates = {expected}
        ready = sorted(
            (t for t in candidates if self._left[t] == 0 and t not in self._completed),
            key=lambda t: (t.level, t.idx, t.idy),
        )
        self._completed.update(ready)
        return ready


def tile_skips(
    tile: TileId,
    scanned: dict[TileId | None, list[Skipped]],
    failed: list[Skipped],
    order: dict[str, int],
) -> list[Skipped]:
    """The ``skipped`` list of ``tile``'s manifest as ``export_tiles`` orders it at the end of a
    run: the scan's skips of the tile, its failed buildings in entry order (``order``: entry id
    -> index), then the skips without a tile (the scan's, then failed ones in entry order).
    ``scanned``: the scan's skips by tile; ``failed``: the failed results so far, as they came."""

    def in_entry_order(items: Iterable[Skipped]) -> list[Skipped]:
        return sorted(items, key=lambda item: order.get(item.id or "", len(order)))

    return (
        scanned.get(tile, [])
        + in_entry_order(item for item in failed if item.tile == tile)
        + scanned.get(None, [])
        + in_entry_order(item for item in failed if item.tile is None)
    )


class Overlap:
    """What ``export_tiles`` does as tiles complete: which results complete a tile
    (:class:`TileCompletion`) and the leaf proxies started then
    (:class:`exporter.tileset.schedule.LeafProxies`), on the proxies' ``workers``.

    Active with a pool of several jobs or a cluster (with one job the run is as before: the
    buildings and every proxy one after the other in this process). Used as a context around the
    results, inside the cluster session if any (the leaf proxies run on it,
    :meth:`ProxyWorkers.share`): its end waits for the leaf proxies and gives the workers back
    their own session for the tileset; an error closes the workers."""

    def __init__(
        self,
        entries: list[Entry],
        out_dir: Path,
        config: Config,
        force: bool,
        jobs: int,
        scheduler: object,
        workers: ProxyWorkers,
    ) -> None:
        self.workers = workers
        active = jobs > 1 or scheduler is not None
        known = [(entry.id, known_tile(entry.format, entry.tile)) for entry in entries]
        self.tracker = TileCompletion(known) if active else None
        self.leaves: LeafProxies | None = None
        self._records: dict[str, dict] = {}
        self._ahead: threading.Thread | None = None
        self._ahead_records: dict[str, dict] = {}
        self._config, self._force, self._local = config, force, scheduler is None
        options = config.tileset
        if active and options.enabled and options.proxies:
            tiles = {tile for _, tile in known if tile is not None} | tiles_in(out_dir)
            self.leaves = LeafProxies(
                out_dir, options, config.textures.jpeg_quality, force, workers, tiles
            )

    def completed(self, result: EntryResult, written: dict[TileId, Any]) -> list[TileId]:
        """The tiles ``result`` completes. A tile in ``written`` (its manifest made early) that
        gets a result after all (only when a reader broke :data:`FIXED_TILE_FORMATS`' rule) is
        dropped from it, so the end of the run writes it again with everything."""
        if self.tracker is None:
            return []
        if result.tile is not None:
            written.pop(result.tile, None)
        found = result.record["id"] if result.record is not None else None
        if found is None and result.skipped is not None:
            found = result.skipped.id
        return self.tracker.done(None if found is None else str(found), result.tile)

    def start_proxy(self, tile: TileId, task: ProxyTask | None = None) -> None:
        """Start ``tile``'s leaf proxy (its manifest is written). ``task``: the one its tile
        tileset was written with, if at hand; else an unchanged tile's summary names its key:
        either way its buildings are not read again to find it."""
        if self.leaves is not None:
            known = task.key if task is not None else self._recorded_key(tile)
            self.leaves.start(tile, known, task)

    def _recorded_key(self, tile: TileId) -> str | None:
        """The leaf proxy key ``tile``'s summary holds while it goes with the tile's manifest
        (:func:`exporter.tileset.external.read_tile_summary`), else None."""
        assert self.leaves is not None
        out_dir = self.leaves.out_dir
        try:
            manifest = (out_dir / tile.name / MANIFEST_NAME).read_bytes()
        except OSError:
            return None
        found = read_tile_summary(
            out_dir, tile, manifest, self.leaves.options, self.leaves.jpeg_quality
        )
        return found.proxy_key if found is not None else None

    def proxy_records(self) -> dict[str, dict]:
        """The records of the proxies built during the results (leaf proxies, and those built
        ahead: :meth:`build_ahead`) by task key (``write_tileset``'s ``early``), after the
        context."""
        return {**self._ahead_records, **self._records}

    @property
    def can_build_ahead(self) -> bool:
        """Whether :meth:`build_ahead` does anything: leaf proxies are made early on a local
        pool and proxies may be taken from an earlier run (no ``--force``)."""
        return self.leaves is not None and self._local and not self._force

    def build_ahead(self, fresh: dict[str, tuple[int, dict]]) -> None:
        """Start building, beside this process, the proxies the tileset would build from
        ``OUT`` as it is now (:func:`exporter.tileset.prebuild_proxies`; ``fresh``: the index
        facts of the tiles written so far), once the leaf proxies started so far are done.
        ``export_tiles`` calls it on a re-run when every changed building is done but unchanged
        ones are still being confirmed: a changed tile's ancestors are built meanwhile, on the
        proxies' workers, instead of after every tile is confirmed. At the end the tileset takes
        them by key (anything they are made from changed since: built again). A failure here only
        leaves the work to the tileset."""
        if not self.can_build_ahead or self._ahead is not None:
            return
        from .tileset import prebuild_proxies

        leaves, options = self.leaves, self._config
        assert leaves is not None

        def run() -> None:
            try:
                self._ahead_records = prebuild_proxies(
                    leaves.out_dir,
                    options.tileset,
                    options.textures.jpeg_quality,
                    fresh,
                    self.workers,
                    leaves.records,  # waited for once the tree is made (its reading overlaps them)
                )
            except Exception:  # the tileset builds what is missing, and says why
                self._ahead_records = {}

        self._ahead = threading.Thread(target=run, name="proxies ahead", daemon=True)
        self._ahead.start()

    def __enter__(self) -> Overlap:
        return self

    def __exit__(self, kind, error, trace) -> None:
        try:
            if error is None and self.leaves is not None:
                self._records = self.leaves.records()
                if self._ahead is not None:
                    self._ahead.join()
        except BaseException:
            self.workers.close()
            raise
        finally:
            self.workers.share(None)  # the session ends with the results
        if error is not None:  # stopped mid-run: the early proxies' pool ends with it
            self.workers.close()


def tiles_in(out_dir: Path) -> set[TileId]:
    """The tile folders an earlier run left in ``out_dir`` (by name)."""
    try:
        with os.scandir(out_dir) as found:
            names = [item.name for item in found if item.is_dir()]
    except OSError:
        return set()
    return {tile for tile in map(tile_from_name, names) if tile is not None}
