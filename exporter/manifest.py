"""The tile manifest (``lod_manifest.json``): what Unity's LODGroup builder reads.

Plain dict assembly from already-computed building records; the JSON Schema beside this module
(``schema/lod_manifest.schema.json``) is the contract, and :func:`validate_manifest` checks a
manifest against it (used by the tests; the exporter builds manifests that satisfy it by design).

Frames: ``tile.placement`` and ``buildings[].placement`` are in the paper's Unity globe frame
(Unity units); ``buildings[].relative_placement`` is in the tile's East/Up/North frame (metres).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from importlib import resources
from typing import Any

from . import __version__
from .config import Config
from .model import Skipped, TileId
from .names import printable, safe_folder_name, slug

__all__ = ["safe_folder_name", "slug"]  # kept importable from here (report, older callers)

FORMAT = "vworld-lod-manifest"
VERSION = "1.0"
MANIFEST_NAME = "lod_manifest.json"


def load_schema(name: str = "lod_manifest.schema.json") -> dict:
    """A JSON schema shipped in ``exporter/schema/`` (the manifest's by default)."""
    return json.loads(
        resources.files("exporter").joinpath(f"schema/{name}").read_text(encoding="utf-8")
    )


def validate_manifest(manifest: dict) -> None:
    """Raise ``jsonschema.ValidationError`` when ``manifest`` breaks the schema (needs jsonschema)."""
    import jsonschema

    jsonschema.validate(manifest, load_schema())


def _mean(values: list[float]) -> float:
    return float(sum(values) / len(values)) if values else 0.0


def summarize_levels(buildings: list[dict], level_count: int) -> list[dict]:
    """Per LoD: mean triangles, ratio of the mean to LOD0's mean (the paper's Table III), texture
    pixels, how many buildings' level is no smaller than their level above (levels >= 1), and
    mean/min/max of every numeric quality metric."""
    levels = []
    lod0_mean = None
    for level in range(level_count):
        lods = [b["lods"][level] for b in buildings if len(b["lods"]) > level]
        triangles = [lod["triangles"] for lod in lods]
        mean_triangles = _mean(triangles)
        if level == 0:
            lod0_mean = mean_triangles
        entry: dict[str, Any] = {
            "level": level,
            "mean_triangles": round(mean_triangles, 4),
            "ratio_to_lod0": round(mean_triangles / lod0_mean, 6) if lod0_mean else 0.0,
            "total_triangles": int(sum(triangles)),
            "mean_texture_pixels": round(
                _mean([lod["texture_size"][0] * lod["texture_size"][1] for lod in lods]), 2
            ),
        }
        if level:
            # Levels whose mesh is no smaller than the level above (the budget allowed no collapse).
            entry["no_smaller_count"] = sum(bool(lod.get("no_smaller_than_above")) for lod in lods)
        metrics: dict[str, list[float]] = {}
        for lod in lods:
            for key, value in (lod.get("quality") or {}).items():
                if (
                    isinstance(value, (int, float))
                    and not isinstance(value, bool)
                    and math.isfinite(value)
                ):
                    metrics.setdefault(key, []).append(float(value))
        if metrics:
            entry["quality_mean"] = {k: round(_mean(v), 6) for k, v in sorted(metrics.items())}
            entry["quality_min"] = {k: round(min(v), 6) for k, v in sorted(metrics.items())}
            entry["quality_max"] = {k: round(max(v), 6) for k, v in sorted(metrics.items())}
        levels.append(entry)
    return levels


def skipped_entry(item: Skipped) -> dict:
    entry = {"source": item.source, "reason": item.reason}
    if item.id is not None:
        entry["id"] = str(item.id)
    return entry


def build_manifest(
    tile: TileId,
    bounds: tuple,
    tile_center: dict,
    tile_placement: dict,
    config: Config,
    buildings: Iterable[dict],
    skipped: Iterable[Skipped],
) -> dict:
    """Assemble the manifest of one tile.

    ``bounds`` is (west, south, east, north) in degrees; ``tile_center`` a ``{lon, lat, elev}``
    dict; ``tile_placement`` the tile root's Unity-globe placement dict; ``buildings`` the records
    made by the pipeline (schema ``$defs/building``), written in id order.
    """
    buildings = sorted(buildings, key=lambda b: b["id"])
    skipped_entries = [skipped_entry(s) for s in skipped]
    west, south, east, north = bounds

    return {
        "format": FORMAT,
        "version": VERSION,
        "generator": {"name": "vworld-lod", "version": __version__},
        "config": config.to_dict(),
        "tile": {
            "level": tile.level,
            "idx": tile.idx,
            "idy": tile.idy,
            "name": tile.name,
            "bounds": {"west": west, "south": south, "east": east, "north": north},
            "center": tile_center,
            "placement": tile_placement,
        },
        "globe": {
            "earth_radius_m": config.globe.earth_radius,
            "unity_radius": config.globe.unity_radius,
            "handedness": "left",
            "up": "y",
            "placement": config.globe.placement,
        },
        "lod_group": {
            "screen_relative_heights": [spec.transition for spec in config.lods],
            "fade_mode": config.unity.fade_mode,
            "animate_cross_fading": config.unity.animate_cross_fading,
            "fade_transition_width": config.unity.fade_transition_width,
            "terrain_levels": config.terrain_levels(),
        },
        "buildings": buildings,
        "skipped": skipped_entries,
        "summary": {
            "buildings": len(buildings),
            "skipped": len(skipped_entries),
            "levels": summarize_levels(buildings, len(config.lods)),
        },
    }


def record_line(text: str) -> str | None:
    """The manifest line of a building record from its JSON text as
    :func:`exporter.records.write_record` wrote it (``json.dumps``' default separators, ASCII
    only): that very text, unless it holds a ``\\u`` escape (the manifest writes non-ASCII
    characters as they are) or a line break; then None (it is encoded again)."""
    return None if "\\u" in text or "\n" in text else text


def dumps(manifest: dict, lines_of: dict[int, str] | None = None) -> str:
    """The manifest as JSON text: one line per top-level key, and one line per item of the
    ``buildings`` and ``skipped`` lists (readable and diff-friendly per building, and written by
    json's C encoder: ``indent`` would switch to its pure-Python one, ~10x slower on a city tile).
    ``lines_of``: items' lines already encoded (:func:`record_line`), by ``id()`` of the item."""
    known = lines_of or {}

    def compact(value) -> str:
        return json.dumps(value, ensure_ascii=False, allow_nan=False, separators=(", ", ": "))

    lines = []
    for key, value in manifest.items():
        if isinstance(value, list) and value and all(isinstance(item, dict) for item in value):
            items = ",\n  ".join(known.get(id(item)) or compact(item) for item in value)
            lines.append(f"{compact(key)}: [\n  {items}\n ]")
        else:
            lines.append(f"{compact(key)}: {compact(value)}")
    text = "{\n " + ",\n ".join(lines) + "\n}\n"
    try:  # source paths from file names that are not UTF-8: written \xNN (names.printable)
        text.encode("utf-8")
    except UnicodeEncodeError:
        return dumps(printable(manifest))
    return text
