"""The tile index of an export (``OUT/tiles.json``): every tile of ``OUT`` the Unity streamer may load.

Data form: one JSON object (schema ``schema/tile_index.schema.json``, written for Unity's
JsonUtility: no variable-key objects, no nested arrays, no top-level array)::

    {"format": "vworld-lod-tile-index", "version": "1.0",
     "tiles": [{"name": "15_279418_116113", "level": 15, "idx": 279418, "idy": 116113,
                "bounds": {"west": .., "south": .., "east": .., "north": ..},   # degrees
                "center": {"lon": .., "lat": .., "elev": 0.0},                  # degrees, metres
                "manifest": "15_279418_116113/lod_manifest.json",               # relative to OUT
                "buildings": 42,
                "globe": {"earth_radius_m": 6378137.0, "unity_radius": 6378137.0}}]}

``globe`` repeats the manifest's radii (R in metres, UR in Unity units), so a streamer can place
tile centres in Unity units before reading any manifest.

``proxies`` (version 1.1, when ``OUT/tileset.json`` has HLOD proxies; :func:`proxy_entry`): per
proxied quadtree tile its ``.glb`` (``file``, relative to OUT), ``bounds``/``center`` as tiles
have them (the proxy's glTF frame, +X West, +Y Up, +Z North, sits at ``center``, elevation 0),
``placement`` (that frame's Unity-globe placement, :func:`exporter.placement.tile_placement`),
``radius_m`` (metres: a sphere about ``center`` holding the proxy), ``geometric_error`` (metres,
tileset.json's), ``texel_m`` (metres per texel of its atlas on its surface: the streamer leaves
out the mip levels a proxy's distance does not need), ``atlas_px`` (pixels per side of its atlas:
proxies' atlases differ in size since 0.6.0), ``children`` (child proxies' names) and ``tiles`` (names of the building tiles
directly under it). A proxy is listed only when its file exists and all its children are listed.

Tiles are listed in (level, idx, idy) order. The index lists every tile folder of ``OUT`` that holds
a manifest, not only the tiles of the run that wrote it, so incremental and multi-run exports into
one ``OUT`` stay complete. Tiles of this run come with their building count
(:class:`exporter.pipeline.TileResult`) and the run's radii; other tiles keep their entry of the previous index when
their manifest is older than it, else their manifest is read. Written atomically
(``exporter.atomic``) after the manifests, so a reader never sees an index naming a manifest that
is not complete yet.
"""

from __future__ import annotations

import functools
import json
import math
import os
from collections.abc import Iterable
from pathlib import Path

from . import manifest
from .atomic import write_text_atomic
from .config import GlobeOptions
from .manifest import MANIFEST_NAME
from .model import TileId
from .placement import tile_placement
from .tiles import tile_bounds, tile_center

FORMAT = "vworld-lod-tile-index"
VERSION = "1.1"
INDEX_NAME = "tiles.json"


@functools.lru_cache(maxsize=1024)  # a re-run asks once per building, of a few tile folders
def tile_from_name(name: str) -> TileId | None:
    """The tile of a ``<level>_<idx>_<idy>`` folder name, or None when the name is not one."""
    parts = name.split("_")
    if len(parts) != 3 or not all(p.isdigit() for p in parts):
        return None
    tile = TileId(int(parts[0]), int(parts[1]), int(parts[2]))
    try:
        tile_bounds(tile)  # IDX/IDY inside the level's grid
    except ValueError:
        return None
    return tile


def _where(tile: TileId) -> dict:
    """Name, level, idx, idy, bounds and centre (degrees; elevation 0 m) of ``tile``."""
    west, south, east, north = tile_bounds(tile)
    lon, lat = tile_center(tile)
    return {
        "name": tile.name,
        "level": tile.level,
        "idx": tile.idx,
        "idy": tile.idy,
        "bounds": {"west": west, "south": south, "east": east, "north": north},
        "center": {"lon": lon, "lat": lat, "elev": 0.0},
    }


def tile_entry(tile: TileId, buildings: int, globe: dict) -> dict:
    """The index entry of ``tile`` with ``buildings`` buildings (bounds and centre in degrees) and
    ``globe`` ``{"earth_radius_m", "unity_radius"}``."""
    return {
        **_where(tile),
        "manifest": f"{tile.name}/{MANIFEST_NAME}",
        "buildings": int(buildings),
        "globe": {
            "earth_radius_m": float(globe["earth_radius_m"]),
            "unity_radius": float(globe["unity_radius"]),
        },
    }


def proxy_entry(record: dict, globe: dict) -> dict:
    """The index entry of a proxy: ``record`` (from :func:`exporter.tileset.write_tileset`:
    ``tile`` (TileId), ``file``, ``radius_m``, ``geometric_error`` and ``texel_m`` (metres),
    ``atlas_px``, ``children``,
    ``tiles``) with the radii ``globe`` of the tiles below it."""
    tile = record["tile"]
    radii = GlobeOptions(
        unity_radius=float(globe["unity_radius"]), earth_radius=float(globe["earth_radius_m"])
    )
    return {
        **_where(tile),
        "file": str(record["file"]),
        # The proxy's glTF frame is the tile root's frame: East/Up/North at the centre, elev 0.
        "placement": tile_placement(tile, radii),
        "radius_m": float(record["radius_m"]),
        "geometric_error": float(record["geometric_error"]),
        "texel_m": float(record.get("texel_m", 0.0)),
        "atlas_px": int(record.get("atlas_px", 0)),
        "children": sorted(record["children"]),
        "tiles": sorted(record["tiles"]),
        "globe": dict(globe),
    }


def proxy_entries(out_dir: Path, records: Iterable[dict], tiles: list[dict]) -> list[dict]:
    """Entries of the proxies of ``records`` (children before parents) whose file exists under
    ``out_dir`` and whose children and building tiles are all listed (``tiles``: tile entries),
    in (level, idx, idy) order; each takes its radii from a tile or child below it."""
    globes = {t["name"]: t["globe"] for t in tiles}
    listed: dict[str, dict] = {}
    for record in records:
        tiles, children = record["tiles"], record["children"]
        if not (out_dir / record["file"]).is_file() or not (tiles or children):
            continue
        if any(t not in globes for t in tiles) or any(c not in listed for c in children):
            continue  # a hole under it: refining it would show nothing there
        globe = globes[tiles[0]] if tiles else listed[children[0]]["globe"]
        listed[record["tile"].name] = proxy_entry(record, globe)
    return sorted(listed.values(), key=lambda e: (e["level"], e["idx"], e["idy"]))


def _facts(buildings, globe) -> tuple[int, dict] | None:
    """``(buildings, globe)`` when both are well formed, else None."""
    try:
        radii = {k: float(globe[k]) for k in ("earth_radius_m", "unity_radius")}
    except (KeyError, TypeError, ValueError):
        return None
    if not all(math.isfinite(v) and v > 0 for v in radii.values()):
        return None
    if not isinstance(buildings, int) or isinstance(buildings, bool) or buildings < 0:
        return None
    return buildings, radii


def _manifest_facts(path: Path) -> tuple[int, dict] | None:
    """``summary.buildings`` and the globe radii of the manifest at ``path``; None when unreadable."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return _facts(data["summary"]["buildings"], data["globe"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _previous_entries(index_path: Path) -> tuple[dict[str, dict], int]:
    """Entries of an earlier index by tile name, and its mtime in ns (0 when there is none)."""
    try:
        stamp = index_path.stat().st_mtime_ns
        data = json.loads(index_path.read_text(encoding="utf-8"))
        tiles = data["tiles"] if data.get("format") == FORMAT else []
        return {t["name"]: t for t in tiles if isinstance(t, dict) and "name" in t}, stamp
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}, 0


def build_index(
    out_dir: str | Path,
    fresh: dict[str, tuple[int, dict]] | None = None,
    proxies: Iterable[dict] = (),
) -> dict:
    """The index of every ``<level>_<idx>_<idy>/lod_manifest.json`` under ``out_dir``.

    ``fresh`` maps tile names of the current run to ``(buildings, globe radii)``; other tiles reuse
    the previous index's entry when their manifest is older than that index, else their manifest's
    ``summary.buildings`` and ``globe`` are read. A manifest that cannot be read is left out.
    ``proxies``: proxy records (see :func:`proxy_entries`), listed under ``proxies`` when usable.
    """
    out_dir = Path(out_dir)
    fresh = fresh or {}
    previous, index_stamp = _previous_entries(out_dir / INDEX_NAME)
    entries = []
    with os.scandir(out_dir) as folders:
        names = sorted(f.name for f in folders if f.is_dir())
    for name in names:
        tile = tile_from_name(name)
        manifest_path = out_dir / name / MANIFEST_NAME
        if tile is None:
            continue
        try:
            manifest_stamp = manifest_path.stat().st_mtime_ns
        except OSError:
            continue  # a tile folder without a complete manifest (or no tile at all)
        facts = fresh.get(name)
        if facts is None and name in previous and manifest_stamp < index_stamp:
            facts = _facts(previous[name].get("buildings"), previous[name].get("globe"))
        if facts is None:
            facts = _manifest_facts(manifest_path)
        if facts is None:
            continue
        entries.append((tile, tile_entry(tile, *facts)))
    entries.sort(key=lambda item: (item[0].level, item[0].idx, item[0].idy))
    index: dict = {"format": FORMAT, "version": VERSION, "tiles": [entry for _, entry in entries]}
    listed = proxy_entries(out_dir, proxies, index["tiles"])
    if listed:
        index["proxies"] = listed
    return index


def fresh_facts(tiles: Iterable = (), globe=None) -> dict[str, tuple[int, dict]]:
    """:func:`build_index`'s ``fresh`` for the run's tiles (:class:`exporter.pipeline.TileResult`)
    written with the globe options ``globe`` (empty without them: their manifests are read)."""
    if globe is None:
        return {}
    radii = {"earth_radius_m": globe.earth_radius, "unity_radius": globe.unity_radius}
    return {r.tile.name: (r.buildings, radii) for r in tiles}


def write_tile_index(
    out_dir: str | Path, tiles: Iterable = (), globe=None, proxies: Iterable[dict] = ()
) -> Path:
    """Write ``OUT/tiles.json`` (atomically, fsynced) for every tile of ``out_dir``; returns its path.

    ``tiles``: the run's :class:`exporter.pipeline.TileResult` (``.tile``, ``.buildings``);
    ``globe``: the run's :class:`exporter.config.GlobeOptions` (without it those tiles' manifests
    are read for their radii); ``proxies``: the tileset's proxy records (``TilesetResult.proxies_index``).
    """
    index = build_index(out_dir, fresh_facts(tiles, globe), proxies)
    text = json.dumps(index, ensure_ascii=False, allow_nan=False, indent=1) + "\n"
    return write_text_atomic(Path(out_dir) / INDEX_NAME, text, durable=True)


def load_schema() -> dict:
    return manifest.load_schema("tile_index.schema.json")


def validate_index(index: dict) -> None:
    """Raise ``jsonschema.ValidationError`` when ``index`` breaks the schema (needs jsonschema)."""
    import jsonschema

    jsonschema.validate(index, load_schema())
