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
- Its **atlas size** (:func:`choose_atlas`, after clustering, before any texture is decoded): the
  smallest power of two from :data:`ATLAS_FLOOR_PX` at which that texel is at most the error
  the tile is shown at (its geometric bound, or its children's largest ``geometricError`` when
  larger: ``ProxyTask.shown_floor``) / :data:`PROXY_TEXEL_FACTOR` (4 px a texel when the proxy
  switches at 16 px; or at most the children's texel, the floor), no larger than its cells'
  finest images need (larger only upsamples), at most ``proxy_atlas_size``.

**Triangles** (:func:`triangle_target`, :func:`coarsened`). Clustering starts on the budget's
cell (:data:`CELL_RATIO` x :func:`budget_m`); coarser cells are tried while the result holds more
than the proxy's target: for a leaf half of ``proxy_max_triangles``; for a parent its largest
child proxy's triangles (each proxy then costs about one child, whatever lies below it: Erikson
et al.), at least ``proxy_max_triangles`` x :data:`PARENT_FLOOR_FRACTION` (9,375 triangles at the
default: a mesh of ~0.2 MB, less than its atlas weighs in a client, so a coarser shape would cost
accuracy and save nothing) and at most half the cap. A parent is coarsened past its budget's cell
only while its faces fall at least as fast as cell^-2 (:data:`DENSITY_SLOPE`; measured from its
children's clustering, on half its cell, to its own first pass, then between passes): its
certified error grows about as the cell, and a client shows it from that much farther away, so
where faces fall slower (buildings already at a box each: the generated cities) a coarser parent
would raise the triangles a viewer sees per screen area and keep the children drawn longer; it
keeps its budget's clustering (or, once within half the cap, the last pass before the slowdown).
Half the cap stays hard. The cells lie on a lattice (2^(1/8) apart, :data:`CELL_STEPS`), each
pass's predicted from the faces measured so far (:func:`next_step`: the cell that meets the
target if faces fall as the slope measured, one step more), so the search is deterministic and
takes fewer passes than doubling the cell did, and stops on a cell of 2^(k/8) rather than 2^k
times the first (a finer cell, a smaller error, where the prediction holds). A pass whose
triangles exceed half the cap before any is restored (:func:`.cluster.clustered_faces`) is only
counted, not clustered: its reach, most of a pass, could not make it acceptable. A proxy with
more than ``proxy_max_triangles`` even on cells larger than its tile is not written (nor are its
ancestors').

Files: ``OUT/tileset_proxies/<tile>.glb`` and ``<tile>.json`` (its inputs' hash, bounds, sizes,
``atlas_px``, ``buildings`` and ``owners``: per vertex, run-length ``[[building index, vertices], ...]``).
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
from ..json_members import top_level_values
from ..model import Part, Texture, TileId
from ..texel import face_texels, kept_face_texels, weighted_quantile
from ..tiles import tile_size_deg
from . import features, frames
from .cluster import Clustered, cell_spots, cluster, clustered_faces
from .glb import GlbPrimitive, read_primitives
from .tree import rounding_slack

PROXY_DIR = "tileset_proxies"
# 11: passes over half the cap counted, not clustered; 10: parents held to a child
PROXY_FORMAT = "vworld-lod-proxy 11"
# Proxy atlas sides, pixels: the smallest chosen, and the fewest pixels a cell side gets at a
# size below ``proxy_atlas_size`` (smaller cells would blur texture into colour).
ATLAS_FLOOR_PX = 64
# A proxy's texels at most this fraction of the error it is shown at: 4 px when it switches at
# 16 px, as the building levels' (exporter.texel.TEXEL_ERROR_FACTOR). Its shape may then be off
# by 16 px (four texels): a finer texture would draw a truer picture on a surface that is not
# there, for 4x the texture memory of the next size down.
PROXY_TEXEL_FACTOR = 4.0
MIN_CELL_PX = 4
# Cell-grid uvs (:func:`atlas_uvs`): (column, row) of the cell + the uv in it, at most LOCAL_MAX
# (below 1: clustering's uv bins, whole fractions of a cell, never span two cells).
LOCAL_MAX = 1.0 - 2.0**-30
UNBOUNDED_PX = 1 << 62  # a cell larger than any texture: :func:`finest_fitting` gives the finest
METRES_PER_DEGREE = math.pi / 180.0 * 6378137.0  # along a meridian, on the sphere
TRANSFORM_SLACK_M = 1e-6  # float64 rounding of the frame changes (ECEF-sized numbers), metres
# Grid cell of the vertex clustering, as a fraction of the budget: a vertex moves at most the
# cell's diagonal (0.87 x the budget), usually far less (a cell's mean lies near its vertices).
CELL_RATIO = 0.5
# A part that would vanish is kept when its distance to what is kept exceeds this x the budget.
KEEP_RATIO = 0.5
# A parent is clustered down to its largest child's triangles, never below this x
# ``proxy_max_triangles`` (9,375 at the default): below it a proxy's mesh weighs far less than its
# atlas (see the module doc), so coarser cells would cost accuracy and save nothing.
PARENT_FLOOR_FRACTION = 1.0 / 32.0
# Coarser cells (:func:`coarsened`) lie on a lattice: CELL_STEPS per doubling (2^(1/8): 9 %).
CELL_STEPS = 8
# A pass grows the cell by 2^(2/8) (1.19x) to 2^(16/8) (4x): progress, and no leap far past.
STEP_RANGE = (2, 16)
# Faces fall about as cell^-2 on surfaces (the slope assumed after one pass; then measured, within
# SLOPE_RANGE); one step more than predicted (the slope flattens as kept parts dominate).
SURFACE_SLOPE = 2.0
SLOPE_RANGE = (0.5, 4.0)
SAFETY_STEPS = 1
# A parent is coarsened past its budget's cell only while its faces fall at least as fast as
# cell^-2: its error grows about as the cell, and it is shown from that much farther away, so
# its triangles per screen area (faces x error^2) must not grow (see the module doc).
DENSITY_SLOPE = 2.0


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
    # Metres: the largest geometricError of the tile's children in the tileset (building chains'
    # coarsest levels, child proxies). The tile's own error is at least that, so a client shows
    # the proxy only where that error is within its screen-space error: its atlas need not be
    # finer than what shows there.
    shown_floor: float = 0.0

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
                repr(self.shown_floor),
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
    atlas_px: int = 0  # pixels per side of its atlas (0: a record written before 0.6.0)

    @property
    def error(self) -> float:
        return max(self.geometric, self.texel)


def atlas_cells(count: int, size: int) -> tuple[int, int]:
    """(cells per side, pixels per cell) of a square grid of ``count`` cells in ``size`` pixels."""
    side = max(1, math.ceil(math.sqrt(count)))
    return side, max(1, size // side)


def atlas_sizes(count: int, largest: int) -> list[int]:
    """Candidate atlas sides in pixels for ``count`` cells, ascending: the powers of two from
    :data:`ATLAS_FLOOR_PX` below ``largest`` whose cells get at least :data:`MIN_CELL_PX` a side,
    then ``largest`` (``proxy_atlas_size``, the maximum; always a candidate)."""
    side, _ = atlas_cells(count, largest)
    sizes, size = [], ATLAS_FLOOR_PX
    while size < largest:
        if size // side >= MIN_CELL_PX:
            sizes.append(size)
        size *= 2
    return sizes + [largest]


def cell_local(grid: np.ndarray, cells: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """(uvs in their cell (n, 2), (column, row) of the cell (n, 2)) of cell-grid uvs ``grid``
    (n, 2) whose cells are ``cells`` (n,), ``count`` cells (:func:`atlas_uvs`)."""
    side, _ = atlas_cells(count, 1)
    corner = np.column_stack([cells % side, cells // side]).astype(np.float64)
    return np.asarray(grid, np.float64) - corner, corner


def atlas_uvs(
    grid: np.ndarray, cells: np.ndarray, plain: np.ndarray, count: int, size: int
) -> np.ndarray:
    """(n, 2) float32 uvs in a ``size``-pixel atlas of ``count`` cells (:func:`atlas_cells`,
    row-major) from the size-free cell-grid form ``grid`` (n, 2) ((column, row) of the vertex's
    cell + its uv in the cell, in [0, 1]); ``cells`` (n,) each vertex's cell;
    ``plain`` (count,) bool: cells filled with one colour (their vertices take the cell's
    centre). A cell's uvs are inset half a texel (bilinear filtering stays inside the cell)."""
    _, cell = atlas_cells(count, size)
    local, corner = cell_local(grid, cells, count)
    local[plain[cells]] = 0.5
    inset = 0.5 / cell
    scaled = inset + local * (1.0 - 2.0 * inset)
    return ((scaled + corner) * cell / size).astype(np.float32)


def _image_px(data: bytes | None) -> int:
    """Larger side in pixels of an encoded image (its header only), 0 when it cannot be read."""
    if data is None:
        return 0
    try:
        with Image.open(io.BytesIO(data)) as image:
            return max(image.size)
    except (OSError, ValueError, Image.DecompressionBombError):
        return 0


class CellTextures:
    """Per atlas cell (one per input primitive, in order) the encoded image that fills it at a
    given cell size, without decoding: a building's part takes the texture of
    :func:`finest_fitting` level (``.glb`` files read once, on first need), a child proxy's its
    atlas. The images' pixel sizes come from their headers."""

    def __init__(self, out: Path) -> None:
        self.out = out
        # per cell: (its primitive, its building's levels or None, its part index)
        self.entries: list[tuple[GlbPrimitive, list[LevelSource] | None, int]] = []
        self._files: dict[str, list[GlbPrimitive]] = {}
        self._px: dict[int, int] = {}  # id of an image's bytes -> its larger side

    def add(self, primitive: GlbPrimitive, levels: list[LevelSource] | None, part: int) -> None:
        self.entries.append((primitive, levels, part))

    def parts(self, file: str) -> list[GlbPrimitive]:
        """The primitives of ``file`` (relative to OUT), read once."""
        if file not in self._files:
            self._files[file] = read_primitives(self.out / file)
        return self._files[file]

    def images(self, cell: int) -> list[bytes | None]:
        """Per cell, the image that fills it at ``cell`` pixels a side (None: its colour). A
        building's levels carry one atlas scaled with the same uv layout (exporter/textures.py),
        so its coarsest geometry's uvs address any level's texture; its own texture is kept when
        the finer level's parts do not match one to one."""
        found: list[bytes | None] = []
        for primitive, levels, part in self.entries:
            image = primitive.image
            if levels is not None and primitive.uvs is not None and image is not None:
                level = finest_fitting(levels, cell)
                if level.file != levels[0].file:
                    finer = self.parts(level.file)
                    if len(finer) == len(self.parts(levels[0].file)):
                        image = finer[part].image or image
            found.append(image if primitive.uvs is not None else None)
        return found

    def finest(self) -> np.ndarray:
        """(cells,) larger side in pixels of the finest image each cell could hold."""
        return self.pixels(self.images(UNBOUNDED_PX))

    def pixels(self, images: list[bytes | None]) -> np.ndarray:
        """(cells,) larger side in pixels of each image (0 without one)."""
        for image in images:
            if image is not None and id(image) not in self._px:
                self._px[id(image)] = _image_px(image)
        return np.array([self._px[id(i)] if i is not None else 0 for i in images], np.int64)


def fineness_of(pixels: np.ndarray, cell: int) -> np.ndarray:
    """(cells,) source texels per atlas texel of each cell, at most 1 (a cell upsampled from a
    smaller image shows that image's texels); 1 for a colour cell (``pixels`` 0)."""
    return np.where(pixels > 0, np.minimum(1.0, pixels / cell), 1.0)


def _cell_image(image: bytes | None, cell: int) -> Image.Image | None:
    """The encoded ``image`` box-filtered to ``cell`` x ``cell`` RGB, or None without a usable
    one (then its base colour is used)."""
    if image is None:
        return None
    try:
        with Image.open(io.BytesIO(image)) as opened:
            # A JPEG is decoded at the smallest DCT scale (1/2, 1/4, 1/8) not below the cell
            # (libjpeg's scaled IDCT): a 256 px texture for a 56 px cell decodes 64 px, not 256.
            opened.draft("RGB", (cell, cell))
            # convert() copies even an RGB image (the files' JPEGs are): only other modes need it
            rgb = opened if opened.mode == "RGB" else opened.convert("RGB")
            return rgb.resize((cell, cell), Image.Resampling.BOX)
    except (OSError, ValueError, Image.DecompressionBombError):
        return None


def pack_atlas(
    images: list[bytes | None], colors: list[tuple], size: int
) -> tuple[Image.Image, np.ndarray]:
    """One RGB atlas (``size`` x ``size``) with a cell per image (:func:`atlas_cells`, row-major),
    each image box-filtered into its cell, or the cell filled with its base colour (r, g, b in
    [0, 1]) without a usable image; returns it and (cells,) bool: the cells filled with a colour."""
    side, cell = atlas_cells(len(images), size)
    atlas = Image.new("RGB", (size, size), (255, 255, 255))
    # Decoding and box-filtering are most of a proxy's time; Pillow releases the GIL in both, so
    # threads use the cores the finished building workers left idle (map keeps the order).
    with ThreadPoolExecutor(max_workers=max(1, min(len(images), os.cpu_count() or 1))) as pool:
        tiles = list(pool.map(_cell_image, images, [cell] * len(images)))
    plain = np.array([tile is None for tile in tiles], bool)
    for index, (tile, color) in enumerate(zip(tiles, colors)):
        row, col = divmod(index, side)
        if tile is None:
            rgb = tuple(int(round(255 * min(max(c, 0.0), 1.0))) for c in color[:3])
            tile = Image.new("RGB", (cell, cell), rgb)
        atlas.paste(tile, (col * cell, row * cell))
    return atlas, plain


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
    grid: np.ndarray  # (n, 2) float64: uvs in the size-free cell-grid form of :func:`atlas_uvs`
    cells: np.ndarray  # (n,) int64: each vertex's atlas cell (its input primitive)
    owners: np.ndarray  # (n,) int64 into ``buildings``
    textures: CellTextures  # per cell, its image at a cell size (not decoded yet)
    buildings: list[str]
    bound: float  # metres: the largest of the inputs' bounds against their LOD0
    texel_floor: float  # metres: the coarsest child's texel (0 for a leaf)
    values: list[dict] = field(default_factory=list)  # per building: its metadata values
    largest_child: int = 0  # triangles of its largest child proxy (0: a leaf)

    @property
    def count(self) -> int:
        """Atlas cells (input primitives)."""
        return len(self.textures.entries)


def stored_values(record: dict) -> list[dict]:
    """A proxy record's ``values`` (per building, name -> (type, value)) as
    :func:`.metadata.building_values` makes them (JSON turned the pairs into lists)."""
    return [{k: (str(v[0]), v[1]) for k, v in item.items()} for item in record.get("values", [])]


def merge_inputs(task: ProxyTask) -> Merged:
    """Read the task's inputs (buildings' coarsest levels, child proxies) into one mesh; their
    textures are only named (:class:`CellTextures`), decoded once the atlas size is chosen."""
    out = Path(task.out_dir)
    to_proxy = frames.inverse_rigid(frames.Y_UP) @ frames.inverse_rigid(task.world)
    textures = CellTextures(out)
    owners: list[np.ndarray] = []
    buildings: list[str] = []
    values: list[dict] = []
    bound = texel_floor = 0.0
    largest_child = 0
    for building in task.buildings:
        coarsest = building.levels[0]
        matrix = to_proxy @ building.world @ frames.Y_UP
        for part, primitive in enumerate(textures.parts(coarsest.file)):
            primitive.positions = frames.apply(matrix, primitive.positions)
            textures.add(primitive, building.levels, part)
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
            textures.add(primitive, None, 0)
            owners.append(owners_of(record["owners"], len(primitive.positions)) + len(buildings))
        buildings.extend(str(b) for b in record["buildings"])
        values.extend(stored_values(record))
        bound = max(bound, child.geometric)
        texel_floor = max(texel_floor, child.texel)
        largest_child = max(largest_child, int(record["triangles"]))
    primitives = [primitive for primitive, _, _ in textures.entries]
    side, _ = atlas_cells(len(primitives), 1)
    grid = []
    for index, primitive in enumerate(primitives):
        row, col = divmod(index, side)
        if primitive.uvs is None:  # a colour cell: its centre
            local = np.full((len(primitive.positions), 2), 0.5)
        else:  # the files' uvs are in [0, 1]; a repeat would bleed into a neighbour
            local = np.clip(primitive.uvs.astype(np.float64), 0.0, LOCAL_MAX)
        grid.append(local + np.array([col, row], np.float64))
    offsets = np.cumsum([0] + [len(p.positions) for p in primitives])
    return Merged(
        np.concatenate([p.positions for p in primitives]),
        np.concatenate([p.triangles + offsets[i] for i, p in enumerate(primitives)]),
        np.concatenate(grid),
        np.repeat(np.arange(len(primitives)), [len(p.positions) for p in primitives]),
        np.concatenate(owners),
        textures,
        buildings,
        bound,
        texel_floor,
        values,
        largest_child,
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


class CellTexels:
    """The clustered mesh's faces as :func:`proxy_texel` measures them, at any atlas size: per
    face its surface area (m^2) and its metres per unit of its cell's own uvs (a cell spans 0..1),
    so at ``p`` atlas pixels per cell unit its texel is that / ``p``. Built once (``positions``
    (n, 3) metres, ``faces`` (m, 3), ``grid`` uvs and ``cells`` (n,) as :class:`Merged` has them,
    ``count`` cells); each size then costs a division and at most one weighted median."""

    def __init__(
        self,
        positions: np.ndarray,
        faces: np.ndarray,
        grid: np.ndarray,
        cells: np.ndarray,
        count: int,
    ) -> None:
        local, _ = cell_local(grid, cells, count)
        self.metres, self.area, kept = kept_face_texels(positions, faces, local, (1, 1))
        self.cell = cells[faces[kept, 0]] if len(faces) else cells[:0]
        self._median: float | None = None  # of self.metres: what one scale for all divides

    def at(self, per_unit: np.ndarray, plain: np.ndarray) -> float:
        """Metres: the area-weighted median texel with ``per_unit`` (cells,) atlas pixels per cell
        unit (the cell's side less its half-texel insets, times its fineness); faces of ``plain``
        (cells,) colour cells left out; 0 without textured faces."""
        used = ~plain[self.cell]
        if not used.any():
            return 0.0
        scale = per_unit[self.cell[used]]
        if used.all() and (scale == scale[0]).all():  # most sizes: the order does not change
            if self._median is None:
                self._median = weighted_quantile(self.metres, self.area)
            return self._median / scale[0]
        return weighted_quantile(self.metres[used] / scale, self.area[used])


def choose_atlas(merged: Merged, texels: CellTexels, target: float, largest: int) -> int:
    """Pixels per side of the proxy's atlas: the smallest of :func:`atlas_sizes` at which its
    texel (:class:`CellTexels`, as :func:`proxy_texel` measures it on the clustered mesh) is at
    most ``target`` metres, else ``largest``; and not beyond the first size whose cells are at
    least as large as every image they hold (a larger atlas would only upsample: the same
    texels, more memory). Only image headers are read (a cell is predicted textured when its
    image's header reads; one that then fails to decode is measured as a colour cell in the
    end, when the texel is measured again on the atlas written)."""
    count = merged.count
    for size in atlas_sizes(count, largest):
        _, cell = atlas_cells(count, size)
        pixels = merged.textures.pixels(merged.textures.images(cell))
        # a cell's uvs span its side less half a texel at each end: cell - 1 pixels
        if cell > 1 and texels.at((cell - 1) * fineness_of(pixels, cell), pixels == 0) <= target:
            return size
        # Larger cells would only upsample every image (first seen at the images of this size,
        # then against the finest each cell has: a building's LOD0 texture, a child's atlas).
        if cell >= pixels.max(initial=0) and cell >= merged.textures.finest().max(initial=0):
            return size
    return largest


def triangle_target(options: TilesetOptions, largest_child: int, parent: bool) -> int:
    """Triangles a proxy is clustered down to: half of ``proxy_max_triangles`` for a leaf; for a
    parent, its largest child's triangles (``largest_child``), at least
    ``proxy_max_triangles`` x :data:`PARENT_FLOOR_FRACTION` and at most the leaves' target (see
    the module doc: each proxy then costs about one child, whatever lies below it)."""
    cap = options.proxy_max_triangles // 2
    if not parent:
        return cap
    floor = int(options.proxy_max_triangles * PARENT_FLOOR_FRACTION)
    return min(cap, max(largest_child, floor))


def fall_slope(before: tuple[int, int], after: tuple[int, int]) -> float:
    """How fast faces fell between two clusterings, (step, faces) each on the lattice of
    :func:`coarsened`: the exponent s of faces ~ cell^-s (0 when they did not fall)."""
    (step_a, faces_a), (step_b, faces_b) = before, after
    if faces_b <= 0 or faces_a <= faces_b or step_b <= step_a:
        return 0.0
    return math.log2(faces_a / faces_b) * CELL_STEPS / (step_b - step_a)


def next_step(measured: list[tuple[int, int]], target: int) -> int:
    """The next clustering pass's cell, in steps of :data:`CELL_STEPS` per doubling, from
    ``measured``: (step, faces) of the clusterings so far (a parent's first is its input: its
    children's clustering, at step -:data:`CELL_STEPS`), the last with more than ``target``
    faces. Faces fall about as cell^-slope (2 on surfaces: assumed after one measure; then the
    slope between the last two, within :data:`SLOPE_RANGE`), so the cell that meets the target is
    the last x (faces / target)^(1 / slope); :data:`SAFETY_STEPS` more, and the growth kept within
    :data:`STEP_RANGE` (progress, and no leap far past the target's cell)."""
    step, faces = measured[-1]
    slope = SURFACE_SLOPE
    if len(measured) > 1:
        slope = fall_slope(measured[-2], measured[-1])
        slope = min(max(slope, SLOPE_RANGE[0]), SLOPE_RANGE[1])
    wanted = CELL_STEPS * math.log2(faces / target) / slope if target > 0 else math.inf
    grow = math.ceil(wanted) + SAFETY_STEPS if math.isfinite(wanted) else STEP_RANGE[1]
    return step + min(max(grow, STEP_RANGE[0]), STEP_RANGE[1])


def coarsened(
    merged: Merged, tile: TileId, budget: float, cap: int, target: int, parent: bool
) -> Clustered | None:
    """The clustering of ``merged`` (in ``tile``'s proxy frame, metres) on cells of the lattice
    ``budget`` x :data:`CELL_RATIO` x 2^(k / :data:`CELL_STEPS`), k >= 0, tried in the order of
    :func:`next_step`; None when ``budget`` is 0 (merged only). It is the first tried that holds
    at most ``target`` faces, or the first larger than the tile (its north-south size), except
    for a ``parent`` (whose input is its children's clustering on half its first cell): once at
    most ``cap`` faces, a pass whose faces fell slower than :data:`DENSITY_SLOPE` since the
    clustering before it ends the search with that one (the first pass: itself), since a coarser
    cell would raise the triangles a viewer sees per screen area (see the module doc)."""
    first = budget * CELL_RATIO
    if first <= 0:
        return None
    limit = tile_size_deg(tile.level) * METRES_PER_DEGREE
    # uv bins: about 1/1024 of the atlas, a whole number a cell (never across two cells)
    side, _ = atlas_cells(merged.count, 1)
    bins = max(1, 1024 // side)
    measured = [(-CELL_STEPS, len(merged.faces))] if parent else []
    step, before = 0, None
    while True:
        cell = first * 2.0 ** (step / CELL_STEPS)  # the lattice: the same cells on any machine
        spot = cell_spots(merged.positions, merged.owners, cell)
        if cell <= limit:
            # A pass that keeps more than the cap before any triangle is restored is passed over
            # unmeasured (its reach is most of a pass): the next cell is predicted from that count.
            kept = clustered_faces(spot, merged.faces)
            if kept > cap:
                measured.append((step, kept))
                before, step = None, next_step(measured, cap)
                continue
        done = cluster(
            merged.positions,
            merged.faces,
            merged.grid,
            merged.owners,
            cell,
            max(budget * KEEP_RATIO, cell),
            bins,
            spot,
        )
        faces = len(done.faces)
        if faces <= target or cell > limit:
            return done
        if parent and faces <= cap and fall_slope(measured[-1], (step, faces)) < DENSITY_SLOPE:
            return before if before is not None and measured[-1][1] <= cap else done
        measured.append((step, faces))
        before, step = done, next_step(measured, target if faces <= cap else cap)


def build_proxy(task: ProxyTask) -> tuple[Proxy, bytes, dict] | None:
    """The proxy of ``task``: (its summary, its ``.glb`` bytes, its record), or None when it has
    more than ``proxy_max_triangles`` triangles."""
    merged = merge_inputs(task)
    positions, faces, grid, owners_all = merged.positions, merged.faces, merged.grid, merged.owners
    used, step = np.arange(len(positions)), 0.0
    budget = budget_m(task.tile, task.options)
    cap = task.options.proxy_max_triangles // 2
    target = triangle_target(task.options, merged.largest_child, bool(task.children))
    done = coarsened(merged, task.tile, budget, cap, target, bool(task.children))
    if done is not None:
        positions, faces, grid, owners_all = done.positions, done.faces, done.uvs, done.owners
        used, step = done.source, done.bound
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
    # The atlas a viewer can tell apart: texels at most 1/PROXY_TEXEL_FACTOR of the error the
    # tile is shown at (its geometric bound, or its children's errors when larger: the tileset's
    # geometricError of the tile is the larger), and no finer than the children's texels (the
    # parent's texel is floored there: finer would show nothing more).
    cells, surface = merged.cells[used], stored.astype(np.float64)
    shown = max(geometric, task.shown_floor)
    wanted = max(shown / PROXY_TEXEL_FACTOR, merged.texel_floor)
    largest = task.options.proxy_atlas_size
    texels = CellTexels(surface, faces, grid, cells, merged.count)
    size = choose_atlas(merged, texels, wanted, largest)
    _, pixels = atlas_cells(merged.count, size)
    images = merged.textures.images(pixels)
    colors = [primitive.color for primitive, _, _ in merged.textures.entries]
    atlas, plain = pack_atlas(images, colors, size)
    uvs = atlas_uvs(grid, cells, plain, merged.count, size)
    fineness = fineness_of(np.where(plain, 0, merged.textures.pixels(images)), pixels)
    measured = proxy_texel(surface, faces, uvs, fineness[cells], size)
    texel = max(measured, merged.texel_floor)
    buffer = io.BytesIO()
    atlas.save(buffer, "JPEG", quality=task.jpeg_quality)
    name = task.tile.name
    texture = Texture(buffer.getvalue(), "image/jpeg", size, size, f"{name}_atlas")
    # glTF frame -> local East/Up/North with outward winding (what the writer takes)
    local = stored.astype(np.float64) * [-1.0, 1.0, 1.0]
    part = Part(local, faces[:, [0, 2, 1]], uvs=uvs, texture=texture)
    data = proxy_glb(part, owners.astype(np.uint32), values, f"{name}_proxy")
    bounds = [float(v) for v in low], [float(v) for v in high]
    proxy = Proxy(task.key, geometric, texel, *bounds, len(faces), size)
    record = {
        "hash": proxy.hash,
        "size": len(data),
        "geometric": proxy.geometric,
        "texel": proxy.texel,
        "atlas_px": proxy.atlas_px,
        "low": proxy.low,
        "high": proxy.high,
        "triangles": proxy.triangles,
        "shown_floor": task.shown_floor,  # metres: what the atlas was sized against, with geometric
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
        int(record.get("atlas_px", 0)),
    )


# The fields of a proxy record that :func:`cached` reads (written first, :func:`build_proxy`).
RECORD_HEAD = frozenset(
    ["hash", "size", "geometric", "texel", "atlas_px", "low", "high", "triangles"]
)


def cached(folder: Path, name: str, key: str) -> tuple[bool, Proxy | None]:
    """(found, proxy): the recorded proxy of tile ``name`` when it was built from ``key`` (None
    when it was too large) and its file still has the size recorded; found is False when it must
    be built."""
    try:
        # A record's summary fields come before its per-building lists (megabytes at the top)
        text = (folder / f"{name}.json").read_text(encoding="utf-8")
        data = {k: v for k, (v, _) in top_level_values(text, RECORD_HEAD).items()}
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
