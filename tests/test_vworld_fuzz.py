"""Fuzzing the VWorld parsers and reader: truncated, bit-flipped and random bytes.

Only ReadError may escape; whatever parses must serialise back to the very same bytes; no parse
allocates much more than its input (a header claiming 4e9 vertices is refused from the counts).
"""

from __future__ import annotations

import struct
import tempfile
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from exporter.errors import ReadError
from exporter.formats.vworld_binary import (
    DatFile,
    DatObject,
    XdoFile,
    XdoMesh,
    parse_dat,
    parse_xdo,
    serialise_dat,
    serialise_xdo,
    version_bytes,
    xdo_image_names,
)
from exporter.model import Building, GeoPoint, Part, TileId
from exporter.readers import vworld

FUZZ = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _mesh(seed: int, name: bytes, thumbnail) -> XdoMesh:
    rng = np.random.default_rng(seed)
    return XdoMesh(
        rng.normal(size=(5, 8)).astype(np.float32),
        rng.integers(0, 5, 9).astype(np.uint16),
        b"\x01\x02\x03\x04",
        1,
        name,
        thumbnail,
    )


def _box() -> tuple:
    return (-3041018.4, -4038791.05, 3888655.1, -3041002.5, -4038774.5, 3888667.2)


SEEDS_XDO = [
    serialise_xdo(
        XdoFile(1, 8, 1, b"K1", _box(), np.float32(30.0), [_mesh(1, b"a.jpg", b"\xff\xd8\xff\xd9")])
    ),
    serialise_xdo(XdoFile(1, 8, 1, b"K1", _box(), np.float32(30.0), [_mesh(2, b"", None)])),
    serialise_xdo(
        XdoFile(
            2,
            8,
            2,
            "건물".encode("euc-kr"),
            _box(),
            np.float32(30.0),
            [_mesh(3, b"a.jpg", b""), _mesh(4, b"", b"xy"), _mesh(5, b"b.jpg", b"")],
        )
    ),
]
SEED_DAT = serialise_dat(
    DatFile(
        15,
        279418,
        116113,
        [
            DatObject(
                version_bytes(i % 2 + 1),
                8,
                b"K%d" % i,
                126.97,
                37.56,
                np.float32(30.0),
                _box(),
                0,
                b"K%d.xdo" % i,
                b"",
            )
            for i in range(3)
        ],
    )
)


def _mutations(seeds: list[bytes]):
    seed = st.sampled_from(seeds)
    truncated = st.tuples(seed, st.integers(0, 10_000)).map(
        lambda s: s[0][: s[1] % (len(s[0]) + 1)]
    )
    flipped = st.tuples(
        seed, st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 7)), min_size=1, max_size=8)
    ).map(_flip)
    spliced = st.tuples(seed, st.integers(0, 10_000), st.binary(max_size=16)).map(
        lambda s: s[0][: s[1] % (len(s[0]) + 1)] + s[2] + s[0][s[1] % (len(s[0]) + 1) + len(s[2]) :]
    )
    return st.one_of(truncated, flipped, spliced, st.binary(max_size=400))


def _flip(args) -> bytes:
    data, flips = bytearray(args[0]), args[1]
    for position, bit in flips:
        data[position % len(data)] ^= 1 << bit
    return bytes(data)


def _bounded(call, data: bytes):
    """Run ``call``; only ReadError may escape and the peak allocation stays near the input size."""
    tracemalloc.start()
    try:
        return call()
    except ReadError:
        return None
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 4 * len(data) + 200_000, f"parsing {len(data)} bytes allocated {peak} bytes"


@FUZZ
@given(data=_mutations(SEEDS_XDO), version=st.sampled_from([None, 1, 2]))
def test_parse_xdo_only_raises_read_error_and_round_trips(data, version):
    parsed = _bounded(lambda: parse_xdo(data, "fuzz.xdo", version), data)
    if parsed is not None:
        assert version in (None, parsed.version)
        assert serialise_xdo(parsed) == data


def _names_or_error(call) -> str:
    try:
        return repr(call())
    except ReadError as error:
        return f"ReadError: {error}"


@FUZZ
@given(data=_mutations(SEEDS_XDO), version=st.sampled_from([None, 1, 2]))
def test_xdo_image_names_are_parse_xdo_names(data, version):
    expected = _names_or_error(
        lambda: [m.image_name for m in parse_xdo(data, "fuzz.xdo", version).meshes]
    )
    assert _names_or_error(lambda: xdo_image_names(data, "fuzz.xdo", version)) == expected


@FUZZ
@given(data=_mutations([SEED_DAT]))
def test_parse_dat_only_raises_read_error_and_round_trips(data):
    parsed = _bounded(lambda: parse_dat(data, "fuzz.dat"), data)
    if parsed is not None:
        assert serialise_dat(parsed) == data


@pytest.mark.parametrize("claim", [4_000_000_000, 0xFFFFFFFF, 2**31])
def test_header_claiming_billions_of_vertices_fails_fast(claim):
    head = (
        struct.pack("<BI", 8, 1) + b"\x00" + struct.pack("<6d", *range(6)) + struct.pack("<f", 0.0)
    )
    for version, data in (
        (1, head + struct.pack("<I", claim)),
        (2, head + b"\x01" + struct.pack("<I", claim) + b"\x00" * 32),
    ):
        tracemalloc.start()
        with pytest.raises(ReadError, match="vertex_count"):
            parse_xdo(data, "huge.xdo", version)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 200_000  # bytes


# --------------------------------------------------------------------------- the reader on damaged files


@pytest.fixture(scope="module")
def tile_files(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("vworld_fuzz_source")
    p = np.array([[0, 0, 0], [4, 0, 0], [4, 5, 0], [0, 5, 0], [0, 0, 3], [0, 5, 3]], float)
    t = np.array([[0, 2, 1], [0, 3, 2], [0, 4, 5], [0, 5, 3]])
    parts = [Part(p, t, uvs=np.zeros((6, 2)), color=(1, 1, 1, 1)), Part(p + 10, t)]
    building = Building("B", "", GeoPoint(127.0, 37.5, 20.0), parts, tile=TileId(15, 1, 2))
    vworld.write_tile(folder, TileId(15, 1, 2), [building])
    return folder


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    flips=st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 7)), min_size=1, max_size=6),
    cut=st.integers(0, 10_000),
)
def test_reader_load_only_raises_read_error(tile_files, flips, cut):
    with tempfile.TemporaryDirectory() as name:
        _load_damaged(tile_files, Path(name), flips, cut)


def _load_damaged(tile_files: Path, folder: Path, flips, cut) -> None:
    for source in tile_files.iterdir():
        (folder / source.name).write_bytes(source.read_bytes())
    xdo = folder / "B.xdo"
    data = _flip((xdo.read_bytes(), flips))
    if cut % 3 == 0:
        data = data[: cut % (len(data) + 1)]
    xdo.write_bytes(data)
    for entry in vworld.scan(folder).entries:
        try:
            building = vworld.load(entry)
        except ReadError as error:
            assert "B.xdo" in str(error)
            continue
        for part in building.parts:
            assert np.all(np.isfinite(part.positions))
            assert part.triangles.min() >= 0 and part.triangles.max() < part.vertex_count
