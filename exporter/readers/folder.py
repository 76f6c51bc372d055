"""Generic folder reader: OBJ (+ MTL + images), glTF and GLB models, one building per file, placed
on the globe by an index file in the folder.

Meshes and materials are read with trimesh; original image bytes are taken from the files the MTL
names or from the glTF's own images (read with pygltflib), so LOD0 keeps the source encoding.

Index file (the first found of ``buildings.csv``, ``buildings.yaml``/``buildings.yml``,
``buildings.json``), one row per model file:

==========  ========  ==========================================================================
column      required  meaning
==========  ========  ==========================================================================
file        yes       model path relative to the folder: ``*.obj``, ``*.gltf`` or ``*.glb``
lon, lat    yes       degrees (WGS84) of the model's origin (0, 0, 0)
elev        yes       metres: height of the model's origin (same datum as the terrain)
up_axis     no        ``y`` (default) or ``z``: which model axis points up (see below)
id          no        building id (default: the file name without extension); must be unique
==========  ========  ==========================================================================

Any other column is an attribute of the building (``Building.attributes``, rules of
:mod:`exporter.attributes`): text that is exactly an integer or a decimal number becomes that
number (``007`` stays text), an empty cell is left out; YAML/JSON values keep their own types.

``buildings.csv`` has a header row with these column names (any order)::

    file,lon,lat,elev,up_axis,id
    hall.glb,126.9780,37.5665,38.5,y,city-hall

``buildings.yaml`` / ``buildings.json`` hold a list of mappings with the same keys, either at the
top level or under a ``buildings`` key::

    buildings:
      - {file: hall.glb, lon: 126.9780, lat: 37.5665, elev: 38.5, up_axis: y, id: city-hall}

Model frames (units are metres; both are right-handed, front faces counter-clockwise):

- ``up_axis: y`` (glTF's and Blender's glTF/OBJ export convention): x = East, y = Up, -z = North
  (+z = South).
- ``up_axis: z`` (GIS/CAD convention): x = East, y = North, z = Up.

Both become the local East/Up/North frame (x = East, y = Up, z = North) by a reflection, so every
triangle's index order is reversed to keep ``(b - a) x (c - a)`` outward. Positions are then moved
from the origin's tangent frame to the building's reference point (centre of its lon/lat box at
its lowest point) on the 6378137 m sphere (:mod:`exporter.geodesy`): a rigid motion, the shape is
unchanged.

Each material becomes one :class:`~exporter.model.Part` (meshes sharing a material are merged);
UVs are given in glTF's convention (origin top-left). The colour is glTF's ``baseColorFactor`` or
MTL's ``Kd`` (white for textured OBJ materials: the texture alone gives the colour). ``Entry.tile`` is the level-15 tile holding the model's origin (the model is not
opened while scanning); ``Building.lonlat_bounds`` gives its true extent and ``Building.tile`` is
None, so the pipeline files it by the centre of that extent.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from PIL import Image

from .. import geodesy
from ..attributes import clean_attributes
from ..config import ReaderOptions
from ..errors import InputError, ReadError, error_text
from ..model import Building, GeoPoint, Part, Skipped, Texture
from ..tiles import tile_of
from . import Entry, Scan
from .confine import OutsideInput, confined

FORMAT = "folder"
INDEX_NAMES = ("buildings.csv", "buildings.yaml", "buildings.yml", "buildings.json")
MODEL_SUFFIXES = (".obj", ".gltf", ".glb")
UP_AXES = ("y", "z")
# Bytes of one building's model file or external glTF buffer: trimesh holds a model several times
# over while reading it (a 3 GiB OBJ took 6.4 GB), and no single building needs more.
MAX_MODEL_BYTES = 512 * 2**20
COLUMNS = ("file", "lon", "lat", "elev", "up_axis", "id")  # the index's own; others: attributes

# Model axes -> local (East, Up, North): rows pick and sign the model's x, y, z. Both have det -1.
TO_LOCAL = {
    "y": np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]),
    "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]),
}


# --------------------------------------------------------------------------- index file


def index_file(folder: Path) -> Path | None:
    for name in INDEX_NAMES:
        if (folder / name).is_file():
            return folder / name
    return None


def _index_rows(path: Path) -> list[dict]:
    """Raw rows of the index file; InputError naming the file when it cannot be parsed at all."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: index file cannot be read ({error})") from None
    if path.suffix == ".csv":
        reader = csv.DictReader(io.StringIO(text))
        columns = [c.strip() for c in reader.fieldnames or []]
        missing = [c for c in ("file", "lon", "lat", "elev") if c not in columns]
        if missing:
            raise InputError(
                f"{path}: missing column(s) {', '.join(missing)}; expected a header row file,lon,lat,elev[,up_axis][,id]"
            )
        return [
            {(k or "").strip(): (v.strip() if isinstance(v, str) else v) for k, v in row.items()}
            for row in reader
        ]
    try:
        data = yaml.safe_load(text) if path.suffix in (".yaml", ".yml") else json.loads(text)
    except (yaml.YAMLError, json.JSONDecodeError) as error:
        raise InputError(
            f"{path}: index file is not valid {path.suffix[1:].upper()} ({str(error).splitlines()[0]})"
        ) from None
    if isinstance(data, dict):
        data = data.get("buildings")
    if not isinstance(data, list) or not all(isinstance(row, dict) for row in data):
        raise InputError(
            f"{path}: expected a list of mappings with keys file, lon, lat, elev[, up_axis][, id] (at the top level or under 'buildings')"
        )
    return data


_INTEGER = re.compile(r"[+-]?(0|[1-9][0-9]*)")
_DECIMAL = re.compile(r"[+-]?([0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)([eE][+-]?[0-9]+)?")


def index_value(value: Any) -> Any:
    """An index row's extra value as an attribute: text that is exactly an integer (no leading
    zero: ``007`` stays text) or a decimal number becomes that number; an empty text is left
    out (None); anything else as it is (YAML/JSON keep their own types)."""
    if not isinstance(value, str):
        return value
    text = value.strip()
    if not text:
        return None
    if _INTEGER.fullmatch(text):
        return int(text)
    if _DECIMAL.fullmatch(text) and not re.match(r"[+-]?0[0-9]", text):
        return float(text)
    return text


def _row_entry(folder: Path, row: dict) -> Entry:
    """One index row -> Entry; ValueError saying what is wrong with the row."""
    file = row.get("file")
    if not isinstance(file, str) or not file.strip():
        raise ValueError("no 'file'")
    file = file.strip()
    if not file.lower().endswith(MODEL_SUFFIXES):
        raise ValueError(f"file {file!r} is not one of {', '.join(MODEL_SUFFIXES)}")
    values = {}
    for key, low, high in (
        ("lon", -180.0, 180.0),
        ("lat", -90.0, 90.0),
        ("elev", -12000.0, 100000.0),
    ):
        raw = row.get(key)
        try:
            value = float(raw)  # type: ignore[arg-type]  # None and the like raise TypeError
        except (TypeError, ValueError):
            raise ValueError(f"{key} {raw!r} is not a number") from None
        if not (math.isfinite(value) and low <= value <= high):
            raise ValueError(f"{key} {raw!r} is outside [{low:g}, {high:g}]")
        values[key] = value
    up_axis = str(row.get("up_axis") or "y").strip().lower()
    if up_axis not in UP_AXES:
        raise ValueError(f"up_axis {row.get('up_axis')!r}; allowed: y or z")
    building_id = str(row.get("id") or "").strip() or Path(file).stem
    model = confined(file, folder)  # OutsideInput (a ValueError): the row is skipped
    too_large = _too_large(model)
    if too_large:
        raise ValueError(f"file {file!r} {too_large}")
    extra = tuple((k, v) for k, v in row.items() if k not in COLUMNS)
    entry_key = (file, values["lon"], values["lat"], values["elev"], up_axis, extra)
    return Entry(
        format=FORMAT,
        id=building_id,
        source=str(model),
        tile=tile_of(values["lon"], values["lat"], 15),
        inputs=[str(model)] + _dependencies(model, folder),
        key=entry_key,
    )


# --------------------------------------------------------------------------- dependencies

_MTLLIB = re.compile(rb"^\s*mtllib\s+(.+?)\s*$", re.MULTILINE)
_MAP_KD = re.compile(r"^\s*map_Kd\s+(.+?)\s*$", re.MULTILINE | re.IGNORECASE)


def _mtl_image_name(argument: str) -> str:
    """The file name of a ``map_Kd`` line, skipping options like ``-s 1 1 1`` (the name is last)."""
    return argument.split()[-1] if argument.split() else argument


@dataclass
class _Named:
    """The files a model names (OBJ ``mtllib``/``map_Kd``, glTF buffer/image ``uri``): those
    found inside the input folder (:mod:`~exporter.readers.confine`) and a problem for each of the
    others, naming it (refused: outside the folder; missing)."""

    mtls: list[Path] = field(default_factory=list)
    images: list[Path] = field(default_factory=list)
    buffers: list[Path] = field(default_factory=list)
    refused: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)

    def named(self, name: str, relative_to: Path, root: Path, what: str) -> Path | None:
        """``name`` (a ``what``: 'material file', 'texture', 'buffer') if inside and present."""
        try:
            path = confined(name, relative_to, root)
        except OutsideInput as refused:
            self.refused.append(f"{what} refused: {refused}")
            return None
        if not path.is_file():
            self.missing.append(f"{what} {name} missing")
            return None
        return path


def _too_large(path: Path) -> str | None:
    """Why ``path`` is over MAX_MODEL_BYTES (None when it is not, or is missing)."""
    try:
        size = path.stat().st_size
    except OSError:
        return None
    if size <= MAX_MODEL_BYTES:
        return None
    return (
        f"is {size / 2**20:,.0f} MiB, over the {MAX_MODEL_BYTES // 2**20} MiB limit for one "
        "building's model (docs/input.md)"
    )


def model_root(model: Path, file: str) -> Path:
    """The input folder of a model listed in its index as ``file`` (``model`` = folder / file)."""
    return model.parents[len(Path(file).parts) - 1]


def _obj_materials(model: Path, root: Path) -> _Named:
    """The MTL files an OBJ names (relative to the OBJ) and the images they name (relative to
    the MTL), inside ``root``."""
    named = _Named()
    try:
        data = model.read_bytes()
    except OSError:
        return named
    for match in _MTLLIB.finditer(data):
        name = match.group(1).decode("utf-8", "replace")
        mtl = named.named(name, model.parent, root, "material file")
        if mtl is None:
            continue
        named.mtls.append(mtl)
        try:
            text = mtl.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        for argument in _MAP_KD.findall(text):
            image = named.named(_mtl_image_name(argument), mtl.parent, root, "texture")
            if image is not None:
                named.images.append(image)
    return named


def _gltf_files(model: Path, root: Path) -> _Named:
    """The external buffers and images a .gltf/.glb names (relative to it), inside ``root``."""
    from urllib.parse import unquote

    named = _Named()
    header = _gltf_header(model) or {}
    for key, what, into in (
        ("buffers", "buffer", named.buffers),
        ("images", "texture", named.images),
    ):
        for item in header.get(key) or []:
            uri = item.get("uri") if isinstance(item, dict) else None
            if isinstance(uri, str) and not uri.startswith("data:"):
                path = named.named(unquote(uri), model.parent, root, what)
                if path is not None:
                    into.append(path)
    return named


def _named_files(model: Path, root: Path) -> _Named:
    if model.suffix.lower() == ".obj":
        return _obj_materials(model, root)
    return _gltf_files(model, root)


def _gltf_header(model: Path) -> dict | None:
    """The JSON part of a .gltf or .glb file (None when it cannot be read)."""
    try:
        with model.open("rb") as handle:
            if model.suffix.lower() != ".glb":
                return json.loads(handle.read())
            head = handle.read(20)  # magic, version, length, then the JSON chunk's length, type
            return json.loads(handle.read(int.from_bytes(head[12:16], "little")))
    except (OSError, ValueError):
        return None


def _dependencies(model: Path, root: Path) -> list[str]:
    """Files besides the model whose bytes decide the building (MTL, images, external buffers),
    those inside the input folder ``root`` (the others are refused when it is loaded)."""
    if not model.is_file():
        return []
    named = _named_files(model, root)
    return [str(p) for p in named.mtls + named.buffers + named.images]


# --------------------------------------------------------------------------- original image bytes


def _encoded_images(model: Path, named: _Named) -> list[tuple[bytes, str]]:
    """(encoded bytes, name) of every image the model file refers to, external ones only from
    ``named`` (inside the input folder)."""
    found = []
    if model.suffix.lower() == ".obj":
        for image in named.images:
            try:
                found.append((image.read_bytes(), image.name))
            except OSError:
                continue
        return found
    import pygltflib

    try:
        gltf = pygltflib.GLTF2().load(str(model))
    except Exception:  # pygltflib raises assorted errors on bad files; trimesh reports them
        return found
    blob = gltf.binary_blob() if model.suffix.lower() == ".glb" else None
    for number, image in enumerate(gltf.images or []):
        data = None
        if image.bufferView is not None:
            view = gltf.bufferViews[image.bufferView]
            buffer = gltf.buffers[view.buffer]
            source = blob if buffer.uri is None else _uri_bytes(model, buffer.uri, named)
            if source is not None:
                data = source[(view.byteOffset or 0) : (view.byteOffset or 0) + view.byteLength]
        elif image.uri:
            data = _uri_bytes(model, image.uri, named)
        if data:
            found.append(
                (
                    bytes(data),
                    image.name
                    or (
                        Path(image.uri).name
                        if image.uri and not image.uri.startswith("data:")
                        else f"image{number}"
                    ),
                )
            )
    return found


def _uri_bytes(model: Path, uri: str, named: _Named) -> bytes | None:
    """The bytes a glTF ``uri`` names: a data URI, or a file among ``named`` (inside the input)."""
    import base64
    from urllib.parse import unquote

    try:
        if uri.startswith("data:"):
            return base64.b64decode(uri.split(",", 1)[1])
        path = model.parent / unquote(uri)
        if path not in named.buffers + named.images:
            return None  # outside the input folder or missing: in named's problems
        return path.read_bytes()
    except (OSError, ValueError, IndexError):
        return None


def _pixel_digest(image: Image.Image) -> tuple:
    return image.size, hashlib.sha1(image.convert("RGBA").tobytes()).hexdigest()


def _texture_for(
    image: Image.Image, candidates: list[tuple[bytes, str]], digests: dict, exact: bool = False
) -> tuple[Texture | None, str | None]:
    """The Texture of a decoded image: the candidate whose decoded pixels are equal (original
    bytes), else the image re-encoded as PNG with a problem note; None when ``exact`` (a named
    image was refused: an image not among the candidates may be that file's pixels)."""
    wanted = _pixel_digest(image)
    for number, (data, name) in enumerate(candidates):
        if number not in digests:
            try:
                with Image.open(io.BytesIO(data)) as decoded:
                    digests[number] = (_pixel_digest(decoded), decoded.format)
            except (OSError, Image.DecompressionBombError):
                digests[number] = (None, None)
        digest, kind = digests[number]
        if digest == wanted:
            mime = Image.MIME.get(kind, f"image/{(kind or 'unknown').lower()}")
            return Texture(data, mime, image.width, image.height, name=name), None
    if exact:
        return None, None
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    note = "texture re-encoded as PNG (its original bytes were not found)"
    return Texture(
        buffer.getvalue(), "image/png", image.width, image.height, name="texture.png"
    ), note


# --------------------------------------------------------------------------- meshes


def _material_of(visual) -> tuple[Image.Image | None, tuple]:
    """(texture image or None, RGBA colour 0..1) of a trimesh visual."""
    material = getattr(visual, "material", None)
    image = None
    color: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0)
    if material is None:
        return image, color
    image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    factor = getattr(material, "baseColorFactor", None)
    if factor is None:
        factor = getattr(material, "diffuse", None)
    if factor is not None:
        values = np.asarray(factor).ravel()
        if values.size in (3, 4):
            # trimesh stores colours as uint8 0..255; plain floats are already 0..1.
            scaled = (
                values / 255.0
                if np.issubdtype(values.dtype, np.integer) or values.max() > 1.0
                else values.astype(np.float64)
            )
            color = tuple(float(c) for c in np.append(scaled, 1.0)[:4])
    return image, color


def _scene_meshes(scene) -> list[tuple[np.ndarray, np.ndarray, np.ndarray | None, Any]]:
    """(vertices (n, 3) model metres, faces (m, 3) CCW front, uv (n, 2) bottom-left origin or None,
    visual) for every mesh instance of the scene graph, node transforms applied."""
    meshes = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        mesh = scene.geometry[name]
        if not hasattr(mesh, "faces") or len(mesh.faces) == 0:
            continue
        vertices = (
            np.asarray(mesh.vertices, dtype=np.float64) @ transform[:3, :3].T + transform[:3, 3]
        )
        faces = np.asarray(mesh.faces, dtype=np.int64)
        if np.linalg.det(transform[:3, :3]) < 0:  # a mirroring node turns faces inside out
            faces = faces[:, ::-1]
        uv = (
            getattr(mesh.visual, "uv", None)
            if getattr(mesh.visual, "kind", None) == "texture"
            else None
        )
        meshes.append(
            (vertices, faces, None if uv is None else np.asarray(uv, dtype=np.float64), mesh.visual)
        )
    return meshes


def _load_scene(model: Path):
    import trimesh

    try:
        return trimesh.load(str(model), force="scene", process=False)
    except Exception as error:  # trimesh raises many types on malformed files
        raise ReadError(
            str(model),
            f"cannot be read as {model.suffix[1:].upper()} ({error_text(error)})",
        ) from None


# --------------------------------------------------------------------------- contract


def detect(folder: Path) -> bool:
    """True when the folder holds an index file (``buildings.csv``/``.yaml``/``.yml``/``.json``)."""
    return index_file(Path(folder)) is not None


def scan(folder: Path, options: ReaderOptions) -> Scan:
    """One Entry per index row of the folder's index file (or of the index file ``folder``
    names; model paths are relative to its folder); bad rows and duplicate ids go to
    ``Scan.skipped``."""
    given = Path(folder)
    folder, index = (given.parent, given) if given.is_file() else (given, index_file(given))
    if index is None:
        raise InputError(
            f"{folder}: no index file ({', '.join(INDEX_NAMES)}) for the OBJ/glTF/GLB models"
        )
    result = Scan(folder=str(given), format=FORMAT)

    seen: set[str] = set()
    for number, row in enumerate(_index_rows(index), start=1):
        source = str(folder / str(row.get("file") or ""))
        try:
            entry = _row_entry(folder, row)
        except ValueError as error:
            result.skipped.append(
                Skipped(
                    source=str(index),
                    reason=f"row {number}: {error}",
                    id=str(row.get("id") or "") or None,
                )
            )
            continue
        if entry.id in seen:
            result.skipped.append(
                Skipped(
                    source=source,
                    reason=f"{index.name} row {number}: duplicate id {entry.id!r}",
                    id=entry.id,
                )
            )
            continue
        seen.add(entry.id)
        result.entries.append(entry)
    return result


def load(entry: Entry, options: ReaderOptions) -> Building:
    """The model ``entry.source`` placed by its index row; raises only ReadError."""
    model = Path(entry.source)
    file, lon, lat, elev, up_axis, extra = entry.key
    if not model.is_file():
        raise ReadError(str(model), f"listed in the index as {file!r} but missing")
    root = model_root(model, file)
    try:
        confined(model.relative_to(root), root)  # e.g. replaced by a symlink since the scan
    except OutsideInput as refused:
        raise ReadError(str(model), f"refused: {refused}") from None
    too_large = _too_large(model)
    if too_large:
        raise ReadError(str(model), too_large)
    named = _named_files(model, root)
    for buffer in named.buffers:
        too_large = _too_large(buffer)
        if too_large:
            raise ReadError(str(buffer), too_large)
    if any(p.startswith("buffer") for p in named.refused + named.missing):
        # The geometry itself would come from outside the input (or is not there): refused.
        raise ReadError(str(model), "; ".join(named.refused + named.missing))
    origin = GeoPoint(float(lon), float(lat), float(elev))
    scene = _load_scene(model)
    meshes = _scene_meshes(scene)
    if not meshes:
        raise ReadError(str(model), "has no triangles")
    to_local = TO_LOCAL[up_axis]

    # Local East/Up/North around the origin, then around the building's own reference point.
    at_origin = [vertices @ to_local.T for vertices, _, _, _ in meshes]
    lonlath = [geodesy.local_to_lonlath(points, origin) for points in at_origin]
    reference, bounds = geodesy.base_centre(np.concatenate(lonlath))

    candidates: list[tuple[bytes, str]] | None = None
    digests: dict[int, tuple] = {}
    # trimesh drops (or, for an OBJ without its MTL, invents a grey 2x2) image where a named file
    # is missing or refused: say so, naming it, and export those parts untextured.
    problems = [f"{problem}: exported untextured" for problem in named.refused + named.missing]
    obj = model.suffix.lower() == ".obj"
    groups: dict[Any, dict] = {}
    for (vertices, faces, uv, visual), points in zip(meshes, lonlath):
        image, color = _material_of(visual)
        texture = None
        if obj and not named.images:
            # No image of its own (its MTL missing or refused, or none named): whatever trimesh
            # made up is not the model's; glTF's default colour, opaque white.
            image, color = None, (1.0, 1.0, 1.0, 1.0)
        key: tuple = ("color", color)
        if image is not None and uv is not None and len(uv) == len(vertices):
            if obj:
                # MTL's Kd next to a map_Kd is commonly a leftover (trimesh writes 0.4 grey); like
                # Blender's importer, the texture alone gives the colour.
                color = (1.0, 1.0, 1.0, color[3])
            if candidates is None:
                candidates = _encoded_images(model, named)
            texture, note = _texture_for(image, candidates, digests, exact=bool(named.refused))
            if note and note not in problems:
                problems.append(note)
            if texture is not None:
                key = ("texture", hashlib.sha1(texture.data).hexdigest(), color)
        group = groups.setdefault(
            key,
            {
                "positions": [],
                "triangles": [],
                "uvs": [],
                "texture": texture,
                "color": color,
                "count": 0,
            },
        )
        group["positions"].append(geodesy.lonlath_to_local(points, reference))
        group["triangles"].append(
            faces[:, ::-1] + group["count"]
        )  # reflection: reverse the winding
        if texture is not None and uv is not None:
            flipped = uv.copy()

            flipped[:, 1] = 1.0 - flipped[:, 1]  # trimesh's bottom-left origin -> glTF top-left
            group["uvs"].append(flipped)
        group["count"] += len(vertices)

    parts = []
    for number, group in enumerate(groups.values()):
        texture = group["texture"]
        parts.append(
            Part(
                positions=np.concatenate(group["positions"]),
                triangles=np.concatenate(group["triangles"]),
                uvs=np.concatenate(group["uvs"]) if texture is not None else None,
                texture=texture,
                color=group["color"],
                name=texture.name if texture is not None else f"material{number}",
            )
        )
    attributes, notes = clean_attributes((k, index_value(v)) for k, v in extra)
    return Building(
        id=entry.id,
        source=str(model),
        reference=reference,
        parts=parts,
        tile=None,
        problems=problems + notes,
        lonlat_bounds=bounds,
        attributes=attributes,
    )
