"""Each building tile's own tileset (``OUT/<tile>/tileset.json``) and its summary, so that the
export's ``tileset.json`` is made from small per-tile records, never from the buildings.

Source: 3D Tiles 1.1, "External tilesets" (https://docs.ogc.org/cs/22-025r4/22-025r4.html: a
tile whose content URI is another tileset JSON, without children; transforms accumulate into
it) and "Metadata" (every class of an external tileset's schema is in the top-level tileset's
schema; CesiumJS reads an external tileset's content metadata with the top-level schema,
CesiumGS/cesium#13407, CesiumGS/3d-tiles#684).

A tile's tileset is written with its manifest (``exporter.pipeline.write_tile_output``, early or
at the end of the run), atomically and only when its bytes change. Beside it,
``.tileset_summary.json`` (:data:`SUMMARY_NAME`) holds its :class:`.tree.TileSummary` (box,
error, leaf proxy key, left-out lines, metadata kinds) with the sha256 of the manifest and of the
tileset it goes with, and the proxy options its key was computed with: the end of the run
(:func:`tile_summaries`) trusts it only while all of them are the same, else it makes the tile's
tileset again from the manifest (an earlier export, an interrupted run, a file edited by hand).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ..atomic import write_bytes_if_changed
from ..config import TilesetOptions
from ..manifest import MANIFEST_NAME
from ..model import TileId
from ..tile_index import build_index
from .metadata import CLASS, properties_digest
from .proxy import PROXY_FORMAT, ProxyTask
from .schedule import leaf_task_of
from .tree import TileSummary, tile_chains
from .write import TILESET_NAME, tile_tileset_json, tileset_bytes

SUMMARY_NAME = ".tileset_summary.json"  # hidden: never taken for a building folder
SUMMARY_FORMAT = "vworld-lod-tile-tileset"
# The layout of a tile's tileset and its summary: a new value makes every tile's again (once).
SUMMARY_VERSION = 1


def proxy_options(options: TilesetOptions, jpeg_quality: int) -> list:
    """What a leaf proxy's key depends on besides the tile's buildings: a summary's key is
    trusted only with the same."""
    return [
        PROXY_FORMAT,
        options.proxies,
        options.proxy_max_triangles,
        options.proxy_atlas_size,
        options.proxy_error_ratio,
        jpeg_quality,
    ]


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def write_tile_tileset(
    out_dir: Path,
    tile: TileId,
    records: list,
    manifest: bytes,
    options: TilesetOptions,
    jpeg_quality: int,
    properties: dict[str, dict] | None = None,
    leaf_tasks: dict[TileId, ProxyTask] | None = None,
) -> TileSummary:
    """Write ``tile``'s tileset from its manifest's building ``records`` (the manifest's bytes:
    ``manifest``) and its summary; returns the summary. ``properties``: the class to type its
    metadata with (default its own buildings', :mod:`.metadata`). A tile without a building to
    show has no tileset (an earlier one is removed) and a summary saying so. ``leaf_tasks``: gets
    the tile's leaf proxy task (whose key the summary holds), for a caller that starts it now
    rather than read the tile's buildings again."""
    tile_dir = Path(out_dir) / tile.name
    path = tile_dir / TILESET_NAME
    left_out: list[str] = []
    chains = tile_chains(Path(out_dir), tile, records, left_out)
    if not chains:
        path.unlink(missing_ok=True)
        summary = TileSummary(tile, 0, [], 0.0, None, left_out, {}, "")
        written = b""
    else:
        tileset, root, kinds = tile_tileset_json(tile, chains, left_out, properties)
        written = tileset_bytes(tileset)
        write_bytes_if_changed(path, written)
        key = None
        if options.proxies:
            task = leaf_task_of(Path(out_dir), tile, root.children, options, jpeg_quality)
            key = task.key if task is not None else None
            if leaf_tasks is not None and task is not None:
                leaf_tasks[tile] = task
        assert root.box is not None
        summary = TileSummary(
            tile,
            len(chains),
            root.box,
            max(top.error for top in root.children),
            key,
            left_out,
            kinds,
            properties_digest(tileset["schema"]["classes"][CLASS]["properties"]),
        )
    data = {
        "format": SUMMARY_FORMAT,
        "version": SUMMARY_VERSION,
        "manifest_sha256": _sha256(manifest),
        "tileset_sha256": _sha256(written) if summary.buildings else None,
        "proxy_options": proxy_options(options, jpeg_quality),
        "buildings": summary.buildings,
        "box": summary.box,
        "error": summary.error,
        "proxy_key": summary.proxy_key,
        "left_out": summary.left_out,
        "kinds": summary.kinds,
        "typed": summary.typed,
    }
    text = json.dumps(data, sort_keys=True, allow_nan=False, separators=(",", ":"))
    write_bytes_if_changed(tile_dir / SUMMARY_NAME, text.encode("utf-8"))
    return summary


def read_tile_summary(
    out_dir: Path, tile: TileId, manifest: bytes, options: TilesetOptions, jpeg_quality: int
) -> TileSummary | None:
    """``tile``'s summary when it goes with its manifest (bytes ``manifest``), its tileset as
    written and these proxy options; else None (then the tile's tileset is made again)."""
    tile_dir = Path(out_dir) / tile.name
    try:
        data = json.loads((tile_dir / SUMMARY_NAME).read_bytes())
        if (
            data["format"] != SUMMARY_FORMAT
            or data["version"] != SUMMARY_VERSION
            or data["manifest_sha256"] != _sha256(manifest)
            or data["proxy_options"] != json.loads(json.dumps(proxy_options(options, jpeg_quality)))
        ):
            return None
        buildings = int(data["buildings"])
        if buildings and data["tileset_sha256"] != _sha256((tile_dir / TILESET_NAME).read_bytes()):
            return None
        return TileSummary(
            tile,
            buildings,
            [float(v) for v in data["box"]],
            float(data["error"]),
            data["proxy_key"],
            [str(line) for line in data["left_out"]],
            dict(data["kinds"]),
            str(data["typed"]),
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None


def tile_summary(
    out_dir: Path,
    tile: TileId,
    options: TilesetOptions,
    jpeg_quality: int,
    problems: list[str],
    properties: dict[str, dict] | None = None,
) -> TileSummary | None:
    """``tile``'s summary: read when it still holds (:func:`read_tile_summary`, and no
    ``properties`` asked for), else its tileset written again from its manifest; None (reason
    appended to ``problems``) when the manifest cannot be read."""
    manifest_name = f"{tile.name}/{MANIFEST_NAME}"
    try:
        manifest = (Path(out_dir) / manifest_name).read_bytes()
        if properties is None:
            found = read_tile_summary(out_dir, tile, manifest, options, jpeg_quality)
            if found is not None:
                return found
        records = json.loads(manifest)["buildings"]
        if not isinstance(records, list):
            raise TypeError("buildings is not a list")
    except (OSError, ValueError, KeyError, TypeError) as error:
        problems.append(f"{manifest_name}: unreadable ({error}); tile left out")
        return None
    return write_tile_tileset(out_dir, tile, records, manifest, options, jpeg_quality, properties)


def tile_summaries(
    out_dir: Path,
    fresh: dict[str, tuple[int, dict]] | None,
    options: TilesetOptions,
    jpeg_quality: int,
    problems: list[str],
) -> list[TileSummary]:
    """The summary of every tile of ``out_dir``'s index (this run's and earlier runs',
    :func:`exporter.tile_index.build_index`; ``fresh``: the run's own tiles' facts), in (level,
    idx, idy) order; tiles whose manifest cannot be read are left out (``problems``)."""
    out: list[TileSummary] = []
    for entry in build_index(out_dir, fresh)["tiles"]:
        tile = TileId(entry["level"], entry["idx"], entry["idy"])
        found = tile_summary(out_dir, tile, options, jpeg_quality, problems)
        if found is not None:
            out.append(found)
    return out
