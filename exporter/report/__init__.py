"""A visual HTML report of every tile's LoD chain.

One public entry point, :func:`write_reports`. For each tile folder ``OUT/<level>_<idx>_<idy>/``
holding a ``lod_manifest.json`` it writes ``OUT/<tile>/report.html`` and the renders next to it in
``OUT/<tile>/report/<building folder>_lod<k>.png`` (plus ``..._lod<k>_atlas.png``, a crop of the
level's atlas, see :mod:`.atlas`); then ``OUT/index.html`` linking every tile.

Flat pipeline per tile: read the manifest -> per building, load each level's ``.glb`` (glTF frame)
-> fit one camera to LOD0 -> render every level from it (:mod:`.render`, numpy only, no GPU) ->
write the PNGs -> write the page (:mod:`.page`, numbers from :mod:`.summary`, plots from
:mod:`.plots`). A building whose file is missing or broken gets a labelled placeholder in place of
its picture; the report never stops for one bad building.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from pathlib import Path
from urllib.parse import quote

from ..atomic import write_bytes_atomic, write_text_atomic
from ..errors import InputError
from ..manifest import MANIFEST_NAME, slug
from .atlas import atlas_detail
from .page import BuildingRenders, LevelRender, TileEntry, index_page, tile_page
from .render import backdrop, fit_view, load_glb, png_bytes, render

__all__ = ["write_reports"]

TILE_NAME = re.compile(r"^[0-9]+_[0-9]+_[0-9]+$")
IMAGE_FOLDER = "report"
IMAGE_SIZE = 256  # pixels per side of each render


def read_tile_manifest(path: Path) -> dict:
    """The parsed manifest; InputError naming the file when it is not JSON or lacks buildings."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise InputError(f"{path}: cannot be read ({error.strerror or error})") from None
    except ValueError as error:
        raise InputError(f"{path}: not valid JSON ({error})") from None
    if not isinstance(data, dict) or not isinstance(data.get("buildings"), list):
        raise InputError(f"{path}: not a vworld-lod manifest (no 'buildings' list)")
    for i, building in enumerate(data["buildings"]):
        if not isinstance(building, dict) or not isinstance(building.get("lods"), list):
            raise InputError(f"{path}: buildings[{i}] has no 'lods' list")
    return data


def image_name(building: dict, level: int) -> str:
    """File name of a level's render: the building's output folder name (already file-system safe)
    or, failing that, its id with unsafe characters replaced."""
    lods = building.get("lods") or [{}]
    folder = Path(str(lods[0].get("file", ""))).parent.name
    if not folder:
        folder = slug(str(building.get("id", "building")))
    return f"{folder}_lod{level}.png"


def detail_name(building: dict, level: int) -> str:
    """File name of a level's atlas detail (see :mod:`.atlas`)."""
    return image_name(building, level).removesuffix(".png") + "_atlas.png"


def render_building(tile_dir: Path, building: dict, size: int = IMAGE_SIZE) -> BuildingRenders:
    """Render every level of one building into ``tile_dir/report/``, all from LOD0's view."""
    result = BuildingRenders(building)
    view, background = None, None
    for lod in building.get("lods", []):
        level = int(lod.get("level", len(result.levels)))
        started = time.perf_counter()
        entry = LevelRender(level, lod)
        try:
            meshes = load_glb(tile_dir / str(lod.get("file", "")))
            if view is None:  # LOD0 (or the first readable level) fixes the camera for the chain
                view = fit_view(meshes, size)
                background = backdrop(view)
            name = image_name(building, level)
            write_bytes_atomic(
                tile_dir / IMAGE_FOLDER / name,
                png_bytes(render(meshes, view, background=background)),
            )
            entry.image = f"{IMAGE_FOLDER}/{quote(name)}"
            detail = atlas_detail(tile_dir / str(lod.get("file", "")))
            if detail is not None:
                name = detail_name(building, level)
                write_bytes_atomic(tile_dir / IMAGE_FOLDER / name, png_bytes(detail))
                entry.detail, entry.detail_size = (
                    f"{IMAGE_FOLDER}/{quote(name)}",
                    (detail.shape[1], detail.shape[0]),
                )
        except InputError as error:
            entry.error = str(error).replace(str(tile_dir) + "/", "")
        entry.seconds = time.perf_counter() - started
        result.levels.append(entry)
    return result


# Part of every render's key: change it when the renders of unchanged files would change
# (camera, light, rasteriser, atlas crop), so a report after such a change draws them again.
RENDER_VERSION = 1
RENDERS_NAME = "renders.json"  # in the tile's report/ folder: each building's key and levels


def render_key(tile_dir: Path, building: dict, size: int) -> str | None:
    """What a building's renders depend on: :data:`RENDER_VERSION`, the picture size and each
    level's file name, size and modification time (an export leaves a level whose bytes are
    unchanged untouched, mtime kept). None when a level's file cannot be stat'ed (drawn again)."""
    parts: list = [RENDER_VERSION, size]
    for lod in building.get("lods", []):
        try:
            stat = (tile_dir / str(lod.get("file", ""))).stat()
        except OSError:
            return None
        parts.append([str(lod.get("file", "")), stat.st_size, stat.st_mtime_ns])
    return hashlib.sha256(json.dumps(parts).encode("utf-8")).hexdigest()


def read_renders(image_dir: Path) -> dict:
    """The previous report's ``renders.json`` (building folder -> {key, levels}), or {}."""
    try:
        data = json.loads((image_dir / RENDERS_NAME).read_text(encoding="utf-8"))
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def reused_renders(
    image_dir: Path, building: dict, key: str | None, previous: dict
) -> BuildingRenders | None:
    """The building's renders from the previous report when its key is unchanged and every image
    it drew is still there, else None."""
    entry = previous.get(image_name(building, 0))
    if key is None or not isinstance(entry, dict) or entry.get("key") != key:
        return None
    lods = {int(lod.get("level", k)): lod for k, lod in enumerate(building.get("lods", []))}
    result = BuildingRenders(building)
    try:
        for item in entry["levels"]:
            level = LevelRender(int(item["level"]), lods[int(item["level"])])
            level.error = item.get("error")
            for kind in ("image", "detail"):
                name = item.get(kind)
                if name is not None and not (image_dir / str(name)).is_file():
                    return None
                setattr(level, kind, None if name is None else f"{IMAGE_FOLDER}/{quote(name)}")
            level.detail_size = tuple(item.get("detail_size", (0, 0)))
            result.levels.append(level)
    except (KeyError, TypeError, ValueError):
        return None
    return result


def renders_entry(renders: BuildingRenders, key: str) -> dict:
    """``renders.json``'s record of one building's renders (image names in ``report/``)."""
    levels = []
    for level in renders.levels:
        levels.append(
            {
                "level": level.level,
                "image": image_name(renders.building, level.level) if level.image else None,
                "detail": detail_name(renders.building, level.level) if level.detail else None,
                "detail_size": list(level.detail_size),
                "error": level.error,
            }
        )
    return {"key": key, "levels": levels}


def remove_stale_images(image_dir: Path, keep: set[str]) -> None:
    """Delete renders not drawn this time (buildings or levels gone, or whose file is now broken)."""
    if image_dir.is_dir():
        for path in image_dir.glob("*.png"):
            if path.name not in keep:
                path.unlink(missing_ok=True)


def write_tile_report(tile_dir: Path, manifest: dict, size: int = IMAGE_SIZE) -> Path:
    """Render one tile's buildings and write ``tile_dir/report.html``; returns the page's path.

    A building whose level files are unchanged since the previous report (:func:`render_key`)
    keeps its images: an unchanged re-run draws nothing (``report/renders.json`` keeps the keys)."""
    started = time.perf_counter()
    image_dir = tile_dir / IMAGE_FOLDER
    previous = read_renders(image_dir)
    renders, entries, reused = [], {}, 0
    for building in manifest["buildings"]:
        key = render_key(tile_dir, building, size)
        found = reused_renders(image_dir, building, key, previous)
        reused += found is not None
        found = found or render_building(tile_dir, building, size)
        renders.append(found)
        if key is not None:
            entries[image_name(building, 0)] = renders_entry(found, key)
    seconds = time.perf_counter() - started
    drawn = {
        image_name(r.building, level.level)
        for r in renders
        for level in r.levels
        if level.image is not None
    }
    drawn |= {
        detail_name(r.building, level.level)
        for r in renders
        for level in r.levels
        if level.detail is not None
    }
    remove_stale_images(image_dir, drawn)
    if entries != previous:
        write_text_atomic(image_dir / RENDERS_NAME, json.dumps(entries, sort_keys=True) + "\n")
    page = tile_page(manifest, renders, seconds, reused)
    return write_text_atomic(tile_dir / "report.html", page)


def find_tiles(out_dir: Path) -> list[Path]:
    """Tile folders of an export (named ``<level>_<idx>_<idy>`` and holding a manifest), sorted."""
    return sorted(
        p
        for p in out_dir.iterdir()
        if p.is_dir() and TILE_NAME.match(p.name) and (p / MANIFEST_NAME).is_file()
    )


def write_reports(out_dir: Path, tiles: list[str] | None = None) -> list[Path]:
    """Write the report pages of an export folder ``out_dir`` (see module doc).

    ``tiles`` limits rendering to those tile folder names (the index still lists every tile).
    Returns the written pages: one per rendered tile, then ``index.html``. Raises InputError when
    ``out_dir`` is not an export folder, a requested tile is absent, or a manifest to render is
    unreadable (an unreadable manifest of a tile not requested is only flagged on the index)."""
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise InputError(
            f"{out_dir}: not a folder (expected the output folder of 'vworld-lod export')"
        )
    tile_dirs = find_tiles(out_dir)
    if not tile_dirs:
        raise InputError(
            f"{out_dir}: no <level>_<idx>_<idy>/{MANIFEST_NAME} found (run 'vworld-lod export' first)"
        )
    names = [p.name for p in tile_dirs]
    if tiles is not None:
        unknown = [t for t in tiles if t not in names]
        if unknown:
            raise InputError(
                f"{out_dir}: no tile folder with a {MANIFEST_NAME} for {', '.join(unknown)} (found: {', '.join(names)})"
            )
    selected = set(names if tiles is None else tiles)
    pages, entries = [], []
    for tile_dir in tile_dirs:
        manifest, error = None, None
        if tile_dir.name in selected:
            manifest = read_tile_manifest(tile_dir / MANIFEST_NAME)
            pages.append(write_tile_report(tile_dir, manifest))
        else:
            try:
                manifest = read_tile_manifest(tile_dir / MANIFEST_NAME)
            except InputError as problem:
                error = str(problem)
        entries.append(
            TileEntry(tile_dir.name, manifest, (tile_dir / "report.html").is_file(), error)
        )
    pages.append(write_text_atomic(out_dir / "index.html", index_page(entries)))
    return pages
