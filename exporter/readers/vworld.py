"""VWorld building tiles: a folder with ``.dat`` tile indexes, ``.xdo`` models and ``.jpg`` textures.

Reader contract (see ``exporter/readers/__init__.py``): :func:`detect`, :func:`scan`, :func:`load`;
plus :func:`write_tile`, the inverse, used by the sample generator and the tests.

Frames (``docs/reference/frames-and-placement.md``):

- **VWorld global**: ``X = R cos(lat) cos(lon), Y = -R cos(lat) sin(lon), Z = R sin(lat)``, metres,
  R = 6 378 137 m (VWorld's sphere). ``.xdo`` positions are float32 metre offsets from the
  bounding-box centre in it; normals are unit vectors in it.
- **Local East/Up/North** (the model's frame): metres, origin at the reference point = the
  ``.dat`` record's centre lon/lat at its ``altitude``. The VWorld global frame -> local frame
  rotation has determinant +1 (both frames are mirror images of a right-handed one), so it keeps
  the winding; which way VWorld winds its triangles is decided per mesh from the stored normals
  (majority vote), and the loaded triangles always have ``(b-a)x(c-a)`` pointing outward.

The reference elevation is the ``.dat`` altitude (the building's base in VWorld's data); the
geometry keeps its absolute position whatever the reference, since positions are offsets from it.
When the model's lowest point is far from that altitude (public parsers report such data) the
building gets a ``problems`` entry quoting the altitude, the model base and the box-centre height.

Attributes (:func:`source_attributes`, rules of :mod:`exporter.attributes`): the record's key,
the ``.xdo``'s object id, the altitude (metres), the ``.dat`` file and index, the ``.xdo`` file.

Files written by :func:`write_tile`: ``<level>_<idx>_<idy>.dat`` (the tile index),
``<building id>.xdo`` per building (id made file-system safe, made unique with ``~<n>``) and each
part's texture under its own file name (``Texture.name``) or ``<xdo stem>_<part>.jpg``/``.png``.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ..atomic import write_bytes_atomic
from ..attributes import clean_attributes
from ..config import ReaderOptions
from ..errors import InputError, ReadError
from ..formats.vworld_binary import (
    MAX_MESHES,
    XDO_TYPE,
    DatFile,
    DatObject,
    XdoFile,
    XdoMesh,
    color_bytes,
    color_rgba,
    decode_text,
    parse_dat,
    parse_xdo,
    serialise_dat,
    serialise_xdo,
    version_bytes,
    xdo_image_names,
)
from ..geodesy import EARTH_RADIUS_M, east_up_north, sphere_ecef
from ..mesh.geometry import cross_rows, row_norms, unit_vectors, vertex_normals
from ..model import Building, GeoPoint, Part, Skipped, Texture, TileId
from ..tiles import tile_bounds
from . import Entry, Scan
from .confine import OutsideInput, confined
from .images import TextureFileError, read_texture_file

MAX_PART_VERTICES = 65535  # u16 indices
ALTITUDE_MISMATCH_M = (
    10.0  # report when the model's base is further than this from the .dat altitude
)
CENTRE_MISMATCH_M = (
    100.0  # report when the model's centre is further than this from the .dat lon/lat
)
BBOX_MISMATCH_M = 1.0  # report when the .dat and .xdo bounding boxes differ by more than this
DISAGREEING_SHARE = 0.1  # report a mesh whose winding disagrees with its normals on more triangles


# --------------------------------------------------------------------------- frames

# The VWorld global frame is the sphere frame of ``exporter.geodesy`` with its Y axis mirrored.
MIRROR_Y = np.array([1.0, -1.0, 1.0])


def enu_rotation(lon: float, lat: float) -> np.ndarray:
    """(3, 3) rotation, rows = local East, Up, North unit vectors in the VWorld global frame.

    ``local = rotation @ global`` for directions; ``lon``/``lat`` in degrees. Determinant +1 (the
    mirrored Y axis and VWorld's left-handed East/Up/North cancel out).
    """
    return east_up_north(lon, lat) * MIRROR_Y


def global_point(point: GeoPoint) -> np.ndarray:
    """(3,) VWorld global position, metres, of a lon/lat (degrees) at ``elev`` metres."""
    return sphere_ecef([[point.lon, point.lat, point.elev]])[0] * MIRROR_Y


def global_to_local(points: np.ndarray, reference: GeoPoint) -> np.ndarray:
    """(n, 3) VWorld global positions (metres) -> local East/Up/North (metres) at ``reference``."""
    return (np.asarray(points, dtype=np.float64) - global_point(reference)) @ enu_rotation(
        reference.lon, reference.lat
    ).T


def local_to_global(points: np.ndarray, reference: GeoPoint) -> np.ndarray:
    """(n, 3) local East/Up/North positions (metres) at ``reference`` -> VWorld global (metres)."""
    return np.asarray(points, dtype=np.float64) @ enu_rotation(
        reference.lon, reference.lat
    ) + global_point(reference)


def lonlat_of(points: np.ndarray) -> tuple:
    """(lon, lat) arrays in degrees of (n, 3) VWorld global positions (metres).

    ``sphere_lonlath``'s arithmetic (same bits) for the two angles only: its ``np.clip`` call,
    height column and ``column_stack`` cost more than the angles on a building's vertices.
    """
    ecef = np.asarray(points, dtype=np.float64).reshape(-1, 3) * MIRROR_Y  # sphere frame
    sine = ecef[:, 2] / row_norms(ecef)
    lon = np.degrees(np.arctan2(ecef[:, 1], ecef[:, 0]))
    return lon, np.degrees(np.arcsin(np.minimum(np.maximum(sine, -1.0), 1.0)))


# --------------------------------------------------------------------------- winding


def winding_votes(positions: np.ndarray, triangles: np.ndarray, directions: np.ndarray) -> tuple:
    """(agree, disagree): triangles whose ``(b-a)x(c-a)`` has a positive / negative dot with
    the sum of the corner ``directions`` ((n, 3), any frame shared with ``positions``)."""
    # One gather per corner (``take`` on an index row: several times faster than fancy indexing
    # into (m, 3, 3) and summing over its middle axis), same sums in the same order.
    a, b, c = (positions.take(corner, axis=0) for corner in triangles.T)
    face = cross_rows(b - a, c - a)
    d0, d1, d2 = (directions.take(corner, axis=0) for corner in triangles.T)
    dots = np.einsum("ij,ij->i", face, d0 + d1 + d2)
    return int(np.count_nonzero(dots > 0)), int(np.count_nonzero(dots < 0))


def outward_triangles(
    positions: np.ndarray, triangles: np.ndarray, normals: np.ndarray, centroid: np.ndarray
) -> tuple:
    """Triangles (m, 3) reordered so ``(b-a)x(c-a)`` points outward, with (agree, disagree) votes.

    The stored vertex ``normals`` vote; when they give no vote (all zero) the direction from the
    building's ``centroid`` (same frame as ``positions``) to each corner votes instead.
    """
    agree, disagree = winding_votes(positions, triangles, normals)
    if agree == 0 and disagree == 0:
        agree, disagree = winding_votes(positions, triangles, positions - centroid)
    if disagree > agree:
        return triangles[:, [0, 2, 1]], (disagree, agree)
    return triangles, (agree, disagree)


# --------------------------------------------------------------------------- files


def detect(folder: str | Path) -> bool:
    """True when the folder holds any ``.dat`` tile index."""
    return any(_dat_files(Path(folder)))


def _dat_files(folder: Path) -> list[Path]:
    # Names first: a Path only for the few .dat among thousands of .xdo/.jpg.
    named = (folder / n for n in os.listdir(folder) if n.lower().endswith(".dat"))
    return sorted(p for p in named if p.suffix.lower() == ".dat" and p.is_file())


def _plain_files(folder: Path) -> frozenset[str]:
    """Names of ``folder``'s regular files (not links), from one listing."""
    with os.scandir(folder) as found:
        return frozenset(e.name for e in found if e.is_file(follow_symlinks=False))


def _find(folder: Path, raw_name: bytes, plain: frozenset[str] = frozenset()) -> Path | None:
    """The file a raw VWorld string names: its exact bytes, its decoded text, then any case.
    Raises OutsideInput when that file is a symlink leading out of ``folder``. ``plain``:
    :func:`_plain_files` of ``folder`` when the caller listed it (a scan: thousands of names),
    such a name found without a stat."""
    if not raw_name:
        return None
    names = [os.fsdecode(raw_name), decode_text(raw_name)]
    for name in names:
        if "/" in name or "\\" in name or name in (".", ".."):
            continue
        if name in plain:
            return folder / name
        if os.path.isfile(os.path.join(folder, name)):
            return confined(name, folder)
    wanted = {n.lower() for n in names}
    for candidate in folder.iterdir():
        if candidate.name.lower() in wanted and candidate.is_file():
            return confined(candidate.name, folder)
    return None


def _child_prefix(folder: Path) -> str:
    """What ``str(folder / name)`` puts before a plain file ``name``: ``str(folder)`` and a
    slash, or nothing for ``.`` (pathlib drops it)."""
    return str(folder / "_")[:-1]


def _scan_find(folder: Path, raw_name: bytes, plain: frozenset[str], prefix: str) -> str | None:
    """``str(_find(folder, raw_name, plain))``, or None: the common case, the exact bytes naming
    a listed file, as text without a Path (a scan: thousands of names). ``prefix``:
    :func:`_child_prefix` of ``folder``."""
    name = os.fsdecode(raw_name)
    if name in plain and "\\" not in name:  # a listed name is never "", ".", ".." nor has "/"
        return prefix + name
    found = _find(folder, raw_name, plain)
    return None if found is None else str(found)


def _expected(folder: Path, raw_name: bytes) -> Path:
    return folder / Path(decode_text(raw_name).replace("\\", "/")).name


def _read(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise ReadError(str(path), "missing") from None
    except OSError as error:
        raise ReadError(str(path), f"cannot be read ({error.strerror or error})") from None


# --------------------------------------------------------------------------- scan


def scan(folder: str | Path, options: ReaderOptions | None = None) -> Scan:
    """One :class:`Entry` per ``.dat`` object record of every ``.dat`` in ``folder`` (or of the
    one ``.dat`` it names: its folder's ``.xdo``/``.jpg`` files are used).

    ``Entry.key`` = (dat file name, record index, the :class:`DatObject`); ``Entry.source`` = the
    ``.xdo`` path (which may be missing: reported by :func:`load`). A ``.dat`` that cannot be read
    goes to ``skipped`` (InputError when it was given alone).
    """
    given = Path(folder)
    result = Scan(folder=str(given), format="vworld")
    single = given.is_file()
    folder, dat_files = (given.parent, [given]) if single else (given, _dat_files(given))
    used_ids: set[str] = set()
    plain, prefix = _plain_files(folder), _child_prefix(folder)
    for dat_path in dat_files:
        try:
            dat = parse_dat(_read(dat_path), str(dat_path))
            tile = TileId(dat.level, dat.idx, dat.idy)
            try:  # the header's tile must exist: checked before any building work
                tile_bounds(tile)
            except ValueError as error:
                raise ReadError(str(dat_path), f"header: {error}") from None
        except ReadError as error:
            if single:
                raise InputError(str(error)) from None
            result.skipped.append(Skipped(source=str(dat_path), reason=error.problem))

            continue
        if dat.trailing:
            result.notes.append(
                f"{dat_path}: {len(dat.trailing)} bytes after the last object record ignored"
            )
        dat_text = str(dat_path)
        for index, record in enumerate(dat.objects):
            refused = None
            try:
                xdo_file = _scan_find(folder, record.data_file, plain, prefix)
                if xdo_file is None and record.key:
                    xdo_file = _scan_find(folder, record.key + b".xdo", plain, prefix)
            except OutsideInput as error:
                xdo_file, refused = None, f"object {index}: .xdo refused: {error}"
            if xdo_file is None and (refused or not record.data_file):
                why = refused or f"object {index} names no .xdo file (empty data_file)"
                result.skipped.append(
                    Skipped(
                        source=str(dat_path),
                        reason=why,
                        id=decode_text(record.key) or None,
                        tile=tile,
                    )
                )
                continue
            if xdo_file is None:
                xdo_file = str(_expected(folder, record.data_file))
            name = decode_text(record.key).strip() or Path(xdo_file).stem
            building_id = _unique(name, used_ids)
            listed = xdo_file.startswith(prefix) and xdo_file[len(prefix) :] in plain
            inputs = [dat_text] + ([xdo_file] if listed or Path(xdo_file).is_file() else [])
            inputs += _texture_files(folder, xdo_file, plain, prefix)
            result.entries.append(
                Entry(
                    format="vworld",
                    id=building_id,
                    source=xdo_file,
                    tile=tile,
                    inputs=inputs,
                    key=(dat_path.name, index, record),
                )
            )
    return result


def _unique(name: str, used: set) -> str:
    candidate, n = name, 1
    while candidate in used:
        n += 1
        candidate = f"{name}~{n}"
    used.add(candidate)
    return candidate


def _texture_files(folder: Path, xdo_file: str, plain: frozenset[str], prefix: str) -> list[str]:
    """Paths (text, sorted) of the texture files the model ``xdo_file`` names, for hashing;
    nothing when the ``.xdo`` cannot be read yet. ``plain``, ``prefix``: :func:`_plain_files`
    and :func:`_child_prefix` of ``folder``."""
    try:
        with open(xdo_file, "rb") as handle:
            names = xdo_image_names(handle.read(), xdo_file, None)
    except (OSError, ReadError):
        return []
    found = set()
    for name in dict.fromkeys(names):  # meshes sharing an atlas name it once
        try:
            found.add(_scan_find(folder, name, plain, prefix))
        except OutsideInput:
            continue  # refused when the building is loaded (a problem)
    return sorted(p for p in found if p is not None)


# --------------------------------------------------------------------------- load


def load(entry: Entry, options: ReaderOptions | None = None) -> Building:
    """Read one building: its ``.xdo`` and textures, in the local East/Up/North frame.

    Raises :class:`ReadError` naming the ``.xdo`` when it is missing, truncated, an XML error page
    or holds no triangles; a missing or broken texture only leaves its part untextured, with a
    ``problems`` entry naming the file.
    """
    dat_name, index, record = entry.key
    xdo_path = Path(entry.source)
    folder = xdo_path.parent
    dat_path = str(folder / dat_name)
    problems: list[str] = []

    if not xdo_path.is_file():
        raise ReadError(
            str(xdo_path),
            f"missing: object {index} ({decode_text(record.key)!r}) of {dat_name} names this .xdo model",
        )
    try:
        confined(xdo_path.name, folder)  # e.g. replaced by a symlink since the scan
    except OutsideInput as refused:
        raise ReadError(str(xdo_path), f"refused: {refused}") from None
    xdo = _parse_declared(_read(xdo_path), xdo_path, record, problems)
    reference = _reference(record, xdo, dat_path, xdo_path, problems)
    # The frame once per building: global_to_local / local_to_global's arithmetic, same bits.
    rotation = enu_rotation(reference.lon, reference.lat)
    origin = global_point(reference)  # metres, VWorld global
    center = xdo.bbox_center
    if not np.isfinite(center).all():
        raise ReadError(str(xdo_path), "bounding box is not finite")
    center_local = ((center[None, :] - origin) @ rotation.T)[0]  # metres, local East/Up/North

    meshes = []
    for j, mesh in enumerate(xdo.meshes):
        triangles = _triangles(mesh, j, xdo_path, problems)
        if triangles is None:
            continue
        with np.errstate(invalid="ignore", over="ignore"):  # non-finite input: refused below
            positions = mesh.positions.astype(np.float64) @ rotation.T + center_local
        if not np.isfinite(positions).all():
            raise ReadError(str(xdo_path), f"mesh {j}: positions are not finite")
        normals = mesh.normals.astype(np.float64)
        if not np.isfinite(
            normals
        ).all():  # nan_to_num only when needed: it costs more than the check
            normals = np.nan_to_num(normals)
        normals = unit_vectors(normals @ rotation.T)
        meshes.append((j, mesh, positions, triangles, normals))
    if not meshes:
        raise ReadError(str(xdo_path), "holds no triangles")

    centroid = np.concatenate([m[2] for m in meshes]).mean(axis=0)
    textures: dict[bytes, Texture | None] = {}
    parts = []
    for j, mesh, positions, triangles, normals in meshes:
        triangles, (agree, disagree) = outward_triangles(positions, triangles, normals, centroid)
        if disagree > DISAGREEING_SHARE * (agree + disagree):
            problems.append(
                f"{xdo_path.name} mesh {j}: {disagree} of {agree + disagree} triangles are wound against the stored normals"
            )
        if mesh.image_name and mesh.image_name not in textures:
            textures[mesh.image_name] = _texture(folder, mesh.image_name, problems)
        texture = textures.get(mesh.image_name)
        has_normals = bool(normals.any())
        parts.append(
            Part(
                positions=positions,
                triangles=triangles,
                normals=normals if has_normals else None,
                uvs=mesh.uvs,
                texture=texture,
                color=part_color(mesh.color, textured=texture is not None),
                name=Path(decode_text(mesh.image_name)).stem if mesh.image_name else f"mesh{j}",
            )
        )

    everything = np.concatenate([p.positions for p in parts])
    _check_base(everything, center, reference, xdo_path, problems)
    lon, lat = lonlat_of(everything @ rotation + origin)  # local_to_global
    bounds = (float(lon.min()), float(lat.min()), float(lon.max()), float(lat.max()))
    attributes, notes = clean_attributes(source_attributes(dat_name, index, record, xdo))
    return Building(
        # The .dat's own id (scan made repeated ones unique as entry.id; the record keeps this one).
        id=decode_text(record.key).strip() or xdo_path.stem,
        source=str(xdo_path),
        reference=reference,
        parts=parts,
        tile=entry.tile,
        problems=problems + notes,
        lonlat_bounds=bounds,
        attributes=attributes,
    )


def source_attributes(dat_name: str, index: int, record: DatObject, xdo: XdoFile) -> list:
    """(name, value) pairs of what the ``.dat`` record and the ``.xdo`` say about the building:
    ``key`` (the record's key text), ``object_id`` (the ``.xdo`` header's), ``altitude`` (metres,
    the record's; left out when not a number), ``dat_file`` and ``dat_index`` (the record's
    position in it, from 0), ``xdo_file``."""
    return [
        ("key", decode_text(record.key)),
        ("object_id", int(xdo.object_id)),
        ("altitude", float(record.altitude)),
        ("dat_file", dat_name),
        ("dat_index", int(index)),
        ("xdo_file", decode_text(record.data_file)),
    ]


def _parse_declared(data: bytes, xdo_path: Path, record: DatObject, problems: list) -> XdoFile:
    """The ``.xdo`` in the layout the ``.dat`` declares, else in the one that fits (noted)."""
    declared = record.xdo_version
    try:
        return parse_xdo(data, str(xdo_path), declared)
    except ReadError as error:
        if declared is None:
            raise
        try:
            xdo = parse_xdo(data, str(xdo_path), 3 - declared)
        except ReadError:
            raise error from None
    problems.append(
        f"{xdo_path.name}: the .dat declares version 3.0.0.{declared} but the file has the 3.0.0.{xdo.version} layout"
    )
    return xdo


def _reference(
    record: DatObject, xdo: XdoFile, dat_path: str, xdo_path: Path, problems: list
) -> GeoPoint:
    """The local frame's origin: the ``.dat`` centre lon/lat at the ``.dat`` altitude."""
    lon, lat = float(record.center_lon), float(record.center_lat)
    if not (math.isfinite(lon) and math.isfinite(lat) and -90.0 <= lat <= 90.0):
        raise ReadError(
            dat_path,
            f"object {decode_text(record.key)!r}: centre lon/lat ({lon}, {lat}) is not a valid position",
        )
    altitude = float(record.altitude)
    if not math.isfinite(altitude):
        altitude = float(xdo.altitude) if math.isfinite(float(xdo.altitude)) else 0.0
        problems.append(
            f"{Path(dat_path).name}: altitude of {decode_text(record.key)!r} is not a number; used {altitude:g} m"
        )
    # Six floats a box (metres): plain float arithmetic, numpy's per-call cost being most of the
    # work here. A non-finite .xdo box is refused by load right after.
    if all(math.isfinite(v) for v in record.bbox):
        largest = max(abs(float(a) - float(b)) for a, b in zip(record.bbox, xdo.bbox))
        if largest > BBOX_MISMATCH_M:
            problems.append(
                f"{xdo_path.name}: bounding box differs from the .dat's by {largest:.1f} m; used the .xdo's"
            )
    return GeoPoint(lon, lat, altitude)


def _triangles(mesh: XdoMesh, j: int, xdo_path: Path, problems: list) -> np.ndarray | None:
    """(m, 3) int64 triangles of a mesh, None (with a problem) for an empty one."""
    if len(mesh.indices) == 0 or len(mesh.vertices) == 0:
        problems.append(f"{xdo_path.name} mesh {j}: empty (no triangles), dropped")
        return None
    if len(mesh.indices) % 3:
        raise ReadError(
            str(xdo_path),
            f"mesh {j}: {len(mesh.indices)} indices is not a whole number of triangles",
        )
    if int(mesh.indices.max()) >= len(mesh.vertices):
        raise ReadError(
            str(xdo_path),
            f"mesh {j}: index {int(mesh.indices.max())} is past the {len(mesh.vertices)} vertices",
        )
    return mesh.indices.astype(np.int64).reshape(-1, 3)


def part_color(raw: bytes, textured: bool) -> tuple:
    """A part's colour factor (RGBA, 0..1) from a mesh's 4 colour bytes, whose byte order public
    readers dispute (A,R,G,B or B,G,R,A; docs/input.md "VWorld colour"). A disputed field never
    tints or turns translucent a photo, nor turns a part translucent that one reading makes
    opaque:

    - a textured part: opaque white (the photo alone gives the colour, as for OBJ);
    - all four bytes zero: opaque white ("no colour set" in practice);
    - else B,G,R,A (:func:`color_rgba`) when that reading is opaque (last byte 0xFF), else
      A,R,G,B when that one is (first byte 0xFF), else B,G,R,A (translucent in both readings).
    """
    if textured or raw == b"\x00\x00\x00\x00":
        return (1.0, 1.0, 1.0, 1.0)
    if raw[3] != 0xFF and raw[0] == 0xFF:
        return (raw[1] / 255.0, raw[2] / 255.0, raw[3] / 255.0, 1.0)  # read as A,R,G,B
    return color_rgba(raw)


def _check_base(
    local: np.ndarray, center: np.ndarray, reference: GeoPoint, xdo_path: Path, problems: list
) -> None:
    """Report a model whose base or centre is far from the ``.dat`` reference (local metres)."""
    # Per axis from a transposed copy: numpy's axis-0 reductions of an (n, 3) array cost 6x more.
    axes = local.T.copy()
    middle = (axes.min(axis=1) + axes.max(axis=1)) / 2.0  # metres, local East/Up/North
    offset = math.hypot(middle[0], middle[2])
    if offset > CENTRE_MISMATCH_M:
        problems.append(
            f"{xdo_path.name}: model centre is {offset:.0f} m from the .dat centre lon/lat; positions kept relative to the .dat centre"
        )
    base = float(axes[1].min())  # metres above the reference (Up)
    if abs(base) > ALTITUDE_MISMATCH_M:
        box_height = float(np.linalg.norm(center)) - EARTH_RADIUS_M
        problems.append(
            f"{xdo_path.name}: model base is {base:+.1f} m from the .dat altitude {reference.elev:.1f} m "
            f"(bounding-box centre height {box_height:.1f} m); positions kept relative to the .dat altitude"
        )


def _texture(folder: Path, raw_name: bytes, problems: list) -> Texture | None:
    """The texture a mesh names, or None with a ``problems`` entry naming the file."""
    name = decode_text(raw_name)
    try:
        path = _find(folder, raw_name)
    except OutsideInput as refused:
        problems.append(f"texture refused: {refused}: exported untextured")
        return None
    if path is None:
        problems.append(f"texture {name} missing: exported untextured")
        return None
    try:
        return read_texture_file(path, path.name)
    except TextureFileError as problem:
        problems.append(f"texture {name} {problem}: exported untextured")
        return None


# --------------------------------------------------------------------------- write


def write_tile(
    folder: str | Path, tile: TileId, buildings: list[Building], *, version: int = 2
) -> list[Path]:
    """Write ``buildings`` as a VWorld tile: ``<level>_<idx>_<idy>.dat``, one ``.xdo`` each, textures.

    Local East/Up/North positions (metres, at each ``Building.reference``) become float32 offsets
    from the bounding-box centre in the VWorld global frame; the ``.dat`` records the reference
    lon/lat and its elevation (as float32). Triangles keep their (outward) order, which is outward
    in the VWorld global frame too, and the normals (``Part.normals`` or computed from the
    triangles) are rotated with the positions. ``Part.color`` is stored as B,G,R,A bytes, each
    texture's bytes unchanged, thumbnails empty.

    ``version`` 1 (3.0.0.1) takes exactly one part per building, 2 (3.0.0.2) 1 to 255. Raises
    ValueError for what the format cannot hold (a part with more than 65535 vertices, a string over
    255 bytes, a wrong number of parts). Returns the written paths, the ``.dat`` first.
    """
    if version not in (1, 2):
        raise ValueError(f"version must be 1 (3.0.0.1) or 2 (3.0.0.2), got {version!r}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    records: list[DatObject] = []
    used_stems: set[str] = set()
    texture_files: dict[str, bytes] = {}
    for number, building in enumerate(buildings):
        stem = _unique(_safe_name(building.id) or f"building{number}", used_stems)
        xdo, record, textures = _building_files(building, number, stem, version, texture_files)
        written.append(
            write_bytes_atomic(folder / record.data_file.decode("utf-8"), serialise_xdo(xdo))
        )
        for name, data in textures:
            written.append(write_bytes_atomic(folder / name, data))
        records.append(record)
    dat = DatFile(tile.level, tile.idx, tile.idy, records)
    dat_path = write_bytes_atomic(folder / f"{tile.name}.dat", serialise_dat(dat))
    return [dat_path] + written


def _safe_name(text: str) -> str:
    # \w keeps non-ASCII letters; 60 characters stay under the 255-byte string limit in UTF-8.
    return re.sub(r"[^\w.-]", "_", text).strip("._")[:60]


def _building_files(
    building: Building, number: int, stem: str, version: int, texture_files: dict
) -> tuple:
    """(XdoFile, DatObject, [(texture file name, bytes) to write]) of one building."""
    parts = building.parts
    if version == 1 and len(parts) != 1:
        raise ValueError(
            f"building {building.id!r}: .xdo 3.0.0.1 holds exactly one part, got {len(parts)}; use version=2"
        )
    if not 1 <= len(parts) <= MAX_MESHES:
        raise ValueError(
            f"building {building.id!r}: .xdo 3.0.0.2 holds 1 to {MAX_MESHES} parts, got {len(parts)}"
        )
    for j, part in enumerate(parts):
        if part.vertex_count > MAX_PART_VERTICES:
            raise ValueError(
                f"building {building.id!r} part {j}: {part.vertex_count} vertices; .xdo indices are u16, at most {MAX_PART_VERTICES} vertices a part"
            )
        if part.vertex_count == 0 or part.triangle_count == 0:
            raise ValueError(f"building {building.id!r} part {j}: no triangles")
    altitude = np.float32(building.reference.elev)
    reference = GeoPoint(building.reference.lon, building.reference.lat, float(altitude))
    rotation = enu_rotation(reference.lon, reference.lat)
    global_parts = [local_to_global(p.positions, reference) for p in parts]
    everything = np.concatenate(global_parts)
    bbox = tuple(float(v) for v in np.concatenate([everything.min(axis=0), everything.max(axis=0)]))
    center = (everything.min(axis=0) + everything.max(axis=0)) / 2.0

    meshes, new_textures = [], []
    for j, (part, positions) in enumerate(zip(parts, global_parts)):
        normals = (
            part.normals
            if part.normals is not None
            else vertex_normals(part.positions, part.triangles)
        )
        uvs = part.uvs if part.uvs is not None else np.zeros((part.vertex_count, 2), np.float32)
        vertices = np.hstack(
            [positions - center, np.asarray(normals, np.float64) @ rotation, uvs]
        ).astype("<f4")
        image_name = b""
        if part.texture is not None:
            name = _texture_name(part.texture, f"{stem}_{j}", texture_files)
            if name not in texture_files:
                texture_files[name] = part.texture.data
                new_textures.append((name, part.texture.data))
            image_name = name.encode("utf-8")
        meshes.append(
            XdoMesh(
                vertices,
                part.triangles.reshape(-1).astype("<u2"),
                color_bytes(part.color),
                0,
                image_name,
                b"",
            )
        )
    key = building.id.encode("utf-8")
    xdo = XdoFile(version, XDO_TYPE, number, key, bbox, altitude, meshes)
    record = DatObject(
        version_bytes(version),
        XDO_TYPE,
        key,
        reference.lon,
        reference.lat,
        altitude,
        bbox,
        0,
        f"{stem}.xdo".encode(),
        meshes[0].image_name,
    )
    return xdo, record, new_textures


def _texture_name(texture: Texture, fallback: str, taken: dict) -> str:
    """A file name for a texture: its own (when free or holding the same bytes), else a new one."""
    extension = ".png" if texture.mime == "image/png" else ".jpg"
    stem, suffix = os.path.splitext(Path(texture.name.replace("\\", "/")).name)
    stem = _safe_name(stem) or fallback
    matching = {"image/jpeg": (".jpg", ".jpeg"), "image/png": (".png",)}.get(texture.mime, ())
    suffix = suffix.lower() if suffix.lower() in matching else extension
    name = stem + suffix
    candidate, n = name, 1
    while candidate in taken and taken[candidate] != texture.data:
        n += 1
        candidate = f"{stem}~{n}{suffix}"
    return candidate
