"""Generic OBJ/glTF/GLB folder reader: placement, winding, textures, index files and errors.

Models are written by trimesh in each test; expected positions are worked out with the
small-angle tangent-plane formulas (exact to ~1e-6 m for a few metres), and expected texture
bytes and UVs are read from the written files with pygltflib or plain text, not with the reader.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pygltflib
import pytest
import trimesh
from PIL import Image

from exporter.config import ReaderOptions
from exporter.errors import InputError, ReadError
from exporter.readers import detect_format, folder, load_entry, scan_folder

R = 6378137.0
LON, LAT, ELEV = 126.978, 37.5665, 30.0


def textured_box(directory: Path, extents=(2.0, 3.0, 4.0)) -> trimesh.Trimesh:
    """A box with one corner at the origin and the opposite at ``extents`` (model metres)."""
    image = Image.new("RGB", (16, 8), (10, 200, 30))
    image.putpixel((0, 0), (255, 0, 0))
    image.save(directory / "atlas.png")
    box = trimesh.creation.box(extents=extents)
    box.apply_translation(np.asarray(extents) / 2)
    uv = np.column_stack(
        [box.vertices[:, 0] / extents[0], 0.1 + 0.5 * box.vertices[:, 1] / extents[1]]
    )  # v in {0.1, 0.6}: a flip shows
    box.visual = trimesh.visual.TextureVisuals(uv=uv, image=Image.open(directory / "atlas.png"))
    return box


def write_csv(directory: Path, rows: list[str]) -> None:
    (directory / "buildings.csv").write_text(
        "file,lon,lat,elev,up_axis,id\n" + "\n".join(rows) + "\n"
    )


def normals(part) -> np.ndarray:
    p, t = part.positions, part.triangles
    return np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])


def assert_outward(building) -> None:
    points = np.concatenate([p.positions for p in building.parts])
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    for part in building.parts:
        mid = part.positions[part.triangles].mean(axis=1)
        assert np.all(np.einsum("ij,ij->i", normals(part), mid - centre) > 0)


def expected_local(model_points: np.ndarray, up_axis: str) -> tuple[np.ndarray, tuple]:
    """Local East/Up/North of model points relative to the reference point (centre of the
    East/North box at the lowest point), and that reference's (lon, lat, elev)."""
    x, y, z = model_points.T
    enu = np.column_stack([x, y, -z]) if up_axis == "y" else np.column_stack([x, z, y])
    low, high = enu.min(axis=0), enu.max(axis=0)
    offset = np.array([(low[0] + high[0]) / 2, low[1], (low[2] + high[2]) / 2])
    lat = LAT + math.degrees(offset[2] / (R + ELEV))
    lon = LON + math.degrees(offset[0] / ((R + ELEV) * math.cos(math.radians(LAT))))
    return enu - offset, (lon, lat, ELEV + offset[1])


def check_placement(building, model_points: np.ndarray, up_axis: str) -> None:
    local, (lon, lat, elev) = expected_local(model_points, up_axis)
    assert building.reference.lon == pytest.approx(lon, abs=1e-8)  # ~1 mm
    assert building.reference.lat == pytest.approx(lat, abs=1e-8)
    assert building.reference.elev == pytest.approx(elev, abs=1e-3)
    positions = np.concatenate([p.positions for p in building.parts])
    # Every read vertex is one of the expected ones (within 1 mm) and the extents agree.
    distance = np.linalg.norm(positions[:, None, :] - local[None, :, :], axis=2).min(axis=1)
    assert distance.max() < 1e-3
    assert positions.min(axis=0) == pytest.approx(local.min(axis=0), abs=1e-3)
    assert positions.max(axis=0) == pytest.approx(local.max(axis=0), abs=1e-3)
    west, south, east, north = building.lonlat_bounds
    assert west < building.reference.lon < east and south < building.reference.lat < north


def test_glb_and_obj_up_y_placement_and_winding(tmp_path):
    box = textured_box(tmp_path)
    box.export(tmp_path / "hall.glb")
    box.export(tmp_path / "hall.obj")
    write_csv(tmp_path, [f"hall.glb,{LON},{LAT},{ELEV},y,G", f"hall.obj,{LON},{LAT},{ELEV},y,O"])
    assert detect_format(tmp_path) == "folder"
    scan = scan_folder(tmp_path)
    assert [e.id for e in scan.entries] == ["G", "O"] and not scan.skipped
    assert scan.entries[0].tile.idx == math.floor((LON + 180) / (36 / 2**15))
    for entry in scan.entries:
        building = load_entry(entry)
        assert building.triangle_count == 12 and len(building.parts) == 1
        check_placement(building, np.asarray(box.vertices), "y")
        assert_outward(building)
        # The model's +z is South: the box (z from 0 to 4 m) lies south of the origin.
        assert building.reference.lat < LAT


def test_up_axis_z_from_yaml_index(tmp_path):
    box = textured_box(tmp_path)
    box.export(tmp_path / "tower.glb")
    (tmp_path / "buildings.yaml").write_text(
        f"buildings:\n  - {{file: tower.glb, lon: {LON}, lat: {LAT}, elev: {ELEV}, up_axis: z}}\n"
    )
    scan = scan_folder(tmp_path)
    assert [e.id for e in scan.entries] == ["tower"]  # id defaults to the file stem
    building = load_entry(scan.entries[0])
    check_placement(building, np.asarray(box.vertices), "z")
    assert_outward(building)
    size = np.ptp(building.parts[0].positions, axis=0)
    assert size == pytest.approx([2.0, 4.0, 3.0], abs=1e-3)  # East, Up, North metres
    assert building.reference.lat > LAT  # the model's +y is North


def test_glb_texture_bytes_and_uvs_unchanged(tmp_path):
    box = textured_box(tmp_path)
    box.export(tmp_path / "hall.glb")
    write_csv(tmp_path, [f"hall.glb,{LON},{LAT},{ELEV},y,G"])
    building = load_entry(scan_folder(tmp_path).entries[0])
    (part,) = building.parts
    gltf = pygltflib.GLTF2().load(str(tmp_path / "hall.glb"))
    blob = gltf.binary_blob()
    view = gltf.bufferViews[gltf.images[0].bufferView]
    assert (
        part.texture.data == blob[view.byteOffset or 0 : (view.byteOffset or 0) + view.byteLength]
    )
    assert part.texture.mime == gltf.images[0].mimeType and (
        part.texture.width,
        part.texture.height,
    ) == (16, 8)
    # glTF's TEXCOORD_0 is already in the model's convention (origin top-left): same values.
    accessor = gltf.accessors[gltf.meshes[0].primitives[0].attributes.TEXCOORD_0]
    uv_view = gltf.bufferViews[accessor.bufferView]
    start = (uv_view.byteOffset or 0) + (accessor.byteOffset or 0)
    raw = np.frombuffer(blob[start : start + accessor.count * 8], dtype="<f4").reshape(-1, 2)
    assert {tuple(np.round(uv, 5)) for uv in raw} == {tuple(np.round(uv, 5)) for uv in part.uvs}
    assert {round(float(v), 5) for v in raw[:, 1]} != {
        round(float(1 - v), 5) for v in raw[:, 1]
    }  # a flip would show


def test_obj_texture_bytes_and_uvs_flipped_from_vt(tmp_path):
    textured_box(tmp_path).export(tmp_path / "hall.obj")
    write_csv(tmp_path, [f"hall.obj,{LON},{LAT},{ELEV},y,O"])
    entry = scan_folder(tmp_path).entries[0]
    mtl_text = (tmp_path / "material.mtl").read_text()
    image_name = next(
        line.split()[-1] for line in mtl_text.splitlines() if line.startswith("map_Kd")
    )
    assert (
        str(tmp_path / "material.mtl") in entry.inputs
        and str(tmp_path / image_name) in entry.inputs
    )
    (part,) = load_entry(entry).parts
    assert part.texture.data == (tmp_path / image_name).read_bytes()
    assert part.color == (1.0, 1.0, 1.0, 1.0)  # the texture alone gives the colour
    vt = np.array(
        [
            [float(v) for v in line.split()[1:3]]
            for line in (tmp_path / "hall.obj").read_text().splitlines()
            if line.startswith("vt ")
        ]
    )
    assert {(round(u, 5), round(1 - v, 5)) for u, v in vt} == {
        tuple(np.round(uv.astype(float), 5)) for uv in part.uvs
    }


def test_node_transforms_mirroring_and_materials(tmp_path):
    red = trimesh.creation.box(extents=[1, 1, 1])
    red.visual = trimesh.visual.ColorVisuals(red, face_colors=[255, 0, 0, 255])
    blue = trimesh.creation.box(extents=[1, 1, 1])
    blue.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=[0, 0, 255, 255])
    )
    scene = trimesh.Scene()
    scene.add_geometry(
        red, node_name="red", transform=trimesh.transformations.translation_matrix([0, 0.5, 0])
    )
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    mirror[:3, 3] = [3.0, 0.5, 0.0]  # a mirrored instance 3 m East
    scene.add_geometry(blue, node_name="blue", transform=mirror)
    scene.export(tmp_path / "pair.glb")
    write_csv(tmp_path, [f"pair.glb,{LON},{LAT},{ELEV},y,P"])
    building = load_entry(scan_folder(tmp_path).entries[0])
    assert building.triangle_count == 24
    positions = np.concatenate([p.positions for p in building.parts])
    assert np.ptp(positions, axis=0) == pytest.approx([4.0, 1.0, 1.0], abs=1e-3)
    for part in building.parts:  # each box's faces point away from its own centre
        centre = part.positions.mean(axis=0)
        mid = part.positions[part.triangles].mean(axis=1)
        assert np.all(np.einsum("ij,ij->i", normals(part), mid - centre) > 0)
    # One part per material: the blue PBR material and the red box's (vertex colours, no material).
    assert len(building.parts) == 2
    (blue,) = [p for p in building.parts if p.color == (0.0, 0.0, 1.0, 1.0)]
    (red,) = [p for p in building.parts if p is not blue]
    assert blue.positions[:, 0].mean() - red.positions[:, 0].mean() == pytest.approx(
        3.0, abs=1e-3
    )  # metres East


def test_missing_and_broken_files_fail_only_their_entry(tmp_path):
    textured_box(tmp_path).export(tmp_path / "ok.glb")
    (tmp_path / "broken.glb").write_bytes(b"glTF\x02\x00\x00\x00garbage")
    write_csv(
        tmp_path,
        [
            f"ok.glb,{LON},{LAT},{ELEV},y,A",
            f"missing.obj,{LON},{LAT},{ELEV},y,B",
            f"broken.glb,{LON},{LAT},{ELEV},y,C",
        ],
    )
    entries = {e.id: e for e in scan_folder(tmp_path).entries}
    assert load_entry(entries["A"]).triangle_count == 12
    with pytest.raises(ReadError, match="missing.obj.*missing"):
        load_entry(entries["B"])
    with pytest.raises(ReadError, match="broken.glb"):
        load_entry(entries["C"])


def test_bad_index_rows_are_skipped_with_reasons(tmp_path):
    textured_box(tmp_path).export(tmp_path / "a.glb")
    write_csv(
        tmp_path,
        [
            f"a.glb,{LON},{LAT},{ELEV},y,A",
            f"a.glb,{LON},{LAT},{ELEV},y,A",
            f"a.glb,east,{LAT},{ELEV},y,B",
            f"a.glb,{LON},95,{ELEV},y,C",
            f"a.glb,{LON},{LAT},{ELEV},x,D",
            f"a.png,{LON},{LAT},{ELEV},y,E",
        ],
    )
    scan = scan_folder(tmp_path)
    assert [e.id for e in scan.entries] == ["A"]
    reasons = " | ".join(s.reason for s in scan.skipped)
    for text in (
        "duplicate id 'A'",
        "lon 'east' is not a number",
        "lat '95' is outside",
        "up_axis 'x'",
        "not one of",
    ):
        assert text in reasons


def test_index_formats_and_errors(tmp_path):
    textured_box(tmp_path).export(tmp_path / "a.glb")
    (tmp_path / "buildings.json").write_text(
        json.dumps([{"file": "a.glb", "lon": LON, "lat": LAT, "elev": ELEV, "id": "J"}])
    )
    scan = scan_folder(tmp_path)
    assert [e.id for e in scan.entries] == ["J"] and scan.entries[0].key[
        4
    ] == "y"  # up_axis defaults to y
    (tmp_path / "buildings.csv").write_text("file,lon,lat\na.glb,1,2\n")
    with pytest.raises(InputError, match="buildings.csv: missing column"):
        scan_folder(tmp_path)
    (tmp_path / "buildings.csv").unlink()
    (tmp_path / "buildings.json").write_text('{"buildings": 3}')
    with pytest.raises(InputError, match="buildings.json"):
        scan_folder(tmp_path)
    (tmp_path / "buildings.json").unlink()
    assert not folder.detect(tmp_path)


def test_entries_are_plain_and_key_decides_hash(tmp_path):
    import pickle

    textured_box(tmp_path).export(tmp_path / "a.glb")
    write_csv(tmp_path, [f"a.glb,{LON},{LAT},{ELEV},y,A"])
    entry = scan_folder(tmp_path).entries[0]
    assert pickle.loads(pickle.dumps(entry)) == entry
    assert entry.key == (
        "a.glb",
        LON,
        LAT,
        ELEV,
        "y",
        (),
    )  # placement in the key: a moved row re-exports
    assert load_entry(entry, ReaderOptions()).id == "A"


def test_obj_with_missing_image_is_untextured_with_a_problem(tmp_path):
    textured_box(tmp_path).export(tmp_path / "hall.obj")
    mtl_text = (tmp_path / "material.mtl").read_text()
    image_name = next(
        line.split()[-1] for line in mtl_text.splitlines() if line.startswith("map_Kd")
    )
    (tmp_path / image_name).unlink()
    write_csv(tmp_path, [f"hall.obj,{LON},{LAT},{ELEV},y,O"])
    building = load_entry(scan_folder(tmp_path).entries[0])
    assert building.triangle_count == 12 and all(
        p.texture is None and p.uvs is None for p in building.parts
    )
    assert any(image_name in p and "missing" in p for p in building.problems)
