"""HLOD proxies: per quadtree tile, the content below it merged into one mesh with one atlas,
with a certified error against the LOD0 surfaces of the buildings it stands for.

Data form: meshes in the proxy tile's **glTF frame** (+X = West, +Y = Up, +Z = North, metres, at
the tile centre, height 0; :func:`.tree.tile_world`), positions (n, 3) float64, triangles (m, 3)
int64, uvs (n, 2) (origin top-left).

A tile holding buildings merges their coarsest chain levels as they are; a tile above merges its
child tiles' proxies, each building's piece of them collapsed by meshoptimizer towards
``proxy_error_ratio`` x the tile's north-south size (so a tile without a proxy has no proxied
ancestor). Each input's texture (or base colour) gets a cell of one atlas (``proxy_atlas_size``
pixels, box-filtered down; a JPEG decoded at the smallest libjpeg scale not below the cell): one
mesh, one material, one draw call. A proxy with more than ``proxy_max_triangles`` is not written
(nor are its ancestors').

Its error (metres) is the larger of
- the geometric bound, kept per building piece: a building's coarsest level starts with its
  certified bound against LOD0; a collapse adds the certified upper bound of
  :func:`exporter.hausdorff.bounds_within` between the piece and the collapse, which is kept only
  when that is within the budget (triangle inequality), every written file adds its float32 rounding; the proxy's is the largest piece's
  (the Hausdorff distance of unions is at most the largest of the pairs'). Pieces are certified
  one by one: a piece's bound is quick, a whole merged tile's is not (1,248 buildings' LOD2
  against their LOD0: 100 s);
- the texel size: a building's coarsest texture spans its LOD0 diagonal, and each merge shrinks
  it into a smaller atlas cell (a tile's texels are its inputs' times their shrink factor, never
  finer than the inputs').

Every proxy vertex keeps the building it came from: each piece's building key (``<tile>/<id>``)
is kept in ``owners`` (through proxies of proxies) and :mod:`.features` writes them as per-vertex
feature ids with a property table of those buildings (``EXT_mesh_features`` +
``EXT_structural_metadata``, docs/tileset.md "Metadata").

Files: ``OUT/tileset_proxies/<tile>.glb`` and ``<tile>.json`` (its inputs' hash, bounds, sizes,
pieces, owners). A proxy is rebuilt only when that hash changes; files of tiles no longer proxied are
removed.
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
from ..mesh.hausdorff import Surface, bounds_within
from ..model import Part, Texture, TileId
from ..simplify.meshopt import SIMPLIFY_ERROR_ABSOLUTE, simplify
from ..tiles import tile_size_deg
from . import features, frames
from .glb import GlbPrimitive, read_primitives
from .metadata import chain_values
from .tree import BuildingChain, Node, rounding_slack
from .write import building_tops

PROXY_DIR = "tileset_proxies"
PROXY_FORMAT = "vworld-lod-proxy 6"  # 5: cells from the JPEG scaled IDCT; 6: feature ids
METRES_PER_DEGREE = math.pi / 180.0 * 6378137.0  # along a meridian, on the sphere
CERTIFY_RTOL = 0.05  # a piece's bound is refined to 5 % of its certified lower bound
TRANSFORM_SLACK_M = 1e-6  # float64 rounding of the frame changes (ECEF-sized numbers), metres


@dataclass
class ProxyInput:
    world: np.ndarray  # 4 x 4: the input's tile frame -> ECEF
    file: Path
    geometric: float  # metres: certified bound of the input against its buildings' LOD0
    texel: float  # metres per texel of its texture (0 when untextured)
    key: str  # what identifies its content (hash)
    pieces: list | None = None  # a child proxy's pieces (see Proxy.pieces); None: a building
    owners: list | None = None  # building key per piece (a building: its one key); .features


@dataclass
class Proxy:
    hash: str
    geometric: float  # metres, certified against the LOD0 surfaces below
    texel: float  # metres per texel of its atlas
    low: list[float]  # glTF-frame bounds, metres
    high: list[float]
    triangles: int
    # One per building: [first vertex, vertices, first face, faces, certified bound (m) of that
    # piece against the building's LOD0 as the file stores it]
    pieces: list = field(default_factory=list)
    owners: list = field(default_factory=list)  # building key per piece (.features)

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


def merged_inputs(
    inputs: list[ProxyInput], world: np.ndarray
) -> tuple[list[GlbPrimitive], list[ProxyInput]]:
    """Every input primitive moved into the proxy's glTF frame (``world``: its tile frame ->
    ECEF), and the input each came from."""
    to_proxy = frames.inverse_rigid(frames.Y_UP) @ frames.inverse_rigid(world)
    primitives, owners = [], []
    for item in inputs:
        matrix = to_proxy @ item.world @ frames.Y_UP
        for primitive in read_primitives(item.file):
            primitive.positions = frames.apply(matrix, primitive.positions)
            primitives.append(primitive)
            owners.append(item)
    return primitives, owners


def budget_m(tile: TileId, options: TilesetOptions) -> float:
    """Metres: the simplification target of a piece of ``tile``'s proxy."""
    return options.proxy_error_ratio * tile_size_deg(tile.level) * METRES_PER_DEGREE


def simplified_piece(
    positions: np.ndarray, faces: np.ndarray, budget: float
) -> tuple[np.ndarray, np.ndarray, float] | None:
    """meshoptimizer's collapse of one building's piece towards ``budget`` metres (attribute seams
    kept, borders free): (kept vertex indices (k,), faces (m', 3) into them, certified Hausdorff
    bound in metres against the piece), or None when it removes nothing or is not certified
    within ``budget``."""
    kept, _ = simplify(faces, positions, 0, budget, SIMPLIFY_ERROR_ABSOLUTE)
    if not 0 < len(kept) < faces.size:
        return None
    used, inverse = np.unique(kept.astype(np.int64), return_inverse=True)
    new_faces = inverse.reshape(-1, 3)
    rounded = positions[used].astype(np.float32).astype(np.float64)  # as the file stores them
    # meshoptimizer's own error is an estimate: the collapse is kept only when certified within
    # the budget (the check stops as soon as a lower bound exceeds it).
    bounds = bounds_within(
        Surface(positions, faces),
        (rounded, new_faces),
        budget,
        rtol=CERTIFY_RTOL,
        atol=0.01 * budget,
    )
    return None if bounds is None else (used, new_faces, bounds[1])


def _pieces(primitives, owners, uvs, budget: float) -> list[tuple]:
    """(positions, faces, uvs, bound) per building piece; pieces of child proxies simplified
    towards ``budget`` metres when that is certified (the bounds add: triangle inequality)."""
    pieces = []
    for primitive, owner, uv in zip(primitives, owners, uvs):
        if owner.pieces is None:  # a building's level: one piece, its certified bound
            pieces.append((primitive.positions, primitive.triangles, uv, owner.geometric))
            continue
        for v0, vn, f0, fn, bound in owner.pieces:
            v0, vn, f0, fn = int(v0), int(vn), int(f0), int(fn)
            positions = primitive.positions[v0 : v0 + vn]
            faces = primitive.triangles[f0 : f0 + fn] - v0
            done = simplified_piece(positions, faces, budget) if budget > 0 else None
            if done is None:
                pieces.append((positions, faces, uv[v0 : v0 + vn], bound))
            else:
                used, new_faces, extra = done
                pieces.append((positions[used], new_faces, uv[v0 : v0 + vn][used], bound + extra))
    return pieces


def build_proxy(
    inputs: list[ProxyInput],
    tile: TileId,
    world: np.ndarray,
    options: TilesetOptions,
    jpeg_quality: int,
    key: str,
    records: dict[str, dict] | None = None,
) -> tuple[Proxy, bytes] | None:
    """The proxy of ``inputs`` for ``tile`` and its ``.glb`` bytes; None when it has more than
    ``options.proxy_max_triangles`` triangles."""
    primitives, owners = merged_inputs(inputs, world)
    atlas, uvs, shrink = pack_atlas(primitives, options.proxy_atlas_size)
    pieces = _pieces(primitives, owners, uvs, budget_m(tile, options))
    if sum(len(faces) for _, faces, _, _ in pieces) > options.proxy_max_triangles:
        return None
    offsets = np.cumsum([0] + [len(p[0]) for p in pieces])
    face_offsets = np.cumsum([0] + [len(p[1]) for p in pieces])
    positions = np.concatenate([p[0] for p in pieces]).astype(np.float32)
    faces = np.concatenate([p[1] + offsets[i] for i, p in enumerate(pieces)])
    low, high = positions.min(axis=0).astype(np.float64), positions.max(axis=0).astype(np.float64)
    slack = rounding_slack(low, high) + TRANSFORM_SLACK_M
    table = [
        [int(offsets[i]), len(p[0]), int(face_offsets[i]), len(p[1]), float(p[3]) + slack]
        for i, p in enumerate(pieces)
    ]
    geometric = max(row[4] for row in table)
    # Never finer than the source: an upscaled cell has its source's texels.
    texel = max(
        [0.0] + [owner.texel * max(factor, 1.0) for owner, factor in zip(owners, shrink) if factor]
    )
    buffer = io.BytesIO()
    atlas.save(buffer, "JPEG", quality=jpeg_quality)
    texture = Texture(
        buffer.getvalue(), "image/jpeg", atlas.width, atlas.height, f"{tile.name}_atlas"
    )
    # glTF frame -> local East/Up/North with outward winding (what the writer takes)
    local = positions.astype(np.float64) * [-1.0, 1.0, 1.0]
    part = Part(
        local, faces[:, [0, 2, 1]], uvs=np.concatenate([p[2] for p in pieces]), texture=texture
    )
    data = glb_bytes([part], f"{tile.name}_proxy")
    owners_out = piece_owners(owners)
    if records is not None:  # the buildings told apart: feature ids -> property table
        ids, keys = features.vertex_feature_ids(owners_out, [len(p[0]) for p in pieces])
        data = features.with_features(data, ids, [records[k] for k in keys])
    low_list, high_list = [float(v) for v in low], [float(v) for v in high]
    proxy = Proxy(key, geometric, texel, low_list, high_list, len(faces), table, owners_out)
    return proxy, data


def piece_owners(owners: list[ProxyInput]) -> list[str]:
    """The building key of every piece :func:`_pieces` makes of primitives from ``owners``: a
    building's primitive is one piece of its building, a child proxy's one piece per its own."""
    keys: list[str] = []
    for owner in owners:
        keys += (owner.owners or [""])[:1] if owner.pieces is None else owner.owners or []
    return keys


def input_key(
    tile: TileId, inputs: list[ProxyInput], options: TilesetOptions, jpeg_quality: int
) -> str:
    """Hash of everything a proxy is made from (its inputs' own keys, errors and the options)."""
    text = json.dumps(
        [
            PROXY_FORMAT,
            tile.name,
            options.proxy_max_triangles,
            options.proxy_atlas_size,
            options.proxy_error_ratio,
            jpeg_quality,
            [[item.key, repr(item.geometric), repr(item.texel)] for item in inputs],
        ]
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _cached(folder: Path, name: str, key: str) -> tuple[bool, Proxy | None]:
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
        proxy = Proxy(
            key,
            float(data["geometric"]),
            float(data["texel"]),
            data["low"],
            data["high"],
            int(data["triangles"]),
            data["pieces"],
            data["owners"],
        )
        return True, proxy
    except (OSError, ValueError, KeyError, TypeError):
        return False, None


def building_key(chain: BuildingChain) -> str:
    """What names a building among all of the export's: ``<tile>/<id>``."""
    return f"{chain.tile.name}/{chain.id}"


def values_digest(chain: BuildingChain) -> str:
    """Hash of a building's metadata values (a proxy is rebuilt when they change)."""
    text = json.dumps(chain_values(chain), sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def _chains(tops: list[Node]) -> list[BuildingChain]:
    """Every building chain of the tree under ``tops``."""
    return [t.building for node in tops for t in building_tops(node) if t.building is not None]


def _inputs(out_dir: Path, node: Node) -> list[ProxyInput] | None:
    """What ``node``'s proxy merges, or None when a child tile has no proxy."""
    inputs = []
    for child in node.children:
        if child.building is not None:
            top = child.building.levels[0]
            building = child.building
            owner = building_key(building)
            key = f"{building.input_hash}:{top.file}:{values_digest(building)}"
            inputs.append(
                ProxyInput(
                    building.world,
                    out_dir / top.file,
                    top.error,
                    building.texel,
                    key,
                    None,
                    [owner],
                )
            )
        elif child.proxy_hash is not None and child.content is not None:
            assert child.world is not None
            inputs.append(
                ProxyInput(
                    child.world,
                    out_dir / child.content,
                    child.geometric,
                    child.texel,
                    child.proxy_hash,
                    child.pieces,
                    child.owners,
                )
            )
        else:
            return None
    return inputs


def add_proxies(
    out_dir: Path,
    tops: list[Node],
    options: TilesetOptions,
    jpeg_quality: int,
    problems: list[str],
    force: bool = False,
) -> tuple[int, int]:
    """Give every tile node of ``tops`` that can have one its proxy (content, error, corners);
    returns (proxies in the tree, proxies built this time); a proxy that cannot be built is
    appended to ``problems``. Stale proxy files are removed. ``force``: build every proxy, none
    taken from an earlier run (a rebuilt file whose bytes come out the same is left as it was)."""
    folder = out_dir / PROXY_DIR
    kept: set[str] = set()
    records = {building_key(chain): chain_values(chain) for chain in _chains(tops)}
    counts = [0, 0]

    def visit(node: Node) -> None:
        for child in node.children:
            if child.tile is not None:
                visit(child)
        if node.tile is None or node.world is None:
            return
        inputs = _inputs(out_dir, node)
        if inputs is None:
            return
        name = node.tile.name
        key = input_key(node.tile, inputs, options, jpeg_quality)
        kept.update({f"{name}.json", f"{name}.glb"})
        found, proxy = (False, None) if force else _cached(folder, name, key)
        if not found:
            counts[1] += 1
            try:
                built = build_proxy(
                    inputs, node.tile, node.world, options, jpeg_quality, key, records
                )
            except (OSError, ValueError, KeyError, IndexError) as problem:
                # An input changed or broke since it was read: no proxy here (nor above), said so.
                problems.append(
                    f"{PROXY_DIR}/{name}.glb: not built ({problem!r}); tile shown without"
                )
                return
            if built is None:
                write_text_atomic(
                    folder / f"{name}.json", json.dumps({"hash": key, "too_large": True})
                )
                (folder / f"{name}.glb").unlink(missing_ok=True)
                return
            proxy, data = built
            write_bytes_if_changed(folder / f"{name}.glb", data)
            record = {
                "hash": key,
                "size": len(data),
                "geometric": proxy.geometric,
                "texel": proxy.texel,
                "low": proxy.low,
                "high": proxy.high,
                "triangles": proxy.triangles,
                "pieces": proxy.pieces,
                "owners": proxy.owners,
            }
            write_text_atomic(
                folder / f"{name}.json", json.dumps(record)
            )  # last: the glb is complete
        if proxy is None:
            return
        counts[0] += 1
        node.content = f"{PROXY_DIR}/{name}.glb"
        node.proxy_hash = key
        node.geometric, node.texel, node.pieces = proxy.geometric, proxy.texel, proxy.pieces
        node.owners = proxy.owners
        node.error = max([proxy.error] + [child.error for child in node.children])
        node.corners = frames.apply(
            node.world, frames.gltf_corners(np.array(proxy.low), np.array(proxy.high))
        )

    for top in tops:
        visit(top)
    remove_stale(folder, kept)
    return counts[0], counts[1]


def remove_stale(folder: Path, kept: set[str]) -> None:
    """Delete proxy files of tiles that no longer have one (``kept``: file names to keep)."""
    if not folder.is_dir():
        return
    for path in folder.iterdir():
        if path.is_file() and path.name not in kept:
            path.unlink(missing_ok=True)
