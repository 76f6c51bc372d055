"""VWorld ``.dat`` tile indexes and ``.xdo`` building models: parse and serialise, byte for byte.

Data form (all little-endian; a *string* is one u8 length then that many raw bytes, no terminator):

- ``.dat``: ``level, idx, idy, object_count`` (4 x u32), then per object ``version`` (4 x u8, e.g.
  3,0,0,2; the last byte selects the ``.xdo`` layout), ``type`` u8, ``key`` string,
  ``center_lon, center_lat`` (2 x f64, degrees), ``altitude`` f32 (metres), bounding box 6 x f64
  (min x, y, z, max x, y, z; metres, VWorld global frame), ``img_level`` u8, ``data_file`` string
  (the ``.xdo`` name), ``img_file_name`` string.
- ``.xdo``: ``type`` u8 (8), ``object_id`` u32, ``key`` string, bounding box 6 x f64 (metres, VWorld
  global frame), ``altitude`` f32 (metres); version 3.0.0.1 then holds exactly one mesh block,
  3.0.0.2 a ``face_count`` u8 and that many mesh blocks. A mesh block is ``vertex_count`` u32,
  ``vertex_count`` x 8 f32 (position x, y, z = metre offsets from the bounding-box centre in the
  VWorld global frame; normal x, y, z in that frame; u, v with the origin top-left), ``index_count``
  u32 and that many u16 (a triangle list), ``color`` 4 bytes, ``image_level`` u8, ``image_name``
  string, then a thumbnail (``size`` u32 + ``size`` bytes of JPEG) -- which some writers leave out
  when ``image_name`` is empty.

Disputed points and how they are settled here:

- thumbnail with an empty ``image_name``: both readings are tried and the one that ends exactly at
  the end of the file is kept (one reading per file); :attr:`XdoMesh.thumbnail` is ``None`` when
  the field is absent, so serialising reproduces the file.
- colour byte order (A,R,G,B or B,G,R,A): the 4 raw bytes are kept; :func:`color_rgba` reads them
  as B,G,R,A, i.e. one little-endian u32 ``0xAARRGGBB`` (Direct3D's ``D3DCOLOR``), which is the
  same bytes the A,R,G,B readers describe as a u32. The reader's colour for a part
  (:func:`exporter.readers.vworld.part_color`) also tries the A,R,G,B reading and ignores the
  field on textured parts (docs/input.md "VWorld colour").
- string encodings: raw bytes are kept; :func:`decode_text` tries UTF-8, then EUC-KR, then
  Latin-1 (which never fails), for display and ids only.
- ``.xdo`` version unknown: both layouts are tried, keeping the one that parses to the exact end.

Every count read from a header is checked against the bytes left before anything is allocated,
and bad input raises only :class:`exporter.errors.ReadError` naming the file and the problem.
The VWorld service answers errors with XML (e.g. ``ERROR_SERVICE_FILE_NOTTHING``); such a file is
reported as an XML error page.

Sources: ``docs/reference/vworld-formats.md`` (compiled from several public VWorld readers in
Java, C#, C++, Rust and TypeScript, which agree on this layout except on the points above).
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass, field

import numpy as np

from ..errors import ReadError

XDO_TYPE = 8  # the .xdo header's type byte, always 8 in known files
VERSION_PREFIX = (3, 0, 0)  # .dat version bytes are 3,0,0,<xdo layout>
XDO_VERSIONS = (1, 2)  # 1 = 3.0.0.1 (one mesh), 2 = 3.0.0.2 (face_count u8, up to 255 meshes)
VERTEX_FLOATS = 8  # x, y, z, nx, ny, nz, u, v as f32
VERTEX_BYTES = 4 * VERTEX_FLOATS
MAX_STRING_BYTES = 255
MAX_MESHES = 255
MAX_INDEX = 65535  # u16 indices

# Smallest possible encodings, used to check counts before allocating.
_DAT_OBJECT_MIN_BYTES = 4 + 1 + 1 + 16 + 4 + 48 + 1 + 1 + 1
_MESH_MIN_BYTES = 4 + 4 + 4 + 1 + 1  # without a thumbnail field

_XML_CODE = re.compile(rb"[A-Z][A-Z0-9]*_[A-Z0-9_]{3,}")


# --------------------------------------------------------------------------- data classes


@dataclass
class DatObject:
    """One object record of a ``.dat``. Strings are raw bytes (see :func:`decode_text`)."""

    version: bytes  # 4 raw bytes, e.g. b"\x03\x00\x00\x02"
    type: int
    key: bytes
    center_lon: float  # degrees
    center_lat: float  # degrees
    altitude: np.float32  # metres; numpy float32 so any bit pattern round-trips
    bbox: tuple  # 6 floats: min x, y, z, max x, y, z; metres, VWorld global frame
    img_level: int
    data_file: bytes  # the .xdo file name
    img_file_name: bytes

    @property
    def xdo_version(self) -> int | None:
        """The ``.xdo`` layout the record declares (1 or 2), or None when the bytes are unknown."""
        return xdo_version_of(self.version)


@dataclass
class DatFile:
    """A ``.dat`` tile index: the tile address and its object records.

    ``trailing`` keeps bytes after the last record (none in well-formed files) so serialising
    reproduces the input.
    """

    level: int
    idx: int
    idy: int
    objects: list[DatObject] = field(default_factory=list)
    trailing: bytes = b""


@dataclass
class XdoMesh:
    """One mesh block of an ``.xdo``.

    ``vertices`` (n, 8) float32: position x, y, z (metre offsets from the bounding-box centre,
    VWorld global frame), normal x, y, z (same frame), u, v (origin top-left). ``indices`` (k,)
    uint16, a triangle list. ``thumbnail`` is None when the field is absent (only possible with an
    empty ``image_name``).
    """

    vertices: np.ndarray
    indices: np.ndarray
    color: bytes  # 4 raw bytes, see color_rgba
    image_level: int
    image_name: bytes
    thumbnail: bytes | None = b""

    @property
    def positions(self) -> np.ndarray:
        """(n, 3) float32 metre offsets from the bounding-box centre, VWorld global frame."""
        return self.vertices[:, 0:3]

    @property
    def normals(self) -> np.ndarray:
        """(n, 3) float32 normals, VWorld global frame."""
        return self.vertices[:, 3:6]

    @property
    def uvs(self) -> np.ndarray:
        """(n, 2) float32 texture coordinates, origin top-left."""
        return self.vertices[:, 6:8]


@dataclass
class XdoFile:
    """An ``.xdo`` building model; ``version`` 1 (3.0.0.1) or 2 (3.0.0.2)."""

    version: int
    type: int
    object_id: int
    key: bytes
    bbox: tuple  # 6 floats: min x, y, z, max x, y, z; metres, VWorld global frame
    altitude: np.float32  # metres
    meshes: list[XdoMesh] = field(default_factory=list)

    @property
    def bbox_center(self) -> np.ndarray:
        """(3,) float64 centre of the bounding box, metres, VWorld global frame."""
        box = np.asarray(self.bbox, dtype=np.float64)
        return (box[:3] + box[3:]) / 2.0


# --------------------------------------------------------------------------- small helpers


def decode_text(raw: bytes) -> str:
    """Display text of a raw string: UTF-8, else EUC-KR, else Latin-1 (never fails)."""
    for encoding in ("utf-8", "euc-kr"):
        try:
            return raw.decode(encoding)
        except UnicodeDecodeError:
            continue
    return raw.decode("latin-1")


def color_rgba(raw: bytes) -> tuple:
    """RGBA in 0..1 from the 4 colour bytes, read as B, G, R, A (little-endian ``0xAARRGGBB``)."""
    if len(raw) != 4:
        raise ValueError(f"a colour is 4 bytes, got {len(raw)}")
    b, g, r, a = raw
    return (r / 255.0, g / 255.0, b / 255.0, a / 255.0)


def color_bytes(rgba) -> bytes:
    """The 4 colour bytes (B, G, R, A) for RGBA in 0..1; the inverse of :func:`color_rgba`."""
    r, g, b, a = (int(round(min(max(float(c), 0.0), 1.0) * 255.0)) for c in rgba)
    return bytes((b, g, r, a))


def version_bytes(xdo_version: int) -> bytes:
    """The ``.dat`` version bytes 3,0,0,<xdo_version>."""
    if xdo_version not in XDO_VERSIONS:
        raise ValueError(f"xdo version must be one of {XDO_VERSIONS}, got {xdo_version!r}")
    return bytes((*VERSION_PREFIX, xdo_version))


def xdo_version_of(version: bytes) -> int | None:
    """1 or 2 for the version bytes 3,0,0,1 / 3,0,0,2; None for anything else."""
    if len(version) == 4 and tuple(version[:3]) == VERSION_PREFIX and version[3] in XDO_VERSIONS:
        return version[3]
    return None


def xml_error(data: bytes) -> str | None:
    """None unless ``data`` is XML (a VWorld error page); then the error code or the first text."""
    head = bytes(data[:4096]).lstrip(b"\xef\xbb\xbf \t\r\n")
    if not head.startswith(b"<"):
        return None
    code = _XML_CODE.search(head)
    if code:
        return code.group(0).decode("ascii")
    return decode_text(head[:80]).replace("\n", " ").strip()


# --------------------------------------------------------------------------- reading


class _Malformed(Exception):
    """Internal: the bytes do not fit the layout; ``offset`` is how far parsing got."""

    def __init__(self, problem: str, offset: int) -> None:
        super().__init__(problem)
        self.problem, self.offset = problem, offset


_U32 = struct.Struct("<I")


class _Cursor:
    """Reads little-endian fields from ``data``, checking the bytes left before every read.

    The readers check and advance inline (no call to :meth:`need` on the success path): a file
    is tens of thousands of fields in a tile, each a few method calls otherwise.
    """

    def __init__(self, data: bytes) -> None:
        self.data, self.pos, self.end = data, 0, len(data)

    @property
    def left(self) -> int:
        return self.end - self.pos

    def need(self, size: int, what: str) -> None:
        if size > self.end - self.pos:
            raise _Malformed(
                f"truncated: {what} needs {size} bytes at offset {self.pos}, only {self.left} left",
                self.pos,
            )

    def take(self, size: int, what: str) -> bytes:
        pos = self.pos
        if size > self.end - pos:
            self.need(size, what)
        self.pos = pos + size
        return self.data[pos : pos + size]

    def u8(self, what: str) -> int:
        pos = self.pos
        if pos >= self.end:
            self.need(1, what)
        self.pos = pos + 1
        return self.data[pos]

    def u32(self, what: str) -> int:
        pos = self.pos
        if 4 > self.end - pos:
            self.need(4, what)
        self.pos = pos + 4
        return _U32.unpack_from(self.data, pos)[0]

    def f32(self, what: str) -> np.float32:
        return np.frombuffer(self.take(4, what), dtype="<f4")[0]

    def f64s(self, count: int, what: str) -> tuple:
        return struct.unpack(f"<{count}d", self.take(8 * count, what))

    def string(self, what: str) -> bytes:
        return self.take(self.u8(f"{what} length"), what)

    def count(self, what: str, item_bytes: int) -> int:
        """A u32 count of items of ``item_bytes`` each, refused when the bytes left cannot hold it."""
        start = self.pos
        count = self.u32(what)
        if count * item_bytes > self.end - self.pos:
            raise _Malformed(
                f"truncated or corrupt: {what} {count} at offset {start} needs {count * item_bytes} bytes, only {self.left} left",
                start,
            )
        return count

    def array(self, count: int, dtype: str, what: str) -> np.ndarray:
        """``count`` items read straight from the file's bytes (one copy, owned and writeable)."""
        size = count * np.dtype(dtype).itemsize
        self.need(size, what)
        out = np.frombuffer(self.data, dtype=dtype, count=count, offset=self.pos).copy()
        self.pos += size
        return out


def _check_bytes(data, path: str, kind: str) -> bytes:
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise TypeError(f"{kind} data must be bytes, got {type(data).__name__}")
    data = bytes(data)
    if not data:
        raise ReadError(path, f"empty file (0 bytes), not a {kind}")
    code = xml_error(data)
    if code is not None:
        raise ReadError(
            path, f"is an XML error page from the VWorld service ({code}), not a {kind}"
        )
    return data


def parse_dat(data: bytes, path: str) -> DatFile:
    """Parse a ``.dat`` tile index; ``path`` only names the file in errors.

    Raises :class:`ReadError` for an empty, truncated or XML file.
    """
    data = _check_bytes(data, path, ".dat tile index")
    cursor = _Cursor(data)
    try:
        level, idx, idy = (cursor.u32(name) for name in ("level", "IDX", "IDY"))
        count = cursor.count("object_count", _DAT_OBJECT_MIN_BYTES)
        objects = []
        for i in range(count):
            what = f"object {i}"
            version = cursor.take(4, f"{what} version")
            kind = cursor.u8(f"{what} type")
            key = cursor.string(f"{what} key")
            lon, lat = cursor.f64s(2, f"{what} centre lon/lat")
            altitude = cursor.f32(f"{what} altitude")
            bbox = cursor.f64s(6, f"{what} bounding box")
            img_level = cursor.u8(f"{what} img_level")
            data_file = cursor.string(f"{what} data_file")
            img_file = cursor.string(f"{what} img_file_name")
            objects.append(
                DatObject(
                    version, kind, key, lon, lat, altitude, bbox, img_level, data_file, img_file
                )
            )
    except _Malformed as error:
        raise ReadError(path, f"not a valid .dat tile index: {error.problem}") from None
    return DatFile(level, idx, idy, objects, trailing=data[cursor.pos :])


def _parse_mesh(
    cursor: _Cursor, what: str, thumbnail_when_empty: bool, seen_empty: list
) -> XdoMesh:
    vertex_count = cursor.count(f"{what} vertex_count", VERTEX_BYTES)
    vertices = cursor.array(vertex_count * VERTEX_FLOATS, "<f4", f"{what} vertices").reshape(
        -1, VERTEX_FLOATS
    )
    index_count = cursor.count(f"{what} index_count", 2)
    indices = cursor.array(index_count, "<u2", f"{what} indices")
    color = cursor.take(4, f"{what} color")
    image_level = cursor.u8(f"{what} image_level")
    image_name = cursor.string(f"{what} image_name")
    if not image_name:
        seen_empty.append(True)
    thumbnail: bytes | None = None
    if image_name or thumbnail_when_empty:
        thumbnail = cursor.take(cursor.count(f"{what} thumbnail size", 1), f"{what} thumbnail")
    return XdoMesh(vertices, indices, color, image_level, image_name, thumbnail)


def _parse_xdo_layout(
    data: bytes, version: int, thumbnail_when_empty: bool, seen_empty: list
) -> XdoFile:
    cursor = _Cursor(data)
    kind = cursor.u8("type")
    object_id = cursor.u32("object_id")
    key = cursor.string("key")
    bbox = cursor.f64s(6, "bounding box")
    altitude = cursor.f32("altitude")
    if version == 1:
        mesh_count = 1
    else:
        mesh_count = cursor.u8("face_count")
        if mesh_count * _MESH_MIN_BYTES > cursor.left:
            raise _Malformed(
                f"truncated or corrupt: face_count {mesh_count} needs at least {mesh_count * _MESH_MIN_BYTES} bytes, only {cursor.left} left",
                cursor.pos - 1,
            )
    meshes = [
        _parse_mesh(cursor, f"mesh {i}", thumbnail_when_empty, seen_empty)
        for i in range(mesh_count)
    ]
    if cursor.left:
        raise _Malformed(
            f"{cursor.left} bytes left over after the last mesh (offset {cursor.pos})", cursor.pos
        )
    return XdoFile(version, kind, object_id, key, bbox, altitude, meshes)


def _first_reading(data: bytes, version: int | None, read) -> tuple:
    """``(reading, None)``: what ``read(data, layout, thumbnail_when_empty, seen_empty)`` gives
    for the first reading of :func:`parse_xdo`'s order that parses to the exact end, or
    ``(None, (layout, _Malformed))`` of the reading that got furthest when none does."""
    best: tuple[int, _Malformed] | None = None
    for layout in [version] if version else [2, 1]:
        for thumbnail_when_empty in (True, False):
            seen_empty: list = []
            try:
                return read(data, layout, thumbnail_when_empty, seen_empty), None
            except _Malformed as error:
                if best is None or error.offset > best[1].offset:
                    best = (layout, error)
            if not seen_empty:
                break  # no empty image_name met: the other thumbnail reading is the same reading
    return None, best


def _check_version(version: int | None) -> None:
    if version is not None and version not in XDO_VERSIONS:
        raise ValueError(f"version must be None or one of {XDO_VERSIONS}, got {version!r}")


def parse_xdo(data: bytes, path: str, version: int | None = None) -> XdoFile:
    """Parse an ``.xdo`` building model; ``path`` only names the file in errors.

    ``version`` is 1 (3.0.0.1), 2 (3.0.0.2) or None (unknown: both layouts are tried). Of the
    readings tried (layouts x thumbnail present/absent with an empty ``image_name``) the first one
    that parses to the exact end of the file is returned. Raises :class:`ReadError` otherwise,
    quoting the reading that got furthest.
    """
    _check_version(version)
    data = _check_bytes(data, path, ".xdo model")
    xdo, best = _first_reading(data, version, _parse_xdo_layout)
    if xdo is not None:
        return xdo
    assert best is not None  # every reading tried either returned or failed
    layout, furthest = best
    tried = f"3.0.0.{layout}" if version else f"3.0.0.1 or 3.0.0.2 (closest: 3.0.0.{layout})"
    raise ReadError(path, f"not a valid .xdo {tried}: {furthest.problem}")


def _layout_image_names(
    data: bytes, version: int, thumbnail_when_empty: bool, seen_empty: list
) -> list[bytes]:
    """The meshes' ``image_name`` in one reading, as :func:`_parse_xdo_layout` reads it: the same
    fields and bounds checks, but the arrays and the thumbnail skipped by their byte counts. A
    failed check raises :class:`_Malformed` with an empty problem (the caller then asks
    :func:`parse_xdo` for its words)."""
    end = len(data)
    # type u8, object_id u32, key length u8; then the key, bbox 6 x f64, altitude f32
    if end < 6:
        raise _Malformed("", 0)
    pos = 6 + data[5] + 48 + 4
    mesh_count = 1
    if version == 2:
        if pos >= end:
            raise _Malformed("", pos)
        mesh_count = data[pos]
        pos += 1
        if mesh_count * _MESH_MIN_BYTES > end - pos:
            raise _Malformed("", pos)
    names = []
    unpack = _U32.unpack_from
    for _ in range(mesh_count):
        if pos + 4 > end:
            raise _Malformed("", pos)
        pos += 4 + VERTEX_BYTES * unpack(data, pos)[0]
        if pos + 4 > end:  # also a vertex array running past the end
            raise _Malformed("", pos)
        pos += 4 + 2 * unpack(data, pos)[0]
        if pos + 6 > end:  # color 4 bytes, image_level u8, image_name length u8
            raise _Malformed("", pos)
        name_end = pos + 6 + data[pos + 5]
        if name_end > end:
            raise _Malformed("", pos)
        name = data[pos + 6 : name_end]
        pos = name_end
        if not name:
            seen_empty.append(True)
        if name or thumbnail_when_empty:
            if pos + 4 > end:
                raise _Malformed("", pos)
            pos += 4 + unpack(data, pos)[0]
            if pos > end:
                raise _Malformed("", pos)
        names.append(name)
    if pos != end:
        raise _Malformed("", pos)
    return names


def xdo_image_names(data: bytes, path: str, version: int | None = None) -> list[bytes]:
    """``[mesh.image_name for mesh in parse_xdo(data, path, version).meshes]`` (raw bytes, mesh
    order), without building the vertex and index arrays: a scan wants only the texture names.

    The readings are tried in :func:`parse_xdo`'s order with the same bounds; when none parses to
    the end, :func:`parse_xdo` itself decides (and raises its :class:`ReadError`).
    """
    _check_version(version)
    data = _check_bytes(data, path, ".xdo model")
    names, _ = _first_reading(data, version, _layout_image_names)
    if names is not None:
        return names
    return [mesh.image_name for mesh in parse_xdo(data, path, version).meshes]


# --------------------------------------------------------------------------- writing


def _string(raw: bytes, what: str) -> bytes:
    raw = bytes(raw)
    if len(raw) > MAX_STRING_BYTES:
        raise ValueError(
            f"{what} is {len(raw)} bytes; a VWorld string holds at most {MAX_STRING_BYTES}"
        )
    return bytes((len(raw),)) + raw


def _f32(value) -> bytes:
    return np.asarray(value, dtype="<f4").reshape(()).tobytes()


def _bbox(values, what: str) -> bytes:
    values = tuple(values)
    if len(values) != 6:
        raise ValueError(f"{what} needs 6 numbers (min x, y, z, max x, y, z), got {len(values)}")
    return struct.pack("<6d", *values)


def serialise_dat(dat: DatFile) -> bytes:
    """The bytes of a ``.dat``; ``parse_dat(serialise_dat(d))`` equals ``d``. ValueError on bad fields."""
    out = [struct.pack("<4I", dat.level, dat.idx, dat.idy, len(dat.objects))]
    for i, obj in enumerate(dat.objects):
        if len(obj.version) != 4:
            raise ValueError(f"object {i}: version must be 4 bytes, got {len(obj.version)}")
        out += [
            bytes(obj.version),
            struct.pack("<B", obj.type),
            _string(obj.key, f"object {i} key"),
            struct.pack("<2d", obj.center_lon, obj.center_lat),
            _f32(obj.altitude),
            _bbox(obj.bbox, f"object {i} bbox"),
            struct.pack("<B", obj.img_level),
            _string(obj.data_file, f"object {i} data_file"),
            _string(obj.img_file_name, f"object {i} img_file_name"),
        ]
    out.append(bytes(dat.trailing))
    return b"".join(out)


def _mesh_bytes(mesh: XdoMesh, what: str) -> list:
    vertices = np.asarray(mesh.vertices)
    if vertices.ndim != 2 or vertices.shape[1] != VERTEX_FLOATS:
        raise ValueError(
            f"{what}: vertices must have shape (n, {VERTEX_FLOATS}), got {vertices.shape}"
        )
    indices = np.asarray(mesh.indices)
    if indices.size and (indices.min() < 0 or indices.max() > MAX_INDEX):
        raise ValueError(f"{what}: indices must fit u16 (0..{MAX_INDEX})")
    if len(mesh.color) != 4:
        raise ValueError(f"{what}: color must be 4 bytes, got {len(mesh.color)}")
    if mesh.thumbnail is None and mesh.image_name:
        raise ValueError(
            f"{what}: a mesh with an image_name always carries a thumbnail field (use b'')"
        )
    out = [
        struct.pack("<I", len(vertices)),
        vertices.astype("<f4", copy=False).tobytes(),
        struct.pack("<I", indices.size),
        indices.astype("<u2").tobytes(),
        bytes(mesh.color),
        struct.pack("<B", mesh.image_level),
        _string(mesh.image_name, f"{what} image_name"),
    ]
    if mesh.thumbnail is not None:
        out += [struct.pack("<I", len(mesh.thumbnail)), bytes(mesh.thumbnail)]
    return out


def serialise_xdo(xdo: XdoFile) -> bytes:
    """The bytes of an ``.xdo``; ``parse_xdo(serialise_xdo(x), p, x.version)`` equals ``x``.

    ValueError when the model cannot be written in its version's layout (3.0.0.1 holds exactly one
    mesh, 3.0.0.2 up to 255) or could not be read back unambiguously (meshes with an empty
    ``image_name`` must all have a thumbnail field or all lack it).
    """
    if xdo.version not in XDO_VERSIONS:
        raise ValueError(f"version must be one of {XDO_VERSIONS}, got {xdo.version!r}")
    if xdo.version == 1 and len(xdo.meshes) != 1:
        raise ValueError(f".xdo 3.0.0.1 holds exactly one mesh, got {len(xdo.meshes)}")
    if len(xdo.meshes) > MAX_MESHES:
        raise ValueError(f".xdo 3.0.0.2 holds at most {MAX_MESHES} meshes, got {len(xdo.meshes)}")
    empty_thumbnails = {m.thumbnail is None for m in xdo.meshes if not m.image_name}
    if len(empty_thumbnails) > 1:
        raise ValueError(
            "meshes with an empty image_name must all have a thumbnail field or all lack it"
        )
    out = [
        struct.pack("<BI", xdo.type, xdo.object_id),
        _string(xdo.key, "key"),
        _bbox(xdo.bbox, "bbox"),
        _f32(xdo.altitude),
    ]
    if xdo.version == 2:
        out.append(struct.pack("<B", len(xdo.meshes)))
    for i, mesh in enumerate(xdo.meshes):
        out += _mesh_bytes(mesh, f"mesh {i}")
    return b"".join(out)
