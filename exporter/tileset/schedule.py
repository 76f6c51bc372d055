"""The tileset's proxies, level by level: children before parents, each level's in parallel.

Proxies of one quadtree level are independent (each reads only its own inputs' files, see
:func:`.proxy.make_proxy`), so a level's proxies to build go to :class:`Workers` at once: this
process (one job), a local process pool (``--jobs N``), or the Dask cluster of ``--scheduler``
(one task per proxy). The main process keeps per tile only what the tree needs (hash, errors,
bounds; a building tile's :class:`.tree.TileSummary`, whose recorded leaf proxy key spares
reading the tile's buildings unless its proxy must be built) and hands the workers a :class:`.proxy.ProxyTask` (the names of the input files and their
errors, no mesh). A proxy whose record matches its inputs' hash is taken as it is (a changed tile
rebuilds its own proxy and its ancestors', each from its children); the bytes do not depend on
where a proxy was built.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path
from typing import Protocol

import numpy as np

from ..config import TilesetOptions
from ..manifest import MANIFEST_NAME
from ..model import TileId
from . import frames
from .metadata import chain_values
from .proxy import (
    PROXY_DIR,
    BuildingSource,
    ChildSource,
    LevelSource,
    Proxy,
    ProxyTask,
    cached,
    make_proxy,
    proxy_of,
    remove_stale,
)
from .tree import BuildingChain, Node, ancestor, building_nodes, tile_chains, tile_world


class Workers(Protocol):
    """Where proxies are built (:class:`InProcess` here; the run layer's pool and Dask cluster:
    :class:`exporter.distributed.ProxyWorkers`)."""

    remote: int  # proxies built on pool or cluster workers (not in this process)

    def map(self, function: Callable, items: list, out_dir: str) -> list:
        """``[function(item) for item in items]``, in order."""
        ...


class InProcess:
    """Every proxy built in this process, one after the other."""

    remote = 0

    def map(self, function: Callable, items: list, out_dir: str) -> list:
        return [function(item) for item in items]


# A proxy record's per-building lists (its buildings, vertex owners, property rows): they stay in
# the record file on disk, never come back to the main process.
PER_BUILDING = ("buildings", "owners", "values")


def build_proxy_record(task: ProxyTask) -> dict:
    """:func:`.proxy.make_proxy` where the workers run it, returning its record without
    :data:`PER_BUILDING` (a parent's lists every building below it): what the tree needs (hash,
    errors, bounds) is all that comes back, so the main process holds no per-building state."""
    record = make_proxy(task)
    return {key: value for key, value in record.items() if key not in PER_BUILDING}


def _tile_nodes_by_height(tops: list[Node]) -> list[list[Node]]:
    """Tile nodes grouped by height above the building tiles (0: no child tile), each group in
    tree order (depth first, children before parents)."""
    groups: list[list[Node]] = []

    def visit(node: Node) -> int:
        below = [visit(child) for child in node.children if child.tile is not None]
        height = 1 + max(below) if below else 0
        if node.tile is not None:
            while len(groups) <= height:
                groups.append([])
            groups[height].append(node)
        return height

    for top in tops:
        visit(top)
    return groups


def _building_source(chain: BuildingChain) -> BuildingSource:
    """What a proxy takes of one building: its levels' files, errors, texture sizes and values."""
    levels = [LevelSource(level.file, level.geometric, level.texture_px) for level in chain.levels]
    values = chain_values(chain)
    digest = hashlib.sha256(
        json.dumps(values, sort_keys=True, default=str).encode("utf-8")
    ).hexdigest()[:16]
    return BuildingSource(
        f"{chain.tile.name}/{chain.id}",
        chain.world,
        levels,
        f"{chain.input_hash}:{digest}",  # a changed attribute rebuilds the proxy
        values,
    )


def manifest_chains(out_dir: Path, tile: TileId) -> list[BuildingChain] | None:
    """``tile``'s buildings as chains (by id) from its manifest under ``out_dir``, as its own
    tileset has them (:func:`.tree.tile_chains`); None when the manifest cannot be read (what is
    left out is reported by the tileset, not here)."""
    try:
        manifest = json.loads((out_dir / tile.name / MANIFEST_NAME).read_text(encoding="utf-8"))
        return tile_chains(out_dir, tile, manifest["buildings"], [])
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def _task(
    out_dir: Path, node: Node, options: TilesetOptions, jpeg_quality: int
) -> ProxyTask | None:
    """What ``node``'s proxy is made from, or None when a child tile has no proxy. A child that
    references a tile's own tileset (:func:`.tree.tileset_reference`) stands for that tile's
    buildings, read from its manifest."""
    assert node.tile is not None and node.world is not None
    task = ProxyTask(str(out_dir), node.tile, node.world, options, jpeg_quality)
    for child in node.children:
        if child.building is not None:
            task.buildings.append(_building_source(child.building))
        elif child.holds is not None:
            chains = manifest_chains(out_dir, child.holds.tile)
            if not chains:
                return None
            task.buildings.extend(_building_source(chain) for chain in chains)
        elif child.proxy_hash is not None and child.tile is not None:
            assert child.world is not None
            task.children.append(
                ChildSource(
                    child.tile.name, child.world, child.geometric, child.texel, child.proxy_hash
                )
            )
        else:
            return None
    task.shown_floor = max((child.error for child in node.children), default=0.0)
    return task


def _leaf_key(node: Node) -> str | None:
    """The proxy key ``node``'s tile summary recorded, when ``node`` is a leaf (its only child the
    reference to its own tileset): its task is then made only if the proxy must be built."""
    if len(node.children) == 1 and node.children[0].holds is not None:
        return node.children[0].holds.proxy_key
    return None


def _place(node: Node, proxy: Proxy) -> None:
    """Give ``node`` its proxy: content, hash, errors (at least its children's), box corners."""
    assert node.tile is not None and node.world is not None
    node.content = f"{PROXY_DIR}/{node.tile.name}.glb"
    node.proxy_hash = proxy.hash
    node.geometric, node.texel, node.atlas_px = proxy.geometric, proxy.texel, proxy.atlas_px
    node.error = max([proxy.error] + [child.error for child in node.children])
    node.corners = frames.apply(
        node.world, frames.gltf_corners(np.array(proxy.low), np.array(proxy.high))
    )


def add_proxies(
    out_dir: Path,
    tops: list[Node],
    options: TilesetOptions,
    jpeg_quality: int,
    problems: list[str],
    force: bool = False,
    workers: Workers | None = None,
    early: dict[str, dict] | None = None,
    built_records: dict[str, dict] | None = None,
    remove: bool = True,
) -> tuple[int, int]:
    """Give every tile node of ``tops`` that can have one its proxy (content, error, corners);
    returns (proxies in the tree, proxies built this time); a proxy that cannot be built is
    appended to ``problems``. Stale proxy files are removed (unless ``remove`` is False).
    ``force``: build every proxy, none taken from an earlier run (a rebuilt file whose bytes
    come out the same is left as it was). ``early``: what :func:`build_proxy_record` returned for
    proxies this run built already, by :attr:`ProxyTask.key` (:class:`LeafProxies`, proxies
    built ahead): a node whose task has one of these keys takes that record as if built here,
    even with ``force``. ``built_records``: gets the record of every proxy built here, by key."""
    folder = out_dir / PROXY_DIR
    kept: set[str] = set()
    placed = built = 0
    workers = workers or InProcess()
    for level in _tile_nodes_by_height(tops):
        # Proxies to build, in tree order, each with its record when built early (LeafProxies).
        todo: list[tuple[Node, ProxyTask | None, dict | None]] = []
        for node in level:
            assert node.tile is not None
            task, key = None, _leaf_key(node)
            if key is None:
                task = _task(out_dir, node, options, jpeg_quality)
                if task is None:
                    continue
                key = task.key
            name = node.tile.name
            if early and key in early:
                kept.update({f"{name}.json", f"{name}.glb"})
                todo.append((node, task, early[key]))
                continue
            found, proxy = (False, None) if force else cached(folder, name, key)
            if not found and task is None:  # a changed leaf: its task from its manifest
                task = leaf_task(out_dir, node.tile, options, jpeg_quality)
                if task is None:
                    continue
            kept.update({f"{name}.json", f"{name}.glb"})
            if not found:
                todo.append((node, task, None))
            elif proxy is not None:
                _place(node, proxy)
                placed += 1
        tasks = [task for _, task, record in todo if record is None]
        records = iter(workers.map(build_proxy_record, tasks, str(out_dir)))
        built += len(todo)
        for node, task, record in todo:
            if record is None:
                record = next(records)
                if built_records is not None and task is not None:
                    built_records[task.key] = record
            if "problem" in record:
                problems.append(record["problem"])
            elif not record.get("too_large"):
                _place(node, proxy_of(record))
                placed += 1
    if remove:
        remove_stale(folder, kept)
    return placed, built


# --------------------------------------------------------------------------- leaf proxies early


def leaf_task_of(
    out_dir: Path,
    tile: TileId,
    tops: list[Node],
    options: TilesetOptions,
    jpeg_quality: int,
) -> ProxyTask | None:
    """The task of ``tile``'s proxy as a leaf, whose buildings' chains have the top nodes
    ``tops`` (:func:`.tree.building_nodes`, by id): the one :func:`add_proxies` builds for that
    tile when it has no child tile."""
    if not tops:
        return None
    node = Node(tile.name, tile_world(tile), children=tops, tile=tile)
    return _task(out_dir, node, options, jpeg_quality)


def leaf_task(
    out_dir: Path, tile: TileId, options: TilesetOptions, jpeg_quality: int
) -> ProxyTask | None:
    """The task of ``tile``'s proxy as a leaf (the tile's buildings, no child tile), from its
    manifest under ``out_dir`` alone (:func:`leaf_task_of`); None when the manifest or every
    building is unusable."""
    chains = manifest_chains(out_dir, tile)
    if not chains:
        return None
    return leaf_task_of(out_dir, tile, building_nodes(chains), options, jpeg_quality)


class Submits(Protocol):
    """Workers that also take one proxy at a time without waiting for it
    (:class:`exporter.distributed.ProxyWorkers`)."""

    def submit(self, function: Callable, item, out_dir: str) -> Future:
        """``function(item)`` started where the workers run it; its result later."""
        ...


def _above(tiles: set[TileId]) -> set[TileId]:
    """Every tile that holds one of ``tiles`` at a finer level (its quadtree ancestors)."""
    return {ancestor(tile, level) for tile in tiles for level in range(tile.level)}


class LeafProxies:
    """Leaf proxies started while the buildings of other tiles are still being made: ``export_tiles``
    calls :meth:`start` when a tile's manifest is written (``exporter.completion``), and hands
    :meth:`records` to :func:`.write_tileset` (``add_proxies``' ``early``), which then builds
    only what is left. ``tiles``: the tiles known to be in ``OUT`` at the end (this run's and
    earlier runs'); a tile with one of them below it gets child tiles in the tree, so its proxy
    is not a leaf and waits for the tileset. A proxy whose record matches (without ``force``) is
    left to the tileset's cache, as at the end."""

    def __init__(
        self,
        out_dir: Path,
        options: TilesetOptions,
        jpeg_quality: int,
        force: bool,
        workers: Submits,
        tiles: set[TileId],
    ) -> None:
        self.out_dir, self.options, self.jpeg_quality = out_dir, options, jpeg_quality
        self.force, self.workers = force, workers
        self._inner = _above(tiles)  # tiles with a child tile: their proxy is not a leaf
        self._started: list[tuple[str, Future]] = []

    def start(
        self, tile: TileId, known_key: str | None = None, task: ProxyTask | None = None
    ) -> bool:
        """Start ``tile``'s leaf proxy when it is one and must be built; True when started.
        ``known_key``: its task's key as the tile's summary recorded it (None: unknown); a proxy
        built from it is taken without reading the tile's buildings (an unchanged tile).
        ``task``: its task when the caller has it (made with its tile's tileset), else it is
        made from the tile's manifest."""
        if tile in self._inner:
            return False
        folder = self.out_dir / PROXY_DIR
        if known_key is not None and not self.force and cached(folder, tile.name, known_key)[0]:
            return False
        if task is None:
            task = leaf_task(self.out_dir, tile, self.options, self.jpeg_quality)
        if task is None:
            return False
        key = task.key  # a key other than the known one: its record looked up too
        if key != known_key and not self.force and cached(folder, tile.name, key)[0]:
            return False
        self._started.append(
            (key, self.workers.submit(build_proxy_record, task, str(self.out_dir)))
        )
        return True

    def records(self) -> dict[str, dict]:
        """What each started proxy's :func:`build_proxy_record` returned, by task key (waits for
        them)."""
        return {key: future.result() for key, future in list(self._started)}  # those started
