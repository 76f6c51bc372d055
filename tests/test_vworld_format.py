"""The VWorld ``.dat``/``.xdo`` byte layouts: byte-for-byte round trips and the disputed points."""

from __future__ import annotations

import struct
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from exporter.errors import ReadError
from exporter.formats import vworld_binary
from exporter.formats.vworld_binary import (
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
    xdo_version_of,
    xml_error,
)

XML_PAGE = b'<?xml version="1.0" encoding="UTF-8"?>\n<response><error>ERROR_SERVICE_FILE_NOTTHING</error></response>'


def mesh(seed: int, n: int = 4, name: bytes = b"tex.jpg", thumbnail: bytes | None = b"") -> XdoMesh:
    rng = np.random.default_rng(seed)
    vertices = rng.normal(size=(n, 8)).astype(np.float32)
    indices = rng.integers(0, n, size=3 * (n - 1)).astype(np.uint16)
    return XdoMesh(vertices, indices, bytes((10, 20, 30, 255)), seed % 7, name, thumbnail)


def xdo(version: int, meshes: list[XdoMesh], key: bytes = b"BLD_0001") -> XdoFile:
    box = (-3041018.4, -4038791.05, 3888655.1, -3041002.5, -4038774.5, 3888667.2)
    return XdoFile(version, 8, 12345, key, box, np.float32(38.25), meshes)


def assert_same_xdo(a: XdoFile, b: XdoFile) -> None:
    assert (a.version, a.type, a.object_id, a.key, a.bbox) == (
        b.version,
        b.type,
        b.object_id,
        b.key,
        b.bbox,
    )
    assert np.float32(a.altitude).tobytes() == np.float32(b.altitude).tobytes()
    assert len(a.meshes) == len(b.meshes)
    for m, n in zip(a.meshes, b.meshes):
        assert np.array_equal(m.vertices, n.vertices) and np.array_equal(m.indices, n.indices)
        assert (m.color, m.image_level, m.image_name, m.thumbnail) == (
            n.color,
            n.image_level,
            n.image_name,
            n.thumbnail,
        )


# --------------------------------------------------------------------------- .xdo round trips


def test_version1_single_mesh_round_trips_byte_for_byte():
    original = xdo(1, [mesh(1, thumbnail=b"\xff\xd8tiny-jpeg\xff\xd9")])
    data = serialise_xdo(original)
    parsed = parse_xdo(data, "a.xdo", 1)
    assert_same_xdo(parsed, original)
    assert serialise_xdo(parsed) == data
    # Layout check independent of the parser: header is 1 + 4 + (1 + 8) + 48 + 4 bytes, then vertex_count.
    assert struct.unpack_from("<I", data, 1 + 4 + 9 + 48 + 4)[0] == 4


def test_version2_multi_mesh_round_trips_and_unknown_version_is_detected():
    original = xdo(2, [mesh(2, 5, b"a.jpg"), mesh(3, 3, b"b.jpg"), mesh(4, 6, b"c.jpg")])
    data = serialise_xdo(original)
    assert data[1 + 4 + 9 + 48 + 4] == 3  # face_count
    parsed = parse_xdo(data, "b.xdo", None)
    assert parsed.version == 2
    assert_same_xdo(parsed, original)
    assert serialise_xdo(parsed) == data
    v1 = serialise_xdo(xdo(1, [mesh(5)]))
    assert parse_xdo(v1, "c.xdo", None).version == 1


@pytest.mark.parametrize("thumbnail", [None, b"", b"\xff\xd8thumb\xff\xd9"])
@pytest.mark.parametrize("version", [1, 2])
def test_empty_image_name_with_and_without_thumbnail(version, thumbnail):
    meshes = [mesh(6, name=b"", thumbnail=thumbnail)]
    if version == 2:
        meshes = [
            mesh(7, name=b"", thumbnail=thumbnail),
            mesh(8, name=b"x.jpg"),
            mesh(9, name=b"", thumbnail=thumbnail),
        ]
    original = xdo(version, meshes)
    data = serialise_xdo(original)
    for declared in (version, None):
        parsed = parse_xdo(data, "e.xdo", declared)
        assert [m.thumbnail for m in parsed.meshes] == [m.thumbnail for m in meshes]
        assert serialise_xdo(parsed) == data


def test_declared_version_that_does_not_fit_is_refused():
    data = serialise_xdo(xdo(2, [mesh(10), mesh(11)]))
    with pytest.raises(ReadError, match=r"d\.xdo.*3\.0\.0\.1"):
        parse_xdo(data, "d.xdo", 1)


@pytest.mark.parametrize(
    "text,encoding", [("서울시청", "utf-8"), ("서울시청", "euc-kr"), ("Gebäude", "utf-8")]
)
def test_non_ascii_keys_keep_raw_bytes_and_decode(text, encoding):
    raw = text.encode(encoding)
    original = xdo(2, [mesh(12, name=f"{text}.jpg".encode(encoding))], key=raw)
    data = serialise_xdo(original)
    parsed = parse_xdo(data, "k.xdo", 2)
    assert parsed.key == raw and serialise_xdo(parsed) == data
    assert decode_text(parsed.key) == text
    assert decode_text(parsed.meshes[0].image_name) == f"{text}.jpg"


def test_undecodable_strings_fall_back_to_latin1():
    raw = b"\xff\xfe\x80bad"
    assert decode_text(raw) == raw.decode("latin-1")


def test_signalling_nan_altitude_round_trips():
    data = bytearray(serialise_xdo(xdo(1, [mesh(13)])))
    data[1 + 4 + 9 + 48 : 1 + 4 + 9 + 48 + 4] = bytes.fromhex("0100807f")  # a signalling NaN f32
    assert serialise_xdo(parse_xdo(bytes(data), "n.xdo", 1)) == bytes(data)


# --------------------------------------------------------------------------- .dat


def dat_object(i: int, key: bytes) -> DatObject:
    return DatObject(
        version_bytes(2),
        8,
        key,
        126.978 + i * 1e-4,
        37.5665,
        np.float32(38.5 + i),
        (1.0, 2.0, 3.0, 4.0, 5.0, 6.0),
        0,
        key + b".xdo",
        key + b".jpg",
    )


def test_dat_round_trips_byte_for_byte():
    original = DatFile(
        15, 279418, 116113, [dat_object(0, b"A"), dat_object(1, "가나".encode("euc-kr"))]
    )
    data = serialise_dat(original)
    assert struct.unpack_from("<4I", data) == (15, 279418, 116113, 2)
    parsed = parse_dat(data, "t.dat")
    assert (parsed.level, parsed.idx, parsed.idy) == (15, 279418, 116113)
    assert [o.key for o in parsed.objects] == [b"A", "가나".encode("euc-kr")]
    assert parsed.objects[1].center_lon == pytest.approx(126.9781) and parsed.objects[
        1
    ].altitude == np.float32(39.5)
    assert parsed.objects[0].xdo_version == 2
    assert serialise_dat(parsed) == data
    with_trailing = data + b"\x00\x00"
    assert parse_dat(with_trailing, "t.dat").trailing == b"\x00\x00"
    assert serialise_dat(parse_dat(with_trailing, "t.dat")) == with_trailing


def test_version_bytes():
    assert version_bytes(1) == bytes((3, 0, 0, 1))
    assert xdo_version_of(bytes((3, 0, 0, 2))) == 2
    assert xdo_version_of(bytes((3, 0, 0, 9))) is None
    with pytest.raises(ValueError):
        version_bytes(3)


# --------------------------------------------------------------------------- colours


def test_colour_is_read_as_bgra_and_written_back():
    assert color_rgba(bytes((0, 128, 255, 255))) == pytest.approx((1.0, 128 / 255, 0.0, 1.0))
    assert color_bytes((1.0, 128 / 255, 0.0, 1.0)) == bytes((0, 128, 255, 255))
    # little-endian u32 0xAARRGGBB (D3DCOLOR) is the same four bytes
    assert color_rgba(struct.pack("<I", 0x80FF0000)) == pytest.approx((1.0, 0.0, 0.0, 128 / 255))


# --------------------------------------------------------------------------- bad input


def test_xml_error_page_is_named():
    assert xml_error(XML_PAGE) == "ERROR_SERVICE_FILE_NOTTHING"
    assert xml_error(b"\x08\x00") is None
    with pytest.raises(
        ReadError, match=r"x\.xdo: is an XML error page .*ERROR_SERVICE_FILE_NOTTHING"
    ):
        parse_xdo(XML_PAGE, "x.xdo")
    with pytest.raises(ReadError, match=r"x\.dat: is an XML error page"):
        parse_dat(b"  \n<html>oops</html>", "x.dat")
    with pytest.raises(ReadError, match="empty file"):
        parse_xdo(b"", "x.xdo")


def test_every_truncation_is_a_read_error():
    data = serialise_xdo(xdo(2, [mesh(14, name=b""), mesh(15)]))
    for end in range(len(data)):
        with pytest.raises(ReadError):
            parse_xdo(data[:end], "t.xdo", None)
    dat = serialise_dat(DatFile(15, 1, 2, [dat_object(0, b"K1"), dat_object(1, b"K2")]))
    for end in range(len(dat)):
        with pytest.raises(ReadError):
            parse_dat(dat[:end], "t.dat")


class PerValueCursor(vworld_binary._Cursor):
    """The cursor as first written: every read through ``need`` and ``take``, ``u8`` by slicing,
    ``u32`` by ``struct.unpack``."""

    def take(self, size: int, what: str) -> bytes:
        self.need(size, what)
        chunk = self.data[self.pos : self.pos + size]
        self.pos += size
        return chunk

    def u8(self, what: str) -> int:
        return self.take(1, what)[0]

    def u32(self, what: str) -> int:
        return struct.unpack("<I", self.take(4, what))[0]

    def count(self, what: str, item_bytes: int) -> int:
        start = self.pos
        count = self.u32(what)
        if count * item_bytes > self.left:
            raise vworld_binary._Malformed(
                f"truncated or corrupt: {what} {count} at offset {start} needs {count * item_bytes} bytes, only {self.left} left",
                start,
            )
        return count


def cuts_and_flips(data: bytes) -> list[bytes]:
    """Every cut of ``data`` (itself included) and ``data`` with each byte flipped in turn."""
    cuts = [data[:end] for end in range(len(data) + 1)]
    return cuts + [
        data[:at] + bytes((data[at] ^ 0xA5,)) + data[at + 1 :] for at in range(len(data))
    ]


def outcome(parse, data: bytes, *args) -> str:
    try:
        return repr(parse(data, *args))
    except ReadError as error:
        return f"ReadError: {error}"


def test_inline_cursor_reads_and_refuses_as_the_per_value_one(monkeypatch):
    """Every cut, and a flipped byte at every offset, of an .xdo (both layouts, empty and named
    images) and a .dat: the same parse or the same error text, offsets included."""
    files = [
        (parse_xdo, serialise_xdo(xdo(2, [mesh(14, name=b""), mesh(15)])), "t.xdo", None),
        (parse_xdo, serialise_xdo(xdo(1, [mesh(16, name=b"", thumbnail=None)])), "t.xdo", 1),
        (
            parse_dat,
            serialise_dat(DatFile(15, 1, 2, [dat_object(0, b"K1"), dat_object(1, b"K2")])),
            "t.dat",
        ),
    ]
    variants = [
        (parse, damaged, args) for parse, data, *args in files for damaged in cuts_and_flips(data)
    ]
    inline = [outcome(parse, data, *args) for parse, data, args in variants]
    monkeypatch.setattr(vworld_binary, "_Cursor", PerValueCursor)
    assert inline == [outcome(parse, data, *args) for parse, data, args in variants]
    assert sum(text.startswith("ReadError") for text in inline) > len(inline) // 2


def parsed_names(data: bytes, path: str, version: int | None) -> list[bytes]:
    return [m.image_name for m in parse_xdo(data, path, version).meshes]


def walked_names(data: bytes, version: int | None) -> list[bytes] | None:
    """The names walk alone (no parse_xdo fallback): None when no reading parses to the end."""
    walk = vworld_binary._layout_image_names
    return vworld_binary._first_reading(data, version, walk)[0]


def name_cases() -> list[bytes]:
    """Every .xdo of the repository, generated ones (both layouts, empty names with and without
    a thumbnail, no meshes, an XML page, nothing), and every cut and flipped byte of three."""
    root = Path(__file__).resolve().parents[1]
    found = [p.read_bytes() for p in sorted(root.glob("samples/**/*.xdo"))]
    found += [p.read_bytes() for p in sorted(root.glob("tests/data/**/*.xdo"))]
    assert found, "the repository's sample .xdo files"
    made = [
        serialise_xdo(xdo(2, [mesh(14, name=b""), mesh(15)])),
        serialise_xdo(xdo(1, [mesh(16, name=b"", thumbnail=None)])),
        serialise_xdo(xdo(2, [mesh(17, name=b"", thumbnail=None), mesh(18, name=b"b.jpg")])),
        serialise_xdo(xdo(2, [mesh(19, thumbnail=b"\xff\xd8jpeg\xff\xd9"), mesh(20, n=1)])),
        serialise_xdo(xdo(1, [mesh(21, name="건물.jpg".encode("euc-kr"))])),
        serialise_xdo(xdo(2, [])),
        XML_PAGE,
        b"",
    ]
    return found + made + [damaged for data in made[:3] for damaged in cuts_and_flips(data)]


def test_image_names_walk_gives_parse_xdo_names():
    """xdo_image_names gives parse_xdo's names or its very error, in every layout asked; the walk
    alone (without the fallback) already gives the names of every file that parses."""
    cases = name_cases()
    parsed_some = 0
    for data in cases:
        for version in (None, 1, 2):
            expected = outcome(parsed_names, data, "n.xdo", version)
            assert outcome(xdo_image_names, data, "n.xdo", version) == expected
            if data and xml_error(data) is None:
                walked = walked_names(data, version)
                assert repr(walked) == ("None" if expected.startswith("ReadError") else expected)
                parsed_some += walked is not None
    assert parsed_some > len(cases) // 4


def test_huge_counts_fail_fast_before_allocating():
    header = (
        struct.pack("<BI", 8, 1) + b"\x01K" + struct.pack("<6d", *range(6)) + struct.pack("<f", 0.0)
    )
    tracemalloc.start()
    with pytest.raises(ReadError, match=r"vertex_count 4000000000 .* needs 128000000000 bytes"):
        parse_xdo(header + struct.pack("<I", 4_000_000_000) + b"\x00" * 64, "big.xdo", 1)
    with pytest.raises(ReadError, match="index_count"):
        parse_xdo(
            header + struct.pack("<I", 0) + struct.pack("<I", 0xFFFFFFFF) + b"\x00" * 16,
            "big.xdo",
            1,
        )
    with pytest.raises(ReadError, match="object_count"):
        parse_dat(struct.pack("<4I", 15, 1, 2, 0xFFFFFFFF) + b"\x00" * 100, "big.dat")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1_000_000  # bytes: nothing of the claimed sizes was allocated


def test_left_over_bytes_are_refused():
    data = serialise_xdo(xdo(1, [mesh(16)]))
    with pytest.raises(ReadError, match="left over"):
        parse_xdo(data + b"\x00" * 3, "o.xdo", 1)


def test_serialise_refuses_what_the_layout_cannot_hold():
    with pytest.raises(ValueError, match="exactly one mesh"):
        serialise_xdo(xdo(1, [mesh(1), mesh(2)]))
    with pytest.raises(ValueError, match="at most 255"):
        serialise_xdo(xdo(2, [mesh(1)] * 256))
    with pytest.raises(ValueError, match="255"):
        serialise_xdo(xdo(2, [mesh(1)], key=b"k" * 256))
    with pytest.raises(ValueError, match="all have a thumbnail field or all lack it"):
        serialise_xdo(xdo(2, [mesh(1, name=b"", thumbnail=None), mesh(2, name=b"", thumbnail=b"")]))
    with pytest.raises(ValueError, match="thumbnail"):
        serialise_xdo(xdo(2, [mesh(1, name=b"a.jpg", thumbnail=None)]))
