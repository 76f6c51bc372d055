"""HLOD proxies: one quadtree tile's content as one mesh with one atlas, built from the level
below it (hierarchical LoD), with a certified error against the LOD0 surfaces of its buildings.

Sources: Erikson, Manocha & Baxter, "HLODs for faster display of large static and dynamic
environments" (I3D 2001: a node's HLOD is simplified from its children's); meshoptimizer
(``meshopt_simplify``, borders free, so small disconnected parts collapse away); the certified
Hausdorff bound of :mod:`exporter.mesh.hausdorff`; the on-surface texel of :mod:`exporter.texel`.

Data form: meshes in the proxy tile's **glTF frame** (+X = West, +Y = Up, +Z = North, metres, at
the tile centre, height 0; :func:`.tree.tile_world`), positions (n, 3) float64, triangles (m, 3)
int64, uvs (n, 2) (origin top-left), ``owners`` (n,) int64: per vertex, the index of its building
in the proxy's ``buildings`` list (``"<tile>/<building id>"``), kept through merging and
simplification (the feature ids of ``EXT_mesh_features``).

- A **leaf** proxy (a tile holding buildings) merges each building's coarsest level (its
  geometric bound: that level's error against LOD0), textured from the coarsest level whose
  texture is at least as large as the building's atlas cell (so the cell is always box-filtered
  *down*; when no level's texture is that large, LOD0's, the finest there is): a building's
  levels carry one atlas scaled, with the same uv layout.
- A **parent** proxy merges its child tiles' proxies (their meshes, owners and atlases: each child
  atlas box-filtered into one cell) and simplifies the union towards ``proxy_error_ratio`` x the
  tile's north-south size (:func:`budget_m`); buildings too small for that budget collapse away.
  Its geometric bound adds up by the triangle inequality: the largest of its inputs' bounds
  against LOD0, plus the certified symmetric Hausdorff bound between the union of its inputs and
  the simplified mesh (which covers what was dropped: every point of a dropped building is
  measured against what is kept), plus the float32 rounding of the file. So a proxy costs about
  its own inputs (four proxies, each within its own budget), not the buildings below it.
- Its texel (metres per atlas texel on the surface) is :func:`exporter.texel.weighted_quantile`
  (area-weighted median) of the faces' texel edges in the atlas, each face's taken no finer than
  its source texture (a cell upsampled from a small texture has that texture's texels) and the
  whole no finer than the children's. Its error (``geometricError``) is the larger of the two.

A proxy with more than ``proxy_max_triangles`` is not written (nor are its ancestors').

Files: ``OUT/tileset_proxies/<tile>.glb`` and ``<tile>.json`` (its inputs' hash, bounds, sizes,
``buildings`` and ``owners``: per vertex, run-length ``[[building index, vertices], ...]``).
:func:`make_proxy` builds one from a :class:`ProxyTask` alone (files in, files out), so proxies of
one quadtree level run in parallel (:mod:`.schedule`).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from ..atomic import write_bytes_if_changed, write_text_atomic
from ..config import TilesetOptions
from ..gltf_writer import glb_bytes
from ..model import Part, Texture, TileId
from ..texel import face_texels, weighted_quantile
from ..tiles import tile_size_deg
from . import features, frames
from .cluster import cluster
from .glb import GlbPrimitive, read_primitives
from .tree import rounding_slack

PROXY_DIR = "tileset_proxies"
PROXY_FORMAT = "vworld-lod-proxy 6"  # 6: from the children's proxies; cells from a finer level
METRES_PER_DEGREE = math.pi / 180.0 * 6378137.0  # along a meridian, on the sphere
TRANSFORM_SLACK_M = 1e-6  # float64 rounding of the frame changes (ECEF-sized numbers), metres
# Grid cell of the vertex clustering, as a fraction of the budget: a vertex moves at most the
# cell's diagonal (0.87 x the budget), usually far less (a cell's mean lies near its vertices).
CELL_RATIO = 0.5
# A part that would vanish is kept when its distance to what is kept exceeds this x the budget.
KEEP_RATIO = 0.5


@dataclass(frozen=True)
class LevelSource:
    file: str  # relative to OUT, '/'-separated
    error: float  # metres: the level's certified geometric bound against LOD0 (0 for LOD0)
    texture_px: int  # larger side of its texture in pixels (0: untextured)


@dataclass
class BuildingSource:
    id: str  # "<tile>/<building id>": the feature's id in the proxies
    world: np.ndarray  # 4 x 4: the building's frame -> ECEF
    levels: list[LevelSource]  # coarsest first, the last LOD0
    key: str  # what identifies its content (its input hash and a digest of its values)
    values: dict = field(default_factory=dict)  # its metadata values (.metadata.chain_values)


@dataclass
class ChildSource:
    tile: str  # the child tile's name: its proxy is OUT/tileset_proxies/<tile>.glb/.json
    world: np.ndarray  # 4 x 4: the child tile's frame -> ECEF
    geometric: float  # metres: its certified bound against its buildings' LOD0
    texel: float  # metres per texel of its atlas
    key: str  # its proxy's hash


@dataclass
class ProxyTask:
    """Everything one proxy is made from (picklable: it goes to a pool or Dask worker)."""

    out_dir: str
    tile: TileId
    world: np.ndarray  # 4 x 4: the tile's frame -> ECEF
    options: TilesetOptions
    jpeg_quality: int
    buildings: list[BuildingSource] = field(default_factory=list)
    children: list[ChildSource] = field(default_factory=list)

    @property
    def key(self) -> str:
        """Hash of everything the proxy is made from (its inputs' keys and errors, options)."""
        text = json.dumps(
            [
                PROXY_FORMAT,
                self.tile.name,
                self.options.proxy_max_triangles,
                self.options.proxy_atlas_size,
                self.options.proxy_error_ratio,
                self.jpeg_quality,
                [
                    [b.id, b.key, [[lv.file, repr(lv.error), lv.texture_px] for lv in b.levels]]
                    for b in self.buildings
                ],
                [[c.tile, c.key, repr(c.geometric), repr(c.texel)] for c in self.children],
            ]
        )
        return hashlib.sha256(text.encode("utf-8")).hexdigest()


@dataclass
class Proxy:
    """What the tree needs of a built proxy (also its record file's main fields)."""

    hash: str
    geometric: float  # metres, certified against the LOD0 surfaces below
    texel: float  # metres per texel of its atlas on its surface
    low: list[float]  # glTF-frame bounds, metres
    high: list[float]
    triangles: int

    @property
    def error(self) -> float:
        return max(self.geometric, self.texel)


def atlas_cells(count: int, size: int) -> tuple[int, int]:
    """(cells per side, pixels per cell) of a square grid of ``count`` cells in ``size`` pixels."""
    side = max(1, math.ceil(math.sqrt(count)))
    return side, max(1, size // side)


def _cell_image(primitive: GlbPrimitive, cell: int) -> Image.Image | None:
    """The primitive's texture box-filtered to ``cell`` x ``cell`` RGB (its source size in
    ``info["source_size"]``), or None without a usable one (then its base colour is used)."""
    if primitive.image is None:
        return None
    try:
        with Image.open(io.BytesIO(primitive.image)) as image:
            size = image.size
            # A JPEG is decoded at the smallest DCT scale (1/2, 1/4, 1/8) not below the cell
            # (libjpeg's scaled IDCT): a 256 px texture for a 56 px cell decodes 64 px, not 256.
            image.draft("RGB", (cell, cell))
            # convert() copies even an RGB image (the files' JPEGs are): only other modes need it
            rgb = image if image.mode == "RGB" else image.convert("RGB")
            tile = rgb.resize((cell, cell), Image.Resampling.BOX)
    except (OSError, ValueError, Image.DecompressionBombError):
        return None
    tile.info["source_size"] = size
    return tile


def pack_atlas(
    primitives: list[GlbPrimitive], size: int
) -> tuple[Image.Image, list[np.ndarray], list[float]]:
    """One RGB atlas (``size`` x ``size``) with a cell per primitive (its image box-filtered, or
    its base colour), each primitive's uvs (n, 2) moved into its cell (clamped to it: the files'
    uvs are in [0, 1], a repeat would bleed into a neighbour), and each primitive's shrink factor
    (its image's larger side / the cell's; 0 without image)."""
    side, cell = atlas_cells(len(primitives), size)
    atlas = Image.new("RGB", (size, size), (255, 255, 255))
    uvs, shrink = [], []
    inset = 0.5 / cell  # half a texel: bilinear filtering stays inside the cell
    # Decoding and box-filtering are most of a proxy's time; Pillow releases the GIL in both, so
    # threads use the cores the finished building workers left idle (map keeps the order).
    with ThreadPoolExecutor(max_workers=max(1, min(len(primitives), os.cpu_count() or 1))) as pool:
        tiles = pool.map(_cell_image, primitives, [cell] * len(primitives))
    for index, (primitive, tile) in enumerate(zip(primitives, tiles)):
        row, col = divmod(index, side)
        if tile is not None and primitive.uvs is not None:
            shrink.append(max(tile.info["source_size"]) / cell)
            local = np.clip(primitive.uvs.astype(np.float64), 0.0, 1.0)
        else:
            colour = tuple(int(round(255 * min(max(c, 0.0), 1.0))) for c in primitive.color[:3])
            tile = Image.new("RGB", (cell, cell), colour)
            local = np.full((len(primitive.positions), 2), 0.5)
            shrink.append(0.0)
        atlas.paste(tile, (col * cell, row * cell))
        scaled = inset + local * (1.0 - 2.0 * inset)
        uvs.append(((scaled + [col, row]) * cell / size).astype(np.float32))
    return atlas, uvs, shrink


def budget_m(tile: TileId, options: TilesetOptions) -> float:
    """Metres: the simplification target of ``tile``'s proxy."""
    return options.proxy_error_ratio * tile_size_deg(tile.level) * METRES_PER_DEGREE


def finest_fitting(levels: list[LevelSource], cell: int) -> LevelSource:
    """The level whose texture fills a ``cell``-pixel atlas cell by box-filtering down: the
    coarsest with a texture of at least ``cell`` pixels (a finer one would filter down to the same
    cell at more cost), else the finest textured level (LOD0's texture is all there is); untextured
    buildings give their coarsest level (a colour cell)."""
    for level in levels:
        if level.texture_px >= cell:
            return level
    textured = [level for level in levels if level.texture_px > 0]
    return textured[-1] if textured else levels[0]


def with_texture(
    parts: list[GlbPrimitive], out: Path, level: LevelSource, coarsest: LevelSource
) -> None:
    """Give the coarsest level's ``parts`` the textures of ``level``: a building's levels carry
    the same atlas scaled (exporter/textures.py: one source texture, a quarter of the pixels per
    level, the same uv layout), so the coarsest geometry's uvs address any level's texture. Left
    as they are when ``level`` is the coarsest or its parts do not match one to one."""
    if level.file == coarsest.file:
        return
    finer = read_primitives(out / level.file)
    if len(finer) != len(parts):
        return
    for part, source in zip(parts, finer):
        if part.image is not None and source.image is not None:
            part.image, part.mime = source.image, source.mime


def owner_runs(owners: np.ndarray) -> list[list[int]]:
    """Run-length form ``[[owner, count], ...]`` of the (n,) per-vertex owners (vertex order)."""
    if len(owners) == 0:
        return []
    starts = np.flatnonzero(np.r_[True, owners[1:] != owners[:-1]])
    counts = np.diff(np.r_[starts, len(owners)])
    return [[int(owners[s]), int(c)] for s, c in zip(starts, counts)]


def owners_of(runs: list, vertices: int) -> np.ndarray:
    """(vertices,) int64 per-vertex owners from :func:`owner_runs`' form; ValueError when the runs
    do not cover exactly ``vertices``."""
    owners = np.repeat(np.array([int(o) for o, _ in runs], np.int64), [int(c) for _, c in runs])
    if len(owners) != vertices:
        raise ValueError(f"owners cover {len(owners)} vertices, the proxy has {vertices}")
    return owners


@dataclass
class Merged:
    """A proxy's inputs in its glTF frame, one mesh: see the module doc for the arrays."""

    positions: np.ndarray  # (n, 3) float64 metres
    faces: np.ndarray  # (m, 3) int64
    uvs: np.ndarray  # (n, 2) float32, in the atlas
    owners: np.ndarray  # (n,) int64 into ``buildings``
    fineness: np.ndarray  # (n,) float: source texels per atlas texel of its cell, at most 1
    buildings: list[str]
    atlas: Image.Image
    bound: float  # metres: the largest of the inputs' bounds against their LOD0
    texel_floor: float  # metres: the coarsest child's texel (0 for a leaf)
    values: list[dict] = field(default_factory=list)  # per building: its metadata values


def stored_values(record: dict) -> list[dict]:
    """A proxy record's ``values`` (per building, name -> (type, value)) as
    :func:`.metadata.building_values` makes them (JSON turned the pairs into lists)."""
    return [{k: (str(v[0]), v[1]) for k, v in item.items()} for item in record.get("values", [])]


def merge_inputs(task: ProxyTask) -> Merged:
    """Read the task's inputs (buildings' chosen levels, child proxies) into one mesh and atlas."""
    out = Path(task.out_dir)
    to_proxy = frames.inverse_rigid(frames.Y_UP) @ frames.inverse_rigid(task.world)
    size = task.options.proxy_atlas_size
    _, cell = atlas_cells(len(task.buildings) + len(task.children), size)
    primitives: list[GlbPrimitive] = []
    owners: list[np.ndarray] = []
    buildings: list[str] = []
    values: list[dict] = []
    bound = texel_floor = 0.0
    for building in task.buildings:
        coarsest = building.levels[0]
        matrix = to_proxy @ building.world @ frames.Y_UP
        parts = read_primitives(out / coarsest.file)
        with_texture(parts, out, finest_fitting(building.levels, cell), coarsest)
        for primitive in parts:
            primitive.positions = frames.apply(matrix, primitive.positions)
            primitives.append(primitive)
            owners.append(np.full(len(primitive.positions), len(buildings), np.int64))
        buildings.append(building.id)
        values.append(building.values)
        bound = max(bound, coarsest.error)
    for child in task.children:
        record = json.loads((out / PROXY_DIR / f"{child.tile}.json").read_text(encoding="utf-8"))
        if record.get("hash") != child.key:
            raise ValueError(f"{PROXY_DIR}/{child.tile}.json changed since it was read")
        matrix = to_proxy @ child.world @ frames.Y_UP
        for primitive in read_primitives(out / PROXY_DIR / f"{child.tile}.glb"):
            primitive.positions = frames.apply(matrix, primitive.positions)
            primitives.append(primitive)
            owners.append(owners_of(record["owners"], len(primitive.positions)) + len(buildings))
        buildings.extend(str(b) for b in record["buildings"])
        values.extend(stored_values(record))
        bound = max(bound, child.geometric)
        texel_floor = max(texel_floor, child.texel)
    atlas, uvs, shrink = pack_atlas(primitives, size)
    offsets = np.cumsum([0] + [len(p.positions) for p in primitives])
    return Merged(
        np.concatenate([p.positions for p in primitives]),
        np.concatenate([p.triangles + offsets[i] for i, p in enumerate(primitives)]),
        np.concatenate(uvs),
        np.concatenate(owners),
        np.concatenate(
            [
                np.full(len(p.positions), min(1.0, f) if f else 1.0)
                for p, f in zip(primitives, shrink)
            ]
        ),
        buildings,
        atlas,
        bound,
        texel_floor,
        values,
    )


def proxy_texel(
    positions: np.ndarray, faces: np.ndarray, uvs: np.ndarray, fineness: np.ndarray, size: int
) -> float:
    """Metres per texel on the surface: the area-weighted median over textured faces of the texel
    edge in the ``size``-pixel atlas, each face's divided by its cell's fineness (a cell upsampled
    from a smaller texture shows that texture's texels); 0 without textured faces."""
    face_fineness = fineness[faces[:, 0]] if len(faces) else fineness[:0]
    sizes, areas = [], []
    for value in np.unique(face_fineness):  # one call per distinct fineness (about one per cell)
        group = faces[face_fineness == value]
        texels, area = face_texels(positions, group, uvs, (size * value, size * value))
        sizes.append(texels)
        areas.append(area)
    if not sizes or not sum(len(a) for a in areas):
        return 0.0
    return float(weighted_quantile(np.concatenate(sizes), np.concatenate(areas)))


def proxy_glb(part: Part, owners: np.ndarray, values: list[dict], name: str) -> bytes:
    """The proxy's ``.glb`` bytes: one mesh, one material. ``owners`` (n,) uint: per vertex of
    ``part``, its building's index in the proxy's buildings, whose metadata ``values`` are
    (:func:`.metadata.building_values`): the buildings told apart by ``EXT_mesh_features``
    feature ids and an ``EXT_structural_metadata`` property table (:mod:`.features`). Without
    values (every building's missing) the ids are left out."""
    data = glb_bytes([part], name)
    if not values or not all(values):
        return data
    return features.with_features(data, owners, values)


def build_proxy(task: ProxyTask) -> tuple[Proxy, bytes, dict] | None:
    """The proxy of ``task``: (its summary, its ``.glb`` bytes, its record), or None when it has
    more than ``proxy_max_triangles`` triangles."""
    merged = merge_inputs(task)
    positions, faces, uvs, owners_all = merged.positions, merged.faces, merged.uvs, merged.owners
    used, step = np.arange(len(positions)), 0.0
    budget = budget_m(task.tile, task.options)
    cell, target = budget * CELL_RATIO, task.options.proxy_max_triangles // 2
    limit = tile_size_deg(task.tile.level) * METRES_PER_DEGREE
    while cell > 0:
        # Coarser cells until the proxy holds at most half the cap: a parent's inputs (four
        # children within that) then cost about its own budget, whatever lies below.
        done = cluster(positions, faces, uvs, owners_all, cell, max(budget * KEEP_RATIO, cell))
        if len(done.faces) <= target or cell > limit:
            positions, faces, uvs, owners_all = done.positions, done.faces, done.uvs, done.owners
            used, step = done.source, done.bound
            break
        cell *= 2.0
    if len(faces) > task.options.proxy_max_triangles:
        return None
    present, owners = np.unique(owners_all, return_inverse=True)  # buildings left, in order
    buildings = [merged.buildings[i] for i in present]
    values = (
        [merged.values[i] for i in present] if len(merged.values) == len(merged.buildings) else []
    )
    stored = positions.astype(np.float32)
    low, high = stored.min(axis=0).astype(np.float64), stored.max(axis=0).astype(np.float64)
    geometric = merged.bound + step + rounding_slack(low, high) + TRANSFORM_SLACK_M
    size = task.options.proxy_atlas_size
    measured = proxy_texel(stored.astype(np.float64), faces, uvs, merged.fineness[used], size)
    texel = max(measured, merged.texel_floor)
    buffer = io.BytesIO()
    merged.atlas.save(buffer, "JPEG", quality=task.jpeg_quality)
    name = task.tile.name
    texture = Texture(buffer.getvalue(), "image/jpeg", size, size, f"{name}_atlas")
    # glTF frame -> local East/Up/North with outward winding (what the writer takes)
    local = stored.astype(np.float64) * [-1.0, 1.0, 1.0]
    part = Part(local, faces[:, [0, 2, 1]], uvs=uvs, texture=texture)
    data = proxy_glb(part, owners.astype(np.uint32), values, f"{name}_proxy")
    proxy = Proxy(
        task.key, geometric, texel, [float(v) for v in low], [float(v) for v in high], len(faces)
    )
    record = {
        "hash": proxy.hash,
        "size": len(data),
        "geometric": proxy.geometric,
        "texel": proxy.texel,
        "low": proxy.low,
        "high": proxy.high,
        "triangles": proxy.triangles,
        "buildings": buildings,
        "owners": owner_runs(owners),
        "values": values,  # a parent's property table rows come from here
    }
    return proxy, data, record


def proxy_of(record: dict) -> Proxy:
    return Proxy(
        record["hash"],
        float(record["geometric"]),
        float(record["texel"]),
        [float(v) for v in record["low"]],
        [float(v) for v in record["high"]],
        int(record["triangles"]),
    )


def cached(folder: Path, name: str, key: str) -> tuple[bool, Proxy | None]:
    """(found, proxy): the recorded proxy of tile ``name`` when it was built from ``key`` (None
    when it was too large) and its file still has the size recorded; found is False when it must
    be built."""
    try:
        data = json.loads((folder / f"{name}.json").read_text(encoding="utf-8"))
        if data.get("hash") != key:
            return False, None
        if data.get("too_large"):
            return True, None
        if (folder / f"{name}.glb").stat().st_size != data["size"]:
            return False, None
        return True, proxy_of(data)
    except (OSError, ValueError, KeyError, TypeError):
        return False, None


def make_proxy(task: ProxyTask) -> dict:
    """Run anywhere that sees ``OUT`` (this process, a pool or a Dask worker): build the task's
    proxy and write its files (``.glb`` then its record, atomically; a file whose bytes come out
    the same is left as it was). Returns its record, ``{"hash", "too_large": True}``, or
    ``{"problem": text}`` when an input could not be read."""
    folder = Path(task.out_dir) / PROXY_DIR
    name, key = task.tile.name, task.key
    try:
        built = build_proxy(task)
    except (OSError, ValueError, KeyError, IndexError, TypeError) as problem:
        # An input changed or broke since it was read: no proxy here (nor above), said so.
        return {"problem": f"{PROXY_DIR}/{name}.glb: not built ({problem!r}); tile shown without"}
    if built is None:
        write_text_atomic(folder / f"{name}.json", json.dumps({"hash": key, "too_large": True}))
        (folder / f"{name}.glb").unlink(missing_ok=True)
        return {"hash": key, "too_large": True}
    _, data, record = built
    write_bytes_if_changed(folder / f"{name}.glb", data)
    write_text_atomic(folder / f"{name}.json", json.dumps(record))  # last: the glb is complete
    return record


def remove_stale(folder: Path, kept: set[str]) -> None:
    """Delete proxy files of tiles that no longer have one (``kept``: file names to keep)."""
    if not folder.is_dir():
        return
    for path in folder.iterdir():
        if path.is_file() and path.name not in kept:
            path.unlink(missing_ok=True)
