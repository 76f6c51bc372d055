"""VWorld reader and writer: building -> write_tile -> scan/load -> the same building, outward faces,
frames, and broken inputs reported per building."""

from __future__ import annotations

import io
import math
import pickle
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from exporter.errors import ReadError
from exporter.formats.vworld_binary import parse_dat, parse_xdo, serialise_dat, serialise_xdo
from exporter.model import Building, GeoPoint, Part, Texture, TileId
from exporter.readers import load_entry, scan_folder, vworld
from exporter.readers.vworld import (
    EARTH_RADIUS_M,
    enu_rotation,
    global_point,
    local_to_global,
    lonlat_of,
)

SEOUL = GeoPoint(126.9780, 37.5665, 38.3)
TILE = TileId(15, 279418, 116113)
XML_PAGE = b'<?xml version="1.0"?><response><error>ERROR_SERVICE_FILE_NOTTHING</error></response>'


def jpeg(width: int = 64, height: int = 32) -> bytes:
    noise = np.random.default_rng(width * height).integers(
        0, 256, (height, width, 3), dtype=np.uint8
    )
    buffer = io.BytesIO()
    Image.fromarray(noise).save(buffer, "JPEG")
    return buffer.getvalue()


def box(x0=-5.0, x1=5.0, z0=-3.0, z1=3.0, height=12.0, base=0.0):
    """A floorless box in local East/Up/North metres: 4 walls + roof, (b-a)x(c-a) outward."""
    p = np.array(
        [
            [x0, base, z0],
            [x1, base, z0],
            [x1, base, z1],
            [x0, base, z1],
            [x0, base + height, z0],
            [x1, base + height, z0],
            [x1, base + height, z1],
            [x0, base + height, z1],
        ]
    )
    quads = [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (4, 5, 6, 7)]
    triangles = [t for a, b, c, d in quads for t in ((a, c, b), (a, d, c))]
    return p, np.array(triangles)


def outward_share(positions: np.ndarray, triangles: np.ndarray, centre: np.ndarray) -> float:
    a, b, c = (positions[triangles[:, k]] for k in range(3))
    face = np.cross(b - a, c - a)
    return float(np.mean(np.einsum("ij,ij->i", face, (a + b + c) / 3 - centre) > 0))


def test_box_fixture_is_outward_in_the_local_frame():
    p, t = box()
    assert outward_share(p, t, np.array([0.0, 6.0, 0.0])) == 1.0  # the fixture itself, checked


def building(parts: list[Part], bid: str = "BLD_0001", reference: GeoPoint = SEOUL) -> Building:
    return Building(id=bid, source="", reference=reference, parts=parts, tile=TILE)


def textured_box(name: str = "wall.jpg", **kw) -> Part:
    p, t = box(**kw)
    uvs = np.random.default_rng(0).random((len(p), 2)).astype(np.float32)
    texture = Texture(jpeg(), "image/jpeg", 64, 32, name=name)
    return Part(p, t, uvs=uvs, texture=texture, color=(1.0, 0.5, 0.25, 1.0))


def load_all(folder: Path) -> list[Building]:
    scan = scan_folder(folder)
    assert scan.format == "vworld"
    return [load_entry(e) for e in scan.entries]


# --------------------------------------------------------------------------- frames


def test_enu_rotation_is_proper_and_points_east_up_north():
    rotation = enu_rotation(SEOUL.lon, SEOUL.lat)
    assert np.allclose(rotation @ rotation.T, np.eye(3)) and np.linalg.det(
        rotation
    ) == pytest.approx(1.0)
    centre = global_point(SEOUL)
    assert np.linalg.norm(centre) == pytest.approx(EARTH_RADIUS_M + SEOUL.elev)
    east, up, north = local_to_global(
        np.array([[100.0, 0, 0], [0, 100.0, 0], [0, 0, 100.0]]), SEOUL
    )
    lon, lat = lonlat_of(np.array([east, north, centre]))
    assert lon[0] > SEOUL.lon and lat[0] == pytest.approx(SEOUL.lat, abs=1e-6)
    assert lat[1] > SEOUL.lat and lon[1] == pytest.approx(SEOUL.lon, abs=1e-6)
    assert (lon[2], lat[2]) == pytest.approx((SEOUL.lon, SEOUL.lat))
    assert np.linalg.norm(up) == pytest.approx(EARTH_RADIUS_M + SEOUL.elev + 100.0)
    # 100 m east at latitude phi is 100 / (R cos phi) radians of longitude
    assert math.radians(lon[0] - SEOUL.lon) == pytest.approx(
        100 / ((EARTH_RADIUS_M + SEOUL.elev) * math.cos(math.radians(SEOUL.lat))), rel=1e-6
    )


def test_written_offsets_are_in_the_vworld_global_frame(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    xdo = parse_xdo((tmp_path / "BLD_0001.xdo").read_bytes(), "BLD_0001.xdo", 2)
    # the roof corners are 12 m up: their global radius is R + altitude + 12 m
    roof = xdo.meshes[0].positions[4:].astype(np.float64) + xdo.bbox_center
    assert np.linalg.norm(roof, axis=1) == pytest.approx(
        EARTH_RADIUS_M + SEOUL.elev + 12.0, abs=0.01
    )
    dat = parse_dat((tmp_path / "15_279418_116113.dat").read_bytes(), "t.dat")
    assert (dat.level, dat.idx, dat.idy) == (15, 279418, 116113)
    assert dat.objects[0].center_lon == SEOUL.lon and dat.objects[0].data_file == b"BLD_0001.xdo"


# --------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("version", [1, 2])
def test_single_part_round_trip(tmp_path, version):
    part = textured_box()
    written = vworld.write_tile(tmp_path, TILE, [building([part])], version=version)
    assert written[0].name == "15_279418_116113.dat" and {p.name for p in written} == {
        "15_279418_116113.dat",
        "BLD_0001.xdo",
        "wall.jpg",
    }
    assert vworld.detect(tmp_path)
    (loaded,) = load_all(tmp_path)
    assert loaded.id == "BLD_0001" and loaded.tile == TILE and loaded.problems == []
    assert (loaded.reference.lon, loaded.reference.lat) == (SEOUL.lon, SEOUL.lat)
    assert loaded.reference.elev == pytest.approx(SEOUL.elev, abs=1e-5)
    (got,) = loaded.parts
    assert np.abs(got.positions - part.positions).max() < 1e-4  # metres (float32 offsets)
    assert np.array_equal(got.triangles, part.triangles)
    assert np.array_equal(got.uvs, part.uvs)
    assert got.texture.data == part.texture.data and got.texture.mime == "image/jpeg"
    assert (got.texture.width, got.texture.height) == (64, 32)
    # The colour bytes (written from (1, 0.5, 0.25, 1)) do not tint a photo (readers.vworld.part_color).
    assert got.color == (1.0, 1.0, 1.0, 1.0)
    west, south, east, north = loaded.lonlat_bounds
    assert west < SEOUL.lon < east and south < SEOUL.lat < north
    assert (east - west) * 111320 * math.cos(math.radians(SEOUL.lat)) == pytest.approx(
        10.0, rel=1e-3
    )


def test_multi_part_round_trip_shares_and_omits_textures(tmp_path):
    walls = textured_box("shared.jpg")
    annex = textured_box("shared.jpg", x0=6, x1=9, height=4)
    plain_p, plain_t = box(x0=-9, x1=-6, height=3)
    plain = Part(plain_p, plain_t, color=(0.2, 0.4, 0.6, 1.0))
    other = Building(
        id="서울_2",
        source="",
        reference=GeoPoint(126.9790, 37.5670, 20.0),
        parts=[textured_box("roof.jpg")],
        tile=TILE,
    )
    written = vworld.write_tile(tmp_path, TILE, [building([walls, annex, plain]), other])
    assert sorted(p.name for p in written if p.suffix == ".jpg") == ["roof.jpg", "shared.jpg"]
    first, second = load_all(tmp_path)
    assert second.id == "서울_2" and (tmp_path / "서울_2.xdo").is_file()
    assert [p.texture is not None for p in first.parts] == [True, True, False]
    assert first.parts[0].texture is first.parts[1].texture  # read once per building
    for want, got in zip([walls, annex, plain], first.parts):
        assert np.abs(got.positions - want.positions).max() < 1e-4
        assert np.array_equal(got.triangles, want.triangles)
    assert first.parts[2].color == pytest.approx((0.2, 0.4, 0.6, 1.0), abs=1 / 255)
    assert np.allclose(first.parts[2].uvs, 0.0)


def test_same_texture_name_with_other_bytes_gets_its_own_file(tmp_path):
    first, second = textured_box("atlas.jpg"), textured_box("atlas.jpg")
    second.texture = Texture(jpeg(32, 32), "image/jpeg", 32, 32, name="atlas.jpg")
    written = vworld.write_tile(tmp_path, TILE, [building([first], "A"), building([second], "B")])
    assert sorted(p.name for p in written if p.suffix == ".jpg") == ["atlas.jpg", "atlas~2.jpg"]
    a, b = load_all(tmp_path)
    assert (
        a.parts[0].texture.data == first.texture.data
        and b.parts[0].texture.data == second.texture.data
    )


def test_writer_refuses_what_the_format_cannot_hold(tmp_path):
    with pytest.raises(ValueError, match="exactly one part"):
        vworld.write_tile(tmp_path, TILE, [building([textured_box(), textured_box()])], version=1)
    many = np.zeros((65536, 3))
    many[:, 0] = np.arange(65536)
    with pytest.raises(ValueError, match="65536 vertices"):
        vworld.write_tile(tmp_path, TILE, [building([Part(many, [[0, 1, 2]])])])


def test_euc_kr_key_in_the_dat_gives_a_decoded_id(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    dat_path = tmp_path / "15_279418_116113.dat"
    dat = parse_dat(dat_path.read_bytes(), str(dat_path))
    dat.objects[0].key = "한국빌딩".encode("euc-kr")
    dat_path.write_bytes(serialise_dat(dat))
    (entry,) = vworld.scan(tmp_path).entries
    assert entry.id == "한국빌딩"
    assert vworld.load(entry).parts[0].triangle_count == 10


# --------------------------------------------------------------------------- winding


def test_loaded_box_faces_point_outward_and_agree_with_normals(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    (loaded,) = load_all(tmp_path)
    part = loaded.parts[0]
    assert outward_share(part.positions, part.triangles, np.array([0.0, 6.0, 0.0])) == 1.0
    votes = vworld.winding_votes(part.positions, part.triangles, part.normals.astype(np.float64))
    assert votes == (10, 0)


def test_file_with_reversed_winding_still_loads_outward(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    path = tmp_path / "BLD_0001.xdo"
    xdo = parse_xdo(path.read_bytes(), str(path), 2)
    xdo.meshes[0].indices = xdo.meshes[0].indices.reshape(-1, 3)[:, ::-1].reshape(-1).copy()
    path.write_bytes(serialise_xdo(xdo))
    (loaded,) = load_all(tmp_path)
    part = loaded.parts[0]
    assert outward_share(part.positions, part.triangles, np.array([0.0, 6.0, 0.0])) == 1.0
    assert loaded.problems == []


def test_without_normals_the_centroid_decides(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    path = tmp_path / "BLD_0001.xdo"
    xdo = parse_xdo(path.read_bytes(), str(path), 2)
    xdo.meshes[0].vertices[:, 3:6] = 0.0
    xdo.meshes[0].indices = xdo.meshes[0].indices.reshape(-1, 3)[:, ::-1].reshape(-1).copy()
    path.write_bytes(serialise_xdo(xdo))
    (loaded,) = load_all(tmp_path)
    part = loaded.parts[0]
    assert part.normals is None
    assert outward_share(part.positions, part.triangles, np.array([0.0, 6.0, 0.0])) == 1.0


# --------------------------------------------------------------------------- broken inputs


def written_entry(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    (entry,) = vworld.scan(tmp_path).entries
    return entry


def test_missing_xdo_is_listed_then_fails_naming_it(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    (tmp_path / "BLD_0001.xdo").unlink()
    (entry,) = vworld.scan(tmp_path).entries
    with pytest.raises(ReadError, match=r"BLD_0001\.xdo: missing"):
        load_entry(entry)


@pytest.mark.parametrize(
    "damage,message",
    [
        (lambda data: XML_PAGE, "XML error page .*ERROR_SERVICE_FILE_NOTTHING"),
        (lambda data: data[: len(data) // 2], "truncated"),
        (lambda data: b"", "empty file"),
    ],
)
def test_broken_xdo_fails_naming_it(tmp_path, damage, message):
    entry = written_entry(tmp_path)
    path = tmp_path / "BLD_0001.xdo"
    path.write_bytes(damage(path.read_bytes()))
    with pytest.raises(ReadError, match=r"BLD_0001\.xdo: .*" + message) as caught:
        load_entry(entry)
    assert caught.value.path.endswith("BLD_0001.xdo")


@pytest.mark.parametrize(
    "damage,message",
    [
        (None, "texture wall.jpg missing"),
        (
            lambda data: XML_PAGE,
            "texture wall.jpg is an XML error page .*ERROR_SERVICE_FILE_NOTTHING",
        ),
        (lambda data: data[: len(data) - 40], "texture wall.jpg is truncated"),
        (lambda data: data[:6], "texture wall.jpg is not a readable image"),
    ],
)
def test_broken_texture_leaves_the_part_untextured(tmp_path, damage, message):
    entry = written_entry(tmp_path)
    path = tmp_path / "wall.jpg"
    if damage is None:
        path.unlink()
    else:
        path.write_bytes(damage(path.read_bytes()))
    loaded = load_entry(entry)
    assert loaded.parts[0].texture is None and loaded.parts[0].triangle_count == 10
    assert len(loaded.problems) == 1 and re.search(message, loaded.problems[0])


def test_broken_dat_is_skipped_and_others_still_scanned(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    (tmp_path / "15_1_1.dat").write_bytes(XML_PAGE)
    scan = vworld.scan(tmp_path)
    assert [e.id for e in scan.entries] == ["BLD_0001"]
    assert (
        len(scan.skipped) == 1
        and "XML error page" in scan.skipped[0].reason
        and scan.skipped[0].source.endswith("15_1_1.dat")
    )


def test_declared_version_mismatch_is_read_and_reported(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])], version=1)
    dat_path = tmp_path / "15_279418_116113.dat"
    dat = parse_dat(dat_path.read_bytes(), str(dat_path))
    dat.objects[0].version = bytes((3, 0, 0, 2))
    dat_path.write_bytes(serialise_dat(dat))
    (loaded,) = load_all(tmp_path)
    assert loaded.parts[0].triangle_count == 10
    assert any("declares version 3.0.0.2" in p for p in loaded.problems)


def test_model_far_from_the_dat_altitude_is_reported(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box(base=40.0)])])
    (loaded,) = load_all(tmp_path)
    assert loaded.parts[0].positions[:, 1].min() == pytest.approx(40.0, abs=1e-3)
    assert any("model base is +40.0 m from the .dat altitude" in p for p in loaded.problems)


def test_model_far_from_the_dat_centre_is_reported(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box(x0=495, x1=505)])])
    (loaded,) = load_all(tmp_path)
    assert loaded.parts[0].positions[:, 0].min() == pytest.approx(495.0, abs=1e-3)
    assert any("model centre is 500 m from the .dat centre" in p for p in loaded.problems)


def test_entries_pickle_and_name_their_inputs(tmp_path):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    (entry,) = vworld.scan(tmp_path).entries
    assert [Path(p).name for p in entry.inputs] == [
        "15_279418_116113.dat",
        "BLD_0001.xdo",
        "wall.jpg",
    ]
    again = pickle.loads(pickle.dumps(entry))
    assert again == entry and str(tmp_path) not in repr(
        entry.key
    )  # the key survives moving the folder
    assert vworld.load(again).parts[0].triangle_count == 10


def test_detect_needs_a_dat(tmp_path):
    (tmp_path / "a.xdo").write_bytes(b"\x08")
    assert not vworld.detect(tmp_path)


def test_vworld_box_arrives_in_unity_facing_outward(tmp_path):
    """The end result as Unity sees it: VWorld file -> load -> glTF -> glTFast's import (negate X,
    reverse winding) -> every face of the box still points away from its inside."""
    import trimesh

    from exporter.gltf_writer import glb_bytes

    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    path = tmp_path / "BLD_0001.xdo"
    xdo = parse_xdo(path.read_bytes(), str(path), 2)  # store the opposite winding, as VWorld might
    xdo.meshes[0].indices = xdo.meshes[0].indices.reshape(-1, 3)[:, ::-1].reshape(-1).copy()
    path.write_bytes(serialise_xdo(xdo))
    (loaded,) = load_all(tmp_path)
    scene = trimesh.load(
        io.BytesIO(glb_bytes(loaded.parts, loaded.id)), file_type="glb", process=False
    )
    (mesh,) = scene.geometry.values()
    unity_positions = np.asarray(mesh.vertices) * [-1.0, 1.0, 1.0]
    unity_triangles = np.asarray(mesh.faces)[:, ::-1]
    assert outward_share(unity_positions, unity_triangles, np.array([0.0, 6.0, 0.0])) == 1.0


def fancy_index_votes(positions, triangles, directions) -> tuple:
    """``winding_votes`` as first written: (m, 3, 3) corner gathers, a sum over the corners."""
    corners = positions[triangles]
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    dots = np.einsum("ij,ij->i", face, directions[triangles].sum(axis=1))
    return int((dots > 0).sum()), int((dots < 0).sum()), dots


@pytest.mark.parametrize("seed", range(6))
def test_winding_votes_equal_the_fancy_index_formulation(seed):
    """Per-corner ``take`` gathers count the same votes from the same dot products, also on
    near-flat triangles and directions summing to about zero (where a reordered sum would flip)."""
    rng = np.random.default_rng(seed)
    positions = rng.normal(size=(200, 3)) * 10.0 ** rng.integers(-6, 4)
    positions[::7] = positions[1::7] + rng.normal(size=positions[::7].shape) * 1e-12
    directions = rng.normal(size=(200, 3))
    directions[1::3] = -directions[::3][: len(directions[1::3])] + 1e-17
    triangles = rng.integers(0, 200, size=(700, 3))
    agree, disagree, dots = fancy_index_votes(positions, triangles, directions)
    assert (np.abs(dots) < 1e-9).any()  # the data does reach the near-zero cases
    assert vworld.winding_votes(positions, triangles, directions) == (agree, disagree)


@pytest.mark.parametrize(
    "dat_shift, xdo_shift, reported",
    [
        (0.5, 0.0, None),
        (0.0, 2.25, "2.2 m"),  # the largest of the six differences, in metres
        (-3.0, 0.0, "3.0 m"),
        (math.nan, 0.0, None),  # the .dat box unusable: not compared
        (0.0, math.nan, ReadError),  # the .xdo box is the one used: refused when not finite
        (0.0, math.inf, ReadError),
    ],
)
def test_bounding_box_mismatch_reports_the_largest_difference(
    tmp_path, dat_shift, xdo_shift, reported
):
    vworld.write_tile(tmp_path, TILE, [building([textured_box()])])
    dat_path = next(tmp_path.glob("*.dat"))
    dat = parse_dat(dat_path.read_bytes(), str(dat_path))
    record = dat.objects[0]
    record.bbox = (record.bbox[0] + dat_shift, *record.bbox[1:])
    dat_path.write_bytes(serialise_dat(dat))
    xdo_path = tmp_path / record.data_file.decode()
    xdo = parse_xdo(xdo_path.read_bytes(), str(xdo_path))
    xdo.bbox = (*xdo.bbox[:4], xdo.bbox[4] + xdo_shift, xdo.bbox[5])
    xdo_path.write_bytes(serialise_xdo(xdo))
    if reported is ReadError:
        with pytest.raises(ReadError, match="bounding box is not finite"):
            load_all(tmp_path)
        return
    problems = [p for p in load_all(tmp_path)[0].problems if "bounding box" in p]
    if reported is None:
        assert problems == []
    else:
        assert problems == [
            f"{xdo_path.name}: bounding box differs from the .dat's by {reported}; used the .xdo's"
        ]


def test_lonlat_of_is_sphere_lonlath_bit_for_bit():
    """Its own two-angle arithmetic equals geodesy's inverse (VWorld Y mirrored) exactly,
    poles and points straight above them included."""
    from exporter.geodesy import sphere_lonlath

    rng = np.random.default_rng(7)
    points = np.concatenate(
        [
            rng.normal(size=(500, 3)) * EARTH_RADIUS_M,
            local_to_global(rng.normal(size=(300, 3)) * 50.0, SEOUL),
            [[0.0, 0.0, EARTH_RADIUS_M], [1e-9, -1e-9, -EARTH_RADIUS_M], [3.0, 4.0, 0.0]],
        ]
    )
    lon, lat = lonlat_of(points)
    expected = sphere_lonlath(points * np.array([1.0, -1.0, 1.0]))
    assert np.array_equal(lon, expected[:, 0]) and np.array_equal(lat, expected[:, 1])
