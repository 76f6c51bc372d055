"""One building's export: read -> mesh LoDs -> texture LoDs -> quality -> placement -> write.

:func:`process_entry` runs in worker processes: the local pool (:mod:`exporter.pipeline`) and a
Dask cluster's workers (:mod:`exporter.distributed`) both call it with the same work items. It
writes the building's ``lod<k>.glb`` files, then its record (``building.json``) last: a record's
presence means the building's files are complete, and its ``input_hash`` lets a later run skip an
unchanged building. It never raises for a bad building: the building comes back skipped, with
the reason.
"""

from __future__ import annotations

import dataclasses
import math
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atomic import write_bytes_atomic, write_bytes_if_changed
from .config import Config
from .crop import crop_to_used
from .errors import ProcessError, ReadError, error_text
from .gltf_writer import Glb, encode_glb
from .ktx2 import ktx2_bytes
from .model import Building, Part, Skipped, Texture, TileId
from .names import name_error, printable, safe_folder_name
from .placement import building_placement, relative_placement
from .plausible import vertex_problem
from .quality import LevelQuality, Source, boundary_quality, exact_quality, measure_lod
from .readers import Entry, load_entry
from .records import file_entry, write_record
from .simplify import build_mesh_chain, degenerate_only
from .texel import level_error_m, level_texel_m
from .textures import build_texture_lods
from .tiles import building_tile as tile_of_bounds
from .tiles import check_tile

RECORD_NAME = "building.json"
STAGES = ("read", "simplify", "textures", "quality", "write")


def building_tile(building: Building, level: int = 15) -> tuple[TileId, TileId | None, str | None]:
    """(tile to write into, tile holding the centre if it differs from the data's, message).

    The data's own tile wins when it has one; the disagreement is reported (tiles.check_tile)."""
    bounds = building.lonlat_bounds or (
        building.reference.lon,
        building.reference.lat,
        building.reference.lon,
        building.reference.lat,
    )
    data_level = building.tile.level if building.tile is not None else level
    tile, message = check_tile(building.tile, bounds, data_level)
    centre = tile_of_bounds(bounds, data_level)
    return tile, (centre if centre != tile else None), message


# --------------------------------------------------------------------------- per-building stages


def texture_levels(
    parts_by_level: list[list[Part]], config: Config, problems: list[str]
) -> list[list[Part]]:
    """Give every level's parts their level's atlas; a texture that cannot be processed leaves its
    parts untextured (with a problem listed), never failing the building."""
    scales = [spec.texture for spec in config.lods]
    reduced: dict[int, list[Texture] | None] = {}
    for part in parts_by_level[0]:
        texture = part.texture
        if texture is None or id(texture) in reduced:
            continue
        try:
            reduced[id(texture)] = build_texture_lods(texture, scales, config.textures)
        except ReadError as error:
            problems.append(
                f"texture {texture.name or texture.source or '?'}: {error.problem}; exported untextured"
            )
            reduced[id(texture)] = None
    out = []
    for level, parts in enumerate(parts_by_level):
        level_parts = []
        for part in parts:
            textures = reduced.get(id(part.texture)) if part.texture is not None else None
            level_parts.append(
                dataclasses.replace(part, texture=textures[level] if textures else None)
            )
        out.append(level_parts)
    return out


def same_geometry(parts: list[Part], other: list[Part]) -> bool:
    """True when two levels have identical meshes (then their quality metrics are identical too)."""
    return len(parts) == len(other) and all(
        np.array_equal(a.triangles, b.triangles) and np.array_equal(a.positions, b.positions)
        for a, b in zip(parts, other)
    )


def lod_record(
    level: int, parts: list[Part], file_name: str, glb: Glb, quality: LevelQuality | None
) -> dict:
    """A level's manifest record of its parts written as ``glb``; ``quality`` None for LOD0 (the
    source: only its ratio, 1).

    ``gltf_bounds``: the file's position bounds as its writer stored them (:class:`Glb`), so the
    tileset needs no read of the file (:func:`exporter.tileset.tree.read_chain`)."""
    textures = [p.texture for p in parts if p.texture is not None and p.triangle_count]
    largest = max(textures, key=lambda t: t.width * t.height, default=None)
    return {
        "level": level,
        "file": file_name,
        "triangles": sum(p.triangle_count for p in parts),
        "vertices": sum(p.vertex_count for p in parts if p.triangle_count),
        "texture_size": [largest.width, largest.height] if largest else [0, 0],
        "texture_bytes": sum(len(t.data) for t in {id(t): t for t in textures}.values()),
        "file_bytes": len(glb.data),
        "gltf_bounds": {"low": glb.low, "high": glb.high},
        "quality": quality.to_manifest() if quality is not None else {"triangle_ratio": 1.0},
    }


def level_fields(level, above: dict) -> dict:
    """A level's error budget (metres, when it has one) and whether its mesh is no smaller than
    the level above's record ``above``."""
    fields = {"no_smaller_than_above": level_triangles(level) >= above["triangles"]}
    if math.isfinite(level.tolerance):
        fields["error_budget_m"] = round(level.tolerance, 6)
    return fields


def level_texel(parts: list[Part]) -> float | None:
    """Metres per texel of the level's atlases on its surface, all textured parts together
    (:func:`exporter.texel.level_texel_m`); None for an untextured level."""
    return level_texel_m(
        [
            (p.positions, p.triangles, p.uvs, (p.texture.width, p.texture.height))
            for p in parts
            if p.texture is not None and p.uvs is not None and p.triangle_count
        ]
    )


def texture_pixels(parts: list[Part]) -> int:
    """Pixels of the level's distinct atlases (a coarser texture LoD has fewer)."""
    textures = {id(p.texture): p.texture for p in parts if p.texture is not None}
    return sum(t.width * t.height for t in textures.values())


def level_error(
    quality: LevelQuality | None, texel: float | None, coarser_texture: bool, diagonal: float
) -> float:
    """A level's ``error_m`` (metres, :func:`exporter.texel.level_error_m`: the larger of its
    certified geometric bound, ``hausdorff_rel`` x LOD0's box ``diagonal`` in metres, and its
    texture error); ``quality`` None for LOD0 (error 0)."""
    geometric = quality.hausdorff_rel * diagonal if quality is not None else None
    return level_error_m(geometric, texel, coarser_texture)


def level_triangles(level) -> int:
    return sum(p.triangle_count for p in level.parts)


def remove_stale_levels(folder: str, count: int) -> None:
    """Delete the ``lod*.glb`` files of ``folder`` other than ``lod0.glb`` .. ``lod<count-1>.glb``:
    levels an earlier export (another configuration) wrote and this one did not."""
    written = {f"lod{level}.glb" for level in range(count)}
    for name in os.listdir(folder):
        # the names Path.glob("lod*.glb") matches (case-sensitive, "*" may be empty)
        if len(name) >= 7 and name[:3] == "lod" and name[-4:] == ".glb" and name not in written:
            try:
                os.unlink(os.path.join(folder, name))
            except FileNotFoundError:
                pass


def chain_qualities(
    chain: list, parts_by_level: list[list[Part]], source: Source | None = None
) -> list[LevelQuality | None]:
    """Each level's quality against LOD0 (None for LOD0 itself), ``chain`` the
    :func:`~exporter.simplify.build_mesh_chain` levels and ``parts_by_level`` their parts (as
    textured): the cheapest path that gives measure_lod's values, the source side prepared once
    (``source``: LOD0's, made here when not given)."""
    source = source if source is not None else Source(parts_by_level[0])
    qualities: list[LevelQuality | None] = [None]  # LOD0 is the source
    for level in range(1, len(parts_by_level)):
        if level > 1 and same_geometry(parts_by_level[level], parts_by_level[level - 1]):
            # The level above's mesh (no_smaller_than_above): its metrics, certified once.
            qualities.append(qualities[-1])
        elif chain[level].exact:  # a lossless re-triangulation: only the bound to certify
            qualities.append(exact_quality(source, parts_by_level[level]))
        elif chain[level].surface_exact:  # same surface, outline changed (a closed slit)
            qualities.append(boundary_quality(source, parts_by_level[level]))
        else:
            # The guard's certified bound when it measured this level: not certified again.
            qualities.append(measure_lod(source, parts_by_level[level], chain[level].deviation))
    return qualities


@dataclass
class EntryResult:
    """What a worker returns for one entry: a manifest record or a skip, plus stage times (s)."""

    tile: TileId | None
    record: dict | None = None
    skipped: Skipped | None = None
    reused: bool = False
    seconds: dict = field(default_factory=dict)


def process_entry(
    entry: Entry, config: Config, out_dir: str, digest: str, fingerprints: tuple = ()
) -> EntryResult:
    """Run the whole per-building pipeline for one entry (see module doc); ``digest`` is its input
    hash and ``fingerprints`` its input files' (:func:`input_fingerprints`), recorded for the next
    run. Never raises for a bad building: returns it as skipped with
    the reason."""
    seconds = {stage: 0.0 for stage in STAGES}
    clock = time.perf_counter()

    def lap(stage: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        seconds[stage] += now - clock
        clock = now

    try:
        building = load_entry(entry, config.readers)
    except ReadError as error:
        return EntryResult(
            tile=entry.tile,
            skipped=Skipped(entry.source, error.problem, entry.id, entry.tile),
            seconds=seconds,
        )
    lap("read")
    building_dir = None
    try:
        implausible = vertex_problem(
            np.concatenate([part.positions for part in building.parts] or [np.zeros((0, 3))]),
            config.readers.max_vertex_distance_m,
        )
        if implausible:
            raise ProcessError(implausible)
        tile, centre_tile, tile_message = building_tile(building)
        problems = list(building.problems)
        if tile_message:
            problems.append(tile_message)
        if building.triangle_count == 0:
            raise ProcessError("no triangles to export")
        if degenerate_only(building.parts):
            raise ProcessError("every triangle is degenerate (narrower than 1 micrometre)")
        chain = build_mesh_chain(building.parts, config.lods, config.simplify)
        parts_by_level = [level.parts for level in chain]
        lap("simplify")
        if config.textures.crop_to_used:
            parts_by_level = crop_to_used(parts_by_level, config.textures)
        parts_by_level = texture_levels(parts_by_level, config, problems)
        lap("textures")
        source = Source(parts_by_level[0])
        qualities = chain_qualities(chain, parts_by_level, source)
        texels = [level_texel(parts) for parts in parts_by_level]
        pixels = [texture_pixels(parts) for parts in parts_by_level]
        lap("quality")
        # The entry's id, not the reader's: the run made entry ids unique across folders and files.
        folder = safe_folder_name(entry.id)
        building_dir = os.path.join(out_dir, tile.name, folder)
        # A link in OUT (never made by this tool) is replaced by a folder: writing through it
        # would overwrite, and remove_stale_levels delete, files of its target.
        if os.path.islink(building_dir):
            os.unlink(building_dir)
        # Only a folder that was there before this building can hold an earlier export's levels.
        existed = os.path.isdir(building_dir)
        lods, files = [], []
        for level, parts in enumerate(parts_by_level):
            glb = encode_glb(
                parts, f"{entry.id}_LOD{level}", ktx2_bytes if config.textures.ktx2 else None
            )
            name = f"lod{level}.glb"
            path = os.path.join(building_dir, name)
            # A level an earlier export wrote byte for byte is left as it is (mtime kept).
            (write_bytes_if_changed if existed else write_bytes_atomic)(path, glb.data)
            files.append(file_entry(name, glb.data))
            lods.append(lod_record(level, parts, f"{folder}/{name}", glb, qualities[level]))
            if texels[level] is not None:
                lods[-1]["quality"]["texel_m"] = texels[level]
            lods[-1]["error_m"] = level_error(
                qualities[level], texels[level], pixels[level] < pixels[0], source.diagonal
            )
            if level:
                lods[-1].update(level_fields(chain[level], lods[-2]))
                lods[-1]["same_geometry_as_above"] = same_geometry(parts, parts_by_level[level - 1])
        if existed:
            remove_stale_levels(building_dir, len(lods))
        record = {
            "id": entry.id,
            "folder": folder,
            "source": entry.source,
            "input_hash": digest,
            "center": {
                "lon": building.reference.lon,
                "lat": building.reference.lat,
                "elev": building.reference.elev,
            },
            "placement": building_placement(building.reference, config.globe),
            "relative_placement": relative_placement(building.reference, tile, config.globe),
            "lods": lods,
            "problems": problems,
        }
        if printable(building.id) != entry.id:  # made unique in the run (a~1): keep the input's
            record["source_id"] = printable(building.id)
        if building.attributes:
            record["attributes"] = building.attributes
        if centre_tile is not None:
            record["tile_from_center"] = {
                "level": centre_tile.level,
                "idx": centre_tile.idx,
                "idy": centre_tile.idy,
            }
        write_record(
            os.path.join(building_dir, RECORD_NAME),
            {
                "tile": {"level": tile.level, "idx": tile.idx, "idy": tile.idy},
                "record": record,
                "files": files,
            },
            list(fingerprints),
        )
        lap("write")
        return EntryResult(tile=tile, record=record, seconds=seconds)
    except OSError as error:
        if not name_error(error):  # the output cannot be written (disk full, read-only, denied)
            raise  # stop the run
        # One building's file name the file system refuses: costs this building only.
        if building_dir is not None:
            shutil.rmtree(building_dir, ignore_errors=True)
        return EntryResult(
            tile=entry.tile,
            skipped=Skipped(
                entry.source,
                f"cannot be written: {Path(error.filename or '?').name}: {error.strerror}",
                entry.id,
                entry.tile,
            ),
            seconds=seconds,
        )
    except Exception as error:  # one broken building never stops the tile
        reason = error.problem if isinstance(error, ReadError) else error_text(error)
        return EntryResult(
            tile=entry.tile,
            skipped=Skipped(entry.source, f"processing failed: {reason}", entry.id, entry.tile),
            seconds=seconds,
        )
