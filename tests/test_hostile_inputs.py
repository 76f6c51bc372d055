"""Hostile and careless inputs a new user met (issue 36), the readers' half, as a table of cases
built in ``tmp_path``: a path named inside the input never reads a file outside the input's
folder; nothing goes wrong silently (every refusal is a problem naming what was refused); the
VWorld colour field never turns a photo translucent; texts taken from input are bounded.

Each case fails on 0.4.3's readers (noted per test)."""

from __future__ import annotations

import dataclasses
import io
import json
import os
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from exporter.formats.vworld_binary import parse_xdo, serialise_xdo
from exporter.model import Building, GeoPoint, Part, Texture, TileId
from exporter.readers import load_entry, scan_folder, vworld
from exporter.readers.confine import OutsideInput, confined
from tests.citygml_writer import appearance_member, box, citygml, texture_member, write
from tests.test_cityjson_reader import BOX_VERTICES, city, unit_box
from tests.test_folder_reader import ELEV, LAT, LON, textured_box, write_csv

SECRET = b"SECRET-OUTSIDE-THE-INPUT"
X0, Y0 = 458870.0, 5438350.0  # EPSG:25832 metres (Karlsruhe)
SEOUL = GeoPoint(126.9780, 37.5665, 38.3)
TILE = TileId(15, 279418, 116113)


def secret_image(path: Path) -> Path:
    """A PNG outside the input whose bytes carry ``SECRET`` (a text chunk survives re-encoding
    nowhere, but the original bytes would be kept)."""
    from PIL import PngImagePlugin

    path.parent.mkdir(parents=True, exist_ok=True)
    info = PngImagePlugin.PngInfo()
    info.add_text("comment", SECRET.decode())
    Image.new("RGB", (8, 4), (250, 0, 250)).save(path, format="PNG", pnginfo=info)
    return path


def no_secret(building: Building) -> bool:
    return all(p.texture is None or SECRET not in p.texture.data for p in building.parts)


def only(folder: Path) -> Building:
    scan = scan_folder(folder)
    assert len(scan.entries) == 1, scan
    return load_entry(scan.entries[0])


# --------------------------------------------------------------------------- the one rule


def test_confined_refuses_absolute_climbing_and_symlinked_names(tmp_path):
    root = tmp_path / "in"
    (root / "sub").mkdir(parents=True)
    outside = secret_image(tmp_path / "secret.png")
    (root / "link.png").symlink_to(outside)
    (root / "sub" / "a.png").write_bytes(b"x")
    assert confined("sub/a.png", root) == root / "sub" / "a.png"
    assert confined("../a.png", root / "sub", root) == root / "sub" / "../a.png"  # still inside
    assert confined("missing.png", root) == root / "missing.png"  # absence is another problem
    for name in (str(outside), "../secret.png", "sub/../../secret.png", "link.png", "a\0b"):
        with pytest.raises(OutsideInput, match="outside the input folder"):
            confined(name, root)


# --------------------------------------------------------------------------- 1. paths leading out


def _cityjson_textured(folder: Path, image: str) -> None:
    geometry = unit_box()
    geometry["texture"] = {
        "t": {"values": [[[[None]], [[0, 0, 1, 2, 3]], [[None]], [[None]], [[None]], [[None]]]]}
    }
    appearance = {
        "textures": [{"image": image, "type": "PNG"}],
        "vertices-texture": [[0, 0], [1, 0], [1, 1], [0, 1]],
    }
    folder.mkdir(parents=True, exist_ok=True)
    data = city({"B": {"type": "Building", "geometry": [geometry]}}, BOX_VERTICES)
    data["appearance"] = appearance
    (folder / "a.city.json").write_text(json.dumps(data))


def _citygml_textured(folder: Path, image: str) -> None:
    full = [(0, 0), (1, 0), (1, 1), (0, 1)]
    data = [{"id": "B", "surfaces": box(X0, Y0, 0.0, 8, 6, 5)}]
    members = texture_member(image, "B_p2", [full])
    write(folder / "a.gml", citygml(data, appearance=appearance_member(members)))


@pytest.mark.parametrize("fmt", ["cityjson", "citygml"])
@pytest.mark.parametrize("how", ["absolute", "climbing", "symlink"])
def test_texture_outside_the_input_is_refused_with_a_problem(tmp_path, fmt, how):
    """0.4.3 read the outside image into LOD0 with ``problems: []``."""
    outside = secret_image(tmp_path / "elsewhere" / "secret.png")
    folder = tmp_path / "in"
    folder.mkdir()
    name = {"absolute": str(outside), "climbing": "../elsewhere/secret.png", "symlink": "s.png"}
    if how == "symlink":
        (folder / "s.png").symlink_to(outside)
    (_cityjson_textured if fmt == "cityjson" else _citygml_textured)(folder, name[how])
    scan = scan_folder(folder)
    assert str(outside) not in scan.entries[0].inputs and not any(
        Path(p).resolve() == outside for p in scan.entries[0].inputs
    )
    building = load_entry(scan.entries[0])
    assert all(p.texture is None for p in building.parts) and no_secret(building)
    assert building.triangle_count > 0  # the building itself is still exported, untextured
    assert any(
        "refused" in p and name[how] in p and "outside the input folder" in p
        for p in building.problems
    ), building.problems


@pytest.mark.parametrize("how", ["absolute", "climbing", "symlink"])
def test_index_row_pointing_outside_is_skipped_with_the_reason(tmp_path, how):
    """0.4.3 exported the outside model."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    textured_box(elsewhere).export(elsewhere / "other.obj")
    folder = tmp_path / "in"
    folder.mkdir()
    textured_box(folder).export(folder / "own.obj")
    file = {
        "absolute": str(elsewhere / "other.obj"),
        "climbing": "../elsewhere/other.obj",
        "symlink": "link.obj",
    }[how]
    if how == "symlink":
        (folder / "link.obj").symlink_to(elsewhere / "other.obj")
    write_csv(folder, [f"own.obj,{LON},{LAT},{ELEV},y,own", f"{file},{LON},{LAT},{ELEV},y,x"])
    scan = scan_folder(folder)
    assert [e.id for e in scan.entries] == ["own"]
    (skipped,) = scan.skipped
    assert "row 2" in skipped.reason and "outside the input folder" in skipped.reason


def test_obj_map_kd_outside_the_folder_is_named_in_a_problem(tmp_path):
    """0.4.3 dropped it silently (trimesh does not follow it; nobody said so)."""
    secret_image(tmp_path / "elsewhere" / "secret.png")
    folder = tmp_path / "in"
    folder.mkdir()
    textured_box(folder).export(folder / "hall.obj")
    mtl = (folder / "material.mtl").read_text()
    image = next(line.split()[-1] for line in mtl.splitlines() if line.startswith("map_Kd"))
    (folder / "material.mtl").write_text(mtl.replace(image, "../elsewhere/secret.png"))
    write_csv(folder, [f"hall.obj,{LON},{LAT},{ELEV},y,O"])
    building = only(folder)
    assert all(p.texture is None for p in building.parts) and no_secret(building)
    assert any(
        "texture refused" in p and "../elsewhere/secret.png" in p for p in building.problems
    ), building.problems


def _gltf_with_external_image(folder: Path, uri: str) -> None:
    """A .gltf box whose image is the external file ``uri`` (trimesh embeds it; moved out)."""
    box_mesh = textured_box(folder)
    files = trimesh.exchange.gltf.export_gltf(trimesh.Scene(box_mesh))
    for name, data in files.items():
        (folder / name).write_bytes(data)
    gltf = json.loads((folder / "model.gltf").read_text())
    gltf["images"] = [{"uri": uri, "mimeType": "image/png"}]
    (folder / "model.gltf").write_text(json.dumps(gltf))


def test_gltf_with_a_missing_image_is_untextured_with_a_problem(tmp_path):
    """0.4.3 exported it untextured with ``problems: []``."""
    _gltf_with_external_image(tmp_path, "gone.png")
    write_csv(tmp_path, [f"model.gltf,{LON},{LAT},{ELEV},y,G"])
    building = only(tmp_path)
    assert all(p.texture is None for p in building.parts) and building.triangle_count == 12
    assert any("gone.png" in p and "missing" in p for p in building.problems), building.problems


def test_gltf_buffer_outside_the_folder_refuses_the_building(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    _gltf_with_external_image(folder, "atlas.png")
    gltf = json.loads((folder / "model.gltf").read_text())
    buffer = gltf["buffers"][0]["uri"]
    (tmp_path / buffer).write_bytes((folder / buffer).read_bytes())
    gltf["buffers"][0]["uri"] = f"../{buffer}"
    (folder / "model.gltf").write_text(json.dumps(gltf))
    write_csv(folder, [f"model.gltf,{LON},{LAT},{ELEV},y,G"])
    (entry,) = scan_folder(folder).entries
    assert str(tmp_path / buffer) not in entry.inputs
    with pytest.raises(Exception, match=r"buffer refused: '\.\./gltf_buffer_0\.bin' leads outside"):
        load_entry(entry)


def test_obj_with_its_mtl_missing_names_the_mtl_and_invents_no_texture(tmp_path):
    """0.4.3 made up a 2x2 grey texture (re-encoded as PNG) and named no MTL."""
    textured_box(tmp_path).export(tmp_path / "hall.obj")
    (tmp_path / "material.mtl").unlink()
    write_csv(tmp_path, [f"hall.obj,{LON},{LAT},{ELEV},y,O"])
    building = only(tmp_path)
    assert [(p.texture, p.uvs, p.color) for p in building.parts] == [
        (None, None, (1.0, 1.0, 1.0, 1.0))
    ]
    assert any("material.mtl missing" in p for p in building.problems), building.problems


def _vworld_tile(folder: Path, color: bytes | None = None) -> None:
    """One textured VWorld building (a 10 x 6 x 12 m box) in ``folder``; ``color`` replaces its
    mesh's 4 colour bytes as stored."""
    p = np.array(
        [[x, y, z] for y in (0.0, 12.0) for x, z in ((-5, -3), (5, -3), (5, 3), (-5, 3))],
        dtype=np.float64,
    )
    quads = [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (4, 5, 6, 7)]
    triangles = np.array([t for a, b, c, d in quads for t in ((a, c, b), (a, d, c))])
    buffer = io.BytesIO()
    Image.new("RGB", (16, 8), (90, 120, 150)).save(buffer, "JPEG")
    texture = Texture(buffer.getvalue(), "image/jpeg", 16, 8, name="wall.jpg")
    uvs = np.random.default_rng(0).random((8, 2)).astype(np.float32)
    part = Part(p, triangles, uvs=uvs, texture=texture)
    building = Building(id="BLD_0001", source="", reference=SEOUL, parts=[part], tile=TILE)
    vworld.write_tile(folder, TILE, [building])
    if color is not None:
        xdo_path = folder / "BLD_0001.xdo"
        xdo = parse_xdo(xdo_path.read_bytes(), str(xdo_path), None)
        xdo.meshes[0] = dataclasses.replace(xdo.meshes[0], color=color)
        xdo_path.write_bytes(serialise_xdo(xdo))


def test_vworld_texture_symlinked_out_of_the_folder_is_refused(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    _vworld_tile(folder)
    secret = secret_image(tmp_path / "secret.png")
    (folder / "wall.jpg").unlink()
    (folder / "wall.jpg").symlink_to(secret)
    building = only(folder)
    assert all(p.texture is None for p in building.parts) and no_secret(building)
    assert any("texture refused" in p and "wall.jpg" in p for p in building.problems)


def test_vworld_xdo_symlinked_out_of_the_folder_is_skipped(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    _vworld_tile(folder)
    (folder / "BLD_0001.xdo").rename(tmp_path / "elsewhere.xdo")
    (folder / "BLD_0001.xdo").symlink_to(tmp_path / "elsewhere.xdo")
    scan = scan_folder(folder)
    assert scan.entries == [] and len(scan.skipped) == 1
    assert ".xdo refused" in scan.skipped[0].reason and "BLD_0001.xdo" in scan.skipped[0].reason


# --------------------------------------------------------------------------- 3. VWorld colour


@pytest.mark.parametrize(
    "raw, textured, expected",
    [
        # The tile: B,G,R,A would make the photo 78 % opaque and grey-tinted.
        (b"\xff\xc8\xc8\xc8", True, (1.0, 1.0, 1.0, 1.0)),
        (b"\x20\x40\x80\xff", True, (1.0, 1.0, 1.0, 1.0)),
        # Untextured: the opaque reading wins; B,G,R,A first, then A,R,G,B.
        (b"\xff\xc8\xc8\xc8", False, (200 / 255, 200 / 255, 200 / 255, 1.0)),  # A,R,G,B
        (b"\x20\x40\x80\xff", False, (128 / 255, 64 / 255, 32 / 255, 1.0)),  # B,G,R,A
        (
            b"\x20\x40\x80\x80",
            False,
            (128 / 255, 64 / 255, 32 / 255, 128 / 255),
        ),  # both translucent
        (b"\x00\x00\x00\x00", False, (1.0, 1.0, 1.0, 1.0)),  # no colour set
    ],
)
def test_vworld_colour_never_makes_a_photo_translucent(tmp_path, raw, textured, expected):
    """0.4.3 read FF C8 C8 C8 as B,G,R,A: photo-textured buildings came out alphaMode BLEND 0.784."""
    _vworld_tile(tmp_path, color=raw)
    if not textured:
        (tmp_path / "wall.jpg").unlink()
    building = only(tmp_path)
    (part,) = building.parts
    assert (part.texture is not None) == textured
    assert part.color == pytest.approx(expected, abs=1e-9)


def test_vworld_photo_textured_tile_exports_opaque(tmp_path):
    """End to end: the glTF of every level has no BLEND material for the FF C8 C8 C8 tile."""
    from exporter.cli import main

    _vworld_tile(tmp_path / "in", color=b"\xff\xc8\xc8\xc8")
    out = tmp_path / "out"
    assert main(["export", str(tmp_path / "in"), "--out", str(out), "--jobs", "1", "--quiet"]) == 0
    glbs = sorted((tmp_path / "out").rglob("*.glb"))
    assert glbs
    for glb in glbs:
        scene = trimesh.load(str(glb), force="scene")
        for geometry in scene.geometry.values():
            material = getattr(geometry.visual, "material", None)
            assert getattr(material, "alphaMode", None) in (None, "OPAQUE"), glb


# --------------------------------------------------------------------------- 2. silent wrong results


def test_cityjson_boundary_index_true_is_refused_not_read_as_vertex_1(tmp_path):
    """0.4.3 read JSON ``true`` as vertex 1 (a Python bool is an int)."""
    geometry = unit_box()
    geometry["boundaries"][0][1] = [[4, 5, True, 7]]
    tmp_path.joinpath("a.city.json").write_text(
        json.dumps(city({"B": {"type": "Building", "geometry": [geometry]}}, BOX_VERTICES))
    )
    scan = scan_folder(tmp_path)
    assert scan.entries == []
    (skipped,) = scan.skipped
    assert skipped.id == "B" and "boundary index true is not a vertex index" in skipped.reason


def _seq_line(number: int) -> str:
    shifted = [[x + 50000 * number, y, z] for x, y, z in BOX_VERTICES]
    return json.dumps(
        {
            "type": "CityJSONFeature",
            "id": f"F{number}",
            "CityObjects": {f"F{number}": {"type": "Building", "geometry": [unit_box()]}},
            "vertices": shifted,
        }
    )


def test_broken_city_jsonl_line_costs_that_feature_only_with_its_line_number(tmp_path):
    """0.4.3 refused the whole file and called the broken line 'line 1'."""
    header = city({}, [])
    lines = [json.dumps(header), _seq_line(0), "", '{"type": "CityJSONFeature", "Ci', _seq_line(1)]
    lines += ['{"type": "CityJSONFeature", "id": "F9", "vertices": []}']  # no CityObjects
    (tmp_path / "seq.city.jsonl").write_text("\n".join(lines) + "\n")
    scan = scan_folder(tmp_path)
    assert [e.id for e in scan.entries] == ["F0", "F1"]
    assert [s.reason.split(" ")[:2] for s in scan.skipped] == [["line", "4"], ["line", "6"]]
    assert "not valid JSON" in scan.skipped[0].reason
    assert "no CityObjects" in scan.skipped[1].reason
    assert all(load_entry(e).triangle_count == 10 for e in scan.entries)  # ground dropped


def test_a_folder_holding_two_formats_is_read_in_both_and_inspect_says_so(tmp_path, capsys):
    """0.4.3 read the VWorld tile only and ``inspect`` said 'problems: 0'."""
    from exporter.cli import main

    _vworld_tile(tmp_path)
    tmp_path.joinpath("a.city.json").write_text(
        json.dumps(city({"B": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES))
    )
    scan = scan_folder(tmp_path)
    assert scan.format == "vworld+cityjson"
    assert sorted(e.id for e in scan.entries) == ["B", "BLD_0001"]
    assert main(["inspect", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "format vworld+cityjson, 2 buildings listed" in out
    assert "note: " + tmp_path.name + ": holds VWorld and CityJSON data; read each" in out


def test_ids_made_unique_keep_the_input_id_in_the_manifest(tmp_path):
    """0.4.3 wrote ``a~1`` with the original id kept nowhere (README: "the id stays in the
    manifest")."""
    from exporter.cli import main
    from exporter.manifest import validate_manifest

    for name, ids in (("x", ["Hall"]), ("y", ["hall", "Hall"])):
        data = city(
            {i: {"type": "Building", "geometry": [unit_box()]} for i in ids},
            [[x + 5000 * k, y, z] for k in range(len(ids)) for x, y, z in BOX_VERTICES],
        )
        for k, i in enumerate(ids):  # each building its own 8 vertices
            geometry = data["CityObjects"][i]["geometry"][0]
            geometry["boundaries"] = [
                [[[c + 8 * k for c in ring[0]]] for ring in geometry["boundaries"][0]]
            ]
        (tmp_path / name).mkdir()
        (tmp_path / name / "a.city.json").write_text(json.dumps(data))
    out = tmp_path / "out"
    assert (
        main(["export", str(tmp_path / "x"), str(tmp_path / "y"), "--out", str(out), "--quiet"])
        == 0
    )
    manifests = [json.loads(p.read_text()) for p in sorted(out.glob("*/lod_manifest.json"))]
    for manifest in manifests:
        validate_manifest(manifest)
    records = [b for manifest in manifests for b in manifest["buildings"]]
    got = sorted((b["id"], b.get("source_id")) for b in records)
    assert got == [("Hall", None), ("Hall~1", "Hall"), ("hall~1", "hall")]


# --------------------------------------------------------------------------- 4. resources


def test_texts_from_input_are_bounded_in_the_manifest(tmp_path):
    """0.4.3 copied a building name whole into building.json and the manifest (a 300 MB name in a
    300 KB .gml.gz made two 315 MB JSON files); here 4 MB and a 5000-character gml:id."""
    import gzip

    from exporter.cli import main

    long_id = "B" * 5000
    data = [{"id": long_id, "name": "N" * 4_000_000, "surfaces": box(X0, Y0, 0.0, 8, 6, 5)}]
    folder = tmp_path / "in"
    folder.mkdir()
    full = [(0, 0), (1, 0), (1, 1), (0, 1)]
    Image.new("RGB", (8, 4), (200, 10, 10)).save(folder / "red.png")
    Image.new("RGB", (8, 4), (10, 10, 200)).save(folder / "blue.png")
    # Two images: one atlas, named after the building's id.
    members = texture_member("red.png", f"{long_id}_p2", [full])
    members += texture_member("blue.png", f"{long_id}_p3", [full])
    with gzip.open(folder / "a.gml.gz", "wt", encoding="utf-8") as handle:
        handle.write(citygml(data, appearance=appearance_member(members)))
    assert (folder / "a.gml.gz").stat().st_size < 100_000
    building = only(folder)
    assert len(building.id) == 1009 and building.id.startswith("B" * 1000 + "…")
    assert len(building.attributes["name"]) == 1009
    assert "id cut to 1000 of 5000 characters" in building.problems
    assert "attribute name cut to 1000 of 4000000 characters" in building.problems
    out = tmp_path / "out"
    assert main(["export", str(folder), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    for path in out.rglob("*"):  # manifests, building.json, glTF (material and image names)
        if path.is_file():
            assert path.stat().st_size < 100_000, path
            assert b"B" * 1001 not in path.read_bytes(), path


def test_escape_sequences_in_ids_and_file_names_are_printed_escaped(tmp_path, capsys):
    """0.4.3 printed them raw: a building id could clear the screen or retitle the terminal."""
    from exporter.cli import main

    folder = tmp_path / "in"
    folder.mkdir()
    data = city({"a\x1b[2J\u202eb": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES)
    (folder / "x\x1b]0;owned\x07.city.json").write_text(json.dumps(data))
    assert main(["inspect", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\u202e" not in out and "\x07" not in out
    assert "a\\x1b[2J\\u202eb: 1 part(s)" in out
    assert main(["export", str(folder / "gone\x1b[31m"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "\x1b" not in err and "gone\\x1b[31m: no such file or folder" in err


def test_a_3_gib_sparse_obj_is_refused_by_size_without_reading_it(tmp_path):
    """0.4.3 read it whole to look for ``mtllib`` and then in trimesh (6.4 GB to ``inspect``).
    Here ``inspect`` runs with its address space capped at 2 GiB."""
    import resource
    import subprocess
    import sys

    textured_box(tmp_path).export(tmp_path / "own.obj")
    with open(tmp_path / "big.obj", "wb") as handle:
        handle.truncate(3 * 2**30)  # sparse: no disk used
    write_csv(tmp_path, [f"own.obj,{LON},{LAT},{ELEV},y,own", f"big.obj,{LON},{LAT},{ELEV},y,big"])

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (2 * 2**30, 2 * 2**30))

    done = subprocess.run(
        [sys.executable, "-m", "exporter", "inspect", str(tmp_path)],
        capture_output=True,
        text=True,
        preexec_fn=cap,
        env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "own: 1 part(s)" in done.stdout
    assert "row 2: file 'big.obj' is 3,072 MiB, over the 512 MiB limit" in done.stdout


def test_numpy_warnings_never_reach_stderr_from_readers(tmp_path):
    """0.4.3 printed numpy RuntimeWarnings ('overflow encountered in multiply', 'invalid value
    encountered in cos') on stderr for a CityJSON whose transform overflows: not one line."""
    import subprocess
    import sys

    data = city({"B": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES)
    data["transform"]["scale"] = [1e306, 1e306, 1e306]
    good = city({"C": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES)
    (tmp_path / "a.city.json").write_text(json.dumps(data))
    (tmp_path / "b.city.json").write_text(json.dumps(good))
    done = subprocess.run(
        [sys.executable, "-m", "exporter", "inspect", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert "not finite" in done.stdout and "C: 1 part(s)" in done.stdout


def test_gltf_image_outside_the_folder_is_refused_with_a_problem(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    secret_image(tmp_path / "secret.png")
    _gltf_with_external_image(folder, "../secret.png")
    write_csv(folder, [f"model.gltf,{LON},{LAT},{ELEV},y,G"])
    (entry,) = scan_folder(folder).entries
    assert str(folder / "../secret.png") not in entry.inputs
    building = load_entry(entry)
    assert all(p.texture is None for p in building.parts) and no_secret(building)
    assert any("texture refused: '../secret.png' leads outside" in p for p in building.problems), (
        building.problems
    )


def test_a_vworld_key_repeated_in_one_dat_keeps_it_as_source_id(tmp_path):
    from exporter.cli import main
    from exporter.formats.vworld_binary import parse_dat, serialise_dat

    folder = tmp_path / "in"
    _vworld_tile(folder)
    dat_path = folder / f"{TILE.name}.dat"
    dat = parse_dat(dat_path.read_bytes(), str(dat_path))
    dat.objects.append(dat.objects[0])  # the same key and .xdo twice
    dat_path.write_bytes(serialise_dat(dat))
    out = tmp_path / "out"
    assert main(["export", str(folder), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    manifest = json.loads((out / TILE.name / "lod_manifest.json").read_text())
    got = sorted((b["id"], b.get("source_id")) for b in manifest["buildings"])
    assert got == [("BLD_0001", None), ("BLD_0001~2", "BLD_0001")]
