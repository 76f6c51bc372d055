"""The tileset's tree, from the manifests on disk: buildings as LoD chains under the VWorld quadtree.

Data form: :class:`Node` (one 3D Tiles tile). ``world`` is the node's tile frame -> ECEF matrix
(4 x 4 float64, :mod:`.frames`) or None when it shares its parent's frame; ``corners`` are the
(8, 3) ECEF corners of its content's box (None without content); ``error`` is its
``geometricError`` in metres.

- A building is a chain, coarsest level first, each level the only child of the one above
  (``REPLACE``); a level's error is the larger of its certified Hausdorff bound against LOD0 in
  metres, the manifest's ``hausdorff_rel`` (relative to LOD0's bounding-box diagonal,
  exporter/quality.py) times that diagonal plus the float32 rounding of both files, and the
  record's ``error_m`` (its texture error too, exporter/texel.py; absent before 0.5.0). Each
  file's glTF-frame bounds come from its record's ``gltf_bounds`` (:func:`level_bounds`; from the
  file's header for records without them). A level is left out only when its mesh and atlas
  equal the next coarser kept level's (:func:`redundant`; the reason kept in
  ``BuildingChain.dropped`` for the tileset's ``extras``), so errors never grow towards LOD0's 0.
- Each tile holding buildings has its own tileset (``OUT/<tile>/tileset.json``, :mod:`.external`):
  its buildings' chains under a root without content, in the tile's frame. The export's
  ``tileset.json`` holds the quadtree of tiles (:func:`tile_tree`), each building tile
  summarised by a :class:`TileSummary` (its box, error, proxy key; never its buildings) and
  shown by a node referencing its tileset (:func:`tileset_reference`); compressed: a tile with
  one child is that child. Several top tiles hang under one root without content.
  :func:`quadtree` builds the same tree with the chains themselves (one tile's tileset, a leaf
  proxy's task, benchmarks).
- Buildings or levels whose files are missing are left out and listed (never referenced).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from ..model import TileId
from ..tile_index import build_index
from ..tiles import tile_center
from . import frames
from .glb import position_bounds, read_header

FLOAT32_ULP = 2.0**-24  # relative rounding of a float32 coordinate (half an ulp)


@dataclass
class Level:
    file: str  # relative to OUT, '/'-separated
    error: float  # metres: its geometricError, max(certified bound, texture error) against LOD0
    low: np.ndarray  # (3,) glTF-frame metres
    high: np.ndarray
    texture_px: int  # larger side of its texture in pixels (0: untextured); for the proxies
    geometric: float  # metres: the certified bound alone (what a proxy's bound adds to)


@dataclass
class BuildingChain:
    tile: TileId
    id: str
    center: tuple[float, float, float]  # lon, lat degrees; elev metres
    input_hash: str
    levels: list[Level]  # coarsest first; the last is LOD0 (error 0)
    source: str = ""  # the file it was read from (manifest record's source)
    attributes: dict = field(default_factory=dict)  # the manifest record's attributes
    dropped: list[str] = field(default_factory=list)  # levels not in the chain, with the reason

    @cached_property
    def world(self) -> np.ndarray:
        """4 x 4: the building's tile frame -> ECEF (the tree and its tile's proxy both use it)."""
        return frames.world_matrix(*self.center)


@dataclass
class TileSummary:
    """What the export's tileset keeps of one building tile (:mod:`.external` writes it beside
    the tile's own tileset): no per-building state."""

    tile: TileId
    buildings: int  # chains in its tileset (0: none to show; no tileset)
    box: list[float]  # 3D Tiles box of its tileset's root in the tile frame (tile_world), metres
    error: float  # metres: the largest geometricError of its chains' coarsest levels
    proxy_key: str | None  # its leaf proxy's ProxyTask.key (None: not computed, proxies off)
    left_out: list[str]  # its buildings' and levels' problems (files unusable, no bound)
    kinds: dict[str, dict]  # .metadata.property_kinds of its buildings (the export's schema)
    typed: str  # .metadata.properties_digest of the class its tileset was written with


@dataclass
class Node:
    key: str
    world: np.ndarray | None
    error: float = 0.0
    content: str | None = None
    corners: np.ndarray | None = None
    children: list[Node] = field(default_factory=list)
    tile: TileId | None = None
    building: BuildingChain | None = None
    proxy_hash: str | None = None
    geometric: float = 0.0  # a proxy's certified geometric bound, metres
    texel: float = 0.0  # a proxy's metres per atlas texel
    atlas_px: int = 0  # a proxy's atlas, pixels per side
    box: list[float] | None = None  # 3D Tiles box in its frame (set by write.finish)
    box_ecef: np.ndarray | None = None  # (8, 3) ECEF corners of ``box`` (a building's top)
    holds: TileSummary | None = None  # the building tile whose own tileset this node references


def rounding_slack(low, high) -> float:
    """Metres: the largest float32 rounding of a point of a file with glTF bounds ``low``/``high``
    (3 floats each)."""
    return max(abs(float(v)) for v in (*low, *high)) * FLOAT32_ULP * math.sqrt(3.0)


Bounds = tuple[list[float], list[float]]  # (low, high): 3 glTF-frame metres each


def valid_bounds(low, high) -> Bounds | None:
    """``low``/``high`` as 3 finite floats each with low <= high, or None (JSON numbers only: not
    bools, strings or nulls)."""
    if not (isinstance(low, list) and isinstance(high, list) and len(low) == len(high) == 3):
        return None
    if any(type(v) not in (int, float) for v in (*low, *high)):
        return None
    try:
        out = [float(v) for v in low], [float(v) for v in high]
    except OverflowError:  # an integer beyond float range
        return None
    finite = all(math.isfinite(v) for v in (*out[0], *out[1]))
    return out if finite and all(a <= b for a, b in zip(*out)) else None


def level_bounds(path: str, lod: dict) -> Bounds:
    """(low, high) glTF-frame metres of the level file ``path`` (manifest record ``lod``).

    The record's ``gltf_bounds`` (written since 0.4.2: the file's POSITION min/max) when valid and
    the file is there with its recorded size; otherwise (records of 0.4.1 and older, a file
    replaced since its record) the file's header. Raises OSError for a missing file, ValueError
    for one without usable positions. A file damaged in place at its recorded size is not seen
    here (the tileset never read file bodies; a re-run's CRC-32 check redoes such a building)."""
    found = lod.get("gltf_bounds")
    if isinstance(found, dict):
        recorded = valid_bounds(found.get("low"), found.get("high"))
        if recorded is not None and os.stat(path).st_size == lod.get("file_bytes"):
            return recorded
    low, high = position_bounds(read_header(path))
    read = valid_bounds(low.tolist(), high.tolist())
    if read is None:
        raise ValueError("position bounds not finite")
    return read


def recorded_error(lod: dict) -> float:
    """Metres: the record's ``error_m`` (its certified geometric bound or its texture error,
    whichever is larger; written since 0.5.0), 0 when absent or unusable (older records: the
    geometric bound alone)."""
    value = lod.get("error_m")
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return 0.0
    return float(value) if math.isfinite(value) and value >= 0 else 0.0


def same_texture(lod: dict, other: dict) -> bool:
    """True when two level records carry the same atlases (size, bytes and texel on the surface)."""
    return all(
        lod.get(key) == other.get(key) for key in ("texture_size", "texture_bytes")
    ) and lod.get("quality", {}).get("texel_m") == other.get("quality", {}).get("texel_m")


def redundant(
    lod: dict, error: float, coarser: dict, coarser_error: float, same_geometry: bool
) -> str | None:
    """Why the level of record ``lod`` (error ``error`` metres) is left out of the chain below
    the next coarser kept level ``coarser`` (error ``coarser_error``), or None to keep it;
    ``same_geometry``: the two levels' meshes are equal (the records' ``same_geometry_as_above``).

    A level is left out when its geometry and its texture are the coarser level's: a client
    would load the same picture twice. A level whose error exceeds the coarser one's cannot be below it (3D Tiles
    errors never grow from parent to child). Records written before 0.5.0 (no ``error_m``:
    errors of geometry alone) keep the earlier rule: a level no better than a coarser one."""
    coarser_name = Path(str(coarser.get("file", "?"))).name
    if "error_m" not in lod or "error_m" not in coarser:
        if error >= coarser_error:
            return f"no better than {coarser_name} (geometric error only: a record before 0.5.0)"
        return None
    if same_geometry and same_texture(lod, coarser):
        return f"same geometry and texture as {coarser_name}"
    if error > coarser_error:
        return f"error {error:.6g} m above {coarser_name}'s {coarser_error:.6g} m"
    return None


def read_chain(
    out_dir: Path, tile: TileId, record: dict, left_out: list[str]
) -> BuildingChain | None:
    """The building of manifest ``record`` as a chain, or None (reason appended to ``left_out``)."""
    name = f"{tile.name}/{record.get('folder') or record.get('id')}"
    bounds: dict[int, Bounds] = {}
    folder = os.path.join(out_dir, tile.name)  # a str: pathlib costs more than the read here
    for lod in record.get("lods", []):
        try:
            bounds[lod["level"]] = level_bounds(os.path.join(folder, lod["file"]), lod)
        except (OSError, ValueError, KeyError, TypeError) as problem:
            left_out.append(
                f"{name}: LOD{lod.get('level')} file {lod.get('file')} unusable ({problem})"
            )
    lods = {lod["level"]: lod for lod in record.get("lods", []) if lod.get("level") in bounds}
    if 0 not in lods:
        left_out.append(f"{name}: no readable LOD0 file; building left out")
        return None
    diagonal = float(np.linalg.norm(np.subtract(bounds[0][1], bounds[0][0])))
    slack0 = rounding_slack(*bounds[0])
    levels: list[Level] = []
    kept: list[dict] = []  # the records of ``levels``
    dropped: list[str] = []
    # Whether the level just coarser than the current one has the mesh of the last kept level.
    as_kept = True
    for level in sorted(lods, reverse=True):
        lod = lods[level]
        # This level's mesh equals the last kept level's: each record between says so.
        above = lods.get(level + 1, {})
        same_geometry = as_kept and above.get("same_geometry_as_above") is True
        as_kept = same_geometry
        if level == 0:
            error = geometric = 0.0
        else:
            rel = lod.get("quality", {}).get("hausdorff_rel")
            if not isinstance(rel, (int, float)) or not math.isfinite(rel):
                left_out.append(f"{name}: LOD{level} has no certified bound; level left out")
                continue
            geometric = (
                rel * diagonal * (1.0 + 4 * FLOAT32_ULP) + slack0 + rounding_slack(*bounds[level])
            )
            error = max(geometric, recorded_error(lod))
        if levels and level:  # LOD0 ends every chain
            reason = redundant(lod, error, kept[-1], levels[-1].error, same_geometry)
            if reason is not None:
                dropped.append(f"{name}/{Path(lod['file']).name}: {reason}")
                continue
        low, high = bounds[level]
        size = max((int(v) for v in lod.get("texture_size", [0, 0])), default=0)
        levels.append(
            Level(
                f"{tile.name}/{lod['file']}", error, np.array(low), np.array(high), size, geometric
            )
        )
        kept.append(lod)
        as_kept = True
    centre = record["center"]
    return BuildingChain(
        tile,
        str(record["id"]),
        (float(centre["lon"]), float(centre["lat"]), float(centre["elev"])),
        str(record.get("input_hash", "")),
        levels,
        str(record.get("source", "")),
        attributes if isinstance(attributes := record.get("attributes"), dict) else {},
        dropped=dropped,
    )


def tile_chains(out_dir: Path, tile: TileId, records: list, left_out: list[str]) -> list:
    """The buildings of ``tile``'s manifest ``records`` as chains, by id; a record that cannot be
    read, with the reason, appended to ``left_out``."""
    chains: list[BuildingChain | None] = []
    for record in records:
        try:
            chains.append(read_chain(out_dir, tile, record, left_out))
        except (KeyError, TypeError, ValueError, AttributeError) as problem:
            left_out.append(f"{tile.name}: a building record unusable ({problem!r}); left out")
    return sorted((c for c in chains if c is not None), key=lambda c: c.id)


def read_buildings(
    out_dir: Path, fresh: dict[str, tuple[int, dict]] | None = None
) -> tuple[dict[TileId, list[BuildingChain]], list[str]]:
    """Every building of every tile manifest under ``out_dir`` (also earlier runs'), by tile, and
    the reasons for what was left out. ``fresh``: the index facts of the run's own tiles
    (:func:`exporter.tile_index.fresh_facts`), so their manifests are read once, here."""
    left_out: list[str] = []
    by_tile: dict[TileId, list[BuildingChain]] = {}
    for entry in build_index(out_dir, fresh)["tiles"]:
        tile = TileId(entry["level"], entry["idx"], entry["idy"])
        try:
            manifest = json.loads((out_dir / entry["manifest"]).read_text(encoding="utf-8"))
            records = manifest["buildings"]
        except (OSError, ValueError, KeyError, TypeError) as error:
            left_out.append(f"{entry['manifest']}: unreadable ({error}); tile left out")
            continue
        kept = tile_chains(out_dir, tile, records, left_out)
        if kept:
            by_tile[tile] = kept
        else:
            left_out.append(f"{tile.name}: no building to show; tile left out")
    return by_tile, left_out


def building_nodes(chains: list[BuildingChain]) -> list[Node]:
    """Each chain as nested nodes (coarsest on top, one transform at the top); the levels'
    corners for all chains at once."""
    levels = [(chain, level) for chain in chains for level in chain.levels]
    if not levels:
        return []
    lows = np.array([level.low for _, level in levels], np.float64)
    highs = np.array([level.high for _, level in levels], np.float64)
    worlds = np.array([chain.world for chain, _ in levels])
    corners = iter(frames.apply_each(worlds, frames.gltf_corners_each(lows, highs)))
    tops = []
    for chain in chains:
        nodes = [
            Node(f"{chain.id}/{level.file}", None, level.error, level.file, next(corners))
            for level in chain.levels
        ]
        for parent, child in zip(nodes, nodes[1:]):
            parent.children = [child]
        nodes[0].world = chain.world
        nodes[0].building = chain
        tops.append(nodes[0])
    return tops


def tile_world(tile: TileId) -> np.ndarray:
    lon, lat = tile_center(tile)
    return frames.world_matrix(lon, lat, 0.0)


def ancestor(tile: TileId, level: int) -> TileId:
    """The tile of ``level`` (at most ``tile.level``) that holds ``tile``."""
    shift = tile.level - level
    return TileId(level, tile.idx >> shift, tile.idy >> shift)


def quadtree(by_tile: dict[TileId, list[BuildingChain]]) -> list[Node]:
    """The compressed quadtree over the building tiles with their chains (:func:`tile_tree`): a
    tile node's children are its buildings' chains (by id), then its child tiles' nodes."""

    every = [chain for chains in by_tile.values() for chain in chains]
    node_of = {id(chain): node for chain, node in zip(every, building_nodes(every))}
    return tile_tree(by_tile, lambda tile: [node_of[id(chain)] for chain in by_tile[tile]])


def tileset_reference(summary: TileSummary) -> Node:
    """The node of the export's tileset that shows a building tile: its content is the tile's own
    tileset (``<tile>/tileset.json``, in the tile's frame: the node has its parent's, the tile
    node's), its box that tileset root's, its error the tile's chains' largest (a client always
    descends into an external tileset; the error bounds its parent's)."""
    tile_frame = tile_world(summary.tile)
    return Node(
        f"{summary.tile.name}/tileset.json",
        None,
        summary.error,
        f"{summary.tile.name}/tileset.json",
        box=list(summary.box),
        box_ecef=frames.apply(tile_frame, frames.box_corners(summary.box)),
        holds=summary,
    )


def tile_tree(tiles: Iterable[TileId], own: Callable[[TileId], list[Node]]) -> list[Node]:
    """The compressed quadtree over the building ``tiles``: its top nodes (level-0 tiles in idx,
    idy order).

    A tile node's children: ``own(tile)`` (what shows its buildings), then its child tiles' nodes
    (SW, SE, NW, NE); a tile without buildings and with one child tile is replaced by that child."""

    held = set(tiles)

    def build(tile: TileId, leaves: list[TileId]) -> Node | None:
        mine = own(tile) if tile in held else []
        below = [t for t in leaves if t.level > tile.level]
        subtiles: list[Node] = []
        level, i, j = tile.level + 1, 2 * tile.idx, 2 * tile.idy
        for child in (
            TileId(level, i, j),
            TileId(level, i + 1, j),
            TileId(level, i, j + 1),
            TileId(level, i + 1, j + 1),
        ):
            inside = [t for t in below if ancestor(t, level) == child]
            node = build(child, inside) if inside else None
            if node is not None:
                subtiles.append(node)
        if not mine and not subtiles:
            return None
        if not mine and len(subtiles) == 1:
            return subtiles[0]
        return Node(tile.name, tile_world(tile), children=mine + subtiles, tile=tile)

    leaves = sorted(held, key=lambda t: (t.level, t.idx, t.idy))
    tops = sorted({ancestor(t, 0) for t in leaves}, key=lambda t: (t.idx, t.idy))
    nodes = [build(top, [t for t in leaves if ancestor(t, 0) == top]) for top in tops]
    return [node for node in nodes if node is not None]
